"""Locate points in the background grid: a vectorised barycentric walk.

The grid is reset after every step, so it never moves: the inverse affine maps
and the facet neighbours of all cells are computed once. Each step starts every
point in the cell it was in before and walks across the facet with the most
negative barycentric coordinate until all coordinates are non-negative. Points
the walk does not settle (it left the grid, or took too many steps) go to a
bounding-box tree search. Everything is numpy over all points at once.

A point on a facet, an edge or a vertex lies in every cell that touches it, and which
one a walk or a search ends in depends on where it started and on how the cells are
numbered, which differs between a serial run and one on several ranks. So a point
within :data:`TIE` of a facet of its cell takes the cell that holds it moved by a
tiny fixed vector (:data:`NUDGE` of the smallest cell's size along
:data:`DIRECTION`, a direction along no facet of a structured grid): the same cell
whatever the partition. Where that moved point leaves the grid (a point on the
grid's edge), the directions with the signs of their components flipped are tried
in a fixed order (:attr:`Tracker.nudges`), and where every one leaves it, the
point keeps a cell that holds it.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx

#: Barycentric coordinates down to ``-BARY_TOL`` count as inside: points on
#: facets and vertices belong to any cell that touches them.
BARY_TOL = 1e-12
#: How far outside a cell (in barycentric units) a point on its facet may lie.
ON_FACET = 1e-6
#: A point whose smallest barycentric coordinate in its cell is below this may lie
#: on a facet, and takes the cell of its nudged position (module docstring).
TIE = 1e-8
#: Length of the nudge that breaks ties, as a fraction of the grid's smallest cell
#: size (longest edge): far below TIE, so only a point on a facet changes cell.
NUDGE = 1e-9
#: Direction of the nudge (unit vector; its first g components, normalised, in 2D).
DIRECTION = np.array([1.0, np.sqrt(2.0) - 1.0, (np.sqrt(5.0) - 2.0)])
#: Two cells hold a point outside them equally well (:meth:`Tracker.snap_to`) when
#: their smallest barycentric coordinates differ by less than this, and are equally
#: near when their centroids' squared distances differ by less than this fraction.
EQUAL_HOLD = 1e-12


def preferred(x: np.ndarray, score: np.ndarray, centroid: np.ndarray) -> int:
    """Which of several cells takes a point ``x`` (g,) from outside: an index into them.

    The largest ``score`` (each cell's smallest barycentric coordinate at ``x``);
    among scores within :data:`EQUAL_HOLD` of it, the cell whose centroid is
    nearest; among those equally near, the lowest centroid (x, then y, then z).
    Ties are common on structured grids (a point beside two triangles of a square),
    and breaking them by the cells' order on a rank made two ranks read a platen
    point's field from another cell than one rank did (the squeezed block of
    :func:`fe_mpm.scenes.platen_compression`); geometry is the same on every
    partition. ``centroid`` is (k, 3) or (k, g); cells with score −inf never win
    unless all do.
    """
    near = score >= np.max(score) - EQUAL_HOLD
    g = x.shape[0]
    d2 = np.where(near, np.sum((centroid[:, :g] - x) ** 2, axis=1), np.inf)
    near &= d2 <= d2.min() * (1.0 + EQUAL_HOLD)
    candidates = np.flatnonzero(near)
    keys = centroid[candidates, :g]
    return int(candidates[np.lexsort(keys.T[::-1])[0]])


class Tracker:
    """Finds the cell of each point among this rank's cells of a fixed affine simplex mesh.

    Args:
        mesh: Triangle or tetrahedron mesh with affine geometry.
        max_walk: Walk steps before a point is handed to the tree search.
        ghosts: Whether this rank's ghost cells count too (after the owned ones, in
            DOLFINx's local order). A point belongs to the rank that owns its cell,
            so the points are tracked in the owned cells only; the point domains'
            pieces (:mod:`fe_mpm.domains`) are cut from ghost cells as well.
    """

    def __init__(self, mesh: dolfinx.mesh.Mesh, max_walk: int = 32, ghosts: bool = False):
        self.mesh = mesh
        self.max_walk = max_walk
        tdim = mesh.topology.dim
        gdim = mesh.geometry.dim
        cell_map = mesh.topology.index_map(tdim)
        #: Cells this tracker searches: the owned ones, and with ``ghosts`` the ghosts.
        self.num_cells = cell_map.size_local + (cell_map.num_ghosts if ghosts else 0)
        nodes_of = mesh.geometry.dofmaps[0][: self.num_cells]
        X = mesh.geometry.x[:, :gdim]
        nodes = X[nodes_of]  # (nc, t+1, g)
        self._x0 = nodes[:, 0, :].copy()
        jac = nodes[:, 1:, :] - self._x0[:, None, :]
        # x = x0 + ξ @ jac with jac rows = edge vectors, so ξ = (x - x0) @ inv(jac).
        self._jac_inv = np.linalg.inv(jac)
        #: Physical centroid of every cell, shape (nc, g).
        self.centroids = nodes.mean(axis=1)
        #: Volume (area in 2D) of every cell, shape (nc,).
        self.volumes = np.abs(np.linalg.det(jac)) / math.factorial(tdim)
        #: Longest edge of every cell (m), shape (nc,).
        edges = [nodes[:, i] - nodes[:, j] for i in range(tdim + 1) for j in range(i)]
        self.sizes = np.max([np.linalg.norm(e, axis=1) for e in edges], axis=0)
        self.neighbours = _facet_neighbours(nodes_of)
        self._nodes_of = nodes_of
        self._tree = None  # built on first need
        self._node_cells = None  # node -> cells (CSR), built on first need
        self._global_nodes = None  # nodes sorted by global index, built on first need
        self._vertex_neighbours = None  # built on first need
        self._heights = None  # each cell's largest height (m), built on first need
        #: Vertices of every cell, shape (nc, t+1, g) in m.
        self.cell_vertices = nodes
        # The same nudge on every rank: the smallest cell of the whole grid.
        smallest = parallel.smallest(mesh.comm, float(self.sizes.min(initial=np.inf)))
        direction = DIRECTION[:gdim] / np.linalg.norm(DIRECTION[:gdim])
        signs = 1.0 - 2.0 * np.array(list(itertools.product((0, 1), repeat=gdim)))
        #: The vectors (2^g, g) in m that break a tie between the cells touching a
        #: point, in the order they are tried: the first along DIRECTION.
        self.nudges = NUDGE * smallest * signs * direction

    @property
    def p1_gradients(self) -> np.ndarray:
        """The gradients of every cell's P1 basis functions (nc, t+1, g), in 1/m.

        Row ``a`` of a cell is that of local vertex ``a`` (the P1 dof order).
        """
        grads = np.swapaxes(self._jac_inv, 1, 2)  # row j: ∇ξ_j, ξ_j = (x − x0)·J⁻¹[:, j]
        return np.concatenate([-grads.sum(axis=1, keepdims=True), grads], axis=1)

    def barycentric(self, x: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """Barycentric coordinates of points ``x`` (n, g) in ``cells`` (n,), shape (n, t+1).

        Column ``i`` belongs to local vertex ``i`` of the cell (geometry order),
        which is also the local dof order of P1 spaces.
        """
        xi = np.einsum("ng,ngk->nk", x - self._x0[cells], self._jac_inv[cells])
        return np.concatenate([1.0 - xi.sum(axis=1, keepdims=True), xi], axis=1)

    def pulled_into(self, x: np.ndarray, cells: np.ndarray, tol: float = ON_FACET) -> np.ndarray:
        """Points ``x`` (n, g) moved to the nearest point of ``cells`` (n,) where outside them (m).

        A point whose smallest barycentric coordinate in its cell is below ``-tol``
        goes to the cell's nearest point (on a facet, an edge or a vertex: the
        nearest of their nearest points); the others are returned as they are, to
        the bit.
        """
        moved = np.array(x, dtype=np.float64, copy=True)
        out = np.flatnonzero(self.barycentric(x, cells).min(axis=1) < -tol)
        if out.size:
            moved[out] = nearest_in_simplices(x[out], self.cell_vertices[cells[out]])
        return moved

    def locate(self, x: np.ndarray, guess: np.ndarray | None = None) -> np.ndarray:
        """Return the cell of each point in ``x`` (n, g), or -1 for points outside the grid.

        Args:
            x: Point coordinates, shape ``(n, g)``.
            guess: Start cells for the walk, shape ``(n,)``; entries outside
                ``[0, num_cells)`` (or no guess) go straight to the tree search. Points
                seeded in a mesh of their own (a disk, a rod) arrive with cells of that
                mesh, which may number more than this grid's.
        """
        return self.locate_with_ties(x, guess)[0]

    def locate_with_ties(
        self, x: np.ndarray, guess: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`locate`, and the points whose first nudge leaves this rank's cells.

        Returns:
            The cells (n,), −1 outside this rank's cells, and the indices of the
            points found here whose position nudged along the first of
            :attr:`nudges` is not: on the grid's edge, or on a facet this rank
            shares with another, whose cell may hold it
            (:func:`fe_mpm.migration.migrate` asks every rank).
        """
        n = x.shape[0]
        cells = np.full(n, -1, dtype=np.int32)
        smallest = np.full(n, -np.inf)  # each point's smallest coordinate in its cell
        if guess is None:
            todo = np.arange(n)
        else:
            guess = np.asarray(guess, dtype=np.int32)
            usable = (guess >= 0) & (guess < self.num_cells)
            walking = np.flatnonzero(usable)
            cells[walking] = guess[walking]
            lost = self._walk(x, cells, walking, smallest=smallest)
            todo = np.concatenate([np.flatnonzero(~usable), lost])
        if todo.size:
            cells[todo] = searched = self._tree_search(x[todo])
            todo = todo[searched >= 0]
            smallest[todo] = self.barycentric(x[todo], cells[todo]).min(axis=1)
        pending = np.flatnonzero((cells >= 0) & (smallest < TIE))
        ties = None
        for nudge in self.nudges:
            if pending.size == 0:
                break
            nudged = x[pending] + nudge
            moved = cells[pending]
            lost = self._walk(nudged, moved, np.arange(pending.size), tol=0.0)
            if lost.size:
                moved[lost] = self.holding(nudged[lost], tol=0.0)
            cells[pending[moved >= 0]] = moved[moved >= 0]
            pending = pending[moved < 0]
            if ties is None:
                ties = pending
        return cells, np.empty(0, dtype=np.int64) if ties is None else ties

    def snap_to(
        self,
        x: np.ndarray,
        cells: np.ndarray,
        allowed: np.ndarray,
        tol: float | np.ndarray = ON_FACET,
    ) -> np.ndarray:
        """Move points whose cell is not ``allowed`` to an allowed cell touching it, if close.

        A point on a facet between an empty and an occupied cell belongs to
        either; boundary points must read the occupied one. Among the allowed
        cells sharing a vertex with the point's cell, the one with the largest
        smallest barycentric coordinate is taken if that is ≥ −tol.

        Args:
            x: Points (n, g).
            cells: Their cells (n,), from :meth:`locate`.
            allowed: Boolean mask over all cells.
            tol: How far outside an allowed cell a point may be, in barycentric
                units and, as a distance, in the cell's largest heights
                (:meth:`within_reach`): one number or one per point (n,); a point
                on a facet (``ON_FACET`` out) always counts.

        Returns:
            Cells (n,): the allowed cell, or -1 where none is close enough.
        """
        out = np.where(allowed[np.maximum(cells, 0)] & (cells >= 0), cells, -1).astype(np.int32)
        tol = np.maximum(np.broadcast_to(tol, cells.shape), ON_FACET)
        for i in np.flatnonzero((out < 0) & (cells >= 0)):
            score, cell = self._best_allowed(x[i], self._nodes_of[cells[i]], allowed, tol[i])
            if score >= -tol[i]:
                out[i] = cell
        return out

    def within_reach(self, x: np.ndarray, cells: np.ndarray, tol: float | np.ndarray) -> np.ndarray:
        """Whether points ``x`` (n, g) lie within ``tol`` times their cell's height of it.

        The distance from each point to its cell in ``cells`` (n,), against ``tol``
        times the cell's largest height (m). A least barycentric coordinate of
        −tol puts a point that distance out across a facet from the vertex
        opposite, but a cell that only shares a vertex or an edge with the point's
        own can hold a point far off with a mild one (a tetrahedron whose facets
        run nearly along the line to the point): this bounds the distance itself.
        """
        if self._heights is None:
            self._heights = 1.0 / np.linalg.norm(self.p1_gradients, axis=2).min(axis=1)
        nearest = nearest_in_simplices(x, self.cell_vertices[cells])
        tol = np.maximum(np.broadcast_to(tol, cells.shape), ON_FACET)
        return np.linalg.norm(x - nearest, axis=1) <= tol * self._heights[cells]

    def _best_allowed(
        self, x: np.ndarray, nodes: np.ndarray, allowed: np.ndarray, tol: float
    ) -> tuple[float, int]:
        """The allowed cell at ``nodes`` that holds the point ``x`` (g,) best.

        Among the allowed cells at any of the (local) ``nodes`` that lie within reach
        of ``x`` (:meth:`within_reach` with ``tol``), the one whose smallest
        barycentric coordinate at ``x`` is largest: (that coordinate, the cell);
        (−inf, −1) if none. (Taking the best coordinate first and asking its reach
        after left a point with no cell where another lay within reach, the review
        of 2026-12-07.)
        """
        owner, starts = self._cells_of_nodes()
        candidates = np.unique(np.concatenate([owner[starts[v] : starts[v + 1]] for v in nodes]))
        candidates = candidates[allowed[candidates]]
        if candidates.size:
            near = np.repeat(x[None, :], candidates.size, axis=0)
            reach = self.within_reach(near, candidates, tol)
            candidates, near = candidates[reach], near[reach]
        if candidates.size == 0:
            return -np.inf, -1
        lam = self.barycentric(near, candidates)
        best = preferred(x, lam.min(axis=1), self.centroids[candidates])
        return float(lam[best].min()), int(candidates[best])

    def claim(
        self, x: np.ndarray, allowed: np.ndarray, tol: float | np.ndarray = ON_FACET
    ) -> tuple[np.ndarray, np.ndarray]:
        """Locate points that every rank holds and give each to one rank's allowed cell.

        :meth:`locate` then :meth:`snap_to` across the ranks of a distributed grid,
        for points held on every rank (boundary points): a point goes to the rank
        whose owned, allowed cell holds it (the lowest such rank on a shared
        facet); failing that, to the allowed cell, on any rank, that shares a
        vertex with the point's cell and has the largest smallest barycentric
        coordinate, if that is ≥ −tol. On one rank this is ``snap_to(x, locate(x))``.
        Collective.

        Args:
            x: Points (n, g), the same on every rank.
            allowed: Boolean mask over this rank's cells.
            tol: As in :meth:`snap_to`.

        Returns:
            ``cells``: the point's cell on this rank, or −1 where another rank (or
            none) takes it; ``found``: whether some rank's cell holds the point (n,).
        """
        comm = self.mesh.comm
        cells, ties = self.locate_with_ties(x)
        if comm.size == 1:
            return self.snap_to(x, cells, allowed, tol), cells >= 0
        n, rank = x.shape[0], comm.rank
        here = cells >= 0
        inside = here & allowed[np.maximum(cells, 0)]
        # The lowest rank whose cell holds the point is its host; one holding it in an
        # allowed cell takes it outright. A point on a facet between ranks goes to the
        # rank that holds its nudged position, as on one rank.
        settled = here.copy()
        settled[ties] = False
        host = _lowest_rank_of(comm, settled, here)
        taker = _lowest_rank_of(comm, settled & inside, inside)
        found, taken = host < comm.size, taker < comm.size
        out = np.where(taker == rank, cells, -1).astype(np.int32)
        # The host's cell's nodes, by global index, for every rank to find its cells there.
        index_map = self.mesh.geometry.index_map()
        k = self._nodes_of.shape[1]
        nodes = np.full((n, k), -1, dtype=np.int64)
        mine = np.flatnonzero(host == rank)
        local = self._nodes_of[cells[mine]].ravel().astype(np.int32)
        nodes[mine] = index_map.local_to_global(local).reshape(-1, k)
        nodes = parallel.largest(comm, nodes)
        score, choice = np.full(n, -np.inf), np.full(n, -1, dtype=np.int32)
        tol_n = np.maximum(np.broadcast_to(tol, (n,)), ON_FACET)
        centroid = np.zeros((n, self.centroids.shape[1]))
        order, sorted_globals = self._nodes_by_global_index()
        starts = self._cells_of_nodes()[1]
        for i in np.flatnonzero(found & ~taken):
            at = np.minimum(np.searchsorted(sorted_globals, nodes[i]), order.size - 1)
            local_nodes = order[at][sorted_globals[at] == nodes[i]]
            local_nodes = local_nodes[local_nodes < starts.size - 1]
            if local_nodes.size:
                score[i], choice[i] = self._best_allowed(x[i], local_nodes, allowed, tol_n[i])
                if choice[i] >= 0:
                    centroid[i] = self.centroids[choice[i]]
        scores = np.array(comm.allgather(score))  # (ranks, n)
        centroids = np.array(comm.allgather(centroid))  # (ranks, n, 3)
        # The rule of one rank across the ranks' best cells: the same cell on any partition.
        winner = np.argmax(scores, axis=0)
        for i in np.flatnonzero(found & ~taken):
            winner[i] = preferred(x[i], scores[:, i], centroids[:, i])
        close = scores[winner, np.arange(n)] >= -tol_n
        snapped = found & ~taken & close & (winner == rank)
        out[snapped] = choice[snapped]
        return out, found

    def _nodes_by_global_index(self) -> tuple[np.ndarray, np.ndarray]:
        """This rank's geometry nodes sorted by global index: (local order, global indices).

        The grid never moves, so this is computed once.
        """
        if self._global_nodes is None:
            index_map = self.mesh.geometry.index_map()
            on_rank = index_map.local_to_global(
                np.arange(index_map.size_local + index_map.num_ghosts, dtype=np.int32)
            )
            order = np.argsort(on_rank)
            self._global_nodes = (order, on_rank[order])
        return self._global_nodes

    def vertex_neighbours(self) -> np.ndarray:
        """The cells that share a vertex with each cell, itself included (nc, s), padded with -1.

        Computed once; ``s`` is the largest such count in the grid.
        """
        if self._vertex_neighbours is None:
            owner, starts = self._cells_of_nodes()
            nodes = self._nodes_of.ravel()
            counts = starts[nodes + 1] - starts[nodes]
            first = np.repeat(starts[nodes], counts)
            within = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
            cell = np.repeat(np.arange(nodes.size) // self._nodes_of.shape[1], counts)
            pairs = np.unique(cell.astype(np.int64) * self.num_cells + owner[first + within])
            cell, other = np.divmod(pairs, self.num_cells)
            per_cell = np.bincount(cell, minlength=self.num_cells)
            column = np.arange(cell.size) - np.repeat(np.cumsum(per_cell) - per_cell, per_cell)
            table = np.full((self.num_cells, per_cell.max()), -1, dtype=np.int32)
            table[cell, column] = other
            self._vertex_neighbours = table
        return self._vertex_neighbours

    def _cells_of_nodes(self) -> tuple[np.ndarray, np.ndarray]:
        """Node -> cells as CSR: the cells of node v are ``owner[starts[v]:starts[v + 1]]``."""
        if self._node_cells is None:
            flat = self._nodes_of.ravel()
            order = np.argsort(flat, kind="stable")
            starts = np.searchsorted(flat[order], np.arange(flat.max() + 2))
            self._node_cells = (order // self._nodes_of.shape[1], starts)
        return self._node_cells

    def _walk(
        self,
        x: np.ndarray,
        cells: np.ndarray,
        active: np.ndarray,
        tol: float = BARY_TOL,
        smallest: np.ndarray | None = None,
    ) -> np.ndarray:
        """Walk the points ``active`` from ``cells`` in place; return those not settled.

        A point counts as inside a cell down to barycentric coordinates of ``-tol``.
        ``smallest`` (n,), if given, gets each settled point's smallest coordinate.
        """
        lost = []
        for _ in range(self.max_walk):
            if active.size == 0:
                break
            lam = self.barycentric(x[active], cells[active])
            worst = np.argmin(lam, axis=1)
            least = lam[np.arange(active.size), worst]
            outside = least < -tol
            if smallest is not None:
                smallest[active[~outside]] = least[~outside]
            active, worst = active[outside], worst[outside]
            nxt = self.neighbours[cells[active], worst]
            # Across a boundary facet the point may still be inside a concave
            # grid: the tree search decides.
            lost.append(active[nxt < 0])
            active = active[nxt >= 0]
            cells[active] = nxt[nxt >= 0]
        lost.append(active)
        lost = np.concatenate(lost)
        cells[lost] = -1
        return lost

    def holding(self, x: np.ndarray, tol: float = BARY_TOL) -> np.ndarray:
        """The cell of this rank that holds each point of ``x`` (n, g) as it is, or −1.

        No tie is broken: a point on a facet gets either cell. Confirmed with
        barycentric coordinates (down to ``-tol``), not only by the bounding-box search.
        """
        cells = self._tree_search(x)
        found = np.flatnonzero(cells >= 0)
        inside = self.barycentric(x[found], cells[found]).min(axis=1) >= -tol
        cells[found[~inside]] = -1
        return cells

    def _tree_search(self, x: np.ndarray) -> np.ndarray:
        if self._tree is None:
            # Without ``ghosts``, owned cells only: a point on a facet between an owned
            # cell and a ghost must not be reported in the ghost, another rank's.
            searched = np.arange(self.num_cells, dtype=np.int32)
            self._tree = dolfinx.geometry.bb_tree(
                self.mesh, self.mesh.topology.dim, entities=searched
            )
        pts = np.zeros((x.shape[0], 3))
        pts[:, : x.shape[1]] = x
        candidates = dolfinx.geometry.compute_collisions_points(self._tree, pts)
        colliding = dolfinx.geometry.compute_colliding_cells(self.mesh, candidates, pts)
        offsets = colliding.offsets
        found = offsets[1:] > offsets[:-1]
        cells = np.full(x.shape[0], -1, dtype=np.int32)
        cells[found] = colliding.array[offsets[:-1][found]]
        return cells


def _lowest_rank_of(comm, first: np.ndarray, then: np.ndarray) -> np.ndarray:
    """Per point, the lowest rank where ``first`` is set, else where ``then`` is (n,)."""
    lowest = parallel.lowest_rank(comm, first)
    return np.where(lowest < comm.size, lowest, parallel.lowest_rank(comm, then))


def _facet_neighbours(nodes_of: np.ndarray) -> np.ndarray:
    """Cell across the facet opposite each local vertex, shape (nc, t+1); -1 on the boundary."""
    nc, nv = nodes_of.shape
    # Facet i of a simplex is the one that omits local vertex i.
    keep = np.array([[j for j in range(nv) if j != i] for i in range(nv)])
    facets = np.sort(nodes_of[:, keep], axis=2).reshape(nc * nv, nv - 1)
    # Sorted by their nodes (lexsort: np.unique(axis=0) took 8-13 times as long), an
    # inner facet's two copies lie side by side.
    order = np.lexsort(facets.T[::-1])
    in_order = facets[order]
    pair = np.flatnonzero(np.all(in_order[1:] == in_order[:-1], axis=1))
    a, b = order[pair], order[pair + 1]  # flat (cell*nv + local) indices sharing a facet
    neighbours = np.full(nc * nv, -1, dtype=np.int32)
    neighbours[a] = b // nv
    neighbours[b] = a // nv
    return neighbours.reshape(nc, nv)


def nearest_in_simplices(x: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """The nearest point to each ``x`` (n, g) of its simplex ``vertices`` (n, k, g), k ≤ 4.

    The nearest of the nearest points of every face of the simplex (vertices,
    edges, triangles, and the simplex itself): each is the orthogonal projection
    onto the face's span, kept where its barycentric coordinates there are all ≥ 0.
    """
    n, k, _ = vertices.shape
    best = np.full(n, np.inf)
    nearest = np.array(vertices[:, 0], copy=True)
    for size in range(1, k + 1):
        for face in itertools.combinations(range(k), size):
            corners = vertices[:, face]  # (n, size, g)
            origin = corners[:, 0]
            if size == 1:
                lam = np.ones((n, 1))
                point = origin
            else:
                edges = corners[:, 1:] - origin[:, None]  # (n, size - 1, g)
                gram = np.einsum("nig,njg->nij", edges, edges)
                rhs = np.einsum("nig,ng->ni", edges, x - origin)
                xi = np.linalg.solve(gram, rhs[..., None])[..., 0]
                lam = np.concatenate([1.0 - xi.sum(axis=1, keepdims=True), xi], axis=1)
                point = origin + np.einsum("ni,nig->ng", xi, edges)
            distance = np.linalg.norm(point - x, axis=1)
            better = (lam.min(axis=1) >= 0.0) & (distance < best)
            best[better], nearest[better] = distance[better], point[better]
    return nearest
