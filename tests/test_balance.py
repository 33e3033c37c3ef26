"""The pieces of load balance that run on one rank (``fe_mpm.balance``).

Under MPI, ``tests/test_mpi.py`` repartitions a grid by its points and checks that the
answer stays the serial one; here the parts are checked one by one.
"""

import numpy as np
import pytest

import fe_mpm
from fe_mpm import balance, meshes
from fe_mpm._dolfinx import dolfinx


def _cells(mesh):
    owned = mesh.topology.index_map(mesh.topology.dim).size_local
    return np.asarray(mesh.geometry.dofmaps[0][:owned], dtype=np.int64)


@pytest.mark.parametrize("tdim", [2, 3])
def test_the_dual_graph_joins_exactly_the_cells_that_share_a_facet(tdim):
    if tdim == 2:
        mesh = meshes.rectangle_mesh((0, 0), (1, 1), (5, 3))
    else:
        mesh = dolfinx.mesh.create_unit_cube(fe_mpm.parallel.MPI.COMM_SELF, 2, 2, 1)
    cells = _cells(mesh)
    xadj, adjncy = balance.dual_graph(cells)
    shared = [set(c) for c in cells]
    for i in range(len(cells)):
        found = sorted(adjncy[xadj[i] : xadj[i + 1]].tolist())
        want = [j for j in range(len(cells)) if j != i and len(shared[i] & shared[j]) == tdim]
        assert found == want, i


@pytest.mark.parametrize("layers", [1, 2])
def test_vertex_layers_give_each_rank_the_cells_within_that_many_vertex_hops(layers):
    """The point domains' ghost layer (balance.with_vertex_layers): each cell lists its
    owner first, then every other rank with a cell within ``layers`` hops across a
    shared vertex, and no other: against a brute-force walk over vertex neighbours."""
    mesh = meshes.rectangle_mesh((0, 0), (3, 1), (9, 3))
    cells = _cells(mesh)
    parts = balance.partition(cells, np.ones(len(cells), dtype=np.int64), 3)
    data, offsets = balance.with_vertex_layers(cells, parts, 3, layers)
    nodes = [set(c) for c in cells]
    near = [{j for j in range(len(cells)) if nodes[i] & nodes[j]} for i in range(len(cells))]
    for i in range(len(cells)):
        reach = {i}
        for _ in range(layers):
            reach |= set().union(*(near[j] for j in reach))
        ranks = data[offsets[i] : offsets[i + 1]].tolist()
        assert ranks[0] == parts[i], i
        assert sorted(ranks[1:]) == sorted({int(parts[j]) for j in reach} - {int(parts[i])}), i
    assert offsets[-1] > len(cells)  # some cells are ghosts somewhere


def test_a_partition_balances_the_weights_not_the_cells():
    """A 32 x 8 grid whose left quarter weighs 31 per cell (three points, weight 10
    each, plus one) and the rest 1: three parts of equal weight within METIS's 3 %
    (and the coarse graph's granularity), so the heavy cells are spread over all."""
    mesh = meshes.rectangle_mesh((0, 0), (4, 1), (32, 8))
    cells = _cells(mesh)
    left = mesh.geometry.x[cells][:, :, 0].mean(axis=1) < 1
    weights = balance.cell_weights(len(cells), np.repeat(np.flatnonzero(left), 3))
    assert set(np.unique(weights)) == {1, 31}
    parts = balance.partition(cells, weights, 3)
    load = np.bincount(parts, weights=weights, minlength=3)
    assert load.max() <= 1.05 * load.mean()
    assert all(np.any(left & (parts == p)) for p in range(3))


def test_original_cell_indices_go_there_and_back_on_one_rank():
    mesh = meshes.rectangle_mesh((0, 0), (1, 1), (4, 4))
    cells = np.array([3, 0, 17, 31])
    where = np.column_stack([np.zeros(4, dtype=np.int64), cells])
    original = balance.original_indices(mesh, where)
    assert np.array_equal(balance.owners_of_original_cells(mesh, original), where)


def test_facet_tags_are_carried_to_a_grid_of_the_same_cells_and_nodes():
    old = meshes.rectangle_mesh((0, 0), (2, 1), (6, 3))
    new = meshes.rectangle_mesh((0, 0), (2, 1), (6, 3))
    old.topology.create_connectivity(1, 2)
    left = dolfinx.mesh.locate_entities_boundary(old, 1, lambda x: np.isclose(x[0], 0.0))
    top = dolfinx.mesh.locate_entities_boundary(old, 1, lambda x: np.isclose(x[1], 1.0))
    facets = np.concatenate([left, top])
    values = np.concatenate([np.full(left.size, 4), np.full(top.size, 9)]).astype(np.int32)
    order = np.argsort(facets)
    tags = dolfinx.mesh.meshtags(old, 1, facets[order], values[order])
    carried = balance.carried_facet_tags(tags, old, new)
    x = dolfinx.mesh.compute_midpoints(new, 1, carried.indices)
    assert sorted(carried.values.tolist()) == sorted(values.tolist())
    assert np.allclose(x[carried.values == 4, 0], 0.0)
    assert np.allclose(x[carried.values == 9, 1], 1.0)


def _block(**options):
    mesh = meshes.rectangle_mesh((0, 0), (1, 1), (4, 4))
    points = fe_mpm.seed(mesh, per_cell=1)
    return fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(E=1e6, nu=0.3), **options)


@pytest.mark.parametrize("value", [1.0, 0.5, float("nan")])
def test_rebalance_above_must_exceed_one(value):
    with pytest.raises(ValueError, match="rebalance_above"):
        _block(rebalance_above=value)


def test_one_rank_never_repartitions():
    sim = _block(rebalance_above=1.0001)
    mesh = sim.mesh
    sim.rebalance()
    assert sim.mesh is mesh and sim.repartitions == 0
    assert not _block().rebalancing.on


def test_a_repartition_is_due_past_the_imbalance_once_the_imbalance_has_paid_for_the_last():
    rule = balance.RebalanceRule(1.25)
    assert not rule.due(1.2, 10.0)  # balanced enough
    assert rule.due(2.0, 1.0)  # nothing paid yet: at once
    rule.paid(0.5)  # it took 0.5 s: costs 1 s with the next step's rebuilding
    assert not rule.due(2.0, 1.0)  # 0.5 s lost so far
    assert rule.due(2.0, 1.0)  # 1 s lost
    rule.restart()
    assert rule.due(1.5, 0.0)
    assert not balance.RebalanceRule(None).due(10.0, 100.0)


def test_on_step_is_told_whether_its_step_repartitions_the_grid():
    """``on_step`` runs on the grid of its step and is told, in ``report.repartitioned``,
    whether the grid is repartitioned after it (until 2026-12-06 the flag was set after
    on_step had run, so a script logging from it never saw a repartition; a helper's
    two-rank run repartitioned 9 times in 50 steps). One rank never repartitions, so
    the rule is made due at every step here; the last steps of a run are left out."""
    sim = _block(rebalance_above=1.5)
    sim.rebalancing.due = lambda imbalance, step_time: True
    seen = []
    reports = sim.run(1.0, 3, progress=False, on_step=lambda r: seen.append(r.repartitioned))
    assert seen == [r.repartitioned for r in reports] == [True, True, False]
