"""Where a tetrahedron overlaps the tetrahedra of a grid: its pieces' volumes and centroids.

The 3D counterpart of :mod:`fe_mpm.clipping`. A point's domain is a tetrahedron;
its overlap with a cell is a convex polyhedron, the domain cut by the cell's four
faces. Each cut is made on a set of tetrahedra: a plane leaves a tetrahedron whole,
removes it, or keeps one tetrahedron (one corner on the kept side) or a triangular
prism (two or three corners), split into three tetrahedra. The prisms are split
along diagonals chosen by one fixed order of their corners, so the three
tetrahedra never overlap (every face of a prism cut from a tetrahedron is planar,
and the prism is convex). The pieces' volumes and centroids are then sums over
their tetrahedra: one quadrature point at the centroid, weighted by the volume,
integrates every linear function over the piece exactly, hence the P1 internal
force of a stress that is constant over the domain.

The cuts are made in each cell's reference coordinates ξ (the cell is then
``ξ₁, ξ₂, ξ₃ ≥ 0, ξ₁ + ξ₂ + ξ₃ ≤ 1``), vectorised over all (domain, cell) pairs.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: The reference tetrahedron's faces, as the signed distances of points ξ (..., 3).
FACES = (
    lambda p: p[..., 0],
    lambda p: p[..., 1],
    lambda p: p[..., 2],
    lambda p: 1.0 - p[..., 0] - p[..., 1] - p[..., 2],
)


def tet_volumes(tets: np.ndarray) -> np.ndarray:
    """Volumes (n,) of tetrahedra with vertices ``tets`` (n, 4, 3), either orientation."""
    a, b, c = (tets[:, k] - tets[:, 0] for k in (1, 2, 3))
    # The triple product: LAPACK's batched det costs twice as much here. Summed in
    # this order, not by einsum, whose order follows the machine's vector width, so
    # that fe_mpm.clip_kernels gives the same volumes to the bit.
    cross = np.cross(b, c)
    return np.abs(a[:, 0] * cross[:, 0] + a[:, 1] * cross[:, 1] + a[:, 2] * cross[:, 2]) / 6.0


def _prism(bottom: list[np.ndarray], top: list[np.ndarray]) -> np.ndarray:
    """Three tetrahedra (3m, 4, 3) filling each prism with corners bottom[i] – top[i] (m, 3)."""
    p0, p1, p2 = bottom
    q0, q1, q2 = top
    # The diagonal of each side runs from its first corner in the order p0 < p1 < p2 <
    # q0 < q1 < q2: consistent on the three sides, so the tetrahedra tile the prism.
    tets = [(p0, p1, p2, q2), (p0, p1, q1, q2), (p0, q0, q1, q2)]
    return np.concatenate([np.stack(t, axis=1) for t in tets])


def cut(tets: np.ndarray, owner: np.ndarray, distance) -> tuple[np.ndarray, np.ndarray]:
    """Keep the part of each tetrahedron where ``distance`` ≥ 0, as tetrahedra.

    Args:
        tets: Tetrahedra (m, 4, 3).
        owner: The piece each belongs to (m,).
        distance: The signed distance of points (..., 3) to the plane.

    Returns:
        The kept tetrahedra (m', 4, 3) and their owners (m',).
    """
    d = distance(tets)
    inside = d >= 0.0
    count = inside.sum(axis=1)
    whole = count == 4
    split = np.flatnonzero((count > 0) & ~whole)  # only these need sorting
    order = np.argsort(~inside[split], axis=1, kind="stable")  # the kept corners first
    rows = split[:, None]
    v = tets[rows, order]
    d = d[rows, order]
    count = count[split]

    def case(k: int) -> tuple[np.ndarray, np.ndarray, Callable]:
        """The corners of the tetrahedra with k kept corners, and their edges' crossings."""
        rows = np.flatnonzero(count == k)
        vk, dk = v[rows], d[rows]

        def on_edge(i: int, j: int) -> np.ndarray:
            """Where the plane crosses edge i–j (corner i kept, j not)."""
            s = dk[:, i] / (dk[:, i] - dk[:, j])
            return vk[:, i] + s[:, None] * (vk[:, j] - vk[:, i])

        return rows, vk, on_edge

    one, v1, edge1 = case(1)
    two, v2, edge2 = case(2)
    three, v3, edge3 = case(3)
    kept = [
        tets[whole],
        np.stack([v1[:, 0], edge1(0, 1), edge1(0, 2), edge1(0, 3)], axis=1),
        _prism([v2[:, 0], edge2(0, 2), edge2(0, 3)], [v2[:, 1], edge2(1, 2), edge2(1, 3)]),
        _prism([v3[:, 0], v3[:, 1], v3[:, 2]], [edge3(0, 3), edge3(1, 3), edge3(2, 3)]),
    ]
    owner_split = owner[split]
    owners = [
        owner[whole],
        owner_split[one],
        np.tile(owner_split[two], 3),
        np.tile(owner_split[three], 3),
    ]
    return np.concatenate(kept), np.concatenate(owners)


def clip_to_reference_tet(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The overlap of tetrahedra with the reference cell ``ξ ≥ 0, ξ₁ + ξ₂ + ξ₃ ≤ 1``.

    Each is cut by the cell's four faces (:func:`cut`); compiled loops do the same
    arithmetic pair by pair (:func:`fe_mpm.clip_kernels.clip_tetrahedra`, the same
    volumes and centroids to the bit, several times faster), unless numba is missing
    or ``FE_MPM_COMPILED=0``. Tetrahedra wholly inside the cell or wholly beyond one
    of its faces are not cut.

    Args:
        xi: The tetrahedra's vertices in the reference coordinates of a cell (n, 4, 3).

    Returns:
        The overlaps' volumes in reference units (n,) ≥ 0 (the whole cell is 1/6), and
        their centroids ξ (n, 3) (0 where the volume is 0).
    """
    from fe_mpm.materials.route import compiled_module

    kernels = compiled_module("fe_mpm.clip_kernels", "the compiled cuts of point domains")
    if kernels is not None:
        return kernels.clip_tetrahedra(np.ascontiguousarray(xi, dtype=np.float64))
    n = len(xi)
    distances = np.stack([face(xi) for face in FACES])  # (4 faces, n, 4 vertices)
    # Most pairs need no cutting: wholly inside the cell, or wholly beyond a face.
    inside = np.all(distances >= 0, axis=(0, 2))
    beyond = np.any(np.all(distances < 0, axis=2), axis=0)
    tets, owner = xi[~inside & ~beyond], np.flatnonzero(~inside & ~beyond)
    for face in FACES:
        tets, owner = cut(tets, owner, face)
    tets = np.concatenate([xi[inside], tets])
    owner = np.concatenate([np.flatnonzero(inside), owner])
    volume = tet_volumes(tets)
    total = np.bincount(owner, weights=volume, minlength=n)
    moment = np.stack(
        [np.bincount(owner, weights=volume * c, minlength=n) for c in tets.mean(axis=1).T], axis=1
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        centroid = np.where(total[:, None] > 0, moment / total[:, None], 0.0)
    return total, centroid
