"""Taylor tests: every residual/Jacobian pair the code assembles is consistent.

For a consistent pair ``‖R(u+εd) − R(u) − ε J d‖`` falls as ε². A term that the
form compiler drops from the residual but keeps in the Jacobian (or vice versa)
shows as rate 1, so this is the test that catches that class of bug.
"""

import numpy as np
import pytest
import ufl
from layouts import random_points

import fe_mpm
from fe_mpm.assembly import StepForm
from fe_mpm.meshes import rectangle_mesh
from fe_mpm.quadrature import OCCUPIED
from fe_mpm.simulation import FORMULATIONS
from fe_mpm.verification import rates, taylor_remainders

EPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4)


def _simulation(dim, formulation, seed=3, material=None):
    rng = np.random.default_rng(seed)
    if dim == 2:
        mesh = rectangle_mesh((0.0, 0.0), (2.0, 1.0), (6, 3))
    else:
        mesh = rectangle_mesh((0.0, 0.0, 0.0), (2.0, 1.0, 1.0), (3, 2, 2))
    ncells = mesh.topology.index_map(dim).size_local
    counts = rng.integers(0, 4, size=ncells)
    counts[counts > 0] += FORMULATIONS[formulation].min_points_per_cell(dim) - 1
    pts, _ = random_points(mesh, rng, counts, F_spread=0.1)
    traction = np.zeros(dim)
    traction[1] = 0.3
    material = material or fe_mpm.NeoHookean(E=10.0, nu=0.3)
    # The history at its initial values, not the elastic state of F that points
    # without one would take (a later stage's): the random F then spans the regions.
    for name, field in material.history.items():
        pts.history[name] = field.initial_values(len(pts))
    sim = fe_mpm.Simulation(
        mesh,
        pts,
        material,
        formulation,
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0))],
        tractions=[fe_mpm.Traction(lambda x: np.isclose(x[0], 2.0), traction)],
        body_force=-np.ones(dim),
    )
    return rng, sim


@pytest.mark.slow
@pytest.mark.parametrize("formulation", FORMULATIONS)
@pytest.mark.parametrize("dim", [2, 3])
def test_step_residual_and_jacobian_are_consistent(dim, formulation):
    assert_first_step_is_consistent(*_simulation(dim, formulation))


def assert_first_step_is_consistent(rng, sim, t_new: float = 1.0) -> None:
    """Taylor test of the residual and Jacobian of ``sim``'s step to ``t_new`` about a
    random grid unknown: the remainder falls as ε², not ε. The step starts as Newton's
    does, so that a starting pressure projected from the points' stresses acts."""
    _, _, R, J, _ = sim.prepare_step(t_new)
    sim._initial_guess()
    sim.w.x.array[:] = rng.uniform(-0.02, 0.02, sim.w.x.array.size)
    d = rng.uniform(-1.0, 1.0, sim.w.x.array.size)
    r0, r1 = taylor_remainders(R, J, sim.w, d, EPS)
    assert np.all(rates(EPS, r0) > 0.9)
    assert np.all(rates(EPS, r1) > 1.9), f"remainders {r1}"


def test_taylor_test_detects_an_inconsistent_jacobian():
    """Negative control: a Jacobian 1 % off the true one gives rate 1, so the test can fail."""
    rng, sim = _simulation(2, "u")
    forms, layout, R, _, _ = sim.prepare_step(1.0)
    ufl_R = forms.residual.ufl_form
    # A Jacobian of a different residual: the same form with the stress scaled by 1.01.
    wrong = ufl.derivative(1.01 * ufl_R, sim.w, ufl.TrialFunction(sim.fields.W))
    J_wrong = StepForm(
        wrong, sim.mesh, sim.conditions.traction_facets, quadratures={OCCUPIED: forms.q}
    ).bind(layout)
    sim.w.x.array[:] = rng.uniform(-0.02, 0.02, sim.w.x.array.size)
    d = rng.uniform(-1.0, 1.0, sim.w.x.array.size)
    _, r1 = taylor_remainders(R, J_wrong, sim.w, d, EPS)
    assert np.all(rates(EPS, r1) < 1.2)
