"""Grid reset: a step depends only on the material-point state, not on earlier steps.

Regression test for tangent entries that PETSc dropped silently: cells empty in
the first step were squeezed out of the matrix pattern, so points entering
them later lost their stiffness (the solve failed or went wrong).
"""

import numpy as np

import fe_mpm
from fe_mpm.meshes import rectangle_mesh
from fe_mpm.particles import MaterialPoints


def _simulation(points):
    mesh = rectangle_mesh((0.0, 0.0), (4.0, 1.0), (16, 4))
    return fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.NeoHookean(E=100.0, nu=0.3),
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))],
        body_force=(0.5, -2.0),
    )


def _copy(points):
    return MaterialPoints(
        x=points.x.copy(), volume=points.volume.copy(), mass=points.mass.copy(), F=points.F.copy()
    )


def test_step_after_points_enter_empty_cells_equals_a_fresh_start():
    mesh = rectangle_mesh((0.0, 0.0), (4.0, 1.0), (16, 4))
    centroid_x = mesh.geometry.x[mesh.geometry.dofmaps[0], 0].mean(axis=1)
    points = fe_mpm.seed(mesh, per_cell=3, cells=np.flatnonzero(centroid_x < 2.0))
    sim = _simulation(points)
    sim.step(1.0)
    cells_of_step_1 = set(points.cell.tolist())

    points.x[:, 0] += 1.3  # a rigid shift into cells that were empty in step 1
    state = _copy(points)
    sim.step(2.0)
    assert not set(points.cell.tolist()) <= cells_of_step_1
    du_continued = sim.w.x.array.copy()

    restart = _simulation(state)  # a grid that has never seen anything else
    restart.step(1.0)
    assert np.abs(du_continued).max() > 1e-3
    assert np.linalg.norm(restart.w.x.array - du_continued) < 1e-10 * np.linalg.norm(du_continued)
    assert np.allclose(restart.points.x, points.x, rtol=0, atol=1e-12)
