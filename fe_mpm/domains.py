"""Point domains: each material point's volume spread over the cells its domain covers.

Standard MPM integrates a cell with the points that lie in it, each with its whole
volume: as points cross facets, a cell's share of the body jumps by a point's volume
at once, cells inside the body can end up with no point at all, and the answer
drifts with the number of load steps (Cook's membrane over 20 steps, n = 32: +25 %).
With ``Simulation(point_domains=m)`` each point carries a triangle of its own volume,
convected with its deformation (like CPDI, Sadeghirad et al. 2011, and Nairn's
convected particle domains), and each step integrates it with ``m²`` sub-points, the
centroids of the domain's regular subdivision, each with a share of the point's
volume and mass and its deformation gradient and history. A point that crosses a
facet thus moves its weight to the next cell a sub-point at a time.

After the step each point takes the mean of its sub-points' increments: ΔF_p (the
domain average of the displacement gradient), Δu_p, and the sub-points' stress,
velocity, acceleration and history; its domain moves with ``x + Δu_p + ΔF_p (X − x)``.
Averaging the history is exact for elastic laws and an approximation for plastic ones
(each sub-point returns from the point's own state).

Cost: a step has ``m²`` times the points. Not yet: 3D (tetrahedral domains), and
splitting a domain that has distorted too far.
"""

from __future__ import annotations

import numpy as np

from fe_mpm.markers import Markers
from fe_mpm.particles import MaterialPoints
from fe_mpm.point_update import apply_update
from fe_mpm.step_forms import PointUpdate


def subdivision_centroids(m: int) -> np.ndarray:
    """Barycentric coordinates (m², 3) of the centroids of a triangle's m x m subdivision.

    The m² sub-triangles (cut by lines parallel to the edges at steps of 1/m) have
    equal areas, so equal weights 1/m² integrate the linear functions exactly.
    """
    centroids = []
    for i in range(m):
        for j in range(m - i):
            corner = np.array([i, j, m - i - j], dtype=float)
            centroids.append((corner + np.array([1, 1, -2]) / 3) / m)  # pointing up
            if i + j < m - 1:
                centroids.append((corner + np.array([2, 2, -4]) / 3) / m)  # pointing down
    return np.array(centroids)


class PointDomains:
    """The domain of every point, and the sub-points that integrate it in a step.

    Args:
        points: The material points (2D), located in their cells.
        cell_vertices: The vertices of each point's cell (n, 3, 2) in m: a point's
            domain is its cell scaled to the point's volume and centred on it (the
            cell itself for one point per cell).
        m: Sub-points per domain edge (m² per domain), ≥ 1; m = 1 is standard MPM.

    Attributes:
        corners: The domains' vertices (n, 3, 2) in m.
    """

    @classmethod
    def of(cls, points: MaterialPoints, mesh, m: int) -> PointDomains | None:
        """The domains of ``points``, located in the cells of ``mesh``; None for m = 1."""
        if m == 1:
            return None
        vertices = mesh.geometry.x[mesh.geometry.dofmaps[0][points.cell], : points.gdim]
        return cls(points, vertices, m)

    def __init__(self, points: MaterialPoints, cell_vertices: np.ndarray, m: int):
        centre = cell_vertices.mean(axis=1, keepdims=True)
        edges = cell_vertices[:, 1:] - cell_vertices[:, :1]
        cell_area = 0.5 * np.abs(np.linalg.det(edges))
        scale = np.sqrt(points.volume / cell_area)[:, None, None]
        self.corners = points.x[:, None, :] + scale * (cell_vertices - centre)
        self.rule = subdivision_centroids(m)
        self.active = False  # True while the sub-points take the step

    def sample(self, points: MaterialPoints) -> MaterialPoints:
        """The sub-points of every domain, each with its share of the point's state."""
        k = len(self.rule)
        share = 1.0 / k

        def repeat(values: np.ndarray) -> np.ndarray:
            return np.repeat(values, k, axis=0)

        x = np.einsum("sc,pcg->psg", self.rule, self.corners).reshape(-1, points.gdim)
        sub = MaterialPoints(
            x,
            repeat(points.volume) * share,
            repeat(points.mass) * share,
            F=repeat(points.F),
            stress=repeat(points.stress),
            cell=repeat(points.cell),
            velocity=repeat(points.velocity),
            acceleration=repeat(points.acceleration),
        )
        sub.history = {name: repeat(values) for name, values in points.history.items()}
        return sub

    def gather(
        self,
        points: MaterialPoints,
        sub: MaterialPoints,
        x_sub: np.ndarray,
        F_sub: np.ndarray,
        markers: Markers,
    ) -> None:
        """Give each point the mean of its sub-points' step; move its domain and the markers.

        Args:
            points: The material points at the start of the step, updated here.
            sub: Their sub-points after the step.
            x_sub: The sub-points' positions at the start of the step (n k, g).
            F_sub: Their deformation gradients then (n k, g, g).
            markers: Moved with their host points.
        """
        n, k = len(points), len(self.rule)

        def mean(values: np.ndarray) -> np.ndarray:
            return values.reshape(n, k, *values.shape[1:]).mean(axis=1)

        new = PointUpdate(
            du=mean(sub.x - x_sub),
            dF=mean(sub.F @ np.linalg.inv(F_sub)),
            stress=mean(sub.stress),
            acceleration=None,
            history={name: mean(values) for name, values in sub.history.items()},
        )
        relative = self.corners - points.x[:, None, :]
        # The points' own update (x, F, V, σ, history, markers); the sub-points' Newmark
        # velocities are already at t_{n+1}, so the points take their mean as it is.
        apply_update(points, new, markers, dynamics=None, dt=0.0)
        points.velocity, points.acceleration = mean(sub.velocity), mean(sub.acceleration)
        self.corners = points.x[:, None, :] + np.einsum("pij,pcj->pci", new.dF, relative)
        points.cell = sub.cell[::k].copy()  # a start for the next step's search


def step_with_domains(sim, t_new: float, rebin: bool):
    """:meth:`Simulation.step` with each point's domain sampled by sub-points.

    The sub-points take the step in the points' place (their markers and output
    wait); then the points gather the sub-points' step (:meth:`PointDomains.gather`),
    and the step's report and output are the points'. A failed step leaves the
    points as they were.
    """
    domains, points, markers, output = sim.domains, sim.points, sim.markers, sim.output
    sub = domains.sample(points)
    x_sub, F_sub = sub.x.copy(), sub.F.copy()
    sim.points, sim.markers, sim.output, domains.active = sub, Markers(), None, True
    try:
        report = sim.step(t_new, rebin)
    finally:
        sim.points, sim.markers, sim.output, domains.active = points, markers, output, False
    domains.gather(points, sub, x_sub, F_sub, markers)
    report.markers = markers.positions()
    sim._write_output()
    return report
