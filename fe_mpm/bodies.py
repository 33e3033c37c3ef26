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
    local_nodes = mesh.geometry.dofmaps[0][occupied]
    index_map = mesh.geometry.index_map()
    global_nodes = index_map.local_to_global(local_nodes.ravel().astype(np.int32))
    gathered = parallel.gathered(mesh.comm, global_nodes.reshape(local_nodes.shape))
    labels = body_labels(gathered)
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
    occupied = np.unique(cells[cells >= 0])
    local_nodes = mesh.geometry.dofmaps[0][occupied]
    index_map = mesh.geometry.index_map()
    global_nodes = index_map.local_to_global(local_nodes.ravel().astype(np.int32))
    gathered = parallel.gathered(mesh.comm, global_nodes.reshape(local_nodes.shape))
    labels = body_labels(gathered)
    return int(labels.max(initial=-1)) + 1
