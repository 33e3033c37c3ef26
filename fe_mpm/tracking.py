"""The first phase of a step: which cell each point is in, and what that layout allows.

:class:`PointTracking` finds every point's cell (or holds it in last step's cell
when a step is retried that way, see :mod:`fe_mpm.retry`), removes or refuses the
points that left the grid, and lays the points out in slots
(:class:`~fe_mpm.quadrature.SlotLayout`). The checks below read a layout: enough
points per cell for P2/P1, and occupied cells hinged to the rest at one node.
"""

from __future__ import annotations

import math

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.errors import ConvergenceError, MarkerHostLeftError, PointsOutsideError, warn
from fe_mpm.formulations import FormulationSpec
from fe_mpm.markers import Markers
from fe_mpm.migration import migrate, owning_ranks, send
from fe_mpm.particles import MaterialPoints
from fe_mpm.quadrature import SlotLayout, slot_count
from fe_mpm.tracker import Tracker
from fe_mpm.transfer import summed_over_ranks

#: A held point may lie this far outside its old cell (the least barycentric coordinate).
HOLD_REACH = 0.5


class PointTracking:
    """Locates the points at every step and lays them out in slots.

    Args:
        tracker: The grid's point locator.
        points_leaving: ``"raise"`` or ``"drop"`` for points that leave the grid.

    Attributes:
        held_points: Points held in last step's cell at the last tracking.
        dropped: Points removed so far over all ranks (``points_leaving="drop"``).
    """

    def __init__(self, tracker: Tracker, points_leaving: str = "raise"):
        self.tracker, self.points_leaving = tracker, points_leaving
        self.held_points = 0
        self.dropped = 0
        self.migrated = 0  # points that moved between ranks at the last tracking
        #: What the last step's update carried out of the grid, in words ("" if nothing).
        self.left = ""
        self._nslot: int | None = None  # slots per entity, kept while they suit
        # (rank, cell) of each point in the last accepted step, kept in step with the
        # points as they migrate: a held point goes back to that rank and cell.
        self._home: np.ndarray | None = None

    def remember(self, cells: np.ndarray) -> None:
        """Keep the cells of an accepted step (n,), where a retry may hold the points."""
        rank = self.tracker.mesh.comm.rank
        self._home = np.column_stack([np.full(cells.size, rank), cells]).astype(np.int64)

    def keep(self, keep: np.ndarray) -> None:
        """Keep the remembered cells of the points where ``keep`` (n,) is true."""
        self._home = None if self._home is None else self._home[keep]

    def forget(self) -> None:
        """No accepted step to hold the points in (set-up, restart)."""
        self._home = None

    def extend_home(self, count: int) -> None:
        """Give ``count`` points appended to the points rows with no cell of a last step."""
        if self._home is not None and count:
            rank = self.tracker.mesh.comm.rank
            rows = np.column_stack([np.full(count, rank), np.full(count, -1)])
            self._home = np.vstack([self._home, rows.astype(self._home.dtype)])

    @property
    def can_hold(self) -> bool:
        """Whether a retry can hold the points in the cells of the last accepted step."""
        return self._home is not None

    def track(
        self,
        points: MaterialPoints,
        markers: Markers,
        step: int = 0,
        t: float = 0.0,
        hold: bool = False,
    ) -> SlotLayout:
        """Find each point's cell (``points.cell``) and return their slot layout.

        Args:
            points: The material points; those that left the grid are removed when
                ``points_leaving="drop"``.
            markers: The markers; their hosts are renumbered after a drop.
            step: The step about to be taken (0: set-up), for messages.
            t: Its end time, for messages.
            hold: Hold each point in its cell of the last accepted step
                (:meth:`remember`) if it lies within :data:`HOLD_REACH` of it.
        """
        comm = self.tracker.mesh.comm
        cells, ties = self.tracker.locate_with_ties(points.x, points.cell)
        self.held_points, self.migrated = 0, 0
        # On one rank a retry holds the points only if every point is in the grid.
        if hold and self._home is not None and (comm.size > 1 or np.all(cells >= 0)):
            cells = self._hold(points, markers, cells)
            ties = None  # a held point stays in its cell, and the points were renumbered
        # The others in another rank's cells go there.
        cells, migrated, self._home = migrate(
            points, markers, self.tracker, cells, self._home, ties
        )
        self.migrated += migrated
        outside = np.flatnonzero(cells < 0)
        where = _when(step, t)
        if parallel.any_rank(comm, outside.size > 0):
            cells = self._drop(points, markers, cells, outside, where)
        points.cell = cells
        return self.lay_out(cells, step, t)

    def leaving(
        self, points: MaterialPoints, markers: Markers, moved: np.ndarray, step: int, t: float
    ) -> np.ndarray:
        """The points a step is about to carry out of the grid, to drop or to tell of.

        Called before the step's update, so that a marker whose host would leave
        (``points_leaving="drop"``) stops the run with nothing updated. With
        ``"drop"`` the points returned are dropped once they have moved; with
        ``"raise"`` none are returned, and :attr:`left` says what left, for the step
        to tell once it is kept: its solution is the grid's, so a one-step solve on a
        grid fitted to the body (Cook's membrane, whose tip bulges past the grid's
        edge) keeps its answer, and the next step's tracking stops the run. Until
        2026-12-07 nothing was said, and a run's last step wrote points outside the
        grid and ended normally (a helper's bad-input probes). It locates every moved
        point (about 0.5 % of a strip footing's step). Points that land in another
        rank's cells are not leaving (the next tracking sends them). Collective.

        Args:
            points: The points, not yet updated (their cells the step's).
            markers: Their markers.
            moved: Their positions after the step (n, g), m.
            step: The step, for the message.
            t: Its end time, for the message.

        Returns:
            This rank's leaving points (indices) with ``"drop"``; none with ``"raise"``.

        Raises:
            MarkerHostLeftError: A marker's host would leave (``"drop"``).
        """
        comm = self.tracker.mesh.comm
        self.left = ""
        lost = np.flatnonzero(self.tracker.locate(moved, points.cell) < 0)
        if comm.size > 1 and parallel.any_rank(comm, lost.size > 0):
            # A point just past the grid's edge is owned within the padding; owned by this
            # rank, whose cells do not hold it, it has left, as migrate() finds it.
            owner = owning_ranks(self.tracker, moved[lost])
            lost = lost[(owner < 0) | (owner == comm.rank)]
        if self.points_leaving == "drop":
            parallel.raise_together(comm, hosts_leaving(markers.hosts(), lost, step, t))
            return lost
        if parallel.any_rank(comm, lost.size > 0):
            count = int(parallel.total(comm, int(lost.size)))
            first = None
            if lost.size:
                # Named by where it started: an index is the rank's own (a helper's
                # run named point 46, 2 and 1 on 1, 2 and 3 ranks).
                first = (
                    f"the point that started at x0 = {points.x0[lost[0]]}, now at x = "
                    f"{moved[lost[0]]}"
                )
            if comm.size > 1:  # the lowest rank that has one gives the example
                first = parallel.first_given(comm, first)
            self.left = (
                f"Step {step} (t = {t:g}) carried {count} material point(s) out of the grid "
                f"(first: {first}). The step is kept, its solution being the grid's, and "
                "the points are written where they went, but no step can follow: the next "
                f"one stops. {LEAVING_ADVICE}"
            )
        return np.zeros(0, dtype=np.int64)

    def drop(
        self,
        points: MaterialPoints,
        markers: Markers,
        lost: np.ndarray,
        step: int,
        t: float,
        domains: bool = False,
    ):
        """Remove the points :meth:`leaving` found, now that the step has moved them out.

        Left to the next step's tracking, the points that the last step of a run
        carried out stayed among the points, in the output and in every total taken
        after the run (found 2026-12-06 by a helper: a block thrown out of its grid
        ended with 12 of its 48 leavers kept). Collective.

        Args:
            points: The points, updated by the step (their cells still the step's).
            markers: Their markers (none hosted by a leaving point).
            lost: This rank's leaving points, from :meth:`leaving`.
            step: The step, for the warning.
            t: Its end time, for the warning.
            domains: Whether the points go with their domains (less than half of each
                inside the grid), which the warning then says: such a point itself may
                still lie inside.
        """
        if self.points_leaving != "drop":
            return
        if parallel.any_rank(self.tracker.mesh.comm, lost.size > 0):
            cells = np.array(points.cell, copy=True)  # the step's, for those kept
            cells[lost] = -1
            points.cell = self._drop(points, markers, cells, lost, _when(step, t), domains)

    def lay_out(self, cells: np.ndarray, step: int = 0, t: float = 0.0) -> SlotLayout:
        """The slot layout of points in ``cells`` (n,), found already (the domains' pieces).

        Collective: the slot count is the same on every rank.
        """
        try:
            self._nslot = slot_count(np.bincount(cells), self._nslot, self.tracker.mesh.comm)
        except ValueError as err:  # the points piled up: say where and when
            raise ValueError(f"{_when(step, t)}: {err}") from None
        return SlotLayout.from_cells(cells, self._nslot)

    def _hold(self, points: MaterialPoints, markers: Markers, cells: np.ndarray) -> np.ndarray:
        """Hold the points near their last accepted cells there; return the cells.

        A point that has since migrated goes back to the rank of that cell first.
        """
        comm = self.tracker.mesh.comm
        if comm.size > 1:
            away = np.flatnonzero(self._home[:, 0] != comm.rank)
            destination = self._home[away, 0]
            cells, migrated, self._home = send(
                points, markers, self.tracker, cells, away, destination, self._home
            )
            self.migrated += migrated
        home = self._home[:, 1].astype(np.int32)
        near = self.tracker.barycentric(points.x, home).min(axis=1) >= -HOLD_REACH
        held = np.where(near, home, cells).astype(np.int32)
        self.held_points = int(np.count_nonzero(held != cells))
        return held

    def _drop(
        self,
        points: MaterialPoints,
        markers: Markers,
        cells: np.ndarray,
        outside: np.ndarray,
        where: str,
        domains: bool = False,
    ) -> np.ndarray:
        """Refuse, or remove with a warning, the points outside the grid; the kept cells.

        Collective: a point left outside here after migration is in no rank's cells.
        Every rank refuses alike, or drops its own such points.
        """
        comm = self.tracker.mesh.comm
        count = int(parallel.total(comm, int(outside.size)))
        first = _outside_message(points, outside, where, count, domains) if outside.size else None
        if comm.size > 1:  # the lowest rank that has one gives the example
            first = parallel.first_given(comm, first)
            if not domains:  # (a point whose domain went may still lie in a cell)
                first += f" (in none of the {comm.size} MPI ranks' cells)"
        if self.points_leaving == "raise":
            # At set-up no step has moved them: the advice on steps does not apply.
            advice = SEEDED_OUTSIDE if where == "set-up" else LEAVING_ADVICE
            parallel.raise_together(
                comm,
                PointsOutsideError(f"{first}. {advice}"),
            )
        warn(first + "; dropped.")
        keep = cells >= 0
        error = None
        try:
            markers.keep_hosts(keep)
        except PointsOutsideError as err:
            error = PointsOutsideError(
                f"{err} at {where}: points_leaving='drop' removes points, but a marker "
                "moves with its host point; put markers on material that stays in the grid"
            )
        parallel.raise_together(comm, error)
        points.keep(keep)
        self._home = None if self._home is None else self._home[keep]
        self.dropped += count  # every rank keeps the total: reading it needs no message
        if parallel.total(comm, len(points)) == 0:
            raise PointsOutsideError(f"all material points have left the grid at {where}")
        return cells[keep]


#: What a run stopped by points outside the grid says to do.
LEAVING_ADVICE = (
    "The grid does not move with the body: leave empty cells "
    "wherever it may go (a face on the grid's edge bulges out of it unless "
    "a Dirichlet condition holds it), or pass points_leaving='drop' to "
    "remove what flies off. Where a condition holds that edge: if it moves "
    "the edge outwards (a lowered trapdoor, a settling base), the body it "
    "holds goes out with it, however short the steps: put the moving "
    "condition on facets inside the grid, with empty cells beyond them; if it "
    "holds the edge still, the step moved the nodes beside it by more than "
    "their cells, turning those cells over: take shorter steps. Where a RigidWall is "
    "that edge, the body went through its springs: an impact that the steps resolve "
    "in one or two does (a disk dropped on a wall, 2026-12-07), so take steps of a "
    "fifth of the contact or shorter (docs/dynamics.md)."
)

#: What set-up says of points that no step moved and that lie outside the grid.
SEEDED_OUTSIDE = (
    "They were given there: make the grid cover every point (with empty cells where "
    "the body will go), or move or remove those points (points.keep(mask)) before "
    "Simulation."
)


def hosts_leaving(
    hosts: dict[str, int], lost: np.ndarray, step: int, t: float
) -> MarkerHostLeftError | None:
    """The error of a step that would carry a marker's host out of the grid, or None.

    ``hosts``: each marker's host point on this rank (name → index); ``lost``: the
    points (or, with point domains, the domains) the step would carry out. Raised
    before anything moves, so nothing was updated.
    """
    lost_set = set(lost.tolist())
    gone = [name for name, host in hosts.items() if host in lost_set]
    if not gone:
        return None
    return MarkerHostLeftError(
        f"the host point of marker {gone[0]!r} left the grid at {_when(step, t)}: "
        "points_leaving='drop' removes points, but a marker moves with its host point; "
        "put markers on material that stays in the grid. Nothing was updated."
    )


def _outside_message(
    points: MaterialPoints, outside: np.ndarray, where: str, count: int, domains: bool = False
) -> str:
    first = outside[0]
    if domains:  # the point itself may still lie inside (a helper's column impact)
        return (
            f"{count} material point(s) left the grid with their domains (less than half "
            f"of each inside) at {where}; first: point {first} at x = {points.x[first]}"
        )
    return (
        f"{count} material point(s) left the grid at {where}; first: "
        f"point {first} at x = {points.x[first]}"
    )


def _when(step: int, t: float) -> str:
    """Where a message puts a tracking: the step and its end time, or set-up (step 0)."""
    return f"step {step} (t = {t:g})" if step else "set-up"


def cell_fill_anywhere(
    mesh: dolfinx.mesh.Mesh,
    cells: np.ndarray,
    volumes: np.ndarray,
    cell_volumes: np.ndarray,
    owned: int,
) -> np.ndarray:
    """The share of each owned cell (owned,) that material fills, summed over the ranks.

    ``cells`` and ``volumes`` (n,) are this rank's points' cells (ghost cells included:
    point domains put pieces there) and volumes (m² or m³); ``cell_volumes`` the
    owned cells' own. Collective under MPI.
    """
    cell_map = mesh.topology.index_map(mesh.topology.dim)
    size = cell_map.size_local + (cell_map.num_ghosts if mesh.comm.size > 1 else 0)
    held = np.bincount(cells, weights=volumes, minlength=size).astype(float)
    if mesh.comm.size > 1:
        held = summed_over_ranks(cell_map, held)
    return held[:owned] / cell_volumes[:owned]


def check_points_per_cell(
    layout: SlotLayout,
    spec: FormulationSpec,
    step_number: int,
    centroids: np.ndarray,
    tied: np.ndarray | None,
    comm,
) -> None:
    """Refuse a layout with fewer points in an occupied cell than the formulation needs.

    ``spec.min_points_per_cell`` is 3 for P2/P1 on triangles and 4 on tetrahedra (the
    rank of the P2 strain) and 1 otherwise; ``centroids`` (cells, g) locate the cell
    named in the message. Cells
    in ``tied`` (those the ghost penalty ties to a neighbour, :mod:`fe_mpm.ghost`)
    may hold fewer. Collective over ``comm``: every rank raises when one finds such a
    cell.

    Raises:
        ValueError: At set-up (``step_number`` 0): seed more points.
        ConvergenceError: Later, when points moved that way: a step may still converge on
            the singular tangent, to a wrong answer (Cook's membrane over 20 steps: 0.17
            for 1.30), so the run stops.
    """
    need = spec.min_points_per_cell(centroids.shape[1])
    if need <= 1:
        return
    counts = np.bincount(layout.cell)[layout.occupied]
    if tied is not None:
        counts[np.isin(layout.occupied, tied)] = need
    # Over every rank: one rank's count read 72, 36 or 24 cells on 1, 2 or 3 ranks.
    few = int(parallel.total(comm, int(np.sum(counts < need))))
    if few == 0:  # every rank knows: no second collective
        return
    error = (
        None
        if counts.min(initial=need) >= need
        else _too_few(counts, need, few, layout, spec, step_number, centroids, tied is not None)
    )
    parallel.raise_together(comm, error)


def _too_few(counts, need, few, layout, spec, step_number, centroids, ghost: bool) -> Exception:
    """The error of a layout with cells of fewer than ``need`` points (counts per occupied cell).

    ``few``: how many cells of every rank hold too few. ``ghost``: whether a ghost
    penalty is on (the advice then does not repeat it). The example cell is named by
    its place, not its index, which is a rank's own.
    """
    formulation = spec.name
    worst = layout.occupied[np.argmin(counts)]
    message = (
        f"formulation {formulation!r} needs at least {need} material points in "
        f"every occupied cell, but {few} cell(s) hold fewer (e.g. the cell near x = "
        f"{centroids[worst]} holds {counts.min()}) and no ghost facet ties it to a "
        "neighbour: the quadratic displacement then has strain modes no point sees."
    )
    # Point domains carry P2 on triangles only.
    domains = centroids.shape[1] == 2
    if step_number == 0:
        return ValueError(
            f"Simulation: {message} Seed more points per cell"
            + (
                ", or pass point_domains=True (then one point per cell is enough)."
                if domains
                else "."
            )
        )
    ghost_advice = (
        "the ghost penalty holds only a cell tied by a facet to cells with enough points, "
        "and this one is not; use"
        if ghost
        else "use a ghost_penalty > 0 (it holds a cell tied by facets to cells with enough points),"
    )
    if domains:
        ghost_advice += " point_domains=True,"
    return ConvergenceError(
        f"step {step_number + 1}: {message} The points no longer support the unknowns; "
        f"{ghost_advice} more points per cell, or the 'up' (P1) formulation."
    )


def sparse_mass_diagnosis(
    mesh: dolfinx.mesh.Mesh, layout: SlotLayout, centroids: np.ndarray, degree: int = 1
) -> str:
    """Explain a failed dynamic step with the consistent mass by its sparsely filled cells.

    The consistent mass of a cell, Σ_p m_p N(x_p) N(x_p)ᵀ, has the rank of the number
    of points it holds (at most the cell's node count: 3 or 4 for P1, 6 or 10 for the
    P2 displacement of ``degree`` 2): a cell with fewer points holds its nodes only
    along the motions its points see. A material that carries no tension (sand flying
    apart) adds no stiffness there, and Newton may then find no solution however short
    the step. Returns "" when every occupied cell holds enough.
    """
    nodes = math.comb(mesh.topology.dim + degree, degree)
    counts = np.bincount(layout.cell, minlength=int(layout.occupied.max(initial=-1)) + 1)
    sparse = layout.occupied[counts[layout.occupied] < nodes]
    if sparse.size == 0:
        return ""
    return (
        f"{sparse.size} occupied cell(s) hold fewer than {nodes} points (first near x = "
        f"{centroids[sparse[0]]}); with the consistent mass (the default) such a cell holds "
        "its nodes only along the motions its points see, and where the material carries "
        "no tension nothing else holds them. mass='lumped' holds every node a point "
        "touches (the granular demos take it; docs/dynamics.md). "
    )


def hinged_cells(
    mesh: dolfinx.mesh.Mesh,
    occupied: np.ndarray,
    held_nodes: np.ndarray | None = None,
    tied_cells: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """The occupied cells hinged to the rest at one node: this rank's, and the count.

    A P1 simplex has a constant strain whatever number of points it holds, so an
    occupied cell that shares at most one node with the other occupied cells can
    rotate freely about it: a mechanism of quasi-static MPM that appears when points
    cross into empty cells. A node in ``held_nodes`` (geometry nodes a condition
    holds) counts as shared, and a cell in ``tied_cells`` (one that a penalty point
    holds) is not hinged. Collective: the nodes' uses are counted over every rank, so
    a cell beside another rank's is not taken for hinged (on two ranks one rank's
    message named a hinged cell and the other's did not; a helper's trench,
    2026-12-06).
    """
    nodes = mesh.geometry.dofmaps[0][occupied]
    index_map = mesh.geometry.index_map()
    uses = np.zeros(index_map.size_local + index_map.num_ghosts)
    np.add.at(uses, nodes.ravel(), 1.0)
    if held_nodes is not None:
        uses[np.asarray(held_nodes, dtype=np.int64)] += 2.0  # shared, on every rank
    uses = summed_over_ranks(index_map, uses)
    shared = (uses[nodes] > 1).sum(axis=1)
    hinged = occupied[shared <= 1]
    if tied_cells is not None:
        hinged = np.setdiff1d(hinged, tied_cells)
    return hinged, int(parallel.total(mesh.comm, int(hinged.size)))


def hinge_diagnosis(mesh: dolfinx.mesh.Mesh, layout: SlotLayout, centroids: np.ndarray) -> str:
    """Explain a singular tangent by occupied cells hinged to the rest at one node.

    See :func:`hinged_cells`. Returns "" when no cell is hinged. Collective: every
    rank returns the same words.
    """
    hinged, count = hinged_cells(mesh, layout.occupied)
    if count == 0:
        return ""
    first = parallel.first_given(mesh.comm, centroids[hinged[0]] if hinged.size else None)
    return (
        f"{count} occupied cell(s) share at most one node with the rest of the "
        f"material (first near x = {first}); such a cell can swing about that "
        "node, so the static tangent is singular there. This typically follows points "
        "crossing into otherwise empty cells; a coarser grid or a dynamic analysis "
        "avoids it. "
    )
