"""The retry ladder of ``Simulation.run``: its attempts in order, and the step length."""

import re

import numpy as np
import pytest

import fe_mpm
from fe_mpm import scenes
from fe_mpm.errors import ConvergenceError
from fe_mpm.force_test import NewtonResult
from fe_mpm.meshes import rectangle_mesh
from fe_mpm.newton import NewtonSolver
from fe_mpm.retry import Attempt, RetryLadder, StepLength


def test_a_static_step_gets_four_attempts_in_the_documented_order():
    attempts = RetryLadder("bt", hold_cells=True).attempts("basic", can_hold=True)
    assert attempts == [
        Attempt(True, None),
        Attempt(True, "bt"),
        Attempt(False, None),
        Attempt(False, "bt"),
    ]


@pytest.mark.parametrize(
    "ladder, configured, can_hold, expected",
    [
        (RetryLadder("bt", True), "basic", False, [(True, None), (True, "bt")]),
        (RetryLadder("bt", True), "bt", True, [(True, None), (False, None)]),
        (RetryLadder(None, True), "basic", True, [(True, None), (False, None)]),
        (RetryLadder("bt", False), "basic", True, [(True, None), (True, "bt")]),
        (RetryLadder(None, False), "basic", True, [(True, None)]),
    ],
)
def test_attempts_drop_what_the_run_cannot_or_need_not_try(ladder, configured, can_hold, expected):
    """No hold in a dynamic run or before the first step; no fallback equal to Newton's
    own line search; each option switched off on its own."""
    attempts = ladder.attempts(configured, can_hold)
    assert [(a.rebin, a.line_search) for a in attempts] == expected


def test_the_step_halves_to_its_floor_and_doubles_back_after_two_successes():
    length = StepLength(nominal=1.0, floor=0.25)
    assert length.cut() and length.dt == 0.5
    length.accepted()
    assert length.dt == 0.5  # one success is not enough
    assert length.cut() and length.dt == 0.25  # a failure resets the count
    length.accepted()
    length.accepted()
    assert length.dt == 0.5
    length.accepted()
    assert length.dt == 0.5  # growing resets the count: two more successes are needed
    length.accepted()
    assert length.dt == 1.0
    length.accepted()
    length.accepted()
    assert length.dt == 1.0  # never beyond the nominal step
    assert length.cut() and length.cut()  # 0.5, then the floor itself
    assert not length.cut()  # 0.125 < 0.25


def _newton(outcomes):
    """A stand-in for Newton: the i-th call converges or not after the given iterations,
    with ‖R‖ = 10, 1, ... per iteration; it records the line search it was given."""
    calls = []

    def solve(search, resume):
        converged, iterations = outcomes[len(calls)]
        calls.append(search if not resume else (search, "resumed"))
        norms = [10.0**-k for k in range(-1, iterations)]
        return NewtonResult(converged, iterations, "stand-in", norms)

    return solve, calls


def test_solve_tries_the_fallback_line_search_and_counts_both_attempts():
    """Newton as configured fails after 3 iterations, the fallback converges after 2: the
    result is the second one, with 5 iterations and the ‖R‖ history of both (4 + 3
    entries) in order. A fallback equal to the configured search is not tried again."""
    newton, calls = _newton([(False, 3), (True, 2)])
    result = RetryLadder("bt", True).solve(newton, "basic")
    assert calls == [None, "bt"]
    assert result.converged and result.iterations == 5
    assert result.residual_norms == [10.0, 1.0, 0.1, 0.01, 10.0, 1.0, 0.1]
    newton, calls = _newton([(False, 3), (True, 2)])
    result = RetryLadder("bt", True).solve(newton, "bt")
    assert calls == [None] and not result.converged and result.iterations == 3


def test_the_fallback_resumes_from_the_best_iterate_only_when_asked():
    newton, calls = _newton([(False, 3), (True, 2)])
    RetryLadder("bt", True, resume=True).solve(newton, "basic")
    assert calls == [None, ("bt", "resumed")]  # the first always starts from rest


@pytest.mark.parametrize("from_best", [False, True])
def test_a_retry_from_the_best_iterate_starts_at_its_residual(from_best):
    """Cook's membrane (Neo-Hookean, u) at ten times its load in one step, Newton cut
    to 3 iterations: full steps fail, and backtracking retries. From the step's start
    its first ‖R‖ is the first attempt's first, and it fails too; with
    ``fallback_from_best`` it is the smallest of the first attempt's (the same iterate
    evaluated again: measured equal to the last bit), and the step converges."""
    sim = scenes.cook_membrane(
        8, 0.3, traction=10 / 16, margin=2, line_search="basic", fallback_line_search="bt",
        fallback_from_best=from_best, petsc_options={"snes_max_it": 3},
    )  # fmt: skip
    if not from_best:
        with pytest.raises(ConvergenceError) as info:
            sim.step(1.0)
        # Each solve's ‖R‖ apart, named by its line search (joined in one list, a
        # solve still falling read as part of the next one; a helper's slope).
        message = str(info.value)
        assert ": the last solve " in message
        found = re.search(r"‖R‖ history: basic \[(.*?)\]; bt \[(.*?)\]", message)
        first, second = (group.split(", ") for group in found.groups())
        assert len(first) == len(second) == 4 and second[0] == first[0]
        return
    norms = sim.step(1.0).residual_norms
    first, second = norms[:4], norms[4:]
    assert min(first) < 1e-2 * first[0]  # the failed attempt made progress
    assert second[0] == pytest.approx(min(first), rel=1e-12)
    assert second[-1] < 1e-10 * first[0]


def test_cut_after_a_failure_names_the_last_step_length_and_the_floor():
    """0.5 ≥ floor 0.3 is tried; the next cut, to 0.25, is below it: the failure's message
    goes on with the step length that failed last (0.5) and the floor."""
    length = StepLength(nominal=1.0, floor=0.3)
    length.cut_after(ConvergenceError("Newton failed."))
    assert length.dt == 0.5
    with pytest.raises(ConvergenceError) as info:
        length.cut_after(ConvergenceError("Newton failed."))
    assert str(info.value) == (
        "Newton failed. The step was cut to 0.5 without success, and the floor is min_step = 0.3."
    )


@pytest.mark.parametrize(
    ("law", "first", "fallback"),
    [
        (fe_mpm.NeoHookean(E=1e7, nu=0.3), "basic", "bt"),
        (fe_mpm.MohrCoulomb.tresca(1e7, 0.3, 1e4), "bt", "basic"),
        (fe_mpm.J2Plasticity(E=1e7, nu=0.3, yield_stress=1e4), "bt", "basic"),
    ],
)
def test_auto_line_search_backtracks_for_plastic_laws_and_falls_back_to_the_other(
    law, first, fallback
):
    """An elastic step converges from its first iterate; a plastic one chatters under full steps.

    Measured (docs/results/speed.md): backtracking first takes the reduced column
    collapse from 26.0 s to 12.3 s, and the 3D locking cantilever (elastic) from 5
    Newton iterations to 18, so "auto" picks by the law.
    """
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    fixed = [fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))]
    sim = fe_mpm.Simulation(mesh, fe_mpm.seed(mesh, 1), law, "u", dirichlet=fixed)
    assert sim.petsc_options["snes_linesearch_type"] == first
    assert sim.ladder.line_searches(first) == [None, fallback]
    options = {"snes_linesearch_type": "l2"}
    forced = fe_mpm.Simulation(
        mesh, fe_mpm.seed(mesh, 1), law, "u", dirichlet=fixed, petsc_options=options
    )
    assert forced.petsc_options["snes_linesearch_type"] == "l2"
    assert forced.ladder.line_searches("l2") == [None, "bt"]


@pytest.mark.parametrize("gamma", [0.0, 0.1])
def test_a_run_with_point_domains_and_no_ghost_penalty_says_so_when_it_stops(gamma):
    """Without a ghost penalty a cell holding a sliver of a domain ties its nodes weakly;
    a domain run that stops with ``ghost_penalty=0`` says so (here Newton is allowed
    one iteration, so every attempt fails); with the penalty the message does not."""
    sim = scenes.cook_membrane(
        4,
        formulation="up",
        point_domains=True,
        ghost_penalty=gamma,
        petsc_options={"snes_max_it": 1},
        min_step=0.5,
    )
    with pytest.raises(ConvergenceError) as info:
        sim.run(1.0, 1, progress=False)
    assert "min_step = 0.5" in str(info.value)
    assert ("ghost_penalty=0" in str(info.value)) == (gamma == 0.0)


@pytest.mark.parametrize(
    ("options", "names_domains"),
    [
        ({}, True),
        ({"dynamic": True}, False),
        ({"point_domains": True, "ghost_penalty": 0.1}, False),
        ({"pressure_by_parts": True}, False),  # refused with domains
        ({"points_leaving": "drop"}, True),  # taken with domains since 2026-12-07
    ],
)
def test_a_static_standard_run_that_stops_names_point_domains(options, names_domains):
    """Standard MPM's points cross cells with their whole volume, which can leave a
    static step without a solution (``scenes.platen_compression``'s J2 block in u-p
    stops so on n = 40): a static run without domains that stops, once a point has
    crossed a facet (here one moved by hand into another's cell), says that domains
    spread them; a dynamic run or one with domains does not, nor (since 2026-12-06,
    when a helper's wall moved 4 mm against cells of 0.25 m was told so) one whose
    points all lie in the cells they started in (Newton is allowed one iteration, so
    every attempt fails)."""
    for crossed in (False, True):
        sim = scenes.cook_membrane(
            4, formulation="up", petsc_options={"snes_max_it": 1}, min_step=0.5, **options
        )
        if crossed and sim.domains is None:
            sim.points.x[0] = sim.points.x[-1]  # from the clamped edge to the loaded one
        with pytest.raises(ConvergenceError) as info:
            sim.run(1.0, 1, progress=False)
        assert "min_step = 0.5" in str(info.value)
        told = "point_domains=True spreads" in str(info.value)
        assert told == (names_domains and crossed)


def test_a_static_plastic_body_past_its_limit_load_is_told_so():
    """A J2 block standing free under rising gravity (8 x 8 cells, ρ g H = 9.81 σ_Y at
    the end) has no static solution once its base yields (ρ g H ≈ 1.15 σ_Y in plane
    strain): run in 10 steps it stops near t = 0.25 (here Newton is allowed one
    iteration, so the first step stops). Found 2026-12-05 trying a new user's scene,
    whose message named only point domains; it now says that a load past the limit
    load has no solution and that a dynamic run follows the collapse. An elastic
    law is not told so."""
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.5), (8, 12))
    below = np.flatnonzero(fe_mpm.meshes.cell_centroids(mesh)[:, 1] < 1.0)
    base = fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))
    for law, told in (
        (fe_mpm.J2Plasticity(1e3, 0.3, 1.0), True),
        (fe_mpm.NeoHookean(1e3, 0.3), False),
    ):
        sim = fe_mpm.Simulation(
            mesh,
            fe_mpm.seed(mesh, per_cell=3, cells=below),
            law,
            "u",
            dirichlet=[base],
            body_force=(0.0, -9.81),
            body_force_scale=lambda t: t,
            petsc_options={"snes_max_it": 1},  # every attempt fails, as past the limit
            min_step=0.5,
        )
        with pytest.raises(ConvergenceError) as info:
            sim.run(1.0, 1, progress=False)
        assert ("limit load" in str(info.value)) == told
        assert "point_domains=True spreads" not in str(info.value)  # no point has crossed


def test_a_static_plastic_body_moved_by_its_supports_is_not_told_of_a_limit_load():
    """A J2 block squeezed by a moving support has no load to pass: its stop message
    does not say so (a helper's Rankine wall, moved 4 mm, was told of a limit load and
    of points crossing cells, 2026-12-06)."""
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (4, 4))
    sim = fe_mpm.Simulation(
        mesh,
        fe_mpm.seed(mesh, per_cell=3),
        fe_mpm.J2Plasticity(1e3, 0.3, 1.0),
        "u",
        dirichlet=[
            fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0)),
            fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 1.0), value=lambda t: (0.0, -0.1 * t)),
        ],
        petsc_options={"snes_max_it": 1},
        min_step=0.5,
    )
    with pytest.raises(ConvergenceError) as info:
        sim.run(1.0, 1, progress=False)
    assert "limit load" not in str(info.value)


@pytest.mark.parametrize(
    ("cohesion", "stressed", "told"),
    [(0.0, False, True), (100.0, False, False), (0.0, True, False)],
)
def test_a_cohesionless_soil_that_fails_from_rest_is_told_to_start_from_its_weight(
    cohesion, stressed, told
):
    """A helper's Janssen silo (Mohr–Coulomb sand, c = 0, between frictional walls,
    gravity ramped) stopped in its first step, cut 4096-fold, told only of a limit
    load; it ran from a geostatic start or with c = 100 Pa. Here Newton is allowed one
    iteration, so the first step stops: the message says what the silo needed, only
    for a cohesionless law whose points started unstressed."""
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.5), (4, 6))
    points = fe_mpm.seed(mesh, per_cell=3, cells=np.arange(16), density=2000.0)
    sim = fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.MohrCoulomb(20e6, 0.3, cohesion, 30.0),
        "u",
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))],
        body_force=(0.0, -9.81),
        body_force_scale=None if stressed else (lambda t: t),
        initial_stress=fe_mpm.geostatic_stress(points, 1.0, 9.81, 0.5) if stressed else None,
        petsc_options={"snes_max_it": 1},
        min_step=0.5,
    )
    with pytest.raises(ConvergenceError) as info:
        sim.run(1.0, 1, progress=False)
    assert ("The law is cohesionless (c = 0)" in str(info.value)) == told


def test_a_ctrl_c_in_newton_leaves_the_simulation_usable(monkeypatch):
    """A Ctrl-C lands mostly inside Newton, in a callback of PETSc's SNES: it came out
    as a PETSc error, which ``except KeyboardInterrupt`` does not catch, and left SNES's
    vectors locked, so every later ``run`` failed at once (PETSc error 73; a helper's
    60 interrupts of a long run, 2026-12-06). Now it is a KeyboardInterrupt, and the
    run goes on from the last step as if never interrupted."""
    calls = {"residuals": 0}
    residual = NewtonSolver._residual

    def interrupted(self, snes, x, b):
        calls["residuals"] += 1
        if calls["residuals"] == 2:  # in the first step's first iterate
            raise KeyboardInterrupt
        return residual(self, snes, x, b)

    monkeypatch.setattr(NewtonSolver, "_residual", interrupted)
    sim = scenes.cook_membrane(4, formulation="up")
    with pytest.raises(KeyboardInterrupt):
        sim.run(1.0, 2, progress=False)
    monkeypatch.undo()
    assert sim.t == 0.0 and calls["residuals"] == 2
    again = sim.run(1.0, 2, progress=False)
    fresh = scenes.cook_membrane(4, formulation="up").run(1.0, 2, progress=False)
    for got, want in zip(again, fresh, strict=True):
        np.testing.assert_array_equal(got.markers["A"], want.markers["A"])
        assert got.newton_iterations == want.newton_iterations


def test_a_ctrl_c_while_a_step_is_accepted_waits_for_its_end(monkeypatch, tmp_path):
    """A Ctrl-C (a real SIGINT) that lands after the points took their update but
    before the clock moved left the step half accepted, and a run continued in the
    same process took it twice (a helper's block ended 1 cm off, 2026-12-07); one that
    landed in a frame's write lost that frame. It now waits for the step's end, frame
    included, and the run goes on as if never interrupted."""
    import os
    import signal

    import fe_mpm.simulation

    update = fe_mpm.simulation.apply_update
    calls = {"n": 0}

    def interrupted(*args, **kwargs):
        update(*args, **kwargs)
        calls["n"] += 1
        if calls["n"] == 2:  # in the second step, its points already moved
            os.kill(os.getpid(), signal.SIGINT)

    def run(folder, interrupt):
        mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (8, 8))
        block = lambda x: -np.maximum(abs(x[0] - 0.5) - 0.2, abs(x[1] - 0.7) - 0.2)  # noqa: E731
        points = fe_mpm.seed(mesh, 1, level_set=block)
        sim = fe_mpm.Simulation(
            mesh, points, fe_mpm.NeoHookean(1e6, 0.3, 1000.0), dynamic=True,
            body_force=(0.0, -9.81), output_dir=folder,
        )  # fmt: skip
        if interrupt:
            monkeypatch.setattr(fe_mpm.simulation, "apply_update", interrupted)
            with pytest.raises(KeyboardInterrupt):
                sim.run(0.1, 4, progress=False)
            monkeypatch.undo()
            assert sim.step_number == 2 and sim.t == pytest.approx(0.05)
        sim.run(0.1, 4 - sim.step_number, progress=False)
        sim.close()
        return points.x.copy(), sorted(p.name for p in folder.glob("particles_*.vtu"))

    (x, frames), (x_cut, frames_cut) = run(tmp_path / "a", False), run(tmp_path / "b", True)
    np.testing.assert_allclose(x_cut, x, rtol=0, atol=1e-14)
    assert frames_cut == frames and len(frames) == 5
