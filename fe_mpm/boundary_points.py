"""The points of every PointDirichlet, PointTraction and PointPressure, and their part in a step."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fe_mpm import parallel
from fe_mpm.boundary import (
    SNAP_REACH,
    PointDirichlet,
    PointPressure,
    PointTraction,
    face_vectors,
)
from fe_mpm.checks import check_range
from fe_mpm.errors import PointsOutsideError, warn
from fe_mpm.grid_conditions import LOST_LOAD_WARNING_STEP
from fe_mpm.quadrature import SlotLayout, slot_count
from fe_mpm.tracker import Tracker

#: A traction point in a cell that the material fills less than this share of loads
#: an occupied neighbour within its reach that is filled more, where there is one:
#: the nodes of a cell that holds a sliver are held as weakly as the sliver is small,
#: and a load on them throws them. Found on a 3D cantilever seeded by level set (a
#: gmsh box, the tip load as a PointTraction on its end face): a load point in a cut
#: cell filled to 1e-7 was thrown 1.6 m in a step of 1/640 of the load; with this
#: the run took 4–5 Newton iterations a step to a tip deflection of 40 % of the
#: length (3 a step at the test's smaller load). Cells filled more than a tenth
#: (the tip's others: 0.13–0.74) are not passed over, nor, since 2026-12-06, cells
#: that the ghost penalty ties to their neighbours in a static run (on by default
#: with point domains there): the sliver is then the body's face, moved into the next
#: cell by the step before, and a load moved off it left it unloaded (a plate pulled
#: on its face drifted from uniform stress by 1.9 % in 8 steps; ``tests/test_point_loads.py``).
LOAD_MIN_FILL = 0.1
#: A P2 field read this far outside a cell (its smallest barycentric coordinate below
#: minus this) bends away from the material, and a PointDirichlet whose points read it
#: there in more than :data:`P2_FAR_SHARE` of its points in a step is warned about (once
#: a run). Measured 2026-12-05 (``docs/cell_crossing.md``, Not yet): a J2 block on a gmsh
#: grid laid over it, sheared by point platens, held by P2/P1 to 1.5 N where P1 holds
#: 22.4 N, 40–88 % of the platens' points reading more than a fifth of a cell out; the
#: squeezed block of ``tests/test_domains.py``, whose P2/P1 force is exact to 0.05 %,
#: 2–6 % of its points.
P2_FAR_READ = 0.2
P2_FAR_SHARE = 0.25
#: A load on a P2 displacement whose points lie one to a cell in more than this share
#: of the cells they load is warned about (once a run): a quadratic vertex function
#: vanishes at an edge's midpoint, so ``facet_points``' default puts a facet's whole
#: load on its middle node. Measured 2026-12-06 (a helper's scene): a block under a
#: uniform PointTraction on its top, midpoints, ``"up-p2p1"``: σ_yy off by up to 39 %,
#: σ_xx up to 0.32 of the load; with ``degree=2`` (two points an edge) exact.
P2_SPARSE_SHARE = 0.5
#: What too many boundary points in a cell are, and the cure (:func:`~fe_mpm.quadrature.bucket`).
CROWDED_CELL = (
    "boundary points (of PointDirichlet, PointTraction and PointPressure together)",
    "place fewer (meshes.facet_points(..., subdivisions=k) puts k^(g-1) pieces on each facet)",
)


class BoundaryPoints:
    """Positions, weights, penalties and tractions of every boundary point, concatenated.

    Args:
        conditions: The point conditions (prescribed displacements and tractions).
        gdim: Geometric dimension g.

    Attributes:
        x: Current positions (N, g), m, convected with the grid solution.
        x0: Initial positions (N, g), m.
        owner: Index of each point's condition (N,).
        weight: Boundary measure of each point (N,).
        stiffness: β on the constrained components, 0 on the free ones and on
            traction points (N, g), Pa/m.
        loaded: Whether each point carries a traction or a pressure (N,), bool; the
            others are penalty points.
        pressed: Whether each point carries a pressure (N,), bool.
        area: The body's face each pressure point carries, ``weight · normal``, as it
            is now (N, g), m (2D) or m² (3D); 0 on the other points.
        corners: The corners of each pressure point's facet piece as they are now
            (N, g, g), m, where its :class:`~fe_mpm.boundary.PointPressure` gave them;
            NaN elsewhere.
        framed: Whether each point's area is read from its corners (N,), bool.
        face_scale: The share of its piece's area vector each framed point carries,
            signed so that it points along the given normal (N,); 0 elsewhere.
    """

    def __init__(
        self, conditions: Sequence[PointDirichlet | PointTraction | PointPressure], gdim: int
    ):
        self.conditions = list(conditions)
        xs, weights, owners, stiffness, reaches, areas = [], [], [], [], [], []
        corners, scales = [], []
        for i, c in enumerate(self.conditions):
            kind = type(c).__name__
            x = np.asarray(c.x, dtype=np.float64)
            if x.ndim != 2 or x.shape[1] != gdim or x.shape[0] == 0:
                raise ValueError(
                    f"{kind} {c.name!r}: x must have shape (n, {gdim}) with n ≥ 1, got {x.shape}"
                )
            w = np.broadcast_to(np.asarray(c.weight, dtype=np.float64), (x.shape[0],))
            if not np.all(w > 0) or not np.all(np.isfinite(w)):
                raise ValueError(f"{kind} {c.name!r}: every weight must be > 0")
            pressure = isinstance(c, PointPressure)
            if not pressure and np.asarray(c.at(0.0)).shape != (gdim,):
                raise ValueError(f"{kind} {c.name!r}: value must have {gdim} components")
            xs.append(x)
            weights.append(w)
            owners.append(np.full(x.shape[0], i))
            framed = pressure and c.corners is not None
            if framed:  # the area is its share of the piece, along the given normal
                vectors = face_vectors(c.corners)
                sign = np.sign(np.einsum("ni,ni->n", vectors, c.normal))
                scale = sign * w / np.linalg.norm(vectors, axis=1)
                corners.append(np.asarray(c.corners, dtype=np.float64))
                scales.append(scale)
                areas.append(scale[:, None] * vectors)
            else:
                corners.append(np.full((x.shape[0], gdim, gdim), np.nan))
                scales.append(np.zeros(x.shape[0]))
                areas.append(w[:, None] * c.normal if pressure else np.zeros((x.shape[0], gdim)))
            if isinstance(c, PointTraction | PointPressure):
                stiffness.append(np.zeros((x.shape[0], gdim)))
                reaches.append(np.full(x.shape[0], SNAP_REACH))
                continue
            reaches.append(c.reach)
            check_range(f"PointDirichlet {c.name!r}", "penalty", c.penalty, lo=0.0, lo_open=True)
            mask = np.zeros(gdim)
            for comp in range(gdim) if c.components is None else c.components:
                check_range(f"PointDirichlet {c.name!r}", "components", comp, lo=0, hi=gdim - 1)
                mask[int(comp)] = 1.0
            stiffness.append(np.tile(c.penalty * mask, (x.shape[0], 1)))
        self.x0 = np.vstack(xs)
        self.x = self.x0.copy()
        self.weight = np.concatenate(weights)
        self.owner = np.concatenate(owners)
        self.stiffness = np.vstack(stiffness)
        self.reach = np.concatenate(reaches)
        kinds = [
            (isinstance(c, PointTraction), isinstance(c, PointPressure)) for c in self.conditions
        ]
        self.pressed = np.array([pressure for _, pressure in kinds])[self.owner]
        self.loaded = np.array([traction or pressure for traction, pressure in kinds])[self.owner]
        self.area = np.vstack(areas)
        self.corners = np.concatenate(corners)
        self.face_scale = np.concatenate(scales)
        self.framed = self.face_scale != 0.0

    def __len__(self) -> int:
        return self.x.shape[0]

    def _values(self, t: float) -> np.ndarray:
        """Each point's displacement or traction at time ``t`` (N, g); 0 at a pressure point."""
        g = self.x.shape[1]
        values = [np.zeros(g) if isinstance(c, PointPressure) else c.at(t) for c in self.conditions]
        return np.array(values)[self.owner]

    def pressures(self, t: float) -> np.ndarray:
        """Pressure at each point at time ``t`` (N,), Pa; zero on the other points."""
        values = [c.at(t) if isinstance(c, PointPressure) else 0.0 for c in self.conditions]
        return np.array(values)[self.owner]

    def targets(self, t: float) -> np.ndarray:
        """Where the points should be at time ``t`` (N, g).

        ``x₀ + value(t)`` for a prescribed displacement; traction points have no
        target and stay where they are.
        """
        return np.where(self.loaded[:, None], self.x, self.x0 + self._values(t))

    def tractions(self, t: float) -> np.ndarray:
        """Traction at each point at time ``t`` (N, g), Pa; zero on penalty points."""
        return np.where(self.loaded[:, None], self._values(t), 0.0)

    def point_forces(self, mismatch: np.ndarray, active: np.ndarray, t: float) -> np.ndarray:
        """Force of each active point on the body (n_active, g), N (N/m in 2D).

        ``−w_b β P_b (x_b − x_b^target)`` for a prescribed displacement, ``w_b t_b``
        for a traction, ``−p a_b`` for a pressure (on the face as it is at the end of
        the step: call it after :attr:`area` is updated).

        Args:
            mismatch: End-of-step gap of the active points (n_active, g), m.
            active: Boolean mask of the points that took part in the step (N,).
            t: Time at the end of the step.
        """
        per_point = self.weight[active, None] * (
            self.tractions(t)[active] - self.stiffness[active] * mismatch
        )
        per_point -= self.pressures(t)[active, None] * self.area[active]
        return per_point

    def by_condition(self, per_point: np.ndarray, active: np.ndarray) -> dict[str, np.ndarray]:
        """The sum of ``per_point`` (n_active, g) over each condition's points (g,)."""
        return {
            c.name: per_point[self.owner[active] == i].sum(axis=0)
            for i, c in enumerate(self.conditions)
        }


class BoundaryPointStep:
    """The boundary points within a step: located, packed, and moved with the solution.

    Only the points in (or within half a cell of) occupied cells take part; the
    others (e.g. a footing point above the soil) follow their target until material
    reaches them. On a distributed grid every rank holds all boundary points (they
    are few) and each point takes part on the one rank whose cell it reads.

    Args:
        points: All boundary points of the simulation.
        tracker: The grid's point locator.
        degree: The displacement's polynomial degree (1 or 2).
    """

    def __init__(self, points: BoundaryPoints, tracker: Tracker, degree: int = 1):
        self.points, self.tracker, self.degree = points, tracker, degree
        self.layout: SlotLayout | None = None
        self._nslot: int | None = None  # slots per entity, kept while they suit
        self._active = np.zeros(len(points), dtype=bool)
        self._gap = np.zeros((0, points.x.shape[1]))
        #: The share of each load's weight (by name) whose points are in no occupied
        #: cell at the last step, where > 0: their load is not applied.
        self.lost_load: dict[str, float] = {}
        self._warned_share: dict[int, float] = {}  # the largest share warned, by condition
        self._warned_far = False
        self._checked_rule = degree == 1  # P2 loads: their points per facet, once
        self._checked_normals = not points.pressed.any()  # pressures' normals, once

    @classmethod
    def of(
        cls,
        conditions: Sequence[PointDirichlet | PointTraction],
        tracker: Tracker,
        degree: int = 1,
    ) -> BoundaryPointStep | None:
        """The boundary points of ``conditions`` on the grid of ``tracker``; None if none."""
        if not conditions:
            return None
        points = BoundaryPoints(conditions, tracker.mesh.geometry.dim)
        _check_same_on_every_rank(tracker.mesh.comm, points)
        return cls(points, tracker, degree)

    def locate(
        self,
        occupied_cells: np.ndarray,
        t_new: float,
        fill: np.ndarray | None = None,
        tied: np.ndarray | None = None,
    ) -> SlotLayout:
        """Slot layout of the boundary points that lie in occupied cells.

        A traction point out of the material has nothing to load, which is worth a
        warning (once per run). Given each owned cell's ``fill`` (the share of it the
        material fills), a traction point in a cell filled less than
        :data:`LOAD_MIN_FILL` loads a better-filled neighbour within reach instead,
        where there is one, unless the ghost penalty ties that cell to its
        neighbours (``tied``, its cells this step): then the load acts where it is.

        Raises:
            PointsOutsideError: A boundary point lies outside the grid.
        """
        pp, tracker = self.points, self.tracker
        occupied = np.zeros(tracker.num_cells, dtype=bool)
        occupied[occupied_cells] = True
        self._occupied = occupied  # where the step's faces read the grid (convect)
        # The body's surface lies between its points, often in a cell whose points
        # have moved on: read the field of an occupied neighbour, up to half a cell out.
        # Every rank holds every boundary point; each takes part on one rank only.
        cells, found = tracker.claim(pp.x, occupied, tol=pp.reach)
        loaded = np.flatnonzero(pp.loaded)
        if fill is not None and loaded.size:
            # A load on the nodes of a cell that holds a sliver of material moves them
            # as far as that sliver is soft (below, LOAD_MIN_FILL).
            well_filled = occupied & (fill >= LOAD_MIN_FILL)
            if tied is not None:
                # A load on the body's face in a cell the penalty holds loads that
                # cell: moved to the next, it leaves the sliver of body beyond it
                # unloaded (below, LOAD_MIN_FILL).
                held = tied[tied < well_filled.size]
                well_filled[held] = occupied[held]
            better, _ = tracker.claim(pp.x[loaded], well_filled, tol=pp.reach[loaded])
            moved = parallel.total(tracker.mesh.comm, (better >= 0).astype(np.int64)) > 0
            cells[loaded[moved]] = better[moved]
        if not np.all(found):
            first = np.flatnonzero(~found)[0]
            raise PointsOutsideError(
                f"boundary point {first} of {type(pp.conditions[pp.owner[first]]).__name__} "
                f"{pp.conditions[pp.owner[first]].name!r} at x = {pp.x[first]} is outside the grid "
                f"(step to t = {t_new:g}). Boundary points move with the body or their "
                "target: give the grid room along their path (empty cells beyond a face "
                "that moves outward, as a wall pulled back from the soil needs)"
            )
        self._active = cells >= 0
        self._count_lost_load(~self._active_anywhere() & pp.loaded, t_new)
        cells = cells[self._active]
        if self.degree == 2 and not self._warned_far:
            self._warn_far_reading(cells, t_new)
        if not self._checked_rule:
            self._checked_rule = True
            self._warn_sparse_loads(cells)
        if not self._checked_normals:
            self._checked_normals = True
            self._warn_inward_normals(cells, occupied)
        counts = np.bincount(cells)
        self._nslot = slot_count(counts, self._nslot, tracker.mesh.comm, CROWDED_CELL)
        self.layout = SlotLayout.from_cells(cells, self._nslot)
        return self.layout

    def _warn_far_reading(self, cells: np.ndarray, t_new: float) -> None:
        """Warn (once) where a PointDirichlet reads a P2 field far outside its cells.

        Args:
            cells: The active points' cells on this rank, in the order of ``_active``.
            t_new: The step's end time, for the message.
        """
        pp, comm = self.points, self.tracker.mesh.comm
        active = np.flatnonzero(self._active)
        outside = self.tracker.barycentric(pp.x[active], cells).min(axis=1)
        held = ~pp.loaded[active]
        n = len(pp.conditions)
        counted = np.bincount(pp.owner[active[held]], minlength=n)
        far = np.bincount(pp.owner[active[held & (outside < -P2_FAR_READ)]], minlength=n)
        counted, far = parallel.total(comm, counted), parallel.total(comm, far)
        share = np.divide(far, counted, out=np.zeros(n), where=counted > 0)
        if np.any(share > P2_FAR_SHARE):
            self._warned_far = True
            k = int(np.argmax(share))
            warn(
                f"{far[k]} of the {counted[k]} points of PointDirichlet "
                f"{pp.conditions[k].name!r} acting at the step to t = {t_new:g} read the "
                f"P2 displacement more than {P2_FAR_READ:g} of a cell outside the cells "
                "that hold material, where a quadratic field bends away from the body: "
                "the hold on it may be lost (docs/limitations.md). Fit the grid's lines "
                "to the edges these points hold, or take a P1 formulation."
            )

    def _count_lost_load(self, idle: np.ndarray, t_new: float) -> None:
        """Record and warn of the share of each load whose points act on nothing.

        A load point in no occupied cell (nor within reach of one) loads nothing, and
        the run goes on with the rest: a helper's cantilever (2026-12-07) ended with
        28 of its 32 tip points acting, 7/8 of the load, told once without the share.
        Each load's share of weight is kept in :attr:`lost_load` for the step's
        report, and warned about whenever it grows by ``LOST_LOAD_WARNING_STEP``.

        Args:
            idle: Which points carry a load that no rank applies (N,), the same on
                every rank.
            t_new: The step's end time (s), for the message.
        """
        pp = self.points
        self.lost_load = {}
        for k in np.unique(pp.owner[idle]):
            mine = pp.owner == k
            share = float(pp.weight[idle & mine].sum() / pp.weight[mine].sum())
            condition = pp.conditions[k]
            self.lost_load[condition.name] = share
            if share > self._warned_share.get(k, 0.0) + LOST_LOAD_WARNING_STEP:
                self._warned_share[k] = share
                first = np.flatnonzero(idle & mine)[0]
                warn(
                    f"{np.count_nonzero(idle & mine)} of the {np.count_nonzero(mine)} points "
                    f"of {type(condition).__name__} {condition.name!r} lie in no occupied "
                    f"cell at the step to t = {t_new:g} (first at x = {pp.x[first]}), so "
                    f"{100 * share:.1f} % of its load is not applied (StepReport.lost_load)."
                )

    def _warn_inward_normals(self, cells: np.ndarray, occupied: np.ndarray) -> None:
        """Warn where a PointPressure's normal points into the body; collective.

        A point's normal points out of the body when a cell's length along it leads
        into no occupied cell and the same length against it into one; a normal
        that points in has it the other way round, and then a positive pressure
        pulls on the face (a helper's probe, 2026-12-07: +1000 Pa on a block's top,
        its normal given as (0, −1), pulled it up by 1000 N/m, without a word).

        Args:
            cells: The active points' cells on this rank, in the order of ``_active``.
            occupied: Which of this rank's cells hold material.
        """
        pp, comm = self.points, self.tracker.mesh.comm
        size = np.zeros(len(pp))
        size[np.flatnonzero(self._active)] = self.tracker.sizes[cells]
        size = parallel.total(comm, size)  # each active point counted on one rank
        probe = np.flatnonzero(pp.pressed & (size > 0.0))
        unit = pp.area[probe] / np.linalg.norm(pp.area[probe], axis=1)[:, None]
        step = size[probe, None] * unit
        ahead, _ = self.tracker.claim(pp.x[probe] + step, occupied, tol=0.0)
        behind, _ = self.tracker.claim(pp.x[probe] - step, occupied, tol=0.0)
        ahead = parallel.total(comm, (ahead >= 0).astype(np.int64)) > 0
        behind = parallel.total(comm, (behind >= 0).astype(np.int64)) > 0
        owner = pp.owner[probe]
        inward = np.bincount(owner[ahead & ~behind], minlength=len(pp.conditions))
        outward = np.bincount(owner[behind & ~ahead], minlength=len(pp.conditions))
        for k in np.flatnonzero(inward > outward):
            condition = pp.conditions[k]
            warn(
                f"PointPressure {condition.name!r}: at {inward[k]} of its "
                f"{np.count_nonzero(owner == k)} points the normal points into the body "
                f"(at {outward[k]} out of it): normal is the body's outward normal and a "
                "positive pressure pushes along −normal, so this one pulls on the face. "
                "Reverse the normals, or give a negative value for a suction."
            )

    def _warn_sparse_loads(self, cells: np.ndarray) -> None:
        """Warn where a load on a P2 displacement has about one point per facet.

        Args:
            cells: The active points' cells on this rank, in the order of ``_active``.
        """
        pp, comm = self.points, self.tracker.mesh.comm
        g = pp.x.shape[1]
        active = np.flatnonzero(self._active)
        n = len(pp.conditions)
        sparse, loaded_cells = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
        for k in np.unique(pp.owner[active[pp.loaded[active]]]):
            counts = np.bincount(cells[pp.owner[active] == k])
            counts = counts[counts > 0]
            sparse[k], loaded_cells[k] = np.count_nonzero(counts < g), counts.size
        sparse, loaded_cells = parallel.total(comm, sparse), parallel.total(comm, loaded_cells)
        share = np.divide(sparse, loaded_cells, out=np.zeros(n), where=loaded_cells > 0)
        if np.any(share > P2_SPARSE_SHARE):
            k = int(np.argmax(share))
            condition = pp.conditions[k]
            warn(
                f"{type(condition).__name__} {condition.name!r}: {sparse[k]} of the "
                f"{loaded_cells[k]} cells it loads hold fewer than {g} of its points. A P2 "
                f"displacement needs {g} points on each facet for the load to reach the "
                "facet's nodes as a grid traction would: one at a facet's midpoint puts "
                "the facet's whole load on its middle node. Place them with "
                "meshes.facet_points(mesh, facets, degree=2)."
            )

    def penalty_cells(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """This step's acting penalty points: their cells, conditions and held components.

        The cells are this rank's (local indices), the conditions indices into
        ``points.conditions``, the components a boolean (k, g) array; empty before the
        first step.
        """
        pp, g = self.points, self.points.x.shape[1]
        if self.layout is None:
            return np.zeros(0, np.int32), np.zeros(0, np.int64), np.zeros((0, g), bool)
        acting = np.flatnonzero(self._active)
        held = pp.stiffness[acting] > 0.0
        stiff = held.any(axis=1)
        return self.layout.cell[stiff], pp.owner[acting[stiff]], held[stiff]

    def _active_anywhere(self) -> np.ndarray:
        """Whether each point takes part in the step on some rank (N,)."""
        return parallel.total(self.tracker.mesh.comm, self._active.astype(np.int64)) > 0

    def pack(self, forms, t_new: float) -> None:
        """Their positions, gaps, penalties and tractions into the step's slot fields."""
        pp, active, qb, layout = self.points, self._active, forms.q_boundary, self.layout
        qb.pack_geometry(
            self._read_at(), pp.weight[active], layout, self.tracker.centroids, self.tracker.volumes
        )
        self._gap = pp.x[active] - pp.targets(t_new)[active]
        qb.pack(forms.gap, layout, self._gap)
        qb.pack(forms.penalty_stiffness, layout, pp.stiffness[active])
        qb.pack(forms.boundary_traction, layout, pp.tractions(t_new)[active])
        if forms.boundary_pressure is not None:  # p a / w: the form's sum weighs by w
            pressure_area = pp.pressures(t_new)[active, None] * pp.area[active]
            qb.pack(forms.boundary_pressure, layout, pressure_area / pp.weight[active, None])

    def _read_at(self) -> np.ndarray:
        """Where each active point reads and loads its cell (n_active, g), m.

        A penalty point reads its cell where it is, up to its ``reach`` outside it
        (the field extended). A load outside its cell (a face that has moved past
        the filled cells, in standard MPM) acts at the cell's nearest point: a P1
        basis function read past the cell is negative on the far nodes, which then
        take a share of the load against its direction. On a plate pulled by a
        ``PointTraction`` whose face had moved a thousandth of a cell past them a
        step, σ_xx beside the face stayed within 0.57 % of uniform after 8 steps,
        against 1.40 % with the field extended (``tests/test_point_loads.py``). The
        point then also moves with the field read there (1.4e-6 m apart on that
        plate after 8 steps).
        """
        pp, active = self.points, self._active
        x = pp.x[active]
        loaded = np.flatnonzero(pp.loaded[active])
        if loaded.size:
            x[loaded] = self.tracker.pulled_into(x[loaded], self.layout.cell[loaded])
        return x

    def convect(
        self, forms, t_new: float, displacement_at=None, held_shares=None
    ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Move the points with the grid solution; return the forces on the body.

        The first dict holds each condition's force (g,); the second, the force each
        reaction boundary takes from the penalty points (g,), to add to its reaction.
        A penalty point's share ``N_I f_b`` on a node that a grid Dirichlet condition
        holds goes straight into that support and never reaches the body: it is moved
        from the point's force to the reaction of the boundary holding the node.
        Found 2026-12-07 by a helper: fixed penalty points in the bottom cells of a
        block on a fixed base, its top pulled by 13.2 kN/m, reported −49.4 kN/m and
        the base +36.3 kN/m, pushing up; only their sum was the body's.

        Args:
            forms: The step's forms (the boundary points' slot expressions).
            t_new: The step's end time (s).
            displacement_at: ``(cells, bary) -> Δu`` (n, g) of the step's solution, to
                move the corners of pressure points that have them; None: no corners
                move (their areas follow Nanson's rule alone).
            held_shares: ``(cells, bary) -> (Σ N_I over held nodes (n, g), {reaction
                boundary: the same over its held nodes})``
                (:meth:`GridConditions.held_shares`); None: nothing is held.
        """
        pp, active, comm = self.points, self._active, self.tracker.mesh.comm
        du = forms.du_at_boundary.evaluate(self.layout)
        if forms.boundary_pressure is not None:
            self._deform_faces(forms)
        per_point = pp.point_forces(self._gap + du, active, t_new)
        passed = {}
        if held_shares is not None:  # (collective: every rank names every boundary)
            supports = per_point * (pp.stiffness[active] > 0.0)  # penalty points only
            cells = self.layout.cell
            at = self.tracker.barycentric(self._read_at(), cells)
            on_held, on_reactions = held_shares(cells, at)
            per_point -= supports * on_held
            passed = {name: (supports * share).sum(axis=0) for name, share in on_reactions.items()}
        forces = pp.by_condition(per_point, active)
        # Each point moves on the rank where it took part; every rank keeps them all.
        moved = np.zeros_like(pp.x)
        moved[active] = du
        moved = parallel.total(comm, moved)
        anywhere = self._active_anywhere()
        if displacement_at is not None and np.any(pp.framed & anywhere):
            self._move_corners(displacement_at, moved, pp.framed & anywhere)
        pp.x[anywhere] += moved[anywhere]
        pp.x[~anywhere] = pp.targets(t_new)[~anywhere]  # outside the material: follow the target
        forces = {name: parallel.total(comm, force) for name, force in forces.items()}
        return forces, {name: parallel.total(comm, force) for name, force in passed.items()}

    def _move_corners(self, displacement_at, moved: np.ndarray, rows: np.ndarray) -> None:
        """Move the pieces' corners of ``rows`` with the grid and read their areas off them.

        Each corner reads the step's displacement in the occupied cell that holds it
        (up to ``SNAP_REACH`` outside, as a load point does), on the one rank that
        claims it; a corner no occupied cell reaches moves with its point (``moved``).
        Collective.
        """
        pp, tracker, comm = self.points, self.tracker, self.tracker.mesh.comm
        g = pp.x.shape[1]
        rows = np.flatnonzero(rows)
        at = pp.corners[rows].reshape(-1, g)
        cells, _ = tracker.claim(at, self._occupied, tol=SNAP_REACH)
        shift = np.zeros_like(at)
        mine = cells >= 0
        if np.any(mine):
            shift[mine] = displacement_at(cells[mine], tracker.barycentric(at[mine], cells[mine]))
        shift = parallel.total(comm, shift)
        # No rank's occupied cell took the corner (found only says the grid holds it):
        # it moves with its point.
        alone = parallel.total(comm, mine.astype(np.int64)) == 0
        shift[alone] = np.repeat(moved[rows], g, axis=0)[alone]
        pp.corners[rows] += shift.reshape(-1, g, g)
        pp.area[rows] = pp.face_scale[rows, None] * face_vectors(pp.corners[rows])

    def _deform_faces(self, forms) -> None:
        """Each pressure point's face by Nanson's rule, ``a ← cof(ΔF) a``, on every rank."""
        pp, active, comm = self.points, self._active, self.tracker.mesh.comm
        g = pp.x.shape[1]
        dF = forms.dF_at_boundary.evaluate(self.layout).reshape(-1, g, g)
        # cof(ΔF) = det(ΔF) ΔF⁻ᵀ, written out for 2x2 and 3x3 (no inverse of a singular one).
        if g == 2:
            cof = np.stack(
                [
                    np.stack([dF[:, 1, 1], -dF[:, 1, 0]], 1),
                    np.stack([-dF[:, 0, 1], dF[:, 0, 0]], 1),
                ],
                1,
            )
        else:
            cof = np.stack(
                [np.cross(dF[:, :, (i + 1) % 3], dF[:, :, (i + 2) % 3]) for i in range(3)], 2
            )
        change = np.zeros_like(pp.area)
        rows = np.flatnonzero(active)
        new = np.einsum("nij,nj->ni", cof, pp.area[rows])
        change[rows] = np.where(pp.pressed[rows, None], new - pp.area[rows], 0.0)
        pp.area += parallel.total(comm, change)


def _check_same_on_every_rank(comm, points: BoundaryPoints) -> None:
    """Raise on every rank unless every rank was given the same boundary points."""
    if comm.size == 1:
        return
    mine = (len(points), points.x0.tobytes(), points.weight.tobytes(), points.area.tobytes())
    differ = [rank for rank, theirs in enumerate(comm.allgather(mine)) if theirs != mine]
    if differ:
        raise ValueError(
            f"PointDirichlet/PointTraction/PointPressure: rank {comm.rank} holds "
            f"{len(points)} boundary "
            f"points and rank {differ[0]} other ones; under MPI every rank must hold every "
            "boundary point (build them from geometry, or with meshes.facet_points, which "
            "gathers them from all ranks)"
        )
