"""Cook's membrane, irreducible form, against Kratos MPM 10.4.4 (U column).

Structured n x n meshes cut lower-left to upper-right, one point per triangle,
one static load step; tolerance 0.5 % (issue: foundation, check 5).
"""

import numpy as np
import pytest

import fe_mpm
from fe_mpm import scenes
from fe_mpm.references import COOK_KRATOS_U

TOL = 0.005


def cook_tip(n, nu, steps=1, margin=0, load="grid"):
    sim = scenes.cook_membrane(n, nu, margin=margin, load=load)
    reports = sim.run(n_steps=steps, progress=False)
    return scenes.tip_deflection(sim), reports


@pytest.mark.parametrize("nu", [0.33, 0.499])
@pytest.mark.parametrize("n", [4, 8, 16, 32])
def test_tip_displacement_matches_kratos_u(n, nu):
    u_y, reports = cook_tip(n, nu)
    reference = COOK_KRATOS_U[nu][n]
    assert abs(u_y / reference - 1) < TOL, f"u_A,y = {u_y:.5f}, Kratos {reference}"
    # Newton is quadratic: the last contraction of ‖R‖ is far below linear.
    norms = reports[0].residual_norms
    assert reports[0].newton_iterations <= 5
    assert norms[2] / norms[1] < 1e-3 * norms[1] / norms[0] or norms[2] < 1e-9 * norms[0]


def test_load_steps_without_cell_crossing_reproduce_one_step():
    """Grid reset between steps, hyperelastic law: while no point changes cell, 4 load
    steps give the one-step answer (path independence) to 0.1 %. The marker follows
    the body, not the grid, so it never reads an empty margin cell."""
    one, _ = cook_tip(16, 0.33)
    four, reports = cook_tip(16, 0.33, steps=4, margin=1)
    assert all(r.occupied_cells == 512 and r.nslot == 1 for r in reports)
    assert abs(four / one - 1) < 1e-3
    assert all(r.newton_iterations <= 4 for r in reports)
    assert np.all(np.diff([r.markers["A"][1] for r in reports]) > 0)


def test_load_steps_with_cell_crossing_stay_close():
    """n = 32, 2 steps: points cross into cells of the empty margin (so the grid
    must be larger than the body). Single-point MPM then carries the known
    cell-crossing error: measured +0.7 %, bounded here by 1 %. The load rides on
    boundary points: the tip node of the grid edge is left without material in the
    second step, and a grid traction there would be lost (-0.7 % then). A cell that a
    second point enters becomes a second entity of the same one-slot rule: nothing
    is recompiled."""
    one, _ = cook_tip(32, 0.33)
    two, reports = cook_tip(32, 0.33, steps=2, margin=2, load="points")
    assert reports[-1].occupied_cells < 2048 and reports[-1].nslot == 1
    assert abs(two / one - 1) < 0.01
    assert all(r.newton_iterations <= 4 for r in reports)


@pytest.mark.parametrize(("formulation", "per_cell"), [("up", 1), ("up-p2p1", 3)])
def test_a_load_on_boundary_points_is_the_grid_load_in_one_step(formulation, per_cell):
    """Before anything moves, ``load="points"`` integrates the traction of the loaded
    edge as the grid traction does: to round-off for P1 (midpoints) and for P2 (two
    Gauss points per facet; the midpoints alone put the whole load on the facets'
    middle nodes and the edge bulges between them)."""
    tips = []
    for load in ("grid", "points"):
        sim = scenes.cook_membrane(8, 0.33, formulation, per_cell=per_cell, load=load)
        sim.run(1.0, 1, progress=False)
        tips.append(scenes.tip_deflection(sim))
    assert tips[1] == pytest.approx(tips[0], rel=1e-10)


@pytest.mark.parametrize(
    ("formulation", "law"),
    [("u", "neo-hookean"), ("up", "neo-hookean"), ("u", "j2"), ("up", "j2")],
)
def test_steps_at_constant_load_settle_a_body_at_equilibrium_where_it_is(formulation, law):
    """A quarter of the load in two steps (no point changes cell), then three steps with
    the load held. The first held step moves the body a little: the load's points were
    placed where the last step began, and now act where the body is. After that a step
    has nothing left to do, and nothing may move: each held step moves the points at
    most 1e-3 of the one before, and the third leaves positions, stress and plastic
    strain as they were. Measured: from held step to held step, 1.8e-4 to 3.7e-4 of the
    move before; the third moves at most 4.3e-11 of the tip, stress 4.4e-10 and the
    history 1.2e-9 relative. A step that re-applied an earlier increment (of load,
    deformation or history), or kept a trial state, fails this. (Point domains fail it:
    ``docs/cell_crossing.md``.)"""
    material = None
    if law == "j2":  # yields along the clamp under this load
        yield_stress = 0.03 if formulation == "u" else 0.04
        material = fe_mpm.J2Plasticity(
            E=70.0, nu=0.3333, yield_stress=yield_stress, hardening=0.135
        )
    sim = scenes.cook_membrane(
        16, 0.3333, formulation, material=material, load="points", traction=0.25 / 16, margin=2
    )
    sim.run(1.0, 2, progress=False)
    tip = scenes.tip_deflection(sim)
    moves = []
    for t in (1.25, 1.5, 1.75):
        x, stress = sim.points.x.copy(), sim.points.stress.copy()
        history = {name: values.copy() for name, values in sim.points.history.items()}
        (report,) = sim.run(t, 1, progress=False)
        assert report.occupied_cells == 512
        moves.append(np.abs(sim.points.x - x).max())
    assert moves[1] < 1e-3 * moves[0]
    assert moves[2] < 1e-9 * tip
    assert np.abs(sim.points.stress - stress).max() < 1e-8 * np.abs(stress).max()
    for name, values in history.items():
        assert np.abs(sim.points.history[name] - values).max() < 1e-7 * np.abs(values).max()
    if law == "j2":
        assert np.count_nonzero(history["plastic_strain"]) > 50
