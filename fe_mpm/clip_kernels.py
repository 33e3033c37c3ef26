"""Compiled loops (numba) for cutting point domains by grid cells.

:mod:`fe_mpm.clipping` (triangles) and :mod:`fe_mpm.tet_clipping` (tetrahedra) say
what is computed; here the same arithmetic runs pair by pair in compiled loops
instead of over whole arrays in numpy. Vectorised, each (domain, cell) pair went
through every pass of every case, with the temporary arrays that takes: about half
of a step of point domains on tetrahedra and a third on triangles went to cutting.
The loops keep numpy's operations and their order, so the pieces come out the same
to the last bit (``tests/test_domains_3d.py`` and ``tests/test_clipping.py`` compare
them with the vectorised cuts).

Imported when domains are first cut.
"""

from __future__ import annotations

import numba
import numpy as np

jit = numba.njit(cache=True, nogil=True)

#: The most vertices a triangle clipped by three half-planes can have.
MAX_POLYGON = 6

#: The most tetrahedra a tetrahedron cut by four planes can leave (3⁴: each cut
#: keeps a tetrahedron whole, as one, or as a prism of three).
MAX_TETS = 81


@jit
def _reference_distance(face, x, y, z):
    """Signed distance of ξ to face ``face`` of the reference simplex (≥ 0 inside).

    Faces 0 … g − 1 are ξ_face = 0; the last, 1 − Σ ξ = 0. ``z`` is unused in 2D
    (face 2 is then the last).
    """
    if face == 0:
        return x
    if face == 1:
        return y
    return z


@jit
def may_meet(corners, inverse, low, high, cell_vertices, box_low, box_high, owner, cell, tol):
    """Whether each (domain, cell) pair may overlap: False where it cannot.

    It cannot where the bounding boxes miss each other, or where the cell lies wholly
    beyond a face of the domain: in the domain's coordinates ξ (x = origin + ξ ·
    edges), every vertex of the cell has ξ_k < tol for one k, or Σ ξ > 1 − tol.

    Args:
        corners: The domains' corners (n, g + 1, g).
        inverse: The inverse of each domain's edge matrix, corners[1:] − corners[0] (n, g, g).
        low: The lower corners of the domains' bounding boxes (n, g).
        high: Their upper corners (n, g).
        cell_vertices: The cells' vertices (nc, g + 1, g).
        box_low: The lower corners of the cells' bounding boxes (nc, g).
        box_high: Their upper corners (nc, g).
        owner: Each pair's domain (m,).
        cell: Each pair's cell (m,).
        tol: Coordinates within this of a face count as beyond it (touching meets nothing).

    Returns:
        Whether each pair may overlap (m,).
    """
    m, v, g = owner.shape[0], corners.shape[1], corners.shape[2]
    meets = np.ones(m, dtype=np.bool_)
    xi = np.empty((v, g))
    for k in range(m):
        d, c = owner[k], cell[k]
        apart = False
        for h in range(g):
            if not (box_low[c, h] <= high[d, h] and box_high[c, h] >= low[d, h]):
                apart = True
        if apart:
            meets[k] = False
            continue
        # ξ = (x − origin) · edges⁻¹, a vertex of the cell in the domain's coordinates
        for a in range(v):
            for h in range(g):
                s = 0.0
                for j in range(g):
                    s += (cell_vertices[c, a, j] - corners[d, 0, j]) * inverse[d, j, h]
                xi[a, h] = s
        beyond = False
        for h in range(g):  # all of the cell beyond the face ξ_h = 0
            every = True
            for a in range(v):
                if not xi[a, h] < tol:
                    every = False
                    break
            if every:
                beyond = True
                break
        if not beyond:  # all of it beyond the face Σ ξ = 1
            every = True
            for a in range(v):
                s = 0.0
                for h in range(g):
                    s += xi[a, h]
                if not s > 1.0 - tol:
                    every = False
                    break
            beyond = every
        meets[k] = not beyond
    return meets


@jit
def clip_triangles(xi):
    """The overlap of each triangle (n, 3, 2) with ``ξ₁, ξ₂ ≥ 0, ξ₁ + ξ₂ ≤ 1`` as a polygon.

    Sutherland–Hodgman against the cell's three edges, as
    :func:`fe_mpm.clipping.clip_half_plane`: each vertex emits itself if inside,
    then its edge's crossing.

    Returns:
        The polygons' vertices (n, 6, 2) in order, and their counts (n,): 0 where
        there is no overlap.
    """
    n = xi.shape[0]
    polygons = np.zeros((n, MAX_POLYGON, 2))
    counts = np.zeros(n, dtype=np.int64)
    current = np.empty((MAX_POLYGON, 2))
    following = np.empty((MAX_POLYGON, 2))
    d = np.empty(MAX_POLYGON)
    for p in range(n):
        # Wholly inside the cell, or wholly beyond one edge: no clipping.
        inside, beyond = True, False
        for face in range(3):
            every_out = True
            for a in range(3):
                x, y = xi[p, a, 0], xi[p, a, 1]
                dist = _reference_distance(face, x, y, 1.0 - x - y)
                # As numpy's all(d >= 0) and all(d < 0): a NaN is neither.
                if not dist >= 0.0:
                    inside = False
                if not dist < 0.0:
                    every_out = False
            if every_out:
                beyond = True
        if beyond:
            continue
        if inside:
            for a in range(3):
                polygons[p, a, 0], polygons[p, a, 1] = xi[p, a, 0], xi[p, a, 1]
            counts[p] = 3
            continue
        count = 3
        for a in range(3):
            current[a, 0], current[a, 1] = xi[p, a, 0], xi[p, a, 1]
        for face in range(3):
            size = 4 + face
            for a in range(count):
                x, y = current[a, 0], current[a, 1]
                d[a] = _reference_distance(face, x, y, 1.0 - x - y)
            out = 0
            for a in range(count):
                b = (a + 1) % count
                if d[a] >= 0.0:
                    t = min(out, size - 1)
                    following[t, 0], following[t, 1] = current[a, 0], current[a, 1]
                    out += 1
                if (d[a] > 0.0 and d[b] < 0.0) or (d[a] < 0.0 and d[b] > 0.0):
                    s = d[a] / (d[a] - d[b])
                    t = min(out, size - 1)
                    following[t, 0] = current[a, 0] + s * (current[b, 0] - current[a, 0])
                    following[t, 1] = current[a, 1] + s * (current[b, 1] - current[a, 1])
                    out += 1
            count = min(out, size)
            for a in range(count):
                current[a, 0], current[a, 1] = following[a, 0], following[a, 1]
        for a in range(count):
            polygons[p, a, 0], polygons[p, a, 1] = current[a, 0], current[a, 1]
        counts[p] = count
    return polygons, counts


@jit
def _tet_distance(face, t, d):
    """Signed distances ``d`` (4,) of a tetrahedron's corners ``t`` (4, 3) to a reference face."""
    for a in range(4):
        x, y, z = t[a, 0], t[a, 1], t[a, 2]
        if face == 3:
            d[a] = 1.0 - x - y - z
        else:
            d[a] = t[a, face]


@jit
def _on_edge(t, d, i, j, out, row, corner):
    """Where the plane crosses edge i–j of ``t`` (corner i kept), into out[row, corner]."""
    s = d[i] / (d[i] - d[j])
    for h in range(3):
        out[row, corner, h] = t[i, h] + s * (t[j, h] - t[i, h])


@jit
def _cut_by_face(tets, count, face, out, order, kept, dist, d, v, prisms):
    """Keep the parts of ``tets[:count]`` inside ``face``, written to ``out``; their number.

    The order is that of :func:`fe_mpm.tet_clipping.cut` for one owner: the whole
    tetrahedra, those with one corner kept, then the prisms' first, second and third
    tetrahedra, those with two corners kept before those with three. ``order`` (≥ count, 4),
    ``kept``, ``dist``, ``d`` (4,), ``v`` (4, 3) and ``prisms`` (≥ count, 6, 3) are work
    arrays.
    """
    # Each tetrahedron's corners, kept first (a stable order), and how many are kept.
    for k in range(count):
        _tet_distance(face, tets[k], d)
        n_in = 0
        for a in range(4):
            if d[a] >= 0.0:
                order[k, n_in] = a
                n_in += 1
        rest = n_in
        for a in range(4):
            if not d[a] >= 0.0:
                order[k, rest] = a
                rest += 1
        kept[k] = n_in
        for a in range(4):
            dist[k, a] = d[order[k, a]]
    m = 0
    for k in range(count):  # whole
        if kept[k] == 4:
            for a in range(4):
                for h in range(3):
                    out[m, a, h] = tets[k, a, h]
            m += 1
    for k in range(count):  # one corner kept: a tetrahedron; two or three: a prism
        if kept[k] == 0 or kept[k] == 4:
            continue
        for a in range(4):
            for h in range(3):
                v[a, h] = tets[k, order[k, a], h]
        if kept[k] == 1:
            for h in range(3):
                out[m, 0, h] = v[0, h]
            _on_edge(v, dist[k], 0, 1, out, m, 1)
            _on_edge(v, dist[k], 0, 2, out, m, 2)
            _on_edge(v, dist[k], 0, 3, out, m, 3)
            m += 1
            continue
        # The prism: bottom p0 p1 p2, top q0 q1 q2 (as fe_mpm.tet_clipping.cut builds it).
        if kept[k] == 2:
            for h in range(3):
                prisms[k, 0, h], prisms[k, 3, h] = v[0, h], v[1, h]
            _on_edge(v, dist[k], 0, 2, prisms, k, 1)
            _on_edge(v, dist[k], 0, 3, prisms, k, 2)
            _on_edge(v, dist[k], 1, 2, prisms, k, 4)
            _on_edge(v, dist[k], 1, 3, prisms, k, 5)
        else:
            for h in range(3):
                prisms[k, 0, h], prisms[k, 1, h], prisms[k, 2, h] = v[0, h], v[1, h], v[2, h]
            _on_edge(v, dist[k], 0, 3, prisms, k, 3)
            _on_edge(v, dist[k], 1, 3, prisms, k, 4)
            _on_edge(v, dist[k], 2, 3, prisms, k, 5)
    for n_kept in (2, 3):
        for part in range(3):
            # The prism's three tetrahedra, as fe_mpm.tet_clipping._prism splits it:
            # (p0 p1 p2 q2), (p0 p1 q1 q2), (p0 q0 q1 q2).
            if part == 0:
                a0, a1, a2, a3 = 0, 1, 2, 5
            elif part == 1:
                a0, a1, a2, a3 = 0, 1, 4, 5
            else:
                a0, a1, a2, a3 = 0, 3, 4, 5
            for k in range(count):
                if kept[k] != n_kept:
                    continue
                for h in range(3):
                    out[m, 0, h] = prisms[k, a0, h]
                    out[m, 1, h] = prisms[k, a1, h]
                    out[m, 2, h] = prisms[k, a2, h]
                    out[m, 3, h] = prisms[k, a3, h]
                m += 1
    return m


@jit
def _tet_volume(t):
    """The volume of tetrahedron ``t`` (4, 3), either orientation."""
    a0, a1, a2 = t[1, 0] - t[0, 0], t[1, 1] - t[0, 1], t[1, 2] - t[0, 2]
    b0, b1, b2 = t[2, 0] - t[0, 0], t[2, 1] - t[0, 1], t[2, 2] - t[0, 2]
    c0, c1, c2 = t[3, 0] - t[0, 0], t[3, 1] - t[0, 1], t[3, 2] - t[0, 2]
    triple = a0 * (b1 * c2 - b2 * c1) + a1 * (b2 * c0 - b0 * c2) + a2 * (b0 * c1 - b1 * c0)
    return abs(triple) / 6.0


@jit
def clip_tetrahedra(xi):
    """The overlap of each tetrahedron (n, 4, 3) with the reference cell: volume and centroid.

    Cut by the cell's four faces as :func:`fe_mpm.tet_clipping.cut` cuts; the volume
    in reference units (the cell is 1/6) and the centroid ξ (0 where the volume is 0).
    """
    n = xi.shape[0]
    volume = np.zeros(n)
    centroid = np.zeros((n, 3))
    one = np.empty((MAX_TETS, 4, 3))
    two = np.empty((MAX_TETS, 4, 3))
    order = np.empty((MAX_TETS, 4), dtype=np.int64)
    kept = np.empty(MAX_TETS, dtype=np.int64)
    dist = np.empty((MAX_TETS, 4))
    d = np.empty(4)
    v = np.empty((4, 3))
    prisms = np.empty((MAX_TETS, 6, 3))
    for p in range(n):
        inside, beyond = True, False
        for face in range(4):
            _tet_distance(face, xi[p], d)
            every_out = True
            for a in range(4):  # as numpy's all(d >= 0) and all(d < 0): a NaN is neither
                if not d[a] >= 0.0:
                    inside = False
                if not d[a] < 0.0:
                    every_out = False
            if every_out:
                beyond = True
        if beyond:
            continue
        for a in range(4):
            for h in range(3):
                one[0, a, h] = xi[p, a, h]
        count = 1
        if not inside:
            source, target = one, two
            for face in range(4):
                count = _cut_by_face(source, count, face, target, order, kept, dist, d, v, prisms)
                source, target = target, source
            tets = source
        else:
            tets = one
        total, mx, my, mz = 0.0, 0.0, 0.0, 0.0
        for k in range(count):
            w = _tet_volume(tets[k])
            total += w
            mx += w * ((((tets[k, 0, 0] + tets[k, 1, 0]) + tets[k, 2, 0]) + tets[k, 3, 0]) / 4.0)
            my += w * ((((tets[k, 0, 1] + tets[k, 1, 1]) + tets[k, 2, 1]) + tets[k, 3, 1]) / 4.0)
            mz += w * ((((tets[k, 0, 2] + tets[k, 1, 2]) + tets[k, 2, 2]) + tets[k, 3, 2]) / 4.0)
        volume[p] = total
        if total > 0.0:
            centroid[p, 0], centroid[p, 1], centroid[p, 2] = mx / total, my / total, mz / total
    return volume, centroid
