"""Boundary points at the midpoints of tagged facets, for loads that follow the body."""

from __future__ import annotations

import numpy as np

from fe_mpm._dolfinx import dolfinx


def facet_points(mesh: dolfinx.mesh.Mesh, facets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Midpoints of straight facets and their measures.

    With one point per facet at its midpoint, weighted by its length (or area),
    ``Σ_b w_b t·δu(x_b)`` integrates a constant traction against a P1 test
    function exactly: what :class:`~fe_mpm.boundary.PointTraction` needs to
    reproduce a grid traction on those facets.

    Args:
        mesh: Affine simplex mesh.
        facets: Local facet indices, e.g. ``facet_tags.find(tag)``, shape (m,).

    Returns:
        ``(x, weight)``: midpoints (m, g) in m and lengths (2D) or areas (3D) (m,).
    """
    g = mesh.geometry.dim
    fdim = mesh.topology.dim - 1
    nodes = dolfinx.mesh.entities_to_geometry(mesh, fdim, np.asarray(facets, dtype=np.int32))
    corners = mesh.geometry.x[nodes][:, :, :g]  # (m, fdim + 1, g)
    edges = corners[:, 1:] - corners[:, :1]
    if fdim == 1:
        weight = np.linalg.norm(edges[:, 0], axis=1)
    else:
        weight = 0.5 * np.linalg.norm(np.cross(edges[:, 0], edges[:, 1]), axis=1)
    return corners.mean(axis=1), weight
