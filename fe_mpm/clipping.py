"""Where a triangle overlaps the triangles of a grid: its pieces, their areas and centroids.

A point's domain (:mod:`fe_mpm.domains`) is a triangle that may cover parts of
several cells. Clipping it against each cell (Sutherland–Hodgman, against the
cell's three edges) gives convex pieces; one quadrature point at a piece's centroid,
weighted by its area, integrates every linear function over the piece exactly, and
so the P1 internal force of a constant stress over the whole domain. For P2, three
points per piece integrate every quadratic exactly (:func:`piece_rule`).

The clipping is done in each cell's reference coordinates ξ (the cell is then
``ξ₁, ξ₂ ≥ 0, ξ₁ + ξ₂ ≤ 1``), vectorised over all (domain, cell) pairs at once.
"""

from __future__ import annotations

import numpy as np

from fe_mpm.materials.route import compiled_module
from fe_mpm.tet_clipping import clip_to_reference_tet, tet_volumes


def clip_half_plane(polygon: np.ndarray, count: np.ndarray, distance: np.ndarray, size: int):
    """Keep the part of each polygon where ``distance`` ≥ 0 (one Sutherland–Hodgman pass).

    Args:
        polygon: Vertices (n, k, 2), the first ``count`` of each row in order.
        count: Vertices per polygon (n,).
        distance: Signed distance of every vertex (n, k); the half-plane is ≥ 0.
        size: Columns of the result (the most vertices a clipped polygon can have).

    Returns:
        The clipped polygons (n, size, 2) and their vertex counts (n,).
    """
    n, k = distance.shape
    column = np.arange(k)
    valid = column[None, :] < count[:, None]
    following = (column[None, :] + 1) % np.maximum(count, 1)[:, None]
    following += k * np.arange(n)[:, None]  # flat indices: faster than take_along_axis
    d_next = distance.reshape(-1)[following]
    v_next = polygon.reshape(-1, 2)[following]
    inside = valid & (distance >= 0)
    crossing = valid & (((distance > 0) & (d_next < 0)) | ((distance < 0) & (d_next > 0)))
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(crossing, distance / (distance - d_next), 0.0)
    cut = polygon + s[..., None] * (v_next - polygon)
    # Each vertex emits itself if inside, then the crossing of its edge: in order.
    emitted = np.stack([polygon, cut], axis=2).reshape(n, 2 * k, 2)
    keep = np.stack([inside, crossing], axis=2).reshape(n, 2 * k)
    row, slot = np.nonzero(keep)
    target = np.cumsum(keep, axis=1)[row, slot] - 1
    # A convex cut adds at most one vertex; round-off on a degenerate polygon must not
    # index past the buffer (fuzzed with 1e7 near-degenerate cases: never happened).
    target = np.minimum(target, size - 1)
    out = np.zeros((n, size, 2))
    out[row, target] = emitted[row, slot]
    return out, np.minimum(keep.sum(axis=1), size)


def simplex_volumes(corners: np.ndarray) -> np.ndarray:
    """Areas or volumes (n,) of simplices with vertices ``corners`` (n, d + 1, d).

    Triangles (d = 2) or tetrahedra (d = 3), either orientation.
    """
    if corners.shape[2] == 3:
        return tet_volumes(corners)
    return 0.5 * np.abs(np.linalg.det(corners[:, 1:] - corners[:, :1]))


def area_and_centroid(polygon: np.ndarray, count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed area (n,) and centroid (n, 2) of polygons with ``count`` (n,) vertices.

    Polygons with fewer than three vertices have area 0 and centroid 0.
    """
    n, k = polygon.shape[:2]
    column = np.arange(k)
    following = (column[None, :] + 1) % np.maximum(count, 1)[:, None]
    p, q = polygon, polygon.reshape(-1, 2)[following + k * np.arange(n)[:, None]]
    cross = np.where(
        column[None, :] < count[:, None], p[..., 0] * q[..., 1] - q[..., 0] * p[..., 1], 0.0
    )
    area = 0.5 * cross.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        centroid = np.einsum("nk,nkg->ng", cross, p + q) / (6.0 * area[:, None])
    return area, np.where(np.abs(area)[:, None] > 0, centroid, 0.0)


def _pieces_in_reference_cell(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The overlaps of triangles ``xi`` (n, 3, 2) with the reference cell, as polygons.

    Sutherland–Hodgman against the cell's three edges, one :func:`clip_half_plane`
    pass each; compiled loops do the same arithmetic pair by pair
    (:func:`fe_mpm.clip_kernels.clip_triangles`, the same polygons to the bit, ten
    times faster), unless numba is missing or ``FE_MPM_COMPILED=0``. Triangles wholly
    inside the cell or wholly beyond one of its edges are not clipped.

    Returns:
        Their vertices (n, 6, 2) in order, and their counts (n,): 0 where there is no
        overlap.
    """
    kernels = compiled_module("fe_mpm.clip_kernels", "the compiled cuts of point domains")
    if kernels is not None:
        return kernels.clip_triangles(np.ascontiguousarray(xi, dtype=np.float64))
    half_planes = (
        lambda p: p[..., 0],
        lambda p: p[..., 1],
        lambda p: 1.0 - p[..., 0] - p[..., 1],
    )
    distances = np.stack([d(xi) for d in half_planes])  # (3 edges, n, 3 vertices)
    # Most pairs need no clipping: the triangle is wholly inside the cell, or wholly
    # beyond one of its edges.
    inside = np.all(distances >= 0, axis=(0, 2))
    cut = ~inside & ~np.any(np.all(distances < 0, axis=2), axis=0)
    polygons = np.zeros((len(xi), 6, 2))
    counts = np.zeros(len(xi), dtype=np.int64)
    polygons[inside, :3], counts[inside] = xi[inside], 3
    polygon, count = xi[cut], np.full(cut.sum(), 3)
    for size, distance in zip((4, 5, 6), half_planes, strict=True):
        polygon, count = clip_half_plane(polygon, count, distance(polygon), size)
    polygons[cut], counts[cut] = polygon, count
    return polygons, counts


def clip_to_reference_cell(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The overlap of triangles with the reference cell ``ξ₁, ξ₂ ≥ 0, ξ₁ + ξ₂ ≤ 1``.

    Args:
        xi: The triangles' vertices in the reference coordinates of a cell (n, 3, 2).

    Returns:
        The overlaps' areas in reference units (n,) ≥ 0 (the whole cell is 1/2), and
        their centroids ξ (n, 2) (0 where the area is 0).
    """
    area, centroid = area_and_centroid(*_pieces_in_reference_cell(xi))
    return np.abs(area), centroid


def piece_rule(xi: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """A quadrature rule on each overlap of simplices with the reference cell.

    Degree 1: the overlap's centroid. Degree 2: three points of equal weight that
    match the overlap's area, centroid and second moments, hence integrate every
    quadratic exactly: ``c + √2 Σ^½ u_k`` with Σ the overlap's covariance and the
    ``u_k`` unit vectors 120° apart. In the coordinates where Σ = I the points lie
    on the circle of radius √2, which a convex polygon with its centroid at the
    origin contains (Kannan, Lovász and Simonovits 1995, Lemma 5.1; a triangle
    touches it at its edges' midpoints), so the points lie in the overlap. The first
    points at the overlap's vertex farthest from its centroid in those coordinates:
    on a triangle the rule is then its usual ``c + (v_i − c)/2``, strictly inside,
    and it stays so on a triangle clipped with a vertex near an edge's midpoint.

    On tetrahedra (:mod:`fe_mpm.tet_clipping`) degree 1 only.

    Args:
        xi: The triangles' vertices in the reference coordinates of a cell (n, 3, 2),
            or the tetrahedra's (n, 4, 3).
        degree: 1 or 2.

    Returns:
        The overlaps' areas (volumes) in reference units (n,) ≥ 0, and the rule's
        points ξ (n, q, d) with q = 1 or 3, each weighted by area / q (0 where the
        area is 0).
    """
    if xi.shape[-1] == 3:  # tetrahedra
        if degree != 1:
            raise NotImplementedError(
                "piece_rule: on tetrahedra only degree 1 (one point per piece) for now"
            )
        volume, centroid = clip_to_reference_tet(xi)
        return volume, centroid[:, None, :]
    polygons, counts = _pieces_in_reference_cell(xi)
    if degree == 1:
        area, centroid = area_and_centroid(polygons, counts)
        return np.abs(area), centroid[:, None, :]
    if degree != 2:
        raise ValueError(f"piece_rule: degree must be 1 or 2, got {degree}")
    # Moments about each polygon's first vertex, against cancellation on small pieces.
    origin = polygons[:, :1, :].copy()
    local = np.where(np.arange(6)[None, :, None] < counts[:, None, None], polygons - origin, 0.0)
    area, centroid, covariance = _second_moments(local, counts)
    points = np.zeros((len(xi), 3, 2))
    has = np.abs(area) > 0
    values, vectors = np.linalg.eigh(covariance[has])
    values = np.maximum(values, np.finfo(float).tiny)
    root = vectors * np.sqrt(values)[:, None, :]  # Σ^½ = V Λ^½ Vᵀ, applied as V Λ^½ (Vᵀ·)
    # Each vertex in the coordinates where Σ = I; the rule points at the farthest,
    # which keeps its points off the polygon's edges.
    white = np.einsum("ngk,nvg->nvk", vectors, local[has] - centroid[has, None, :])
    white /= np.sqrt(values)[:, None, :]
    reach = np.where(np.arange(6) < counts[has, None], np.einsum("nvk,nvk->nv", white, white), -1)
    towards = white[np.arange(len(white)), np.argmax(reach, axis=1)]
    angle = np.arctan2(towards[:, 1], towards[:, 0])[:, None] + 2.0 * np.pi / 3.0 * np.arange(3)
    u = np.sqrt(2.0) * np.stack([np.cos(angle), np.sin(angle)], axis=2)  # (m, 3, 2)
    points[has] = centroid[has, None, :] + np.einsum("ngk,nqk->nqg", root, u)
    points += origin
    return np.abs(area), np.where(has[:, None, None], points, 0.0)


def _second_moments(
    polygon: np.ndarray, count: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed area (n,), centroid (n, 2) and covariance (n, 2, 2) of polygons (n, k, 2)."""
    area, centroid = area_and_centroid(polygon, count)
    n, k = polygon.shape[:2]
    column = np.arange(k)
    following = (column[None, :] + 1) % np.maximum(count, 1)[:, None]
    p, q = polygon, polygon.reshape(-1, 2)[following + k * np.arange(n)[:, None]]
    valid = column[None, :] < count[:, None]
    cross = np.where(valid, p[..., 0] * q[..., 1] - q[..., 0] * p[..., 1], 0.0)
    # ∫ x_a x_b over a polygon: Σ cross (2 p_a p_b + p_a q_b + q_a p_b + 2 q_a q_b) / 24.
    pair = (
        2.0 * np.einsum("nka,nkb->nkab", p, p)
        + np.einsum("nka,nkb->nkab", p, q)
        + np.einsum("nka,nkb->nkab", q, p)
        + 2.0 * np.einsum("nka,nkb->nkab", q, q)
    )
    second = np.einsum("nk,nkab->nab", cross, pair) / 24.0
    with np.errstate(invalid="ignore", divide="ignore"):
        covariance = second / area[:, None, None] - np.einsum("na,nb->nab", centroid, centroid)
    return area, centroid, np.where(np.abs(area)[:, None, None] > 0, covariance, 0.0)
