"""Distorted point domains re-tiled by flipping the edge they share with a neighbour (2D).

Two triangular domains that share an edge cover a quadrilateral. Where it is convex,
its other diagonal cuts it into two other triangles that cover the same ground (a
Lawson flip, as in Delaunay triangulation). A domain that a squeeze or a shear band
has made a needle or a cap is flipped with the neighbour across the edge that gives
the pair the better worst shape, and the domains still tile the body. Redrawing it
around its point instead (:meth:`fe_mpm.domains.PointDomains._reset_distorted`, which
stays for the domains no flip helps) breaks the tiling: the redrawn domain overlaps
its neighbours or leaves a gap. Measured (``docs/cell_crossing.md``): a J2 block in
P2/P1 squeezed to half its length ends 12.3 % off its exact force with redrawn
domains and 0.5 % off with flips; the strip footing without the ghost penalty ends
20 % above standard MPM's curve at s/B = 1.9 with redrawn domains and 4 % with flips.

Each of the two points takes one of the new triangles (the pairing that moves them
least) and the parts of the old pair that triangle covers: its volume and mass are
those parts' shares of the old points' (so both are conserved, and a domain's volume
per area stays that of the ground it covers), its ``F``, stress and history their
volume-weighted mean, its velocity and acceleration their mass-weighted mean (so
momentum is conserved). The point moves to its new triangle's centroid, and ``x0``
with it. This is a remap of the pair's state: a smoothing over two domains, at the
place where the body deforms most.

Under MPI the two domains of a pair may live on two ranks. Every rank sends the
distorted domains' corners to all, then each rank the rows of its domains that share
two corners with one of them (the candidates, with their state); every rank chooses
the same flips from the same rows in the same order (sorted by position, not by rank),
and updates its own points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fe_mpm import parallel
from fe_mpm.particles import MaterialPoints
from fe_mpm.tilings import shape_quality
from fe_mpm.tracker import Tracker

#: A flip must raise the worse shape quality of its pair by this factor.
FLIP_GAIN = 1.2
#: Corners within this fraction of the grid's extent are the same corner.
CORNER_TOL = 1e-10
#: Two pairs' areas that differ by less than this relative amount are equal (the
#: test of a convex quadrilateral).
AREA_TOL = 1e-9
#: Shape qualities are compared to this many decimals when ordering the domains
#: to flip, so that ranks and a serial run order them alike.
QUALITY_DIGITS = 9


@dataclass
class Flip:
    """Two domains that swap their shared edge for the quadrilateral's other diagonal.

    Attributes:
        first, second: The two domains (indices into the corners given to
            :func:`choose_flips`).
        corners: Their new triangles (2, 3, 2) in m: ``corners[0]`` is the first's.
        taken: (2, 2): ``taken[i, k]`` is the fraction of old domain k (first,
            second) that new triangle i covers; each column adds up to 1.
    """

    first: int
    second: int
    corners: np.ndarray
    taken: np.ndarray


def _area(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """The signed area of the triangle (a, b, c) (m²)."""
    return 0.5 * float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


def _edge_partners(ids: np.ndarray) -> np.ndarray:
    """Each edge's partner: the edge 3d' + k' of the one other domain that has it.

    Edge 3d + k is the one opposite corner k of domain d; a free edge, or one that
    more than two domains share, has -1. ``ids`` (n, 3): each corner's index among
    the distinct corners.
    """
    n = len(ids)
    k = np.arange(3)
    ends = np.stack([ids[:, (k + 1) % 3], ids[:, (k + 2) % 3]], axis=-1).reshape(3 * n, 2)
    lo, hi = ends.min(axis=1), ends.max(axis=1)
    order = np.lexsort((hi, lo))
    lo, hi = lo[order], hi[order]
    starts = np.r_[True, (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])]
    group = np.cumsum(starts) - 1
    two = np.bincount(group)[group] == 2
    first = np.flatnonzero(starts & two)
    partner = np.full(3 * n, -1)
    partner[order[first]] = order[first + 1]
    partner[order[first + 1]] = order[first]
    return partner


def _flipped(corners: np.ndarray, d: int, k: int, e: int, j: int):
    """Domain d flipped with domain e across the edge opposite d's corner k.

    ``j`` is e's corner opposite the same edge. Returns the new triangles (2, 3, 2),
    their qualities (2,) and the fractions of d and e each covers (2, 2); None where
    the pair's quadrilateral is not convex.
    """
    c, a, b = corners[d, k], corners[d, (k + 1) % 3], corners[d, (k + 2) % 3]
    f = corners[e, j]
    old_d, old_e = abs(_area(a, b, c)), abs(_area(a, b, f))
    new_a, new_b = _area(a, f, c), _area(b, c, f)
    if new_a * new_b <= 0.0 or abs(abs(new_a) + abs(new_b) - old_d - old_e) > AREA_TOL * (
        old_d + old_e
    ):
        return None
    # The diagonals ab and cf cross at o = a + s (b − a); (a, f, c) is (a, o, c) of d
    # and (a, f, o) of e.
    s = np.linalg.solve(np.column_stack([b - a, c - f]), c - a)[0]
    o = a + s * (b - a)
    to_a = np.array([abs(_area(a, o, c)) / old_d, abs(_area(a, f, o)) / old_e])
    triangles = np.array([[a, f, c], [b, c, f]])
    return triangles, shape_quality(triangles), np.array([to_a, 1.0 - to_a])


def choose_flips(corners: np.ndarray, quality: np.ndarray, bad: np.ndarray, scale: float):
    """The flips that re-tile the distorted domains ``bad``, taken in that order.

    Args:
        corners: The domains (n, 3, 2) in m.
        quality: Their shape qualities (n,).
        bad: The distorted ones, in the order to treat them.
        scale: The grid's extent (m), for telling corners apart (:data:`CORNER_TOL`).

    Returns:
        The flips (:class:`Flip`); a domain takes part in one at most. A distorted
        domain is flipped across the edge that gives its pair the best worst quality,
        if that beats the pair's worse quality now by :data:`FLIP_GAIN`.
    """
    keys = np.round(corners.reshape(-1, 2) / (CORNER_TOL * scale))
    ids = np.unique(keys, axis=0, return_inverse=True)[1].reshape(len(corners), 3)
    partner = _edge_partners(ids)
    taken = np.zeros(len(corners), dtype=bool)
    flips = []
    for d in bad:
        if taken[d]:
            continue
        best = None
        for k in range(3):
            if partner[3 * d + k] < 0:
                continue
            e, j = divmod(int(partner[3 * d + k]), 3)
            if taken[e]:
                continue
            flipped = _flipped(corners, d, k, e, j)
            if flipped is None:
                continue
            worst = flipped[1].min()
            if worst > FLIP_GAIN * min(quality[d], quality[e]) and (
                best is None or worst > best[0]
            ):
                best = (worst, e, flipped)
        if best is None:
            continue
        _, e, (triangles, _, fractions) = best
        # Each point takes the triangle nearer its domain's centroid.
        now = corners[[d, e]].mean(axis=1)
        new = triangles.mean(axis=1)
        if np.sum((now - new) ** 2) > np.sum((now - new[::-1]) ** 2):
            triangles, fractions = triangles[::-1], fractions[::-1]
        flips.append(Flip(int(d), int(e), triangles, fractions))
        taken[d] = taken[e] = True
    return flips


def _state(points: MaterialPoints, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points' state that a flip remaps, as rows: (volume-weighted, mass-weighted).

    Volume-weighted: F, stress and the history (by name, in sorted order);
    mass-weighted: velocity and acceleration.
    """

    def flat(values: np.ndarray) -> np.ndarray:  # (k, size), also for k = 0
        return values[rows].reshape(len(rows), int(np.prod(values.shape[1:])))

    by_volume = [flat(points.F), flat(points.stress)]
    by_volume += [flat(points.history[name]) for name in sorted(points.history)]
    return np.hstack(by_volume), np.hstack([points.velocity[rows], points.acceleration[rows]])


def _set_state(points: MaterialPoints, row: int, by_volume: np.ndarray, by_mass: np.ndarray):
    """Write one point's remapped state (the rows of :func:`_state`)."""
    start = 0
    for array in [points.F, points.stress] + [
        points.history[name] for name in sorted(points.history)
    ]:
        size = int(np.prod(array.shape[1:]))
        array[row] = by_volume[start : start + size].reshape(array.shape[1:])
        start += size
    g = points.velocity.shape[1]
    points.velocity[row], points.acceleration[row] = by_mass[:g], by_mass[g:]


def flip_distorted(
    corners: np.ndarray,
    limit: np.ndarray,
    points: MaterialPoints,
    tracker: Tracker,
    scale: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Flip the domains whose shape quality is below ``limit``, where a flip helps.

    Collective.

    Args:
        corners: This rank's domains (n, 3, 2) in m.
        limit: The quality below which each is distorted (n,).
        points: Their points, updated here: those of flipped domains take their new
            triangle's share of the pair's volume, mass and state, and its centroid.
        tracker: The tracker the points' cells are looked for in.
        scale: The grid's extent (m), the same on every rank.

    Returns:
        The new corners (a new array where any domain flipped; ``corners`` itself
        otherwise) and which of this rank's domains flipped (n,).
    """
    comm, n = tracker.mesh.comm, len(corners)
    quality = shape_quality(corners)
    distorted = quality < limit
    flipped = np.zeros(n, dtype=bool)
    if not parallel.any_rank(comm, bool(distorted.any())):
        return corners, flipped
    # This rank's candidates: its distorted domains and those sharing two corners
    # with a distorted domain of any rank.
    keys = np.round(corners.reshape(-1, 2) / (CORNER_TOL * scale))
    far = parallel.gathered(comm, keys.reshape(n, 3, 2)[distorted].reshape(-1, 2))
    ids = np.unique(np.vstack([far, keys]), axis=0, return_inverse=True)[1]
    shared = np.isin(ids[len(far) :], ids[: len(far)]).reshape(n, 3).sum(axis=1) >= 2
    mine = np.flatnonzero(distorted | shared)
    by_volume, by_mass = _state(points, mine)
    rows = np.column_stack(
        [
            corners[mine].reshape(-1, 6),
            quality[mine],
            limit[mine],
            points.volume[mine],
            points.mass[mine],
            np.full(len(mine), comm.rank),
            mine,
            by_volume,
            by_mass,
        ]
    )
    rows = parallel.gathered(comm, rows)
    # One order on every rank, whatever the partition: by the domains' centroids.
    centre = np.round(rows[:, :6].reshape(-1, 3, 2).mean(axis=1) / (CORNER_TOL * scale))
    rows = rows[np.lexsort((centre[:, 1], centre[:, 0]))]
    all_corners, all_quality = rows[:, :6].reshape(-1, 3, 2), rows[:, 6]
    bad = np.flatnonzero(all_quality < rows[:, 7])
    bad = bad[np.argsort(np.round(all_quality[bad], QUALITY_DIGITS), kind="stable")]
    flips = choose_flips(all_corners, all_quality, bad, scale)
    if not flips:
        return corners, flipped
    volume, mass, rank, index = rows[:, 8], rows[:, 9], rows[:, 10], rows[:, 11].astype(int)
    width = by_volume.shape[1]
    weighted_by_volume, weighted_by_mass = rows[:, 12 : 12 + width], rows[:, 12 + width :]
    new = corners.copy()
    for flip in flips:
        pair = [flip.first, flip.second]
        # taken[i, k] of old domain k's volume and mass goes to new triangle i.
        parts_v, parts_m = flip.taken * volume[pair], flip.taken * mass[pair]
        for i, member in enumerate(pair):
            if rank[member] != comm.rank:
                continue
            row = index[member]
            v, m = parts_v[i].sum(), parts_m[i].sum()
            points.volume[row], points.mass[row] = v, m
            s_v = parts_v[i] @ weighted_by_volume[pair] / v
            s_m = parts_m[i] @ weighted_by_mass[pair] / m if m > 0 else weighted_by_mass[member]
            _set_state(points, row, s_v, s_m)
            centroid = flip.corners[i].mean(axis=0)
            points.x0[row] += centroid - points.x[row]
            points.x[row] = centroid
            new[row] = flip.corners[i]
            flipped[row] = True
    moved = np.flatnonzero(flipped)
    if moved.size:
        cells = tracker.locate(points.x[moved], points.cell[moved])
        points.cell[moved] = np.where(cells >= 0, cells, points.cell[moved])
    return new, flipped
