"""Point domains: each material point's volume spread over the cells its domain covers.

Standard MPM integrates a cell with the points that lie in it, each with its whole
volume: as points cross facets, a cell's share of the body jumps by a point's volume
at once, cells inside the body can end up with no point at all, and the answer
drifts with the number of load steps (Cook's membrane over 20 steps, n = 32: +25 %).

With ``Simulation(point_domains=True)`` each point carries a triangle (2D) or a
tetrahedron (3D), its domain; at the start the domains tile the body
(:mod:`fe_mpm.tilings`). Every step cuts each domain by the cells it covers
(:mod:`fe_mpm.clipping`, :mod:`fe_mpm.tet_clipping`) and integrates each piece
with one sub-point at the piece's centroid, carrying the piece's share (its area
over the domain's; "area" is volume in 3D throughout) of the point's volume and
mass: exact for the P1 internal force of a domain's stress, so a point that
crosses a facet moves its weight to the next cell continuously. The sub-points
take the point's deformation gradient, history and state, and the step.

The domains' corners then move with the grid's displacement (as in CPDI2,
Sadeghirad et al. 2013, and Nairn's convected particle domains), so the domains keep
tiling the deformed body; each point's ``ΔF`` is the affine map of its domain's
corners, so its volume and its domain's area change by the same factor. The stored
deformation is thus that of one continuous piecewise-linear motion of the domains;
the mean of the pieces' increments would drift further with the number of load
steps (Cook, 5 N, n = 32, 80 steps: 1.3769 against 1.3910, converged 1.3542). With
P2 displacements and more than one point in a cell the points keep that mean
instead (:func:`keeps_mean_increment`): there the corners' map is unstable. The
point's position is its domain's centroid; its stress, history,
velocity and acceleration are the share-weighted means of its pieces'. Where all of
a point's pieces stepped elastically, its elastic left Cauchy–Green tensor (bᵉ, b̄ᵉ)
is instead carried forward by its own increment (:func:`convected_mean`), consistent
with its F; where one yielded, the mean is an approximation (each piece returns
from the point's own state).

A triangle that has distorted too far (:func:`shape_quality`) is flipped with a
neighbour across the edge they share at the start of a step, which keeps the tiling
(:mod:`fe_mpm.domain_flips`); one that no flip helps, and a distorted tetrahedron, is
redrawn around its point, which breaks the tiling there. The ghost penalty
(:mod:`fe_mpm.ghost`, on by default with domains in static runs) ties the cells the domains fill
in part. With P2 displacements each piece has three sub-points that integrate
quadratics exactly (:func:`~fe_mpm.clipping.piece_rule`; triangles only). Not yet:
P2 on tetrahedra, and splitting a distorted domain into smaller ones. The
measurements: ``docs/cell_crossing.md``.

Under MPI a point and its domain live on the rank that owns the cell the point lies
in (:meth:`PointDomains.migrate`, after every step). The rank cuts the domain by its
own cells and its ghosts, and assembles each piece in the cell it lies in, a ghost
cell too: DOLFINx adds what a rank assembles at another rank's nodes to theirs, and
the per-cell sums that read the pieces (the ghost penalty's fill, the occupied
cells of the boundary points) add the ranks' shares. A piece reaches cells across a
vertex of the rank's own, so :class:`~fe_mpm.simulation.Simulation` gives the grid
:data:`DOMAIN_GHOST_LAYERS` layers of them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from fe_mpm import parallel
from fe_mpm.clipping import piece_rule, simplex_volumes
from fe_mpm.domain_flips import flip_distorted
from fe_mpm.errors import ConvergenceError, PointsOutsideError, StepLeavesGridError
from fe_mpm.markers import Markers
from fe_mpm.materials.route import compiled_module
from fe_mpm.materials.spectral import embedded_3d
from fe_mpm.materials.zones import MATERIAL
from fe_mpm.migration import migrate, owning_ranks, send
from fe_mpm.particles import MaterialPoints
from fe_mpm.point_update import apply_update, keep_volume_of_pressure
from fe_mpm.step_forms import PointUpdate
from fe_mpm.tilings import initial_domains, shape_quality, shrunk_cells
from fe_mpm.tracker import Tracker
from fe_mpm.tracking import hosts_leaving

#: A domain's pieces must add up to its area to this relative tolerance.
COVERAGE_TOL = 1e-9
#: Round-off of a domain's pieces, as a fraction of the largest cell they lie in:
#: the clipping's error is the cells' size, not the domain's. A level set that runs
#: a hair from a gmsh grid's nodes seeds sliver points (1e-11 of their cell, a
#: helper's block on cells of 0.125 m, 2026-12-07), whose pieces then missed
#: COVERAGE_TOL, and every first step failed as "degenerated".
COVERAGE_ROUNDOFF = 1e-12
#: The most that tolerance may be: a domain's pieces must still add up to its area.
COVERAGE_MOST = 1e-3
#: A domain with less than this fraction of its area inside the grid has left it.
MIN_INSIDE = 0.5
#: Pieces smaller than this fraction of their domain are dropped (slivers of
#: round-off). Larger slivers stay: a corner's own cell must hold material, or its
#: free nodes are pinned and hold the corner back, and the ghost penalty ties the
#: nodes of a cell held by a sliver. Measured on Cook at 10 N, n = 32, 160 steps,
#: without the penalty: a cell held by 4e-5 of its area stalls Newton in step 133.
MIN_SHARE = 1e-9
#: A domain whose shape quality (:func:`shape_quality`) falls below this, and below
#: half of what it had when drawn, is redrawn at the start of the next step (a right
#: isosceles triangle has 0.87, sheared by x += 2y 0.22; the tiles of skewed cells
#: start below 0.2). Measured on the strip footing (h = 0.2, 100 steps to s/B = 2):
#: with 0.2 alone both runs finish; with a quarter of the first quality alone the
#: run without the ghost penalty stops at s/B = 0.98.
RESET_QUALITY = 0.2
#: Under MPI each rank cuts its points' domains by its own cells and its ghosts: the
#: cells within this many layers of cells sharing a vertex with its own
#: (:func:`fe_mpm.balance.with_vertex_layers`). A domain's corners lie about a cell
#: from its point; two layers leave room for a domain stretched to twice that.
DOMAIN_GHOST_LAYERS = 2
#: A first domain's corner whose barycentric coordinates in its point's cell are all
#: above minus this lies in that cell (:func:`_inside_the_grid`).
CELL_TOLERANCE = 1e-12
#: A corner past the grid's edge moves with the cell of its domain's pieces that it is
#: least outside of, compared to this many decimals of the barycentric coordinates.
CORNER_TIE_DIGITS = 9


@dataclass
class Pieces:
    """The domains cut by the cells of the grid, for one step: their sub-points.

    A piece has one sub-point (at its centroid) or three (P2, see
    :func:`~fe_mpm.clipping.piece_rule`); the arrays run over the sub-points.

    Attributes:
        owner: The point of each sub-point (k,), in increasing order.
        cell: Its cell (k,).
        share: Its fraction of its domain's area (k,); each point's add up to 1.
        x: Its position (k, d) in m.
        corner_cell: The cell whose grid increment moves each domain corner
            (n × (d + 1),): its own, or for a corner past the grid's edge its
            domain's nearest piece's.
        corner_bary: The corners' barycentric coordinates there (n × (d + 1), d + 1), outside
            [0, 1] for a corner outside that cell.
        left: The domains that have left the grid (indices), which have no pieces:
            only where points that leave are dropped (``points_leaving="drop"``).
    """

    owner: np.ndarray
    cell: np.ndarray
    share: np.ndarray
    x: np.ndarray
    corner_cell: np.ndarray
    corner_bary: np.ndarray
    left: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def kept(self, keep: np.ndarray) -> Pieces:
        """The pieces of the domains ``keep`` (n,) bool, renumbered as the kept points are."""
        v = self.corner_bary.shape[1]  # corners per domain
        new_index = np.cumsum(keep) - 1
        mine = keep[self.owner]
        corners = np.repeat(keep, v)
        return Pieces(
            owner=new_index[self.owner[mine]],
            cell=self.cell[mine],
            share=self.share[mine],
            x=self.x[mine],
            corner_cell=self.corner_cell[corners],
            corner_bary=self.corner_bary[corners],
        )


def share_weighted_mean(
    values: np.ndarray, owner: np.ndarray, share: np.ndarray, n: int
) -> np.ndarray:
    """Each of ``n`` points' mean of its pieces' ``values`` (k, ...), weighted by ``share`` (k,).

    ``owner`` (k,) is each piece's point; a point's shares add up to 1.
    """
    weighted = values * share.reshape(-1, *([1] * (values.ndim - 1)))
    out = np.zeros((n, *values.shape[1:]))
    np.add.at(out, owner, weighted)
    return out


#: A piece took an elastic step when its tensor pulled back by its increment is the
#: point's at t_n times a number (1 in an elastic step, since 2026-12-06 in u-p too;
#: the number stays for a point held at a cone's apex) to this share of the latter's
#: size (round-off is ~1e-15).
ELASTIC_PULL_BACK = 1e-9


def convected_mean(
    values: np.ndarray,
    mean: np.ndarray,
    start: np.ndarray,
    piece_F: np.ndarray,
    point_F: np.ndarray,
    point_dF: np.ndarray,
    kind: str,
    owner: np.ndarray,
    share: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Each point's convected tensor from its pieces', consistent with its own step.

    The pieces took their own increments ΔF_k; the point keeps ``point_dF``. A plain
    mean of the pieces' bᵉ_k = ΔF_k bᵉ ΔF_kᵀ differs from ΔF bᵉ ΔFᵀ by the spread of
    the ΔF_k, even in an elastic step, and the point's bᵉ then disagrees with its F
    (and its volume), a little more every step: a geostatic layer of HenckyJ2 that
    yields nowhere, P2/P1 with one point per cell, was 11 % off after 60 steps and
    103 % after 100, where NeoHookean (no history) stays within 1.5 % (found
    2026-12-06 by a helper). So where every piece of a point stepped elastically,
    its value pulled back by its increment, ΔF_k⁻¹ b_k ΔF_k⁻ᵀ, being s_k bᵉ_n (s_k = 1
    for an elastic step, in u-p too, :mod:`~fe_mpm.materials.mixed_return`; other
    values only at a cone's apex; to
    :data:`ELASTIC_PULL_BACK`), the point takes s̄ ΔF bᵉ_n ΔFᵀ with its own
    increment and the pieces' mean s̄: exact. Where a piece yielded the point keeps
    the pieces' plain mean: pushing the mean of their plastic corrections forward by
    the point's increment put the J2 block squeezed between platens (P2/P1) 0.77 %
    off its force, against 0.13 %. The caller checks that the carried values lie
    within the law's surface (:meth:`PointDomains.gather`).

    Args:
        values: The pieces' tensors at t_{n+1} (k, 3, 3).
        mean: Their share-weighted mean by point (n, 3, 3) (:func:`share_weighted_mean`).
        start: The points' tensors at t_n (n, 3, 3).
        piece_F: The pieces' deformation gradients at t_{n+1} (k, g, g).
        point_F: The points' deformation gradients at t_n (n, g, g).
        point_dF: The points' own increments of the step (n, g, g).
        kind: ``"left"`` or ``"left isochoric"`` (:class:`~fe_mpm.materials.HistoryField`).
        owner: Each piece's point (k,).
        share: Its share of its point (k,).

    Returns:
        The points' tensors (n, 3, 3), and which of them were carried by their own
        increment (n,) bool (the others are ``mean``'s).
    """

    def embedded(F: np.ndarray) -> np.ndarray:
        out = embedded_3d(F)
        if kind == "left isochoric":
            out *= np.linalg.det(out)[:, None, None] ** (-1.0 / 3.0)
        return out

    n = point_F.shape[0]
    # Compared where the pieces are (ΔF_k bᵉ_n ΔF_kᵀ against b_k / s_k): one inverse
    # per point, not per piece (100k points, 400k pieces: 1.0 s a step, 2.2 s with a
    # pull-back per piece, 0.08 s for the plain mean).
    piece_dF = embedded(piece_F @ np.linalg.inv(point_F)[owner])
    carried_k = piece_dF @ start[owner] @ np.swapaxes(piece_dF, 1, 2)
    scale = np.cbrt(np.linalg.det(values) / np.linalg.det(carried_k))
    size = np.linalg.norm(carried_k, axis=(1, 2))
    off = np.linalg.norm(values / scale[:, None, None] - carried_k, axis=(1, 2))
    carried = np.bincount(owner, weights=off > ELASTIC_PULL_BACK * size, minlength=n) == 0
    out = mean.copy()
    forward = embedded(point_dF[carried])
    volume = share_weighted_mean(scale, owner, share, n)[carried]
    out[carried] = volume[:, None, None] * (forward @ start[carried] @ np.swapaxes(forward, 1, 2))
    return out, carried


class PointDomains:
    """The domain of every point, and the pieces that integrate it in a step.

    Args:
        points: The material points, located in their cells. Points that tile
            their cell move to the centroids of their tiles.
        tracker: The grid's tracker.
        degree: The displacement's degree: 1 integrates each piece with one sub-point
            at its centroid, 2 with three that integrate quadratics exactly
            (:func:`~fe_mpm.clipping.piece_rule`), so that every P2 cell a domain
            covers sees a full-rank stiffness.
        volume_average: Whether the pieces take a node-averaged volume change
            (``u-nbva``): the point then keeps its corners' isochoric deformation and
            its pieces' mean averaged volume change.
        shared: Whether the pieces share their point's increment
            (:mod:`fe_mpm.shared_increment`): the point then keeps it.
        keeps_no_shape: Whether the points are a fluid's in a mixed form (u-p or
            ``u-nbva``), whose pieces end each step with the isotropic F of their
            volume change (:func:`~fe_mpm.point_update.keep_volume_of_pressure`): the
            point then keeps the same, with its pieces' mean volume change.
        mean_increment: Whether each point keeps the share-weighted mean of its
            pieces' increments ΔF instead of its corners' affine map (see
            :func:`keeps_mean_increment`; its volume then no longer follows its
            domain's area exactly).
        drop_leaving: Whether a point whose domain leaves the grid (less than
            :data:`MIN_INSIDE` of it inside after a step) is dropped with it
            (``points_leaving="drop"``); else the step stops the run.

    Attributes:
        corners: The domains' vertices (n, d + 1, d) in m.
        active: True while the pieces take a step in the points' place.
        marker_hosts: The markers' host points (name → index), set before a step: a
            step that would carry a host's domain out of the grid is refused.
    """

    def __init__(
        self,
        points: MaterialPoints,
        tracker: Tracker,
        degree: int = 1,
        volume_average: bool = False,
        shared: bool = False,
        mean_increment: bool = False,
        keeps_no_shape: bool = False,
        drop_leaving: bool = False,
    ):
        self.corners = _inside_the_grid(
            points, initial_domains(points, tracker.cell_vertices), tracker
        )
        self.degree = degree
        self.volume_average = volume_average
        self.shared = shared
        self.mean_increment = mean_increment
        self.keeps_no_shape = keeps_no_shape
        self.drop_leaving = drop_leaving
        self.active = False
        self.marker_hosts: dict[str, int] = {}
        self._pieces: Pieces | None = None  # those of the step being taken
        self._moved = self.corners  # the corners after that step, once it converged
        self._next: Pieces | None = None  # the pieces of the moved corners
        self._ready: tuple | None = None  # (corners, their pieces), cut ahead
        #: Domains redrawn so far because they had distorted (:data:`RESET_QUALITY`),
        #: on this rank (:func:`fe_mpm.parallel.total` sums the ranks').
        self.resets = 0
        #: Distorted domains flipped with a neighbour so far (:mod:`fe_mpm.domain_flips`;
        #: triangles only), on this rank, each flip counting its two domains.
        self.flips = 0
        self._drawn_quality = shape_quality(self.corners)
        self._short = _no_short(self.corners.shape)  # domains the last cut found short
        self.regrid(tracker)

    def regrid(self, tracker: Tracker) -> None:
        """Cut by the cells of ``tracker``'s grid from now on (after a repartition).

        Collective.
        """
        # The cells' bounding boxes (lower and upper corners, each (nc, d)).
        self._boxes = (tracker.cell_vertices.min(axis=1), tracker.cell_vertices.max(axis=1))
        comm = tracker.mesh.comm  # collective: a rank without cells takes part too
        lower = parallel.smallest(comm, self._boxes[0].min(axis=0, initial=np.inf))
        upper = parallel.largest(comm, self._boxes[1].max(axis=0, initial=-np.inf))
        self._extent = float(np.max(upper - lower))  # the grid's, for telling corners apart
        self._ready = None  # pieces numbered by the old grid's cells

    def saved_state(self) -> tuple[np.ndarray, np.ndarray]:
        """What a checkpoint keeps: the corners (n, d + 1, d) and the drawn quality (n,)."""
        return self.corners, self._drawn_quality

    def restore_state(
        self,
        corners: np.ndarray,
        quality: np.ndarray,
        resets: int,
        tracker: Tracker,
        flips: int = 0,
    ) -> None:
        """Take a checkpoint's domains (:meth:`saved_state`), of the points read with them.

        ``resets`` and ``flips`` go on from the checkpoint's counts (on one rank).
        """
        self.corners, self._drawn_quality = corners, quality
        self.resets, self.flips = resets, flips
        self._pieces = None
        self.regrid(tracker)

    def migrate(self, points: MaterialPoints, markers: Markers, tracker: Tracker) -> int:
        """Send each point, with its domain, to the rank that owns the cell it lies in.

        Collective. After :meth:`gather` a point's cell is its domain's heaviest
        piece's, which may be this rank's ghost; here it becomes the cell the point
        lies in (on one rank too: a domain redrawn at the next step is centred in it),
        looked for in the owned cells of ``tracker``, and the point is sent with its
        domain's corners to the rank that owns it. A point that lies in no rank's cell
        (its domain reaching past the grid's edge) goes to the rank that owns the cell
        of a place of its domain inside the grid (:meth:`_strays_home`), or stays
        where none is found, in its heaviest piece's cell. Returns how many points
        moved between ranks (all ranks together).
        """
        cells, ties = tracker.locate_with_ties(points.x, points.cell)
        if tracker.mesh.comm.size == 1:
            points.cell = np.where(cells >= 0, cells, points.cell).astype(np.int32)
            return 0
        n, v, g = self.corners.shape
        # The corners, the quality they were drawn with, and the cell each point is in.
        carried = np.column_stack(
            [self.corners.reshape(n, v * g), self._drawn_quality, points.cell.astype(float)]
        )
        cells, moved, carried = migrate(points, markers, tracker, cells, carried, ties)
        cells, strays, carried = self._strays_home(points, markers, tracker, cells, carried)
        self.corners = np.ascontiguousarray(carried[:, : v * g]).reshape(-1, v, g)
        self._drawn_quality = carried[:, v * g].copy()
        points.cell = np.where(cells >= 0, cells, carried[:, -1].astype(np.int32)).astype(np.int32)
        return moved + strays

    def _strays_home(
        self,
        points: MaterialPoints,
        markers: Markers,
        tracker: Tracker,
        cells: np.ndarray,
        carried: np.ndarray,
    ) -> tuple[np.ndarray, int, np.ndarray]:
        """Send each point in no rank's cell to a rank that holds its domain's inside.

        A kept point may lie past the grid's edge while most of its domain is inside;
        it stayed on the rank it was on, which after a restart on more ranks (a serial
        checkpoint read on two) held none of the cells its domain covers, and the next
        step stopped as if the domain had stretched past the ghost cells (a helper's
        outflow, 2026-12-07). Its domain's corners and the midpoints between them and
        the point are tried in turn; the first that some rank owns sends the point
        there, and gives its cell on arrival (the last column of ``carried``).
        Collective. Returns the cells, the points sent and ``carried``, as
        :func:`~fe_mpm.migration.migrate` does.
        """
        comm, (_, v, g) = tracker.mesh.comm, self.corners.shape
        stray = np.flatnonzero(cells < 0)
        if not parallel.any_rank(comm, stray.size > 0):
            return cells, 0, carried

        def probes(x: np.ndarray, corners: np.ndarray) -> np.ndarray:
            """Places of each domain to try, inside first (k, 2 (d + 1), g)."""
            return np.concatenate([0.5 * (x[:, None, :] + corners), corners], axis=1)

        corners = carried[stray, : v * g].reshape(-1, v, g)
        tried = probes(points.x[stray], corners)
        owner = owning_ranks(tracker, tried.reshape(-1, g)).reshape(len(stray), 2 * v)
        found = owner >= 0
        first = np.argmax(found, axis=1)
        destination = np.where(found.any(axis=1), owner[np.arange(len(stray)), first], comm.rank)
        away = destination != comm.rank
        kept = len(points) - int(np.count_nonzero(away))
        cells, sent, carried = send(
            points, markers, tracker, cells, stray[away], destination[away], carried
        )
        # An arrival in no cell here takes the cell of its first place this rank holds
        # (the sender's cell number means nothing here); those that stayed keep theirs.
        arrived = kept + np.flatnonzero(cells[kept:] < 0)
        tried = probes(points.x[arrived], carried[arrived, : v * g].reshape(-1, v, g))
        held = tracker.locate(tried.reshape(-1, g)).reshape(len(arrived), 2 * v)
        has = held >= 0
        cell = held[np.arange(len(arrived)), np.argmax(has, axis=1)]
        carried[arrived[has.any(axis=1)], -1] = cell[has.any(axis=1)]
        return cells, sent, carried

    def pieces(self, tracker: Tracker, guess: np.ndarray) -> Pieces:
        """Each domain cut by the cells it covers (see :meth:`_cut`)."""
        return self._cut(self.corners, tracker, guess)

    def _cut(
        self, corners: np.ndarray, tracker: Tracker, guess: np.ndarray, may_leave: bool = False
    ) -> Pieces:
        """Each domain with ``corners`` (n, d + 1, d) cut by the cells it covers.

        Args:
            corners: The domains' corners.
            tracker: The grid's tracker.
            guess: A cell near each domain (n,), where the searches start.
            may_leave: Whether a domain less than :data:`MIN_INSIDE` inside the grid
                is left without pieces (listed in ``Pieces.left``) instead of raising.

        Returns:
            The pieces, and where the corners are.

        The cells a domain may cover are those around its corners' cells; for a
        domain stretched past them, or one that reaches past the grid's edge, every
        cell whose bounding box meets the domain's. A domain that reaches past the
        grid's edge (at a corner, or between corners where the grid has a notch)
        keeps the pieces inside, and its point's volume is shared among them.

        Raises:
            PointsOutsideError: Less than half of a domain is inside the grid (unless
                ``may_leave``).
            ConvergenceError: A domain's pieces do not add up to it (a degenerate one).
        """
        n, v, g = corners.shape
        if n == 0:  # a rank without points, under MPI
            self._short = _no_short(corners.shape)
            none, cells = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int32)
            return Pieces(none, cells, np.zeros(0), np.zeros((0, g)), cells, np.zeros((0, v)))
        corner_cells = tracker.locate(corners.reshape(-1, g), np.repeat(guess, v))
        outside = corner_cells < 0
        # A corner that has left the grid (a body bulging past the grid's edge) is
        # searched around the domain's last cell; its part outside the grid is lost.
        corner_cells = np.where(outside, np.repeat(guess, v), corner_cells)
        neighbours = tracker.vertex_neighbours()
        candidates = np.sort(neighbours[corner_cells.reshape(n, v)].reshape(n, -1), axis=1)
        repeated = np.zeros_like(candidates, dtype=bool)
        repeated[:, 1:] = candidates[:, 1:] == candidates[:, :-1]
        owner, column = np.nonzero((candidates >= 0) & ~repeated)
        cell = candidates[owner, column]
        partly_outside = np.any(outside.reshape(n, v), axis=1)
        bounds = corners.min(axis=1), corners.max(axis=1)
        # The cells around a last cell may miss where a domain crosses the grid's
        # edge: try every cell for those (few), so that what is missing is outside.
        if np.any(partly_outside):
            everywhere = self._cells_meeting(bounds, partly_outside)
            owner, cell = _replaced(partly_outside, (owner, cell), everywhere)
        area, rule = self._overlaps(corners, bounds, tracker, owner, cell)
        domain_area = simplex_volumes(corners)
        covered = np.bincount(owner, weights=area, minlength=n) / domain_area
        tol = _coverage_tolerance(owner, cell, tracker, domain_area)
        # A domain stretched past the cells around its corners (a spreading flow)
        # misses the cells between them: try every cell for those too.
        short = (covered < 1.0 - tol) & ~partly_outside
        if np.any(short):
            more_owner, more_cell = self._cells_meeting(bounds, short)
            more = self._overlaps(corners, bounds, tracker, more_owner, more_cell)
            owner, cell, area, rule = _replaced(
                short, (owner, cell, area, rule), (more_owner, more_cell, *more)
            )
            covered = np.bincount(owner, weights=area, minlength=n) / domain_area
            tol = _coverage_tolerance(owner, cell, tracker, domain_area)
        # For _beyond_ghosts: under MPI a domain short of its area may reach into
        # another rank's cells past this rank's ghosts, between corners that are not.
        short = covered < 1.0 - tol
        self._short = corners[short], covered[short] * domain_area[short]
        left = covered < MIN_INSIDE if may_leave else np.zeros(n, dtype=bool)
        if not may_leave and np.any(covered < MIN_INSIDE):
            p = int(np.argmin(covered))
            raise PointsOutsideError(
                f"the domain of point {p} (corners {corners[p].tolist()}) has left the "
                f"grid ({covered[p]:.3g} of it inside); extend the grid around the body"
            )
        # Searched everywhere, a domain still short of its area reaches past the
        # grid's edge between its corners (a grid with a notch): like one with a
        # corner outside, it keeps the pieces inside.
        wrong = np.abs(covered - 1.0) > tol
        wrong &= (~(partly_outside | short) | (covered > 1.0)) & ~left
        if np.any(wrong):  # only round-off on a degenerate domain can get here
            p = int(np.flatnonzero(wrong)[0])
            raise ConvergenceError(
                f"the pieces of the domain of point {p} add up to {covered[p]:.12g} of its "
                "area: it has degenerated."
            )
        # A round-off sliver is dropped; the domain's other pieces share its area.
        keep = (area > MIN_SHARE * domain_area[owner]) & ~left[owner]
        owner, cell, area, rule = owner[keep], cell[keep], area[keep], rule[keep]
        # A corner moves with the field of its own cell: the same for every domain that
        # shares it, so the domains keep tiling the body. Past the grid's edge it
        # reads the field of its domain's nearest piece, extended (its polynomial).
        corner_cell = corner_cells
        if np.any(outside & ~np.repeat(left, v)):
            corner_cell = np.where(
                outside, _corner_cells(corners, tracker, owner, cell, guess), corner_cells
            )
        # Each piece's rule has q points of equal weight, each a sub-point.
        q = rule.shape[1]
        bary = np.concatenate([1.0 - rule.sum(axis=2, keepdims=True), rule], axis=2)
        x = np.einsum("kqv,kvg->kqg", bary, tracker.cell_vertices[cell]).reshape(-1, g)
        share = area / np.bincount(owner, weights=area, minlength=n)[owner]
        return Pieces(
            owner=np.repeat(owner, q),
            cell=np.repeat(cell, q).astype(np.int32),
            share=np.repeat(share / q, q),
            x=x,
            corner_cell=corner_cell,
            corner_bary=tracker.barycentric(corners.reshape(-1, g), corner_cell),
            left=np.flatnonzero(left),
        )

    def _cells_meeting(
        self, bounds: tuple[np.ndarray, np.ndarray], which: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The pairs (domain, cell) of the domains ``which`` (n,) with every cell.

        Every cell whose bounding box meets the domain's (``bounds``: the domains'
        lower and upper corners); the pairs come sorted by domain.
        """
        (low, high), (box_low, box_high) = bounds, self._boxes
        found = [
            np.flatnonzero(np.all((box_low <= high[d]) & (box_high >= low[d]), axis=1))
            for d in np.flatnonzero(which)
        ]
        owner = np.repeat(np.flatnonzero(which), [c.size for c in found])
        return owner, np.concatenate(found)

    def _overlaps(
        self,
        corners: np.ndarray,
        bounds: tuple[np.ndarray, np.ndarray],
        tracker: Tracker,
        owner: np.ndarray,
        cell: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The overlap of each (domain, cell) pair: its area in m² (m³) and its rule.

        The pairs keep their order; pairs that cannot overlap get area 0 without
        being cut. ``bounds``: the domains' lower and upper corners.
        """
        n, v, g = corners.shape
        # Only the cells whose bounding boxes meet the domain's can overlap it, and
        # not a cell whose vertices all lie beyond one face of the domain (most of the
        # rest in 3D, where cutting is dear; a cell beyond one of its own faces is cut
        # away at once).
        meets = _may_overlap(corners, bounds, tracker.cell_vertices, self._boxes, owner, cell)
        o, c = owner[meets], cell[meets]
        xi = tracker.barycentric(corners[o].reshape(-1, g), np.repeat(c, v))
        met_area, met_rule = piece_rule(xi.reshape(-1, v, v)[..., 1:], self.degree)
        area = np.zeros(len(owner))
        rule = np.zeros((len(owner), *met_rule.shape[1:]))
        area[meets], rule[meets] = met_area, met_rule
        area *= math.factorial(g) * tracker.volumes[cell]  # reference → physical
        return area, rule

    @property
    def current(self) -> Pieces:
        """The pieces of the step being taken."""
        return self._pieces

    def sample(
        self,
        points: MaterialPoints,
        tracker: Tracker,
        markers: Markers | None = None,
        tracking=None,
        step: int = 0,
        t: float = 0.0,
    ) -> MaterialPoints:
        """A sub-point for every piece of every domain, with its share of the point's state.

        With ``points_leaving="drop"``, a domain that a flip or redraw at the step's
        start left less than half inside the grid goes with its point before the step
        (through ``tracking`` and ``markers``, :meth:`_dropped`; ``step`` and
        ``t`` are the step's, for the warning).
        """
        self._reset_distorted(points, tracker)
        ready, self._ready = self._ready, None
        self._short, error = _no_short(self.corners.shape), None
        try:
            if ready is not None and np.array_equal(ready[0], self.corners):
                p = ready[1]
            else:  # none yet, or cut for corners that have changed since (a reset, migration)
                may_leave = self.drop_leaving and tracking is not None
                p = self._cut(self.corners, tracker, points.cell, may_leave=may_leave)
        except (PointsOutsideError, ConvergenceError) as err:
            error = err
        parallel.raise_together(tracker.mesh.comm, self._beyond_ghosts(tracker) or error)
        if tracking is not None:
            p = self._dropped(p, points, markers, tracking, step, t)
        self._pieces = p
        sub = MaterialPoints(
            p.x,
            points.volume[p.owner] * p.share,
            points.mass[p.owner] * p.share,
            F=points.F[p.owner],
            stress=points.stress[p.owner],
            cell=p.cell,
            velocity=points.velocity[p.owner],
            acceleration=points.acceleration[p.owner],
        )
        sub.history = {name: values[p.owner] for name, values in points.history.items()}
        return sub

    def _reset_distorted(self, points: MaterialPoints, tracker: Tracker) -> bool:
        """Re-tile or redraw the domains whose shape quality fell too far (:data:`RESET_QUALITY`).

        Collective. A distorted triangle is first flipped with a neighbour across the
        edge they share (:mod:`fe_mpm.domain_flips`), which keeps the tiling and
        remaps the pair's state; :attr:`flips` counts them. A domain that no flip
        helps (on the body's edge, a tetrahedron, one that no longer tiles) is
        redrawn as its point's cell, shrunk to the domain's area and centred on the
        point; it no longer tiles with its neighbours (it may overlap them or leave a
        gap), which is the price of going on. The point's ``F``, volume and state
        are then untouched: only where its volume lies changes. Returns whether any
        domain was flipped or redrawn; :attr:`resets` counts the redrawn ones.
        """
        limit = np.minimum(RESET_QUALITY, 0.5 * self._drawn_quality)
        quality = shape_quality(self.corners)
        flipped = np.zeros(len(self.corners), dtype=bool)
        if self.corners.shape[2] == 2:
            # A new array where any flipped: the pieces cut ahead (sample) hold the old.
            self.corners, flipped = flip_distorted(
                self.corners, quality, limit, points, tracker, self._extent
            )
            # A flipped domain is drawn anew and not distorted (choose_flips).
            self._drawn_quality[flipped] = shape_quality(self.corners[flipped])
            self.flips += int(flipped.sum())
        bad = np.flatnonzero((quality < limit) & ~flipped)
        if bad.size == 0:
            return bool(flipped.any())
        own = tracker.cell_vertices[points.cell[bad]]
        redrawn = shrunk_cells(points.x[bad], simplex_volumes(self.corners[bad]), own)
        g = own.shape[2]
        # A redrawn domain that would reach past the grid's edge keeps its old shape.
        inside = tracker.locate(redrawn.reshape(-1, g), np.repeat(points.cell[bad], g + 1)) >= 0
        inside = np.all(inside.reshape(-1, g + 1), axis=1)
        bad, redrawn = bad[inside], redrawn[inside]
        # A new array: the pieces cut ahead (:meth:`sample`) hold the old one, and are
        # those of the old corners.
        self.corners = self.corners.copy()
        self.corners[bad] = redrawn
        self._drawn_quality[bad] = shape_quality(redrawn)
        self.resets += bad.size
        return bad.size > 0 or bool(flipped.any())

    def move_corners(
        self,
        grid_displacement: Callable[[np.ndarray, np.ndarray], np.ndarray],
        tracker: Tracker,
        step: int,
        t: float,
    ) -> None:
        """The corners' positions after the converged step, checked before anything moves.

        Args:
            grid_displacement: The step's grid displacement Δu (k, g) at given cells
                (k,) and barycentric coordinates (k, g + 1)
                (:meth:`~fe_mpm.formulations.GridFields.displacement_at`).
            tracker: The grid's tracker.
            step: The step's number, for messages.
            t: Its end time, for messages.

        Raises:
            ConvergenceError: A domain would turn inside out, or degenerate (the
                step is cut).
            PointsOutsideError: A domain would leave the grid.
        """
        p, n, g = self._pieces, len(self.corners), self.corners.shape[2]
        moved = self.corners + grid_displacement(p.corner_cell, p.corner_bary).reshape(n, g + 1, g)
        before = np.linalg.det(self.corners[:, 1:] - self.corners[:, :1])
        after = np.linalg.det(moved[:, 1:] - moved[:, :1])
        self._short, error = _no_short(self.corners.shape), None
        if np.any(after / before <= 0):
            bad = int(np.flatnonzero(after / before <= 0)[0])
            error = ConvergenceError(
                f"the domain of point {bad} (corners {self.corners[bad].tolist()}) would turn "
                f"inside out in step {step} (t = {t:g}): take smaller steps, or the grid there "
                "distorts it too far. Nothing was updated."
            )
        else:
            self._moved = moved
            # The next step's pieces, now: a domain that degenerates or leaves the grid
            # then fails this step, which a shorter step may avoid.
            try:
                guess = _heaviest_cells(self._pieces, n)  # every domain of the step has pieces
                self._next = self._cut(moved, tracker, guess, may_leave=self.drop_leaving)
                error = hosts_leaving(self.marker_hosts, self._next.left, step, t)
            except PointsOutsideError as err:  # refused before anything moved
                error = StepLeavesGridError(f"{err} (step {step}, t = {t:g}). Nothing was updated.")
            except ConvergenceError as err:
                error = ConvergenceError(f"{err} in step {step} (t = {t:g}). Nothing was updated.")
        parallel.raise_together(tracker.mesh.comm, self._beyond_ghosts(tracker) or error)

    def drop_left(
        self, points: MaterialPoints, markers: Markers, tracking, step: int, t: float
    ) -> None:
        """Drop the points whose domains the step carried out of the grid (after :meth:`gather`).

        With ``points_leaving="drop"`` a domain less than :data:`MIN_INSIDE` inside the
        grid after a step goes with its point, its mass and momentum (:meth:`_dropped`),
        and the pieces cut ahead for the next step lose their rows. Collective.
        """
        self._next = self._dropped(self._next, points, markers, tracking, step, t)
        self._ready = (self.corners, self._next)

    def _dropped(
        self, pieces: Pieces, points: MaterialPoints, markers: Markers, tracking, step, t
    ) -> Pieces:
        """The ``pieces`` of the domains kept, the points of those that left dropped.

        ``tracking`` (:class:`~fe_mpm.tracking.PointTracking`) removes the points of
        ``pieces.left`` with a warning and counts them; the domains lose their rows.
        Collective.
        """
        if not parallel.any_rank(tracking.tracker.mesh.comm, pieces.left.size > 0):
            return pieces
        keep = np.ones(len(self.corners), dtype=bool)
        keep[pieces.left] = False
        self.corners = self.corners[keep]
        self._drawn_quality = self._drawn_quality[keep]
        tracking.drop(points, markers, pieces.left, step, t, domains=True)
        return pieces.kept(keep)

    def _beyond_ghosts(self, tracker: Tracker) -> ConvergenceError | None:
        """The error of a domain that reaches past this rank's cells into another rank's.

        Collective. On one rank a domain that leaves the tracker's cells leaves the
        grid; under MPI it may reach past this rank's ghost layer
        (:data:`DOMAIN_GHOST_LAYERS`) instead, at a corner or between corners, where
        the cut would lose its pieces. Such a domain is short of its area (the last
        cut recorded those), and its area in every rank's owned cells adds up to more
        than this rank found.
        """
        comm = tracker.mesh.comm
        corners, inside = self._short
        if comm.size == 1 or not parallel.any_rank(comm, len(corners) > 0):
            return None
        lost = inside < self._area_in_owned_cells(corners, tracker) * (1.0 - COVERAGE_TOL)
        if not np.any(lost):
            return None
        return ConvergenceError(
            f"a point domain (its corners {corners[np.flatnonzero(lost)[0]].tolist()}) "
            "reaches past the cells this MPI rank holds "
            f"({DOMAIN_GHOST_LAYERS} layers of ghost cells): in this step it moved, or "
            "stretched, farther past the rank's own cells than that (a cantilever's tip, "
            "a cell and a half in one step, left its rank's ghosts undeformed). Take "
            "smaller steps (run() cuts this one and goes on), or run on fewer ranks."
        )

    def _area_in_owned_cells(self, corners: np.ndarray, tracker: Tracker) -> np.ndarray:
        """The area of each domain (n, d + 1, d) in the cells every rank owns, (n,).

        Collective: every rank cuts every rank's domains by its owned cells, and the
        ranks' areas add up, each cell being owned once.
        """
        comm, (n, v, g) = tracker.mesh.comm, corners.shape
        counts = comm.allgather(n)
        everyone = parallel.gathered(comm, corners.reshape(n, v * g)).reshape(-1, v, g)
        bounds = everyone.min(axis=1), everyone.max(axis=1)
        owner, cell = self._cells_meeting(bounds, np.ones(len(everyone), dtype=bool))
        owned = cell < tracker.mesh.topology.index_map(tracker.mesh.topology.dim).size_local
        owner, cell = owner[owned], cell[owned]
        area, _ = self._overlaps(everyone, bounds, tracker, owner, cell)
        total = parallel.total(comm, np.bincount(owner, weights=area, minlength=len(everyone)))
        first = sum(counts[: comm.rank])
        return total[first : first + n]

    def gather(
        self, points: MaterialPoints, sub: MaterialPoints, markers: Markers, law=None
    ) -> None:
        """Give each point its domain's step (after :meth:`move_corners`).

        Args:
            points: The material points at the start of the step, updated here.
            sub: Their sub-points after the step.
            markers: Moved with their host points.
            law: The material law: a point whose pieces all stepped elastically
                carries its history fields that an elastic step carries
                (:attr:`~fe_mpm.materials.HistoryField.convected`) forward by its own
                increment (:func:`convected_mean`); None averages every field.
        """
        n, p = len(points), self._pieces

        def mean(values: np.ndarray) -> np.ndarray:
            return share_weighted_mean(values, p.owner, p.share, n)

        corners = self._moved
        if self.shared or self.mean_increment:
            # The pieces took the point's own increment (shared), or the point keeps
            # their mean (keeps_mean_increment).
            dF = mean(sub.F) @ np.linalg.inv(points.F)
        else:
            edges = corners[:, 1:] - corners[:, :1]
            old_edges = self.corners[:, 1:] - self.corners[:, :1]
            # The affine map of the corners: (new edges) = ΔF (old edges).
            dF = np.swapaxes(edges, 1, 2) @ np.linalg.inv(np.swapaxes(old_edges, 1, 2))
            if self.volume_average:
                # The pieces took the averaged volume change J̄ at their places: the
                # point keeps the corners' isochoric part and its pieces' mean J̄ (NB-VA).
                g = dF.shape[1]
                averaged = mean(np.linalg.det(sub.F)) / np.linalg.det(points.F)
                dF *= (averaged / np.linalg.det(dF))[:, None, None] ** (1.0 / g)
        new = PointUpdate(
            du=corners.mean(axis=1) - self.corners.mean(axis=1),  # a point is its centroid
            dF=dF,
            stress=mean(sub.stress),
            acceleration=None,
            history=self._history(points, sub, dF, law),
        )
        self.corners = corners
        # The points' own update (x, F, V, σ, history, markers); the sub-points' Newmark
        # velocities are already at t_{n+1}, so the points take their mean as it is.
        apply_update(points, new, markers, dynamics=None, dt=0.0)
        if self.keeps_no_shape:
            # As without domains (fe_mpm.materials.fluid): left with its corners' map, a
            # u-p fluid point's volume drifted from its pressure's (by 0.4 % in 0.3 s in a
            # slosh, where 1 − p/K moves by 3e-6) until the surface blew up.
            keep_volume_of_pressure(points, mean(np.linalg.det(sub.F)))
        points.velocity, points.acceleration = mean(sub.velocity), mean(sub.acceleration)
        points.cell = _heaviest_cells(self._next, n)  # where most of it lies
        self._ready = (corners, self._next)

    def _history(self, points: MaterialPoints, sub: MaterialPoints, dF: np.ndarray, law) -> dict:
        """The points' history at t_{n+1} from their pieces' (see :meth:`gather`).

        A point carries its convected fields (:func:`convected_mean`) where its law's
        return map runs in numpy and can check them: pushed by the point's own ΔF,
        which none of its elastic pieces took exactly, a bᵉ may lie outside the
        surface (a Tresca footing with domains: f up to 0.45 c_u near the footing's
        edge, where the pieces' mean gave −0.21, found 2026-12-06 by a helper), and
        such a point keeps its pieces' mean; so do the points of a law written in UFL
        (``J2Plasticity``), which has no return map to check with. With several laws
        a point is judged on its own law's fields only (another law's stay at their
        initial value and say nothing).
        """
        p, n = self._pieces, len(points)
        plain = {
            name: share_weighted_mean(values, p.owner, p.share, n)
            for name, values in sub.history.items()
            if name != MATERIAL  # a label, kept: its mean was 1 ± 1e-16 (a helper's, 2026-12-07)
        }
        if MATERIAL in sub.history:
            plain[MATERIAL] = points.material.astype(np.float64)
        checkable = _checkable_fields(law, points.history, n)
        if not checkable:
            return plain
        history = dict(plain)
        carried = np.ones(n, dtype=bool)
        for name, (kind, uses) in checkable.items():
            history[name], own = convected_mean(
                sub.history[name],
                plain[name],
                points.history[name],
                sub.F,
                points.F,
                dF,
                kind,
                p.owner,
                p.share,
            )
            carried &= own | ~uses
        users = np.zeros(n, dtype=bool)
        for _, uses in checkable.values():
            users |= uses
        carried &= users
        if np.any(carried):
            at_rest = np.tile(np.eye(dF.shape[1]), (int(carried.sum()), 1, 1))
            returned = law.return_map(
                at_rest, {name: values[carried] for name, values in history.items()}
            ).history
            check = np.flatnonzero(carried)
            for name, (_, uses) in checkable.items():
                given = history[name][carried]
                moved = np.linalg.norm(returned[name] - given, axis=(1, 2))
                size = np.linalg.norm(given, axis=(1, 2))
                carried[check[uses[check] & (moved > ELASTIC_PULL_BACK * size)]] = False
        for name, (_, uses) in checkable.items():
            mean = ~(carried & uses)
            history[name][mean] = plain[name][mean]
        return history


def _checkable_fields(law, history: dict[str, np.ndarray], n: int) -> dict:
    """The convected fields a point can carry: name -> (kind, which points' law uses it).

    Those a law with a numpy return map gives back (:meth:`PointDomains._history`); with
    several laws (:class:`~fe_mpm.materials.MaterialZones`) each field is its own laws'
    points'. Empty without such a law.
    """
    if law is None or not hasattr(law, "return_map"):
        return {}
    fields = law.history
    convected = {name: h.convected for name, h in fields.items() if h.convected}
    laws = getattr(law, "laws", None)
    if laws is None:
        return {name: (kind, np.ones(n, dtype=bool)) for name, kind in convected.items()}
    labels = law.labels(history)
    out = {}
    for name, kind in convected.items():
        own = [
            k for k, each in enumerate(laws) if name in each.history and hasattr(each, "return_map")
        ]
        if own:
            out[name] = (kind, np.isin(labels, own))
    return out


def keeps_mean_increment(degree: int, most_points_in_a_cell: int) -> bool:
    """Whether points keep their pieces' mean ``ΔF`` rather than their corners' affine map.

    Only with P2 displacements (``degree`` 2) and more than one point in some cell
    at the start (``most_points_in_a_cell``, the largest count over every rank's
    cells). A P2 increment is quadratic in a cell, which the corners of a domain
    smaller than its cell do not follow: with three points per triangle (the
    three-triangle fan about the centroid, :func:`~fe_mpm.tilings.equal_tiling`)
    the corners' map lets the points' det F spread step by step until the body
    turns over, whatever the step (Cook at 10 N, n = 8, 30 of 60 steps: det F
    0.75–1.22 against 0.99–1.01 with the mean; n = 16, 160 steps: turned over,
    against 2.6937, +2.1 %, and n = 32: +1.1 %). With four or six per cell the
    mean ends as close as the corners do, on the other side (n = 16, 160 steps:
    +0.75 and +0.58 % against −0.86 and −1.04 %), with det F within 1.2 and 2.4 %
    of 1 against 5.9 and 9.2 %. A point alone in its cell, whose domain is the cell,
    keeps its corners' map: there the mean ends 3.2 % high (n = 32, 40 steps)
    against 0.6 % low. Measured 2026-12-05; ``docs/cell_crossing.md``.
    """
    return degree == 2 and most_points_in_a_cell > 1


def step_with_domains(sim, t_new: float, rebin: bool):
    """:meth:`Simulation.step` with each point's domain sampled by sub-points.

    The sub-points take the step in the points' place (their markers and output
    wait); then the points gather the sub-points' step (:meth:`PointDomains.gather`),
    and the step's report and output are the points'. A failed step leaves the
    points as they were, but for the flips and redraws of distorted domains made at
    its start (:meth:`PointDomains.sample`), which the retry starts from. ``rebin``
    is ignored: the sub-points are new every attempt, so none can be held in a cell
    of the last step.

    Under MPI each rank cuts its points' domains by its cells and its ghosts
    (``sim.domain_tracker``), and assembles the pieces where they lie, ghost cells
    included: DOLFINx adds what a rank assembles at another rank's nodes to theirs;
    after the step the points go to the ranks that own their cells
    (:meth:`PointDomains.migrate`).
    """
    domains, points, markers, output = sim.domains, sim.points, sim.markers, sim.output
    tracker = sim.tracker
    # Between steps the points lie in owned cells (below), but for those a repartition
    # (Simulation.rebalance) left without one: they go to their new ranks first.
    moved = 0
    if parallel.any_rank(tracker.mesh.comm, bool(np.any(points.cell < 0))):
        moved = domains.migrate(points, markers, tracker)
    sim.tracking.migrated = moved
    sub = domains.sample(
        points, sim.domain_tracker, markers, sim.tracking, sim.step_number + 1, t_new
    )
    domains.marker_hosts = markers.hosts()
    sim.points, sim.markers, sim.output, domains.active = sub, Markers(), None, True
    sim.tracker = sim.domain_tracker  # the pieces' cells include this rank's ghosts
    try:
        report = sim._step_points(t_new, True)  # never held: the pieces differ per attempt
    finally:
        sim.points, sim.markers, sim.output, domains.active = points, markers, output, False
        sim.tracker = tracker
    domains.gather(points, sub, markers, sim.material)
    sim.tracking.forget()  # it remembers the pieces' cells, not the points'
    domains.drop_left(points, markers, sim.tracking, report.step, report.t)
    # Now, so that between steps the points lie in owned cells, as without domains.
    report.migrated_points += domains.migrate(points, markers, tracker)
    report.markers = markers.positions()
    sim._write_output()
    return report


def _inside_the_grid(points: MaterialPoints, corners: np.ndarray, tracker: Tracker) -> np.ndarray:
    """First domains (n, d + 1, d) that reach past the grid's edge, moved into their cells.

    A point that does not tile its cell (a cell a level set cuts, or a trimmed body)
    takes its cell shrunk around it, which reaches past the cell where the point lies
    near its side, and past the grid where that side is the grid's edge. Such a
    domain then lost its part outside, and the rest of it carried the point's volume
    (a 3D slope seeded by level set in a gmsh box stopped at set-up, 0.45 of a
    domain inside the grid). Each is moved towards its cell's centroid until it lies
    in the cell, and its point moves with it (``x`` and ``x0``, as a tiled point
    moves to its tile). Domains inside the grid are left as they are.
    """
    n, v, g = corners.shape
    if n == 0:
        return corners
    flat, cells = corners.reshape(-1, g), np.repeat(points.cell, v)
    # Only a corner past its point's cell may be past the grid: a tile's corners on the
    # grid's edge are in their cell, whatever the search says of them.
    beyond = np.flatnonzero(tracker.barycentric(flat, cells).min(axis=1) < -CELL_TOLERANCE)
    lost = beyond[tracker.locate(flat[beyond], cells[beyond]) < 0]
    out = np.unique(lost // v)
    if out.size == 0:
        return corners
    scale = (
        simplex_volumes(corners[out]) / simplex_volumes(tracker.cell_vertices[points.cell[out]])
    ) ** (1.0 / g)
    out, scale = out[scale < 1.0], scale[scale < 1.0]  # a larger domain cannot lie in its cell
    own = tracker.cell_vertices[points.cell[out]]
    centre = own.mean(axis=1)
    # The copy x + s (cell − centre) lies in the cell iff every barycentric coordinate
    # of x is at least s / (d + 1): move x towards the centre until the least one is
    # (it is less, as the copy reaches past the cell; so 1 / (d + 1) − least > 0).
    least = tracker.barycentric(points.x[out], points.cell[out]).min(axis=1)
    need = scale / v
    t = np.minimum(1.0, (1.0 / v - need) / (1.0 / v - least))
    x = centre + t[:, None] * (points.x[out] - centre)
    corners = corners.copy()
    corners[out] = x[:, None, :] + scale[:, None, None] * (own - centre[:, None, :])
    points.x0[out] += x - points.x[out]  # as a tiled point's (fe_mpm.tilings)
    points.x[out] = x
    return corners


def _coverage_tolerance(
    owner: np.ndarray, cell: np.ndarray, tracker: Tracker, domain_area: np.ndarray
) -> np.ndarray:
    """Each domain's tolerance on its pieces' sum, a fraction of its area (n,).

    :data:`COVERAGE_TOL`, plus :data:`COVERAGE_ROUNDOFF` of the largest cell its
    pieces lie in over its own area, at most :data:`COVERAGE_MOST` (a domain 1e-13 of
    its cell would otherwise pass any sum: a reviewer).
    """
    largest = np.zeros(domain_area.size)
    np.maximum.at(largest, owner, tracker.volumes[cell])
    return np.minimum(COVERAGE_TOL + COVERAGE_ROUNDOFF * largest / domain_area, COVERAGE_MOST)


def _no_short(shape: tuple) -> tuple[np.ndarray, np.ndarray]:
    """No domain found short of its area: corners (0, d + 1, d) and areas (0,)."""
    return np.zeros((0, *shape[1:])), np.zeros(0)


def _corner_cells(
    corners: np.ndarray, tracker: Tracker, owner: np.ndarray, cell: np.ndarray, guess: np.ndarray
) -> np.ndarray:
    """For every corner (n × (d + 1),), the cell of its domain's piece it is least outside of.

    A domain without pieces (one that has left the grid, to be dropped) keeps its
    ``guess`` (n,).
    """
    n, v, g = corners.shape
    if len(owner) == 0:
        return np.repeat(guess, v).astype(np.int32)
    lam = tracker.barycentric(corners[owner].reshape(-1, g), np.repeat(cell, v))
    inside = lam.reshape(-1, v, v).min(axis=2)  # (pieces, corner)
    # Equally good cells (a corner past the grid's edge above a facet between two)
    # extrapolate differently: take the one first by its centroid, not by its local
    # number, which differs with the number of ranks.
    inside = np.round(inside, CORNER_TIE_DIGITS)
    centroids = tuple(tracker.centroids[cell].T[::-1])
    corner_cell = np.repeat(guess[:, None], v, axis=1).astype(np.int32)
    has = np.bincount(owner, minlength=n) > 0
    for j in range(v):
        order = np.lexsort((*centroids, -inside[:, j], owner))  # by domain, the best first
        first = np.searchsorted(owner[order], np.flatnonzero(has))
        corner_cell[has, j] = cell[order[first]]
    return corner_cell.reshape(-1)


def _heaviest_cells(pieces: Pieces, n: int) -> np.ndarray:
    """The cell of each of the ``n`` points' heaviest piece (n,).

    −1 for a domain without pieces, one that has left the grid (:attr:`Pieces.left`).
    """
    cells = np.full(n, -1, dtype=np.int32)
    has = np.flatnonzero(np.bincount(pieces.owner, minlength=n) > 0)
    by_weight = np.lexsort((-pieces.share, pieces.owner))  # by point, the heaviest first
    cells[has] = pieces.cell[by_weight[np.searchsorted(pieces.owner[by_weight], has)]]
    return cells


def _replaced(
    which: np.ndarray, old: tuple[np.ndarray, ...], new: tuple[np.ndarray, ...]
) -> tuple[np.ndarray, ...]:
    """Per-pair arrays with the pairs of the domains ``which`` (n,) replaced.

    ``old`` and ``new`` hold the same arrays, the pairs' domains first; the new ones
    are those of the domains ``which``. The pairs come back sorted by domain.
    """
    keep = ~which[old[0]]
    merged = [np.concatenate([a[keep], b]) for a, b in zip(old, new, strict=True)]
    order = np.argsort(merged[0], kind="stable")
    return tuple(a[order] for a in merged)


def _may_overlap(
    corners: np.ndarray,
    bounds: tuple[np.ndarray, np.ndarray],
    cell_vertices: np.ndarray,
    boxes: tuple[np.ndarray, np.ndarray],
    owner: np.ndarray,
    cell: np.ndarray,
) -> np.ndarray:
    """False for the (domain, cell) pairs that cannot overlap (m,).

    Those whose bounding boxes (``bounds`` of the domains, ``boxes`` of the cells: lower
    and upper corners) miss each other, and those whose cell lies wholly beyond a face
    of the domain; in compiled loops (:func:`fe_mpm.clip_kernels.may_meet`) unless
    numba is missing or ``FE_MPM_COMPILED=0``.
    """
    origin, edges = corners[:, 0], corners[:, 1:] - corners[:, :1]  # (n, d), (n, d, d)
    # x = origin + ξ · edges, so ξ = (x − origin) · edges⁻¹ for each domain.
    inverse = np.linalg.inv(edges)
    # A cell touching the domain at a face, edge or vertex (ξ = 0 there up to
    # round-off) meets it in nothing: the tolerance drops those too.
    tol = 1e-12
    kernels = compiled_module("fe_mpm.clip_kernels", "the compiled cuts of point domains")
    if kernels is not None:
        return kernels.may_meet(
            *(np.ascontiguousarray(a, dtype=np.float64) for a in (corners, inverse, *bounds)),
            *(np.ascontiguousarray(a, dtype=np.float64) for a in (cell_vertices, *boxes)),
            np.ascontiguousarray(owner, dtype=np.int64),
            np.ascontiguousarray(cell, dtype=np.int64),
            tol,
        )
    (low, high), (box_low, box_high) = bounds, boxes
    meets = np.all((box_low[cell] <= high[owner]) & (box_high[cell] >= low[owner]), axis=1)
    o, c = owner[meets], cell[meets]
    xi = np.einsum("kvg,kgh->kvh", cell_vertices[c] - origin[o, None], inverse[o])
    beyond = np.any(np.all(xi < tol, axis=1), axis=1) | np.all(xi.sum(axis=2) > 1.0 - tol, axis=1)
    meets[meets] = ~beyond
    return meets
