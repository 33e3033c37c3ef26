"""The first domains of the points: each cell tiled by as many equal simplices as it has points.

Triangles: a cell with ``m²`` points is cut by the lines parallel to its edges at
steps of 1/m; ``3 m²`` and ``6 m²`` points cut each of those triangles further,
from its centroid to its corners (3) or to its corners and edge midpoints (6).
Tetrahedra: ``8^L`` points cut the cell L times into eight by its edges' midpoints
(Bey 1995: four corner tetrahedra and the inner octahedron split along one
diagonal, all of equal volume); ``4·8^L`` and ``24·8^L`` points cut each of those
further from its centroid, to its faces (4) or by its barycentric subdivision (24:
corner, edge midpoint, face centroid, centroid). Of :func:`fe_mpm.seed`'s counts
per tetrahedron these cover 1, 4 and 24 (the others, 57 and up, are Gauss rules
of higher degree); 8, 32, 64, … serve points placed by hand.

Each point takes the nearest free tile as its domain, so the domains tile the body
without gaps or overlaps, and the points of the cell share its points' volume and
mass equally (:func:`fe_mpm.seed`'s Gauss weights differ for 6 and 12 points;
unequal volumes on equal tiles would integrate a constant stress inexactly once the
domains straddle cells). A point's volume and its domain's change together (both by
det ΔF). Only a cell its points fill is tiled. A cell whose count has no such
tiling (7 or 15 points on triangles, 57 on tetrahedra), or that a trimmed body
fills in part, gives each point the cell shrunk to the point's volume around the
point instead (these domains may overlap or reach past the body).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from fe_mpm.clipping import simplex_volumes
from fe_mpm.materials.zones import MATERIAL
from fe_mpm.particles import MaterialPoints

#: A cell is full when its points' volumes add up to its area to this tolerance.
FULL_TOL = 1e-9


def _subdivision(m: int) -> list[np.ndarray]:
    """The m² triangles of a triangle cut at steps of 1/m, as barycentric vertices (3, 3)."""
    lattice = [(i, j) for i in range(m) for j in range(m - i)]
    triangles = []
    for i, j in lattice:
        triangles.append([(i, j), (i + 1, j), (i, j + 1)])  # pointing up
        if i + j < m - 1:
            triangles.append([(i + 1, j), (i + 1, j + 1), (i, j + 1)])  # pointing down
    out = []
    for corners in triangles:
        xi = np.array(corners, dtype=float) / m
        out.append(np.column_stack([1.0 - xi.sum(axis=1), xi]))
    return out


def _fan(triangle: np.ndarray, pieces: int) -> list[np.ndarray]:
    """A triangle (3, 3) cut from its centroid into 3 (to the corners) or 6 (and midpoints)."""
    centre = triangle.mean(axis=0)
    if pieces == 3:
        ring = [triangle[0], triangle[1], triangle[2]]
    else:
        ring = []
        for a in range(3):
            ring += [triangle[a], 0.5 * (triangle[a] + triangle[(a + 1) % 3])]
    return [np.array([centre, ring[i], ring[(i + 1) % len(ring)]]) for i in range(len(ring))]


def _bey(tet: np.ndarray) -> list[np.ndarray]:
    """A tetrahedron (4, 4) cut into 8 of equal volume by its edges' midpoints (Bey 1995)."""
    x0, x1, x2, x3 = tet
    m = {(i, j): 0.5 * (tet[i] + tet[j]) for i in range(4) for j in range(i + 1, 4)}
    children = [
        (x0, m[0, 1], m[0, 2], m[0, 3]),
        (m[0, 1], x1, m[1, 2], m[1, 3]),
        (m[0, 2], m[1, 2], x2, m[2, 3]),
        (m[0, 3], m[1, 3], m[2, 3], x3),
        # The octahedron, split along its diagonal m02–m13.
        (m[0, 1], m[0, 2], m[0, 3], m[1, 3]),
        (m[0, 1], m[0, 2], m[1, 2], m[1, 3]),
        (m[0, 2], m[0, 3], m[1, 3], m[2, 3]),
        (m[0, 2], m[1, 2], m[1, 3], m[2, 3]),
    ]
    return [np.array(c) for c in children]


def _tet_fan(tet: np.ndarray, pieces: int) -> list[np.ndarray]:
    """A tetrahedron (4, 4) cut from its centroid to its faces (4) or barycentrically (24)."""
    centre = tet.mean(axis=0)
    if pieces == 4:
        return [np.array([centre, *np.delete(tet, i, axis=0)]) for i in range(4)]
    return [
        np.array([tet[a], 0.5 * (tet[a] + tet[b]), (tet[a] + tet[b] + tet[c]) / 3.0, centre])
        for a, b, c, _ in itertools.permutations(range(4))
    ]


def equal_tiling(k: int, dim: int = 2) -> np.ndarray | None:
    """``k`` simplices of equal size that tile a simplex, barycentric vertices (k, d + 1, d + 1).

    Triangles (``dim`` 2): None unless ``k`` is ``m²``, ``3 m²`` or ``6 m²``.
    Tetrahedra (``dim`` 3): None unless ``k`` is ``8^L``, ``4·8^L`` or ``24·8^L``.
    """
    if dim == 3:
        for fan in (1, 4, 24):
            if k % fan:
                continue
            levels = round(math.log(k // fan, 8))
            if 8**levels != k // fan:
                continue
            tets = [np.eye(4)]
            for _ in range(levels):
                tets = [child for t in tets for child in _bey(t)]
            if fan > 1:
                tets = [piece for t in tets for piece in _tet_fan(t, fan)]
            return np.array(tets)
        return None
    for fan in (1, 3, 6):
        m = math.isqrt(k // fan)
        if k % fan == 0 and m * m * fan == k:
            triangles = _subdivision(m)
            if fan > 1:
                triangles = [piece for t in triangles for piece in _fan(t, fan)]
            return np.array(triangles)
    return None


def shrunk_cells(x: np.ndarray, size: np.ndarray, own: np.ndarray) -> np.ndarray:
    """Cells ``own`` (n, d + 1, d) shrunk to ``size`` (n,) in m² (m³), centred on ``x`` (n, d)."""
    scale = (size / simplex_volumes(own)) ** (1.0 / x.shape[1])
    return x[:, None, :] + scale[:, None, None] * (own - own.mean(axis=1, keepdims=True))


def initial_domains(points: MaterialPoints, cell_vertices: np.ndarray) -> np.ndarray:
    """Every point's first domain, a simplex (n, d + 1, d) in m; tiled points move.

    Args:
        points: The material points, located in their cells. The points of a
            tiled cell move to their tiles' centroids (``x`` and ``x0``) and share
            the cell's points' volume and mass equally, so that the volume per area
            is the same in every tile of the cell.
        cell_vertices: The vertices of every cell of the grid (nc, d + 1, d) in m.

    Full cells whose point count has a tiling (:func:`equal_tiling`) are tiled, and
    each of their points takes the nearest free tile (greedy); other points (a cell
    that a trimmed body fills in part, or a count with no tiling) take their cell shrunk to
    their volume and centred on them.
    """
    x, volume, cell = points.x, points.volume, points.cell
    corners = shrunk_cells(x, volume, cell_vertices[cell])
    order = np.argsort(cell, kind="stable")
    cells, starts, counts = np.unique(cell[order], return_index=True, return_counts=True)
    for k in np.unique(counts):
        tiles = equal_tiling(int(k), x.shape[1])
        if tiles is None:
            continue
        group = np.flatnonzero(counts == k)
        members = order[starts[group][:, None] + np.arange(k)]  # (cells, k) point indices
        # Only a cell its points fill (their volumes add up to its area) is tiled: a
        # body trimmed from a seeded grid leaves cells with some of their points.
        area = simplex_volumes(cell_vertices[cells[group]])
        full = np.abs(volume[members].sum(axis=1) / area - 1.0) < FULL_TOL
        group, members = group[full], members[full]
        if group.size == 0:
            continue
        tile_corners = np.einsum("tcv,nvg->ntcg", tiles, cell_vertices[cells[group]])
        corners[members] = _assign(x[members], tile_corners)
        for values in (points.volume, points.mass):
            values[members] = values[members].mean(axis=1, keepdims=True)
        moved_to = corners[members].mean(axis=2)
        for values in _fields_of_place(points):
            values[members] = carried(values[members], x[members], moved_to)
    moved = corners.mean(axis=1)
    points.x0 = points.x0 + (moved - points.x)  # a fresh point's x0 is its new place
    points.x = moved
    return corners


#: Directions in which a cell's old places spread less than this share of their
#: largest are not fitted (:func:`carried`): the field keeps no slope along them.
FIT_RCOND = 1e-3


def _fields_of_place(points: MaterialPoints) -> list[np.ndarray]:
    """The points' arrays that a script may have set from where the points were.

    An initial stress from ``geostatic_stress`` and its history, a starting velocity
    field: moved with their points, they would belong to other places. Found
    2026-12-06 by a helper: a level layer started from its geostatic stress with point
    domains carried σ_yy off ρ g (H − y) by up to ρ g h/2 at its moved points, and
    stayed at rest, each cell's force unchanged.
    """
    fields = [points.F, points.stress, points.velocity, points.acceleration]
    fields += [
        values
        for name, values in points.history.items()
        if name != MATERIAL and np.issubdtype(values.dtype, np.floating)  # a label: not fitted
    ]
    return fields


def carried(values: np.ndarray, old: np.ndarray, new: np.ndarray) -> np.ndarray:
    """A field of each cell's points (cells, k, ...) read at their new places (cells, k, d).

    The affine least-squares fit of its values at the old places, per cell: exact for
    a field affine in x (a geostatic stress, a rigid spin's velocity) where a cell's
    old places span it. A field that is uniform in a cell is left as it is, to the bit.
    """
    cells, k, d = old.shape
    flat = values.reshape(cells, k, -1)
    varies = np.any(flat.max(axis=1) != flat.min(axis=1), axis=1)
    if not np.any(varies):
        return values
    centre = old[varies].mean(axis=1, keepdims=True)
    # In units of the points' spread, so that a cell's nearly collinear points (a
    # user's seeding) leave the fit no slope across them to extrapolate far along.
    spread = np.sqrt(((old[varies] - centre) ** 2).sum(axis=2).mean(axis=1))[:, None, None]
    ones = np.ones((int(varies.sum()), k, 1))
    fit = np.concatenate([ones, (old[varies] - centre) / spread], axis=2)
    at = np.concatenate([ones, (new[varies] - centre) / spread], axis=2)
    out = flat.copy()
    out[varies] = at @ (np.linalg.pinv(fit, rcond=FIT_RCOND) @ flat[varies])
    return out.reshape(values.shape)


def _assign(x: np.ndarray, tiles: np.ndarray) -> np.ndarray:
    """Each point of a cell (cells, k, d) its nearest free tile of ``tiles``.

    ``tiles`` holds each cell's tiles (cells, k, d + 1, d); returns the points' own.
    """
    distance = np.linalg.norm(x[:, :, None, :] - tiles.mean(axis=2)[:, None, :, :], axis=-1)
    taken = np.empty(x.shape[:2], dtype=np.int64)
    rows = np.arange(len(x))
    for _ in range(x.shape[1]):
        flat = np.argmin(distance.reshape(len(x), -1), axis=1)
        point, tile = np.divmod(flat, x.shape[1])
        taken[rows, point] = tile
        distance[rows, point, :] = np.inf
        distance[rows, :, tile] = np.inf
    return np.take_along_axis(tiles, taken[:, :, None, None], axis=1)


def shape_quality(corners: np.ndarray) -> np.ndarray:
    """The mean-ratio quality of simplices (n, d + 1, d): 1 if regular, 0 if flat.

    Triangles: 4√3 A / Σ edge²; tetrahedra: 12 (3V)^(2/3) / Σ edge² (over the six edges).
    """
    d = corners.shape[2]
    i, j = np.triu_indices(d + 1, k=1)
    edges = corners[:, i] - corners[:, j]
    squares = np.einsum("ncg,ncg->n", edges, edges)
    if d == 2:
        return 4.0 * np.sqrt(3.0) * simplex_volumes(corners) / squares
    return 12.0 * (3.0 * simplex_volumes(corners)) ** (2.0 / 3.0) / squares
