"""Load balance: the grid partitioned by the points its cells hold, not by its cells.

DOLFINx gives each rank about as many cells as the others, but MPM points fill part
of the grid only (a column collapse starts in a corner of it), and part of the work
of a step goes with the points: tracking, packing, the return map, the assembly
over occupied cells. The rest goes with the grid (the matrix keeps the pattern of
every cell, empty nodes are pinned), which is why it does not always pay
(docs/limitations.md). A rank owns the points in its cells, so
:func:`repartitioned` builds the same grid again with a partition from METIS
(through ``pymetis``) of the cells' dual graph, each cell weighted by the points it
holds (:func:`cell_weights`).

The new grid keeps every cell's original index (``mesh.topology.original_cell_index``)
and every node's input index, so a cell is the same cell on any partition:
:func:`owners_of_original_cells` finds where it went. Facet tags are carried over
by their nodes (:func:`carried_facet_tags`). The grid is rebuilt from the whole
topology gathered on rank 0, as a mesh is when it is read from gmsh; the partition
is computed there too, so it is the same in every run on the same number of ranks.
A grid with ghost cells (DOLFINx's ``GhostMode.shared_facet``, the default of
``create_rectangle``/``create_box`` and of fe-mpm's gmsh scenes) keeps them: each
rank also holds the cells across its facets on other ranks, which the ghost
penalty's facet integrals need. A grid without them gets none.
"""

from __future__ import annotations

import os
import sys

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx

#: A cell's weight per point it holds; an empty cell weighs 1, so a rank's share of
#: the grid counts a little too (its nodes are in the vectors and the tracking).
POINT_WEIGHT = 10


class RebalanceRule:
    """When a run repartitions its grid: past an imbalance, once the imbalance has paid.

    Due when the imbalance (the most points on a rank over the mean) exceeds
    ``above`` and the time the imbalance has cost since the last repartition exceeds
    what that repartition cost: a step of ``step_time`` seconds on the busiest rank
    would take about 1/imbalance of it balanced. A repartition's cost is taken as
    twice its own time, as the next step builds the forms and the solver again
    (measured about as long). So a flow that keeps unbalancing the ranks is not
    repartitioned at every step. Its inputs must be the same on every rank.

    Args:
        above: The imbalance (> 1) past which a repartition may be due; None: never.
    """

    def __init__(self, above: float | None):
        self.above = above
        self.restart()

    @property
    def on(self) -> bool:
        """Whether the run ever repartitions."""
        return self.above is not None

    def restart(self) -> None:
        """Nothing lost, nothing paid (at set-up and after a restore): due at once."""
        self._lost, self._cost = 0.0, 0.0

    def due(self, imbalance: float, step_time: float = 0.0) -> bool:
        """Whether to repartition after a step of ``step_time`` s at ``imbalance``."""
        if self.above is None:
            return False
        self._lost += step_time * (1.0 - 1.0 / imbalance)
        return imbalance > self.above and self._lost >= self._cost

    def paid(self, seconds: float) -> None:
        """A repartition took ``seconds`` (the slowest rank's)."""
        self._lost, self._cost = 0.0, 2.0 * seconds


def cell_weights(num_cells: int, cells: np.ndarray) -> np.ndarray:
    """The METIS weight of each owned cell: 1 + :data:`POINT_WEIGHT` × its points.

    Args:
        num_cells: This rank's owned cells.
        cells: The cell of each of this rank's points (n,).

    Returns:
        Integer weights, shape (num_cells,).
    """
    # A point not looked for since a repartition counts nowhere.
    cells = cells[(cells >= 0) & (cells < num_cells)]
    return 1 + POINT_WEIGHT * np.bincount(cells, minlength=num_cells).astype(np.int64)


def has_facet_ghosts(mesh: dolfinx.mesh.Mesh) -> bool:
    """Whether every rank holds the cells across its facets (``GhostMode.shared_facet``).

    Collective. True on one rank. A facet between two ranks' cells that a rank sees
    with one cell only, and that is not on the grid's boundary, says no.
    """
    if mesh.comm.size == 1:
        return True
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    facet_cells = mesh.topology.connectivity(tdim - 1, tdim)
    owned = mesh.topology.index_map(tdim - 1).size_local
    one_sided = np.flatnonzero(np.diff(facet_cells.offsets)[:owned] == 1)
    exterior = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    missing = np.setdiff1d(one_sided, exterior).size
    return not parallel.any_rank(mesh.comm, missing > 0)


def with_facet_ghosts(mesh: dolfinx.mesh.Mesh) -> dolfinx.mesh.Mesh:
    """The grid of ``mesh`` with the cells across each rank's facets as ghosts.

    Collective. Every cell stays on the rank that owns it (no METIS); only the
    shared-facet ghost layer that the ghost penalty and a fluid's pressure by parts
    integrate over is added, as ``GhostMode.shared_facet`` would have given it. The
    new grid keeps the original cell and input node indices, so
    :func:`owners_of_original_cells` and :func:`carried_facet_tags` map onto it.
    """
    if mesh.comm.size == 1:
        return mesh
    return _rebuilt(mesh, np.ones(mesh.topology.index_map(mesh.topology.dim).size_local), 0, True)


def repartitioned(
    mesh: dolfinx.mesh.Mesh, weights: np.ndarray, vertex_layers: int = 0
) -> dolfinx.mesh.Mesh:
    """The grid of ``mesh`` partitioned so that the ranks' weights are about equal.

    Collective. On one rank ``mesh`` itself is returned.

    Args:
        mesh: An affine simplex grid, distributed over its communicator's ranks.
        weights: The weight of each owned cell, shape (owned cells,), integers ≥ 1.
        vertex_layers: 0: ghost cells as ``mesh`` has them (shared-facet or none);
            k > 0: every cell within k layers of cells sharing a vertex with a
            rank's own (:func:`with_vertex_layers`), which the point domains need.

    Returns:
        A new mesh of the same cells and nodes, each cell owned by the rank METIS
        gave it, with the same original cell and input node indices.

    Raises:
        ImportError: ``pymetis`` (a dependency of fe-mpm) is not installed.
    """
    if mesh.comm.size == 1:
        return mesh
    _pymetis()  # on every rank: a missing pymetis stops them all, not rank 0 alone
    return _rebuilt(mesh, weights, vertex_layers, False)


def _rebuilt(
    mesh: dolfinx.mesh.Mesh, weights: np.ndarray, vertex_layers: int, keep_owners: bool
) -> dolfinx.mesh.Mesh:
    """The grid rebuilt: :func:`repartitioned`, or :func:`with_facet_ghosts`.

    With ``keep_owners`` every cell stays on its rank and the shared-facet ghost
    layer is added; otherwise METIS partitions the cells by ``weights``.
    """
    comm = mesh.comm
    tdim, gdim = mesh.topology.dim, mesh.geometry.dim
    ghosted = keep_owners or parallel.any_rank(comm, mesh.topology.index_map(tdim).num_ghosts > 0)
    owned = mesh.topology.index_map(tdim).size_local
    node_input = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)
    cells = node_input[mesh.geometry.dofmaps[0][:owned]]
    original = owned_original_cells(mesh)
    n_nodes = mesh.geometry.index_map().size_local
    gathered = comm.gather(
        (
            original,
            cells,
            np.asarray(weights, dtype=np.int64)[:owned],
            node_input[:n_nodes],
            mesh.geometry.x[:n_nodes, :gdim],
        )
    )
    parts = np.zeros(0, dtype=np.int32)
    all_cells = np.zeros((0, tdim + 1), dtype=np.int64)
    x = np.zeros((0, gdim))
    graph = (np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64))
    error = None
    if comm.rank == 0:
        try:
            all_cells, x, parts, graph = _partitioned(gathered, comm.size, tdim, gdim, keep_owners)
        except (ValueError, RuntimeError, MemoryError) as err:  # METIS's own included
            error = err
    parallel.raise_together(comm, error)  # rank 0 alone may fail; the others would wait
    if vertex_layers > 0:
        layers = with_vertex_layers(all_cells, parts, comm.size, vertex_layers)
        destinations = dolfinx.graph.adjacencylist(*layers)
    elif ghosted:
        destinations = dolfinx.graph.adjacencylist(*with_facet_neighbours(graph, parts))
    else:
        destinations = dolfinx.graph.adjacencylist(parts)

    def partitioner(comm, nparts, cell_types, topology):
        # Called by create_mesh with the cells as given: all on rank 0, in original order.
        return destinations._cpp_object

    element = mesh.ufl_domain().ufl_coordinate_element()
    return dolfinx.mesh.create_mesh(comm, all_cells, element, x, partitioner=partitioner)


def _partitioned(gathered: list, size: int, tdim: int, gdim: int, keep_owners: bool = False):
    """On rank 0: the cells' nodes, the nodes' positions, the parts and the dual graph.

    Cells and nodes are in input order; the dual graph is (xadj, adjncy).

    Args:
        gathered: Each rank's (original cell indices, cell nodes, weights, node input
            indices, node positions).
        size: The number of ranks.
        tdim: The cells' dimension.
        gdim: The nodes' dimension.
        keep_owners: Each cell's part is the rank that owns it now (no METIS).

    Raises:
        ValueError: The original cell indices are not 0, ..., N − 1 (the new grid
            numbers its cells by their place in the list it is given).
    """
    original = np.concatenate([g[0] for g in gathered])
    order = np.argsort(original, kind="stable")
    if not np.array_equal(original[order], np.arange(original.size)):
        raise ValueError(
            "repartition: the grid's original cell indices are not 0, ..., N - 1 "
            "(mesh.topology.original_cell_index); build the grid with create_mesh, "
            "create_rectangle/box or from gmsh"
        )
    all_cells = np.concatenate([g[1] for g in gathered])[order]
    cell_weight = np.concatenate([g[2] for g in gathered])[order]
    inputs = np.concatenate([g[3] for g in gathered])
    x = np.zeros((int(inputs.max()) + 1, gdim))  # rows no cell uses are never read
    x[inputs] = np.concatenate([g[4] for g in gathered])
    graph = dual_graph(all_cells)  # METIS's, and the ghost layer's if the grid has one
    now = np.repeat(np.arange(size), [len(g[0]) for g in gathered])[order]
    if keep_owners:
        return all_cells, x, now.astype(np.int32), graph
    parts = partition(all_cells, cell_weight, size, graph)
    return all_cells, x, _kept_in_place(parts, now, cell_weight, size), graph


def with_facet_neighbours(
    graph: tuple[np.ndarray, np.ndarray], parts: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Each cell's ranks: its owner first, then the other owners of its facet neighbours.

    The destinations of a shared-facet ghost layer, as DOLFINx's own partitioners
    give them with ``GhostMode.shared_facet``.

    Args:
        graph: The cells' facet adjacency (xadj, adjncy), as :func:`dual_graph` gives it.
        parts: The owning rank of each cell (n,).

    Returns:
        ``(data, offsets)`` of an adjacency list (int32).
    """
    n = len(parts)
    if n == 0:  # a rank other than the one that holds the whole grid
        return np.zeros(0, dtype=np.int32), np.zeros(1, dtype=np.int32)
    xadj, adjncy = graph
    cell = np.repeat(np.arange(n), np.diff(xadj))
    other = parts[adjncy]
    ghosts = np.unique(np.column_stack([cell, other])[other != parts[cell]], axis=0)
    return _owner_first(parts, ghosts)


def _owner_first(parts: np.ndarray, ghosts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The adjacency list (data, offsets) of each cell's owner, then its ghosts' ranks.

    ``parts``: the owner of each cell (n,); ``ghosts``: (cell, rank) pairs (k, 2),
    sorted by cell, of the ranks that hold a cell as a ghost.
    """
    n = len(parts)
    pairs = np.concatenate([np.column_stack([np.arange(n), parts]), ghosts])
    pairs = pairs[np.argsort(pairs[:, 0], kind="stable")]  # the owner stays first
    offsets = np.zeros(n + 1, dtype=np.int32)
    np.cumsum(np.bincount(pairs[:, 0], minlength=n), out=offsets[1:])
    return pairs[:, 1].astype(np.int32), offsets


def with_vertex_layers(
    cells: np.ndarray, parts: np.ndarray, size: int, layers: int
) -> tuple[np.ndarray, np.ndarray]:
    """Each cell's ranks: its owner first, then every rank that holds it as a ghost.

    A rank holds as ghosts the cells within ``layers`` layers of its own, a layer
    being the cells that share a vertex with the last: a point domain near a rank's
    edge covers cells past it (:mod:`fe_mpm.domains`), often across a vertex only.

    Args:
        cells: The nodes of every cell (n, t + 1), on the rank that holds them all.
        parts: The owning rank of each cell (n,).
        size: The number of ranks.
        layers: How many vertex layers, ≥ 1.

    Returns:
        ``(data, offsets)`` of an adjacency list (int32).
    """
    n = len(parts)
    if n == 0:  # a rank other than the one that holds the whole grid
        return np.zeros(0, dtype=np.int32), np.zeros(1, dtype=np.int32)
    held = np.zeros((n, size), dtype=bool)
    held[np.arange(n), parts] = True
    k = cells.shape[1]
    for _ in range(layers):  # a rank reaches a node through its cells, then its cells
        at_node = np.zeros((int(cells.max()) + 1, size), dtype=np.uint8)
        np.maximum.at(at_node, cells.ravel(), np.repeat(held, k, axis=0).astype(np.uint8))
        held = at_node[cells].max(axis=1).astype(bool)
    cell, rank = np.nonzero(held & (np.arange(size)[None, :] != parts[:, None]))
    return _owner_first(parts, np.column_stack([cell, rank]))


def partition(
    cells: np.ndarray,
    weights: np.ndarray,
    parts: int,
    graph: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """The part (0 to ``parts`` − 1) of each cell: METIS on the cells' dual graph.

    Args:
        cells: The nodes of each simplex, shape (n, t + 1).
        weights: Integer weight of each cell (n,), ≥ 1.
        parts: How many parts.
        graph: The cells' :func:`dual_graph`, if already built; None builds it.

    Returns:
        Shape (n,), int32: parts of about equal total weight, with few facets cut.
    """
    xadj, adjncy = dual_graph(cells) if graph is None else graph
    metis = _pymetis()
    adjacency = metis.CSRAdjacency(xadj, adjncy)
    _, membership = metis.part_graph(parts, adjacency=adjacency, vweights=weights)
    return np.asarray(membership, dtype=np.int32)


def _kept_in_place(parts: np.ndarray, now: np.ndarray, weights: np.ndarray, size: int):
    """``parts`` renumbered so that each goes to the rank that holds most of it now.

    METIS numbers its parts arbitrarily; given to the ranks as numbered, most points
    would change rank. Greedily, the heaviest overlap of a part and a rank first.

    Args:
        parts: The part of each cell (n,).
        now: The rank that owns each cell now (n,).
        weights: Each cell's weight (n,).
        size: The number of parts and ranks.
    """
    overlap = np.zeros((size, size))
    np.add.at(overlap, (parts, now), weights)
    rank_of = np.full(size, -1)
    taken = np.zeros(size, dtype=bool)
    for flat in np.argsort(-overlap, axis=None, kind="stable"):
        part, rank = divmod(int(flat), size)
        if rank_of[part] < 0 and not taken[rank]:
            rank_of[part], taken[rank] = rank, True
    return rank_of[parts].astype(np.int32)


def _pymetis():
    """The ``pymetis`` module, loaded so that it calls its own METIS.

    PETSc, loaded with DOLFINx, brings a METIS of its own into the process's global
    symbols; pymetis's extension would bind to it and crash (its index width and
    options differ). ``RTLD_DEEPBIND`` makes the extension prefer its own copy. A
    pymetis imported before PETSc needs nothing; one imported after it without this
    (by the user) cannot be fixed here.
    """
    if "pymetis" in sys.modules:
        return sys.modules["pymetis"]
    flags = sys.getdlopenflags()
    sys.setdlopenflags(flags | getattr(os, "RTLD_DEEPBIND", 0))
    try:
        import pymetis
    except ImportError as err:
        raise ImportError(
            "fe-mpm balances the points over MPI ranks with pymetis: pip install pymetis "
            "(or pass rebalance_above=None to Simulation)"
        ) from err
    finally:
        sys.setdlopenflags(flags)
    return pymetis


def dual_graph(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cells' facet adjacency in CSR form (xadj, adjncy), for METIS.

    Args:
        cells: The nodes of each simplex, shape (n, t + 1).
    """
    n, k = cells.shape
    # Each facet leaves out one node; sorted, equal rows are one facet of two cells.
    facets = np.sort(np.concatenate([np.delete(cells, j, axis=1) for j in range(k)]), axis=1)
    owner = np.tile(np.arange(n), k)
    order = np.lexsort(facets.T[::-1])
    facets, owner = facets[order], owner[order]
    shared = np.flatnonzero(np.all(facets[1:] == facets[:-1], axis=1))
    a, b = owner[shared], owner[shared + 1]
    source, target = np.concatenate([a, b]), np.concatenate([b, a])
    order = np.argsort(source, kind="stable")
    xadj = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(source, minlength=n), out=xadj[1:])
    return xadj, target[order].astype(np.int64)


def owners_of_original_cells(mesh: dolfinx.mesh.Mesh, original: np.ndarray) -> np.ndarray:
    """Where each cell of the given original indices is owned now: (rank, local cell).

    Collective; every rank asks for its own cells. The ranks answer through a
    directory: the cell of original index i is registered on rank i mod size.

    Args:
        mesh: The grid.
        original: Original cell indices (n,).

    Returns:
        Shape (n, 2): the owning rank and the cell's local index there.
    """
    comm, tdim = mesh.comm, mesh.topology.dim
    owned = mesh.topology.index_map(tdim).size_local
    mine = owned_original_cells(mesh)
    original = np.asarray(original, dtype=np.int64)
    if comm.size == 1:
        where = np.full(int(mine.max(initial=-1)) + 1, -1, dtype=np.int64)
        where[mine] = np.arange(owned)
        return np.column_stack([np.zeros_like(original), where[original]])
    size = comm.size
    entries = np.column_stack([mine, np.full(owned, comm.rank), np.arange(owned)])
    registered = np.concatenate(comm.alltoall([entries[mine % size == r] for r in range(size)]))
    asked = comm.alltoall([original[original % size == r] for r in range(size)])
    order = np.argsort(registered[:, 0])
    keys = registered[order, 0]
    at = [np.searchsorted(keys, q) for q in asked]
    known = all(np.all(i < keys.size) and np.array_equal(keys[i], q) for i, q in zip(at, asked))
    parallel.raise_together(
        comm, None if known else ValueError("owners_of_original_cells: no such original cell")
    )
    replies = comm.alltoall([registered[order[i], 1:] for i in at])
    out = np.empty((original.size, 2), dtype=np.int64)
    for r in range(size):
        out[original % size == r] = replies[r]
    return out


def owned_original_cells(mesh: dolfinx.mesh.Mesh, fallback: bool = False) -> np.ndarray:
    """The original (input) index of each owned cell (owned,).

    A grid cut from another by ``dolfinx.mesh.create_submesh`` has none (DOLFINx
    0.11: "Mixed topology unsupported"; found 2026-12-06 by a helper, whose slotted
    grid stopped its first output, as ``benchmarks/tank_drain.py``'s did). With
    ``fallback`` the cells' global indices stand in (they change with the number of
    ranks); without, it is refused with what needs the numbering.

    Raises:
        ValueError: No original indices and no fallback.
    """
    owned = mesh.topology.index_map(mesh.topology.dim).size_local
    try:
        return np.asarray(mesh.topology.original_cell_index[:owned], dtype=np.int64)
    except RuntimeError as err:
        if fallback:
            cell_map = mesh.topology.index_map(mesh.topology.dim)
            return np.asarray(cell_map.local_to_global(np.arange(owned, dtype=np.int32)))
        raise ValueError(
            f"the grid has no original cell indices ({str(err).rstrip('.')}: a grid made by "
            "dolfinx.mesh.create_submesh): checkpoints and repartitions need them; build "
            "the grid with create_mesh, create_rectangle/box or from gmsh (a cut-out "
            "region can be drawn in gmsh)"
        ) from None


def original_indices(
    mesh: dolfinx.mesh.Mesh, where: np.ndarray, fallback: bool = False
) -> np.ndarray:
    """The original index of each cell given as (rank, local cell); collective.

    Args:
        mesh: The grid.
        where: Shape (n, 2): the rank that owns each cell and its local index there.
        fallback: Whether a grid without original indices gives global ones instead
            (:func:`owned_original_cells`).

    Returns:
        Original cell indices (n,).
    """
    comm = mesh.comm
    mine = owned_original_cells(mesh, fallback)
    where = np.asarray(where, dtype=np.int64).reshape(-1, 2)
    if comm.size == 1:
        return mine[where[:, 1]]
    asked = comm.alltoall([where[where[:, 0] == r, 1] for r in range(comm.size)])
    replies = comm.alltoall([mine[q] for q in asked])
    out = np.empty(where.shape[0], dtype=np.int64)
    for r in range(comm.size):
        out[where[:, 0] == r] = replies[r]
    return out


def carried_facet_tags(
    tags: dolfinx.mesh.MeshTags, old: dolfinx.mesh.Mesh, new: dolfinx.mesh.Mesh
) -> dolfinx.mesh.MeshTags:
    """The facet tags of ``old`` on ``new``, a repartition of the same grid; collective.

    A facet is known by its nodes' input indices, the same on both grids.
    """
    fdim = old.topology.dim - 1
    keys, values = _facet_keys(old, tags.indices), np.asarray(tags.values)
    keys = np.concatenate(old.comm.allgather(keys))
    values = np.concatenate(old.comm.allgather(values))
    keys, first = np.unique(keys, axis=0, return_index=True)
    values = values[first]
    new.topology.create_entities(fdim)
    facet_map = new.topology.index_map(fdim)
    candidates = np.arange(facet_map.size_local + facet_map.num_ghosts, dtype=np.int32)
    theirs = _facet_keys(new, candidates)
    at = _rows_in(theirs, keys)
    found = at >= 0
    return dolfinx.mesh.meshtags(
        new, fdim, candidates[found], values[at[found]].astype(np.asarray(tags.values).dtype)
    )


def _facet_keys(mesh: dolfinx.mesh.Mesh, facets: np.ndarray) -> np.ndarray:
    """The sorted input node indices of each facet (n, t)."""
    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
    nodes = dolfinx.mesh.entities_to_geometry(mesh, fdim, np.asarray(facets, dtype=np.int32))
    inputs = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)
    return np.sort(inputs[nodes], axis=1).reshape(-1, fdim + 1)


def _rows_in(rows: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Each row's index in ``table`` (unique rows, as ``np.unique`` gives); −1 if absent."""
    if table.shape[0] == 0:
        return np.full(rows.shape[0], -1)
    both = np.concatenate([table, rows])
    _, inverse = np.unique(both, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    # table is unique, so its rows are the first len(table) labels; map label -> table row.
    label_to_row = np.full(inverse.max() + 1, -1)
    label_to_row[inverse[: table.shape[0]]] = np.arange(table.shape[0])
    return label_to_row[inverse[table.shape[0] :]]
