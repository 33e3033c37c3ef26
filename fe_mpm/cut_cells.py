"""The part of each grid cell inside a body given by a level set, as simplices.

:func:`fe_mpm.seed` with ``level_set=`` places points on the body ``φ(x) ≥ 0``. A cell
the surface cuts is seeded on its inside part only, so that the points integrate the
body, not a ragged row of whole cells' Gauss points. That matters at a free surface:
with points that integrate linear functions over the body exactly, the hydrostatic
pressure of a fluid at rest balances its weight node by node, where Gauss points
dropped above the surface leave each cut cell out of balance by ρ g times a point
spacing, and water at rest then moves (cm/s on a gmsh tank, whatever the cell size).

The inside part is where the linear interpolant of φ on the cell is ≥ 0: exact for a
planar surface, second order for a curved one. In 2D it is a polygon of at most four
vertices, fanned into triangles; in 3D a tetrahedron or a prism of three tetrahedra
(:func:`fe_mpm.tet_clipping.cut`).
"""

from __future__ import annotations

import numpy as np

from fe_mpm.clipping import clip_half_plane, simplex_volumes
from fe_mpm.tet_clipping import cut

#: Pieces smaller than this share of their cell are dropped: a surface through a
#: vertex or along an edge leaves slivers of no volume, whose points would have no mass.
SLIVER = 1e-12


def inside_simplices(corners: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split cells into the simplices of their part where the level set is ≥ 0.

    Args:
        corners: The cells' vertices, shape ``(n, d + 1, d)`` (m), d = 2 or 3.
        values: The level set at those vertices, shape ``(n, d + 1)``.

    Returns:
        The simplices, shape ``(m, d + 1, d)``, and the cell (row of ``corners``) each
        lies in, shape ``(m,)``. A cell with every vertex ≥ 0 is returned whole; one
        with every vertex < 0 not at all.
    """
    dim = corners.shape[2]
    whole = np.all(values >= 0.0, axis=1)
    split = np.flatnonzero(~whole & np.any(values > 0.0, axis=1))
    if dim == 3:
        # cut() asks for the distances of the corners it is given, once, and
        # interpolates linearly along the edges it cuts: the level set's values.
        at_corners = values[split]
        tets, owner = cut(corners[split], split, lambda _: at_corners)
    else:
        polygon, count = clip_half_plane(corners[split], np.full(split.size, 3), values[split], 4)
        triangles, owners = [], []
        for k in (1, 2):  # fan: triangles (0, k, k + 1) of polygons with k + 2 vertices
            has = count >= k + 2
            triangles.append(polygon[has][:, [0, k, k + 1]])
            owners.append(split[has])
        tets, owner = np.concatenate(triangles), np.concatenate(owners)
    keep = simplex_volumes(tets) > SLIVER * simplex_volumes(corners[owner])
    kept = np.flatnonzero(whole)
    return (
        np.concatenate([corners[kept], tets[keep]]),
        np.concatenate([kept, owner[keep]]).astype(np.int64),
    )
