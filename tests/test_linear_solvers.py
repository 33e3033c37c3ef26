"""The iterative linear solvers give the direct solver's answer and keep Newton quadratic.

``linear_solver="iterative"`` is GMRES with GAMG (rigid body modes as the near null
space) for u, and a Schur field split for u-p. Its Krylov tolerance (1e-12) is meant
to leave Newton's history unchanged, so both the answer and the iteration count are
compared with MUMPS's.
"""

import warnings

import numpy as np
import pytest
from newton_rates import quadratic

import fe_mpm
from fe_mpm import scenes
from fe_mpm.meshes import rectangle_mesh


def _cook(formulation, solver):
    sim = scenes.cook_membrane(
        16, 0.33 if formulation == "u" else 0.499, formulation, linear_solver=solver
    )
    (report,) = sim.run(progress=False)
    return scenes.tip_deflection(sim), report, sim


@pytest.mark.parametrize("formulation", ["u", "up"])
def test_iterative_cook_matches_direct(formulation):
    tip_direct, rep_direct, _ = _cook(formulation, "direct")
    tip_iter, rep_iter, sim = _cook(formulation, "iterative")
    assert abs(tip_iter / tip_direct - 1) < 1e-9
    assert rep_iter.newton_iterations == rep_direct.newton_iterations
    assert quadratic(rep_iter.residual_norms)
    ksp = sim._newton.snes.getKSP()
    assert ksp.getConvergedReason() > 0
    assert ksp.getType() == ("gmres" if formulation == "u" else "fgmres")
    if formulation == "up":  # the split's inner solvers as LINEAR_SOLVERS has them
        # (read when the preconditioner is set up, in the solve: until 2026-12-06 the
        # options were gone by then, and each block fell back to GMRES with ILU)
        inner = [(k.getType(), k.getPC().getType()) for k in ksp.getPC().getFieldSplitSubKSP()]
        assert inner == [("preonly", "gamg"), ("preonly", "jacobi")]


@pytest.mark.parametrize("formulation", ["u", "up"])
def test_iterative_3d_block_under_gravity(formulation):
    """A 3D block on a fixed base: six rigid body modes; base reaction = weight."""

    def run(solver):
        mesh = rectangle_mesh((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (4, 4, 4))
        sim = fe_mpm.Simulation(
            mesh,
            fe_mpm.seed(mesh, 4, density=1000.0),
            fe_mpm.NeoHookean(1e6, 0.3, 1000.0),
            formulation,
            dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[2], 0.0))],
            body_force=(0.0, 0.0, -9.81),
            reactions={"base": lambda x: np.isclose(x[2], 0.0)},
            linear_solver=solver,
        )
        report = sim.step(1.0)
        return sim, report

    sim_d, rep_d = run("direct")
    sim_i, rep_i = run("iterative")
    assert np.abs(sim_i.points.x - sim_d.points.x).max() < 1e-10
    assert rep_i.newton_iterations == rep_d.newton_iterations
    weight = 1000.0 * 9.81 * 1.0
    assert abs(rep_i.reactions["base"][2] - weight) < 1e-8 * weight


def test_unknown_linear_solver_is_named():
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    with pytest.raises(ValueError, match="linear_solver"):
        fe_mpm.Simulation(mesh, fe_mpm.seed(mesh), fe_mpm.NeoHookean(1.0, 0.3), linear_solver="cg")


def _block_on_its_base(petsc_options: dict, **options) -> fe_mpm.Simulation:
    """A 1 m square of 2 × 2 cells, one point each, under gravity on its base."""
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    return fe_mpm.Simulation(
        mesh,
        fe_mpm.seed(mesh, 1, density=1000.0),
        fe_mpm.NeoHookean(1e6, 0.3, 1000.0),
        "u",
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))],
        body_force=(0.0, -9.81),
        petsc_options=petsc_options,
        **options,
    )


def test_a_simulations_petsc_options_do_not_reach_the_next_one():
    """PETSc's options database is left as it was found, by Newton and by the mass solve.

    A user's ``petsc_options`` (here a monitor and an iteration limit) are set under the
    solver's prefix while it configures and removed afterwards; an option that was
    there before (as from the command line) keeps its value. Until 2026-12-06 every
    option stayed in the database, so a later Simulation in the same script printed
    the first one's SNES monitor.
    """
    from petsc4py import PETSc

    opts = PETSc.Options()
    opts["fe_mpm_u_snes_rtol"] = "1e-9"  # as if given on the command line
    try:
        before = opts.getAll()
        sim = _block_on_its_base(
            {"snes_monitor_cancel": None, "-snes_max_it": 7},
            dynamic=True,  # as typed
        )
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # both keys were read: no warning
            sim.step(1e-3)
        assert sim._newton.snes.getTolerances()[3] == 7  # the option acted
        assert opts.getAll() == before
    finally:
        opts.delValue("fe_mpm_u_snes_rtol")


def test_petsc_options_that_petsc_never_reads_warn_after_the_first_step():
    """Found 2026-12-07: misspelt keys (``snes_rtoll``) were ignored without a word.
    After the first step the user's keys that PETSc read neither in Newton's solves nor
    in the mass solve are named, once; a key for a solver the run does not use
    (MUMPS's ICNTL with the iterative solver, or without the direct solver's prefix
    ``redistribute_``, where it never acted either) is named too."""

    def simulation(options, solver="direct"):
        return _block_on_its_base(options, linear_solver=solver)

    sim = simulation({"snes_rtoll": 1e-3, "-snes_max_it": 9, "ksp_typo": "cg"})
    with pytest.warns(UserWarning, match=r"\['ksp_typo', 'snes_rtoll'\] were not read by PETSc"):
        sim.step(0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once only
        sim.step(1.0)
    sim = simulation({"mat_mumps_icntl_14": 50}, solver="iterative")
    with pytest.warns(UserWarning, match=r"\['mat_mumps_icntl_14'\] were not read"):
        sim.step(1.0)
    # The direct solver's MUMPS sits behind PCREDISTRIBUTE: its options take that prefix.
    sim = simulation({"mat_mumps_icntl_14": 50})
    with pytest.warns(UserWarning, match=r"with the prefix redistribute_"):
        sim.step(1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # read by MUMPS during the solve
        simulation({"redistribute_mat_mumps_icntl_14": 50}).step(1.0)
        # A first step in equilibrium solves nothing: it is judged after the next one.
        sim = _block_on_its_base(
            {"redistribute_mat_mumps_icntl_14": 50},
            body_force_scale=lambda t: max(0.0, t - 1.0),
        )
        assert sim.step(1.0).newton_iterations == 0
        sim.step(2.0)
