"""Point-to-grid projections, against sums written out from the cells' own nodes."""

import numpy as np

import fe_mpm
from fe_mpm.meshes import rectangle_mesh
from fe_mpm.transfer import consistent_projection, mass_weighted_projection


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


def test_consistent_projection_is_the_lumped_one_in_one_pass_and_solves_the_mass_system():
    """One pass is the mass-weighted projection exactly; more passes converge to the
    solution of the consistent-mass system M ṽ = Σ_p N m_p v_p (the matrix written out
    from the cells' own nodes), so that a P1 field comes back from its values at the
    points. Measured on this block (5 × 4 cells, three points per triangle, masses
    varying fivefold): a linear field's error at the points 0.12, 0.040, 3.2e-3 and
    4e-16 after 1, 2, 8 and 400 passes."""
    rng = np.random.default_rng(7)
    mesh = rectangle_mesh((0, 0), (1, 1), (5, 5))
    points = fe_mpm.seed(mesh, per_cell=3, cells=np.arange(40), density=1000.0)
    sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1e4, 0.3, density=1000.0), dynamic=True)
    points.mass *= rng.uniform(0.4, 2.0, len(points))
    layout = sim._track()
    V = sim.dynamics.space
    bary = sim.tracker.barycentric(points.x, layout.cell)
    linear = np.column_stack([1.0 + 2.0 * points.x[:, 0] - points.x[:, 1], points.x[:, 1]])

    def error(passes):
        nodal, _ = consistent_projection(V, layout.cell, bary, points.mass, linear, passes)
        at_points = np.einsum("pv,pvc->pc", bary, nodal[V.dofmap.list[layout.cell]])
        return np.abs(at_points - linear).max()

    once = mass_weighted_projection(V, layout.cell, bary, points.mass, linear)[0]
    assert np.array_equal(
        consistent_projection(V, layout.cell, bary, points.mass, linear, 1)[0], once
    )
    errors = [error(k) for k in (1, 2, 8, 400)]
    assert errors[0] > 0.05  # the lumped projection does not keep a linear field here
    assert errors[0] > errors[1] > errors[2] > errors[3]
    assert errors[3] < 1e-10
    # The limit solves the consistent-mass system, written out point by point.
    nodes = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    M, rhs = np.zeros((nodes, nodes)), np.zeros((nodes, 2))
    for p, cell in enumerate(layout.cell):
        N, dofs = _shape_values(V, cell, points.x[p]), V.dofmap.cell_dofs(cell)
        M[np.ix_(dofs, dofs)] += points.mass[p] * np.outer(N, N)
        rhs[dofs] += points.mass[p] * np.outer(N, linear[p])
    reached = np.diag(M) > 0
    exact = np.linalg.solve(M[np.ix_(reached, reached)], rhs[reached])
    limit, _ = consistent_projection(V, layout.cell, bary, points.mass, linear, 400)
    assert np.allclose(limit[reached], exact, rtol=0, atol=1e-9)
