"""Boundary conditions and loads on the background grid.

Both act on grid facets, chosen by a facet tag (an integer from the mesh's facet
tags, e.g. a gmsh physical group) or by a marker ``x -> bool`` on the facet
vertices' coordinates (shape ``(3, n)``), as in ``dolfinx.mesh.locate_entities_boundary``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from fe_mpm._dolfinx import dolfinx

Where = int | Callable[[np.ndarray], np.ndarray]
Value = float | Sequence[float] | Callable[[float], float | Sequence[float]]
Profile = Callable[[np.ndarray, float], np.ndarray]


@dataclass(frozen=True)
class Dirichlet:
    """Prescribed displacement on grid nodes.

    Args:
        where: Facet tag or boundary marker.
        value: Total prescribed displacement (m) as a function of time ``t``, or
            a constant. The grid is reset every step, so the step from ``t_n`` to
            ``t_{n+1}`` imposes ``value(t_{n+1}) − value(t_n)`` on the grid nodes
            (a constant therefore fixes the nodes). A vector for all components,
            a scalar with ``component``.
        component: Constrain only this component (0, 1 or 2), e.g. a roller.
        profile: Space- and time-dependent prescribed displacement ``(x, t) ->
            u`` with ``x`` of shape ``(3, n)`` and ``u`` of shape ``(g, n)`` (or
            ``(n,)`` with ``component``). Replaces ``value`` when given; the step
            again imposes ``profile(x, t_{n+1}) − profile(x, t_n)``.
    """

    where: Where
    value: Value = 0.0
    component: int | None = None
    profile: Profile | None = None

    def at(self, t: float) -> np.ndarray:
        """Prescribed displacement at time ``t`` as an array."""
        v = self.value(t) if callable(self.value) else self.value
        return np.asarray(v, dtype=np.float64)


@dataclass(frozen=True)
class Traction:
    """Surface traction on grid facets, per unit area of the grid (Pa).

    Args:
        where: Facet tag or boundary marker.
        value: Traction vector (Pa), length g.
        scale: Load factor as a function of time, ``t -> float``; constant 1 if None.
            For static load stepping use e.g. ``scale=lambda t: t`` with ``t_end=1``.
    """

    where: Where
    value: Sequence[float]
    scale: Callable[[float], float] | None = None

    def at(self, t: float) -> np.ndarray:
        """Traction vector at time ``t`` (Pa)."""
        factor = 1.0 if self.scale is None else float(self.scale(t))
        return factor * np.asarray(self.value, dtype=np.float64)


def boundary_facets(
    mesh: dolfinx.mesh.Mesh, where: Where, facet_tags: dolfinx.mesh.MeshTags | None
) -> np.ndarray:
    """Local indices of the exterior facets selected by ``where``."""
    fdim = mesh.topology.dim - 1
    if callable(where):
        facets = dolfinx.mesh.locate_entities_boundary(mesh, fdim, where)
    else:
        if facet_tags is None:
            raise ValueError(f"boundary tag {where} given but the mesh has no facet tags")
        facets = facet_tags.find(int(where))
        if facets.size == 0:
            raise ValueError(
                f"boundary tag {where} selects no facets; tags present: "
                f"{sorted(set(facet_tags.values.tolist()))}"
            )
    if facets.size == 0:
        raise ValueError("boundary marker selects no exterior facets")
    return np.asarray(facets, dtype=np.int32)


@dataclass(frozen=True)
class PointDirichlet:
    """Prescribed displacement at boundary points, imposed by a penalty (non-conforming).

    The grid does not follow a moving boundary such as a rigid footing, so no
    grid node lies on it. Kratos MPM imposes such conditions through boundary
    material points with a penalty; so does this. Each boundary point is convected
    with the grid solution like a material point, and the penalty pulls it onto its
    target ``x₀ + value(t)``: the step adds ``Σ_b β w_b (x_b + Δu(x_b) − x_b^target)·δu(x_b)``
    (constrained components only) to the residual. The gap left is about
    ``load / β``; it does not accumulate over steps.

    Args:
        name: Name of the condition; its force on the body is reported in
            ``StepReport.reactions[name]`` (N, per unit thickness in 2D).
        x: Initial positions of the boundary points (n, g), m.
        weight: Boundary measure each point represents (n,): length (m) in 2D,
            area (m²) in 3D, > 0. Points may also fill a rigid body to tie the grid
            nodes inside it (see ``meshes.footing_points``); each then carries the
            stiffness β·w of a boundary point of the same spacing.
        value: Total prescribed displacement of the boundary at time ``t`` (m), a
            vector of length g (a rigid motion: the same for every point).
        components: Constrained components, e.g. ``(1,)`` for a smooth footing;
            None constrains all (a rough footing).
        penalty: Penalty stiffness β (Pa/m), > 0. About 10³ E/h (E Young's modulus,
            h cell size) keeps the gap negligible and the tangent well conditioned.
    """

    name: str
    x: np.ndarray
    weight: np.ndarray
    value: Callable[[float], Sequence[float]]
    penalty: float
    components: tuple[int, ...] | None = None

    def at(self, t: float) -> np.ndarray:
        """Prescribed displacement at time ``t``, shape (g,)."""
        return np.asarray(self.value(t), dtype=np.float64)


@dataclass(frozen=True)
class PointTraction:
    """Surface traction carried by boundary points that move with the body.

    A :class:`Traction` stays on its grid facets; once the body moves off them its
    load acts on nothing. These points are convected with the grid solution like
    material points (Kratos MPM's particle line loads), so the load follows the
    body. The step adds ``−Σ_b w_b t(t)·δu(x_b)`` to the residual: with the points
    at the midpoints of boundary facets and ``w_b`` their lengths, this is exactly
    the grid traction's integral while the body still lies on those facets
    (``meshes.facet_points`` places them so).

    Args:
        name: Name of the load; the force it applies is reported in
            ``StepReport.reactions[name]`` (N, per unit thickness in 2D).
        x: Initial positions of the points (n, g), m, on the body's boundary.
        weight: Boundary measure each point represents (n,): length (m) in 2D, area in 3D.
        value: Traction vector (Pa), length g, a dead load (fixed direction).
        scale: Load factor as a function of time, ``t -> float``; constant 1 if None.
    """

    name: str
    x: np.ndarray
    weight: np.ndarray
    value: Sequence[float]
    scale: Callable[[float], float] | None = None

    def at(self, t: float) -> np.ndarray:
        """Traction vector at time ``t`` (Pa)."""
        factor = 1.0 if self.scale is None else float(self.scale(t))
        return factor * np.asarray(self.value, dtype=np.float64)
