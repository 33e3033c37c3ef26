"""The separate bodies the material forms on the grid: groups of cells that share no node."""

from __future__ import annotations

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.errors import warn


def body_labels(cell_nodes: np.ndarray, nodes: int | None = None) -> np.ndarray:
    """A label per cell, the same for cells joined through shared nodes, (cells,).

    Hooks each cell's nodes to their lowest label and halves the paths to the roots
    (pointer jumping) until every cell's nodes agree: a few sweeps, not one per cell
    across the body.

    Args:
        cell_nodes: The nodes of each cell (cells, nodes per cell), any integers.
        nodes: If given, the nodes are already numbered 0 … ``nodes`` − 1 (a rank's
            local nodes), which spares renumbering them (most of the time on 10⁵ cells).

    Returns:
        Each cell's body, numbered 0, 1, … in order of first appearance.
    """
    if cell_nodes.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    if nodes is None:
        numbered, local = np.unique(cell_nodes, return_inverse=True)
        local, nodes = local.reshape(cell_nodes.shape), numbered.size
    else:
        local = cell_nodes
    parent = np.arange(nodes)
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

    Each rank finds the bodies of its own cells; only the nodes that ranks share
    travel, with the local body they belong to, and every rank joins the local
    bodies that meet at one (collective). So the cost per rank grows with its cells
    and the partition's interface, not with the whole grid: cheap enough for a check
    at every step (:class:`TearWatch`).

    Args:
        mesh: The grid.
        cells: This rank's occupied cells (local indices; repeats and -1 ignored).

    Returns:
        ``np.unique(cells[cells >= 0])``'s bodies (numbered alike on every rank), and
        the number of bodies over all ranks.
    """
    dofmap = mesh.geometry.dofmaps[0]
    nodes = dofmap[_each_once(cells, dofmap.shape[0])]
    local = body_labels(nodes, mesh.geometry.x.shape[0])
    comm = mesh.comm
    if comm.size == 1:
        return local, int(local.max(initial=-1)) + 1
    here = int(local.max(initial=-1)) + 1
    first = comm.exscan(here) or 0  # (exscan leaves rank 0's None)
    everywhere = comm.allreduce(here)
    index_map = mesh.geometry.index_map()
    at_shared = _shared_nodes(index_map)[nodes]
    meeting = np.column_stack(
        [
            index_map.local_to_global(nodes[at_shared].astype(np.int32)),
            first + np.broadcast_to(local[:, None], nodes.shape)[at_shared],
        ]
    )
    meeting = parallel.gathered(comm, meeting.astype(np.int64))
    # A table of "cells" that body_labels joins through shared "nodes": one row per
    # local body (itself twice, so it counts alone), one per (shared node, local body),
    # the nodes numbered after the bodies.
    itself = np.repeat(np.arange(everywhere, dtype=np.int64)[:, None], 2, axis=1)
    joins = np.column_stack([meeting[:, 1], everywhere + meeting[:, 0]])
    body = body_labels(np.vstack([itself, joins]))[:everywhere]
    return body[first + local], int(body.max(initial=-1)) + 1


def _each_once(cells: np.ndarray, count: int) -> np.ndarray:
    """``np.unique(cells[cells >= 0])`` for cells numbered below ``count``, in linear time."""
    seen = np.zeros(count, dtype=bool)
    seen[cells[cells >= 0]] = True
    return np.flatnonzero(seen)


def _shared_nodes(index_map) -> np.ndarray:
    """Whether each of this rank's nodes is on another rank too, (local nodes,) bool.

    Its ghosts, and the owned nodes that other ranks ghost (collective).
    """
    count = dolfinx.la.vector(index_map, 1, dtype=np.int32)
    count.array[index_map.size_local :] = 1
    count.scatter_reverse(dolfinx.la.InsertMode.add)
    shared = count.array > 0
    shared[index_map.size_local :] = True
    return shared


def count_bodies(mesh: dolfinx.mesh.Mesh, cells: np.ndarray) -> int:
    """How many separate bodies the material in ``cells`` forms, over all ranks.

    Two occupied cells belong to one body when a chain of occupied cells, each
    sharing a node with the next, joins them: bodies that touch at the start are one.
    Collective (:func:`bodies_of_cells`).

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


#: What a dynamic run with point domains says when two of its bodies meet.
DOMAINS_MEETING = (
    "two bodies of the material had met: their occupied cells share a node, so the "
    "grid's single velocity field joins them (MPM has no contact between bodies of its "
    "own). With point_domains=True that meeting creates energy: two elastic bars "
    "closing at 0.1 m/s pushed on each other from two cells apart and left at 1.074 "
    "times their speed, their strain energy peaking at 2.9 times the start (11.6 "
    "times on a finer grid), where standard MPM kept the energy to 0.5 % (a helper's "
    "scene, 2026-12-07): each point keeps its domain's corner map while its pieces "
    "balance with their cells' own increments. shared_increment=True (serial) kept "
    "that impact's energy to 1.1 % (the bars left at 0.98 times their speed, the "
    "contact still starting two cells early); standard MPM is the reference for "
    "impacts between bodies (said once)."
)


#: What a dynamic run of standard MPM says when two of its elastic bodies meet.
GRID_MEETING = (
    "two bodies of the material had met: their occupied cells share a node, so the "
    "grid's single velocity field joins them. MPM has no contact between bodies of its "
    "own, and that joint pulls as well as pushes, from up to two cells apart: two "
    "equal elastic bars, one striking the other at rest, pulled on each other (3.1 "
    "ρ c v at the striker's face), moved together for about three wave transits and "
    "parted with a restitution of 0.60, where the same impact seen from their centre "
    "of mass parted at 0.98 (a helper's scene, 2026-12-07). An impact on a rigid body "
    "is a RigidWall's, which pushes only (said once)."
)


class TearWatch:
    """Warns, once, when a run's material comes apart into more bodies.

    Watched in static runs and in dynamic runs of elastic solids (in a plastic or
    fluid flow a grain or a splash may fly off): their laws have no fracture, so
    material that splits is the grid losing hold of points. Standard MPM ties two
    points only through the cells they share, and a strip stretched until its points
    lie more than a cell apart tore, lost the force across the gap (1e-9 N of 2.7e5
    at λ = 3) and converged in every step (a new user's scene, 2026-12-07). Point
    domains tile the body and kept that strip whole to within 0.003 %.

    Counted at each step's start and after a run's last step (or at ``close()``),
    against the count at the first step: bodies that touch later and part again (a
    contact) are not told, nor a tear that only brings the count back to the first.

    Attributes:
        bodies_at_start: How many bodies the material formed at the first step, or
            at the first step after points were added or removed (None until then:
            :meth:`Simulation.add_points` and ``remove_points`` set it so).
        warned: Whether the run was warned.
    """

    def __init__(self) -> None:
        self.bodies_at_start: int | None = None
        self.warned = False
        self.meeting_warned = False  # bodies met in dynamics (said once)
        self._counted_at: float | None = None  # the time of the points last counted

    def look(
        self,
        mesh: dolfinx.mesh.Mesh,
        occupied: np.ndarray,
        t: float,
        *,
        domains: bool,
        dynamic: bool = False,
    ) -> None:
        """Count the bodies the material forms now and warn if there are more (collective).

        In a dynamic run, fewer bodies than at the start (two that met) are warned
        about too: :data:`DOMAINS_MEETING` with point domains, :data:`GRID_MEETING`
        without.

        Args:
            mesh: The grid.
            occupied: This rank's occupied cells (local indices; repeats and -1 ignored).
            t: The time the points have reached (s).
            domains: Whether the points carry domains (the advice differs).
            dynamic: Whether the run is dynamic.
        """
        meeting = dynamic and not self.meeting_warned
        if (self.warned and not meeting) or (
            t == self._counted_at and self.bodies_at_start is not None
        ):
            return  # said once, or counted where the points lie now (run's end, close)
        self._counted_at = t
        body, count = bodies_of_cells(mesh, occupied)
        if self.bodies_at_start is None:  # the first step, or points added or removed
            self.bodies_at_start = count
            return
        if meeting and count < self.bodies_at_start:
            self.meeting_warned = True
            warn(f"By t = {t:g} {DOMAINS_MEETING if domains else GRID_MEETING}")
        if self.warned or count <= self.bodies_at_start:
            return
        self.warned = True
        occupied = _each_once(occupied, mesh.geometry.dofmaps[0].shape[0])  # body's order
        cells = parallel.total(mesh.comm, np.bincount(body, minlength=count))
        least = int(np.argmin(cells))
        g = mesh.geometry.dim
        corners = mesh.geometry.x[mesh.geometry.dofmaps[0][occupied[body == least]], :g]
        lo = parallel.smallest(mesh.comm, corners.reshape(-1, g).min(axis=0, initial=np.inf))
        hi = parallel.largest(mesh.comm, corners.reshape(-1, g).max(axis=0, initial=-np.inf))
        if domains:
            advice = (
                "Point domains tile the body, so a gap means that domains redrawn when "
                "they distorted no longer meet"
            )
        else:
            advice = (
                "Standard MPM ties points only through the cells they share: a body "
                "stretched until its points lie more than a cell apart tears, and the "
                "force across the gap is lost while every step converges. "
                "point_domains=True keeps a stretched body whole"
            )
        warn(
            f"By t = {t:g} the material had come apart: its occupied cells form {count} "
            f"groups that share no node, where there were {self.bodies_at_start} at the "
            f"start (cells in each: {cells.tolist() if count <= 6 else '…'}; the "
            f"smallest lies in the box from {lo.round(6).tolist()} to "
            f"{hi.round(6).tolist()}). The laws here do not fracture, so this is the "
            f"grid letting go. {advice}. Bodies that touch at the start count "
            "as one: the grid's nodes glue them, with no contact between them, until "
            "they part (docs/user_scenes.md, Supports and loads; said once)."
        )
