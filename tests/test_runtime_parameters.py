"""A law's numbers are run-time constants of the forms (issue: throughput, item 4).

A new (E, ν), yield stress, cohesion or PPP α must give the same generated code, so that
a parameter sweep compiles once; and the constants must carry the numbers (the block's
weight is carried for each law, so a constant left at a wrong value would show).
"""

from mpi4py import MPI

import dolfinx.mesh
import ffcx.naming
import numpy as np
import pytest

import fe_mpm
from fe_mpm.materials.runtime import RuntimeParameters, with_runtime_parameters

RHO, G = 2000.0, 9.81

LAWS = {
    "neo-hookean u": (lambda s: fe_mpm.NeoHookean(E=1e7 * s, nu=0.3 * s), "u"),
    "neo-hookean up": (lambda s: fe_mpm.NeoHookean(E=1e7 * s, nu=0.3 * s), "up"),
    "j2 u": (lambda s: fe_mpm.J2Plasticity(E=1e7 * s, nu=0.3, yield_stress=2e4 * s), "u"),
    "tresca up": (lambda s: fe_mpm.MohrCoulomb.tresca(1e7 * s, 0.3 * s, 2e4 * s), "up"),
}


def block(law, formulation, ppp_alpha=1.0):
    """A 1 m block of 8 x 8 cells under gravity, fixed at its base, after one static step."""
    mesh = dolfinx.mesh.create_rectangle(
        MPI.COMM_SELF, [[0, 0], [1, 1]], [8, 8], dolfinx.mesh.CellType.triangle
    )
    points = fe_mpm.seed(mesh, per_cell=3, density=RHO)
    extra = {"ppp_alpha": ppp_alpha} if formulation == "up" else {}
    sim = fe_mpm.Simulation(
        mesh,
        points,
        law,
        formulation=formulation,
        body_force=(0.0, -G),
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))],
        **extra,
    )
    sim.run(t_end=1.0, n_steps=1, progress=False)
    return sim


def generated_code(sim) -> list[str]:
    """Names of the residual's and tangent's modules and of the point update's kernel.

    FFCx names a kernel by the signature of its UFL, which is its key in the JIT cache.
    """
    (forms,) = sim._forms._forms.values()
    update = forms.update.expression
    return [
        forms.residual.compiled.module.__name__,
        forms.jacobian.compiled.module.__name__,
        ffcx.naming.expression_name((update.ufl_expression, update.X()), ""),
    ]


@pytest.mark.parametrize("name", LAWS)
def test_new_parameters_reuse_the_generated_code(name):
    make, formulation = LAWS[name]
    first, second = block(make(1.0), formulation), block(make(1.1), formulation, ppp_alpha=0.5)
    assert generated_code(first) == generated_code(second)
    # The numbers did reach the kernels: the stiffer block settles less.
    settle = [np.max(np.abs(s.points.x - s.points.x0)) for s in (first, second)]
    assert settle[1] < settle[0] / 1.05


@pytest.mark.parametrize("name", LAWS)
def test_weight_is_carried_with_the_constants(name):
    """The base row's vertical stress is the weight above it (as the user-scene check asks)."""
    make, formulation = LAWS[name]
    sim = block(make(1.0), formulation)
    low = sim.points.x[:, 1] < 0.125
    want = -RHO * G * np.mean(1.0 - sim.points.x[low, 1])
    assert np.mean(sim.points.stress[low, 1, 1]) == pytest.approx(want, rel=0.10)


def test_the_view_reads_constants_and_binds_the_law():
    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_SELF, 1, 1)
    law = fe_mpm.MohrCoulomb(E=2e7, nu=0.25, cohesion=1e4, friction_angle=30.0)
    view = with_runtime_parameters(law, mesh)
    assert isinstance(view, RuntimeParameters)
    assert set(view.constants) == {"E", "nu", "cohesion", "friction_angle", "dilatancy_angle"}
    assert float(view.constants["E"].value) == 2e7
    assert view.history.keys() == law.history.keys()  # a property, bound to the view
    with pytest.raises(AttributeError, match="read-only"):
        view.E = 1.0


def test_a_law_of_ones_own_is_left_as_it_is():
    """A user's law need not be a dataclass; its numbers are then compiled in."""

    class Mine:
        mu = 1.0

    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_SELF, 1, 1)
    law = Mine()
    assert with_runtime_parameters(law, mesh) is law
