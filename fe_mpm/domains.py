"""Point domains: each material point's volume spread over the cells its domain covers.

Standard MPM integrates a cell with the points that lie in it, each with its whole
volume: as points cross facets, a cell's share of the body jumps by a point's volume
at once, cells inside the body can end up with no point at all, and the answer
drifts with the number of load steps (Cook's membrane over 20 steps, n = 32: +25 %).

With ``Simulation(point_domains=True)`` each point carries a triangle, its domain;
at the start the domains tile the body (:mod:`fe_mpm.tilings`). Every step cuts each
domain by the cells it covers (:mod:`fe_mpm.clipping`) and integrates each piece
with one sub-point at the piece's centroid, weighted by its area: exact for the P1
internal force of a domain's stress, so a point that crosses a facet moves its
weight to the next cell continuously. The sub-points take the point's deformation
gradient, history and state, and the step.

The domains' corners then move with the grid's displacement (as in CPDI2,
Sadeghirad et al. 2013, and Nairn's convected particle domains), so the domains keep
tiling the deformed body; each point's new ``F`` is the affine map of its domain's
corners and its volume the domain's area. The stored deformation is thus that of a
continuous piecewise-linear motion of the domains, and does not drift with the
number of load steps as a mean of the sub-points' increments would (Cook, 5 N,
n = 32, 80 steps: +0.3 % against +2.7 %). The point's position, stress, history,
velocity and acceleration are the area-weighted means of its pieces'. Averaging the
history is exact for elastic laws and an approximation for plastic ones (each piece
returns from the point's own state).

Not yet: 3D (tetrahedral domains), and splitting a domain that has distorted too
far (a domain wider than the cells around its corners stops the run with a message).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fe_mpm.clipping import clip_to_reference_cell
from fe_mpm.errors import ConvergenceError, PointsOutsideError
from fe_mpm.markers import Markers
from fe_mpm.particles import MaterialPoints
from fe_mpm.point_update import apply_update
from fe_mpm.step_forms import PointUpdate
from fe_mpm.tilings import initial_domains
from fe_mpm.tracker import Tracker

#: A domain's pieces must add up to its area to this relative tolerance.
COVERAGE_TOL = 1e-9
#: A domain with less than this fraction of its area inside the grid has left it.
MIN_INSIDE = 0.5
#: Pieces smaller than this fraction of their domain are dropped (measured on Cook's
#: membrane at 10 N, n = 32, 160 steps: with 1e-12 a cell held by a sliver of 4e-5 of
#: its area stalls Newton in step 133; with 1e-3 or 1e-2 the run completes and the
#: tip moves by 0.03 %).
MIN_SHARE = 1e-3


@dataclass
class Pieces:
    """The domains cut by the cells of the grid, for one step.

    Attributes:
        owner: The point of each piece (k,), in increasing order.
        cell: Its cell (k,).
        share: Its fraction of its domain's area (k,); each point's add up to 1.
        x: Its centroid (k, 2) in m, where its sub-point integrates it.
        corner_cell: The cell of each domain's corners (n × 3,), or the domain's last
            cell for a corner past the grid's edge.
        corner_bary: The corners' barycentric coordinates there (n × 3, 3).
    """

    owner: np.ndarray
    cell: np.ndarray
    share: np.ndarray
    x: np.ndarray
    corner_cell: np.ndarray
    corner_bary: np.ndarray


class PointDomains:
    """The domain of every point, and the pieces that integrate it in a step.

    Args:
        points: The material points (2D), located in their cells. Points that tile
            their cell move to the centroids of their tiles.
        tracker: The grid's tracker.

    Attributes:
        corners: The domains' vertices (n, 3, 2) in m.
        active: True while the pieces take a step in the points' place.
    """

    def __init__(self, points: MaterialPoints, tracker: Tracker):
        self.corners = initial_domains(points.x, points.volume, points.cell, tracker.cell_vertices)
        points.x = self.corners.mean(axis=1)
        points.x0 = points.x.copy()
        self.active = False
        self._pieces: Pieces | None = None  # those of the step being taken

    def pieces(self, tracker: Tracker, guess: np.ndarray) -> Pieces:
        """Each domain cut by the cells it covers.

        Args:
            tracker: The grid's tracker.
            guess: A cell near each domain (n,), where the searches start.

        Returns:
            The pieces, and where the corners are.

        A domain that reaches past the grid's edge keeps the pieces inside, and its
        point's volume is shared among them.

        Raises:
            PointsOutsideError: Less than half of a domain is inside the grid.
            ConvergenceError: A domain reaches past the cells around its corners.
        """
        n = len(self.corners)
        corner_cells = tracker.locate(self.corners.reshape(-1, 2), np.repeat(guess, 3))
        outside = corner_cells < 0
        # A corner that has left the grid (a body bulging past the grid's edge) is
        # searched from the domain's last cell; its part outside the grid is lost.
        corner_cells = np.where(outside, np.repeat(guess, 3), corner_cells)
        neighbours = tracker.vertex_neighbours()
        candidates = np.sort(neighbours[corner_cells.reshape(n, 3)].reshape(n, -1), axis=1)
        repeated = np.zeros_like(candidates, dtype=bool)
        repeated[:, 1:] = candidates[:, 1:] == candidates[:, :-1]
        owner, column = np.nonzero((candidates >= 0) & ~repeated)
        cell = candidates[owner, column]
        # Only the cells whose bounding boxes meet the domain's can overlap it.
        low, high = self.corners.min(axis=1), self.corners.max(axis=1)
        vertices = tracker.cell_vertices[cell]
        meets = np.all(
            (vertices.min(axis=1) <= high[owner]) & (vertices.max(axis=1) >= low[owner]), axis=1
        )
        owner, cell = owner[meets], cell[meets]
        xi = tracker.barycentric(self.corners[owner].reshape(-1, 2), np.repeat(cell, 3)).reshape(
            -1, 3, 3
        )[..., 1:]
        area, centroid = clip_to_reference_cell(xi)
        area *= 2.0 * tracker.volumes[cell]
        domain_area = 0.5 * np.abs(np.linalg.det(self.corners[:, 1:] - self.corners[:, :1]))
        covered = np.bincount(owner, weights=area, minlength=n) / domain_area
        partly_outside = np.any(outside.reshape(n, 3), axis=1)
        if np.any(covered < MIN_INSIDE):
            p = int(np.argmin(covered))
            raise PointsOutsideError(
                f"the domain of point {p} (corners {self.corners[p].tolist()}) has left the "
                f"grid ({covered[p]:.3g} of it inside); extend the grid around the body"
            )
        wrong = np.abs(covered - 1.0) > COVERAGE_TOL
        wrong &= ~partly_outside | (covered > 1.0)
        if np.any(wrong):
            p = int(np.flatnonzero(wrong)[0])
            raise ConvergenceError(
                f"the domain of point {p} covers more than the cells around its corners "
                f"(found {covered[p]:.6f} of its area): it has distorted too far"
            )
        # A sliver is dropped and its area shared by the domain's other pieces: alone
        # in a cell it would hold that cell's nodes with almost no stiffness.
        keep = area > MIN_SHARE * domain_area[owner]
        owner, cell, area, centroid = owner[keep], cell[keep], area[keep], centroid[keep]
        bary = np.column_stack([1.0 - centroid.sum(axis=1), centroid])
        return Pieces(
            owner=owner,
            cell=cell.astype(np.int32),
            share=area / np.bincount(owner, weights=area, minlength=n)[owner],
            x=np.einsum("kv,kvg->kg", bary, tracker.cell_vertices[cell]),
            corner_cell=corner_cells,
            corner_bary=tracker.barycentric(self.corners.reshape(-1, 2), corner_cells),
        )

    def sample(self, points: MaterialPoints, tracker: Tracker) -> MaterialPoints:
        """A sub-point for every piece of every domain, with its share of the point's state."""
        self._pieces = p = self.pieces(tracker, points.cell)
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

    def gather(
        self,
        points: MaterialPoints,
        sub: MaterialPoints,
        grid_displacement: Callable[[np.ndarray, np.ndarray], np.ndarray],
        markers: Markers,
    ) -> None:
        """Move the domains with the grid and give each point its domain's step.

        Args:
            points: The material points at the start of the step, updated here.
            sub: Their sub-points after the step.
            grid_displacement: The step's grid displacement Δu (k, g) at given cells
                (k,) and barycentric coordinates (k, g + 1)
                (:meth:`~fe_mpm.formulations.GridFields.displacement_at`).
            markers: Moved with their host points.
        """
        n, p = len(points), self._pieces

        def mean(values: np.ndarray) -> np.ndarray:
            weighted = values * p.share.reshape(-1, *([1] * (values.ndim - 1)))
            out = np.zeros((n, *values.shape[1:]))
            np.add.at(out, p.owner, weighted)
            return out

        g = points.gdim
        corners = self.corners + grid_displacement(p.corner_cell, p.corner_bary).reshape(n, 3, g)
        edges = corners[:, 1:] - corners[:, :1]
        old_edges = self.corners[:, 1:] - self.corners[:, :1]
        new = PointUpdate(
            du=corners.mean(axis=1) - self.corners.mean(axis=1),  # a point is its centroid
            # The affine map of the corners: (new edges) = ΔF (old edges).
            dF=np.swapaxes(edges, 1, 2) @ np.linalg.inv(np.swapaxes(old_edges, 1, 2)),
            stress=mean(sub.stress),
            acceleration=None,
            history={name: mean(values) for name, values in sub.history.items()},
        )
        self.corners = corners
        # The points' own update (x, F, V, σ, history, markers); the sub-points' Newmark
        # velocities are already at t_{n+1}, so the points take their mean as it is.
        apply_update(points, new, markers, dynamics=None, dt=0.0)
        points.velocity, points.acceleration = mean(sub.velocity), mean(sub.acceleration)
        by_weight = np.lexsort((-p.share, p.owner))  # by point, the heaviest piece first
        heaviest = by_weight[np.searchsorted(p.owner[by_weight], np.arange(n))]
        points.cell = sub.cell[heaviest].copy()  # a start for the next step's search


def step_with_domains(sim, t_new: float, rebin: bool):
    """:meth:`Simulation.step` with each point's domain sampled by sub-points.

    The sub-points take the step in the points' place (their markers and output
    wait); then the points gather the sub-points' step (:meth:`PointDomains.gather`),
    and the step's report and output are the points'. A failed step leaves the
    points as they were.
    """
    domains, points, markers, output = sim.domains, sim.points, sim.markers, sim.output
    sub = domains.sample(points, sim.tracker)
    sim.points, sim.markers, sim.output, domains.active = sub, Markers(), None, True
    try:
        report = sim.step(t_new, rebin)
    finally:
        sim.points, sim.markers, sim.output, domains.active = points, markers, output, False
    domains.gather(points, sub, sim.fields.displacement_at, markers)
    report.markers = markers.positions()
    sim._write_output()
    return report
