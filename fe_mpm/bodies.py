"""The separate bodies the material forms on the grid: groups of cells that share no node."""

from __future__ import annotations

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx


def body_labels(cell_nodes: np.ndarray) -> np.ndarray:
    """A label per cell, the same for cells joined through shared nodes, (cells,).

    Hooks each cell's nodes to their lowest label and halves the paths to the roots
    (pointer jumping) until every cell's nodes agree: a few sweeps, not one per cell
    across the body.

    Args:
        cell_nodes: The nodes of each cell (cells, nodes per cell), any integers.

    Returns:
        Each cell's body, numbered 0, 1, … in order of first appearance.
    """
    if cell_nodes.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    nodes, local = np.unique(cell_nodes, return_inverse=True)
    local = local.reshape(cell_nodes.shape)
    parent = np.arange(nodes.size)
    while True:
        roots = parent[local]
        lowest = roots.min(axis=1)
        if np.all(roots.max(axis=1) == lowest):
            break
        np.minimum.at(parent, roots.ravel(), np.repeat(lowest, local.shape[1]))
        while True:  # every node straight to its root
            jumped = parent[parent]
            if np.array_equal(jumped, parent):
                break
            parent = jumped
    _, first, body = np.unique(parent[local[:, 0]], return_index=True, return_inverse=True)
    return np.argsort(np.argsort(first))[body]


def _gathered_globally(comm, index_map, local: np.ndarray) -> np.ndarray:
    """Every rank's rows of local entity indices ``local`` (n, k), as global indices."""
    ids = index_map.local_to_global(local.ravel().astype(np.int32)).reshape(local.shape)
    return parallel.gathered(comm, ids)


def bodies_of_cells(mesh: dolfinx.mesh.Mesh, cells: np.ndarray) -> tuple[np.ndarray, int]:
    """The body of each of this rank's occupied cells, and how many bodies there are.

    As :func:`count_bodies` (collective; gathers the occupied cells' nodes).

    Args:
        mesh: The grid.
        cells: This rank's occupied cells (local indices; repeats and -1 ignored).

    Returns:
        ``np.unique(cells[cells >= 0])``'s bodies (numbered alike on every rank), and
        the number of bodies over all ranks.
    """
    occupied = np.unique(cells[cells >= 0])
    nodes = mesh.geometry.dofmaps[0][occupied]
    labels = body_labels(_gathered_globally(mesh.comm, mesh.geometry.index_map(), nodes))
    counts = mesh.comm.allgather(occupied.size) if mesh.comm.size > 1 else [occupied.size]
    start = int(sum(counts[: mesh.comm.rank]))
    return labels[start : start + occupied.size], int(labels.max(initial=-1)) + 1


def count_bodies(mesh: dolfinx.mesh.Mesh, cells: np.ndarray) -> int:
    """How many separate bodies the material in ``cells`` forms, over all ranks.

    Two occupied cells belong to one body when a chain of occupied cells, each
    sharing a node with the next, joins them: bodies that touch at the start are one.
    Gathers the occupied cells' nodes on every rank; meant for a check at set-up.

    Args:
        mesh: The grid.
        cells: This rank's occupied cells (local indices; repeats and -1 ignored).
    """
    return bodies_of_cells(mesh, cells)[1]


def joined_at_a_node(mesh: dolfinx.mesh.Mesh, cells: np.ndarray) -> np.ndarray | None:
    """Where parts of the material touch at a node only, if they do (collective).

    Occupied cells that share a facet form a part; two parts that share nodes but no
    facet are joined by a hinge (in 2D) or a ball (at a node in 3D), about which one
    turns freely unless each is held: two blocks stacked corner to corner failed a
    static step with no hint (a helper's scene, 2026-12-06). Gathers the occupied
    cells' facets and nodes on every rank; meant for a stop message.

    Args:
        mesh: The grid.
        cells: This rank's occupied cells (local indices; repeats and -1 ignored).

    Returns:
        The coordinates (g,) of a node where two parts meet, the same on every rank,
        or None.
    """
    tdim, g = mesh.topology.dim, mesh.geometry.dim
    occupied = np.unique(cells[cells >= 0])
    mesh.topology.create_connectivity(tdim, tdim - 1)
    to_facets = mesh.topology.connectivity(tdim, tdim - 1)
    # Every simplex has d + 1 facets: the adjacency list is a table.
    local_facets = to_facets.array.reshape(-1, tdim + 1)[occupied].astype(np.int32)
    facets = _gathered_globally(mesh.comm, mesh.topology.index_map(tdim - 1), local_facets)
    local_nodes = mesh.geometry.dofmaps[0][occupied]
    nodes = _gathered_globally(mesh.comm, mesh.geometry.index_map(), local_nodes)
    coordinates = parallel.gathered(mesh.comm, mesh.geometry.x[local_nodes, :g])
    part = body_labels(facets)
    if part.size == 0 or part.max() == body_labels(nodes).max():
        return None  # each body is one part
    # A node whose cells lie in more than one part.
    flat_nodes, flat_parts = nodes.ravel(), np.repeat(part, nodes.shape[1])
    pairs = np.unique(np.column_stack([flat_nodes, flat_parts]), axis=0)
    node_ids, counts = np.unique(pairs[:, 0], return_counts=True)
    shared = node_ids[counts > 1]
    if shared.size == 0:
        return None
    where = np.flatnonzero(flat_nodes == shared[0])[0]
    return coordinates.reshape(-1, g)[where]
