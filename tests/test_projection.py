"""Point-to-grid projections, against sums written out from the cells' own nodes."""

import numpy as np

import fe_mpm
from fe_mpm.meshes import rectangle_mesh
from fe_mpm.transfer import mass_weighted_projection


def _shape_values(V, cell, x):
    """N_I(x) of the cell's P1 dofs, from their coordinates alone (not the tracker's map)."""
    coords = V.tabulate_dof_coordinates()[V.dofmap.cell_dofs(cell), :2]
    return np.linalg.solve(np.vstack([np.ones(3), coords.T]), np.append(1.0, x))


def test_mass_weighted_projection_weights_each_point_by_its_mass():
    """Σ_p N_I(x_p) m_p v_p / Σ_p N_I(x_p) m_p with masses that differ tenfold and a field
    that is not constant, so that neither weighting by point count nor by N_I alone
    passes; nodes no point reaches get 0."""
    rng = np.random.default_rng(5)
    mesh = rectangle_mesh((0, 0), (1, 1), (5, 5))
    points = fe_mpm.seed(mesh, per_cell=3, cells=np.arange(20), density=1000.0)
    sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1e4, 0.3, density=1000.0), dynamic=True)
    points.mass *= rng.uniform(0.2, 2.0, len(points))
    values = np.column_stack(
        [np.sin(4 * points.x[:, 0]), points.x[:, 1] ** 2, rng.standard_normal(len(points))]
    )
    layout = sim._track()
    V = sim.dynamics.space
    bary = sim.tracker.barycentric(points.x, layout.cell)
    nodal, mass = mass_weighted_projection(V, layout.cell, bary, points.mass, values)
    nodes = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    expected_mass, moment = np.zeros(nodes), np.zeros((nodes, 3))
    for p, cell in enumerate(layout.cell):
        N = _shape_values(V, cell, points.x[p])
        for I, share in zip(V.dofmap.cell_dofs(cell), N):
            expected_mass[I] += share * points.mass[p]
            moment[I] += share * points.mass[p] * values[p]
    reached = expected_mass > 0
    assert 0 < reached.sum() < nodes
    assert np.allclose(mass, expected_mass, rtol=1e-12, atol=0)
    assert np.allclose(
        nodal[reached], moment[reached] / expected_mass[reached, None], rtol=1e-12, atol=1e-15
    )
    assert np.all(nodal[~reached] == 0.0)
