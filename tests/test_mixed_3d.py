"""The mixed forms in 3D: a nearly incompressible cantilever of tetrahedra.

Timoshenko beam theory for the tip deflection under an end shear F on a 4 x 1 x 1
beam (E = 100, ν → 0.5, G = E/3, κ = 5/6): F L³/(3 E I) + F L/(κ G A) = 0.1352.
On this coarse 8 x 2 x 2 grid, measured: u 0.0079 (locked), up 0.1097, P2/P1 0.1253.
"""

import numpy as np
import pytest

import fe_mpm
from fe_mpm.meshes import rectangle_mesh

F, L, E = 0.05, 4.0, 100.0
TIMOSHENKO = F * L**3 / (3 * E / 12) + F * L / (5 / 6 * E / 3)


def tip(formulation, per_cell):
    mesh = rectangle_mesh((0, 0, 0), (L, 1, 1), (8, 2, 2))
    points = fe_mpm.seed(mesh, per_cell=per_cell)
    sim = fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.NeoHookean(E, 0.4999),
        formulation,
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0))],
        tractions=[fe_mpm.Traction(lambda x: np.isclose(x[0], L), (0.0, 0.0, F))],
    )
    sim.add_marker("tip", (L, 0.5, 0.5))
    (report,) = sim.run(progress=False)
    return sim.marker("tip")[2] - 0.5, report.newton_iterations


@pytest.mark.parametrize(
    "formulation,per_cell,low,high",
    [
        ("u", 1, 0.0, 0.1),  # locked
        ("up", 1, 0.75, 0.9),  # P1/P1 + PPP, coarse
        ("up-p2p1", 4, 0.88, 1.0),  # Taylor–Hood
    ],
)
@pytest.mark.slow
def test_cantilever_tip_against_timoshenko(formulation, per_cell, low, high):
    w, iterations = tip(formulation, per_cell)
    assert low < w / TIMOSHENKO < high, f"{formulation}: w = {w:.4f}, beam theory {TIMOSHENKO:.4f}"
    assert iterations <= 5
