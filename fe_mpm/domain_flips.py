"""Distorted point domains re-tiled by flipping the edge they share with a neighbour (2D).

Two triangular domains that share an edge cover a quadrilateral. Where it is convex,
its other diagonal cuts it into two other triangles that cover the same ground (a
Lawson flip, as in Delaunay triangulation). A domain that a squeeze or a shear band
has made a needle or a cap is flipped with the neighbour across the edge that gives
the pair the better worst shape, where that leaves neither distorted, and the domains
still tile the body. Redrawing it
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
momentum is conserved; the pair's mass centre moves where their densities differ).
The point moves to its new triangle's centroid, and ``x0`` with it. This is a remap
of the pair's state: a smoothing over two domains, at the place where the body
deforms most. Where the mean of the two F would lose much of their volume (two F
rotated far apart, :data:`MIN_DET_KEPT`) the pair is not flipped but redrawn. Flips
made at the start of a step that then fails stay: the retry starts from them.

Under MPI the two domains of a pair may live on two ranks. Every rank sends the
distorted domains' corners to all, then each rank the rows of its domains that have
two corners among them (the candidates, with their state); every rank chooses
the same flips from the same rows in the same order (sorted by position, not by rank),
and updates its own points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fe_mpm import parallel
from fe_mpm.materials.zones import MATERIAL
from fe_mpm.particles import MaterialPoints
from fe_mpm.tilings import shape_quality
from fe_mpm.tracker import Tracker

#: A flip must raise the worse shape quality of its pair by this factor, and leave
#: both above the quality below which they count as distorted.
FLIP_GAIN = 1.2
#: A flip is not made where a point's remapped F, the mean of two, would have less
#: than this fraction of the smaller det F of the pair (two F rotated far apart, in
#: a shear band, average to a nearly singular one).
MIN_DET_KEPT = 0.5
#: Corners are told apart by their coordinates rounded to this fraction of the
#: grid's extent.
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


def _keys(x: np.ndarray, scale: float) -> np.ndarray:
    """Points (n, 2) in m as keys that tell them apart (:data:`CORNER_TOL`), (n, 2)."""
    return np.round(x / (CORNER_TOL * scale))


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
    convex = new_a * new_b > 0.0 and abs(abs(new_a) + abs(new_b) - old_d - old_e) <= (
        AREA_TOL * (old_d + old_e)
    )
    if not convex or old_d == 0.0 or old_e == 0.0:
        return None
    # The diagonals ab and cf cross at o = a + s (b − a). (a, f, c) is (a, o, c) of d
    # and (a, o, f) of e, triangles on ab with d's and e's apexes: a fraction s of each.
    s = np.linalg.solve(np.column_stack([b - a, c - f]), c - a)[0]
    triangles = np.array([[a, f, c], [b, c, f]])
    return triangles, shape_quality(triangles), np.array([[s, s], [1.0 - s, 1.0 - s]])


def choose_flips(
    corners: np.ndarray,
    quality: np.ndarray,
    limit: np.ndarray,
    bad: np.ndarray,
    scale: float,
    zone: np.ndarray | None = None,
) -> list[Flip]:
    """The flips that re-tile the distorted domains ``bad``, taken in that order.

    Args:
        corners: The domains (n, 3, 2) in m.
        quality: Their shape qualities (n,).
        limit: The quality below which each counts as distorted (n,).
        bad: The distorted ones, in the order to treat them.
        scale: The grid's extent (m), for telling corners apart (:data:`CORNER_TOL`).
        zone: Each domain's law (n,), where the body has several: two domains of
            different laws are not flipped (a remap would mix their states).

    Returns:
        The flips (:class:`Flip`); a domain takes part in one at most. A distorted
        domain is flipped across the edge that gives its pair the best worst quality,
        if that beats the pair's worse quality now by :data:`FLIP_GAIN` and leaves
        neither of them distorted.
    """
    keys = _keys(corners.reshape(-1, 2), scale)
    ids = np.unique(keys, axis=0, return_inverse=True)[1].reshape(len(corners), 3)
    partner = _edge_partners(ids)
    used = np.zeros(len(corners), dtype=bool)
    flips = []
    for d in bad:
        if used[d]:
            continue
        best = None
        for k in range(3):
            if partner[3 * d + k] < 0:
                continue
            e, j = divmod(int(partner[3 * d + k]), 3)
            if used[e] or (zone is not None and zone[e] != zone[d]):
                continue
            flipped = _flipped(corners, d, k, e, j)
            if flipped is None:
                continue
            worst = flipped[1].min()
            better = worst > FLIP_GAIN * min(quality[d], quality[e])
            if better and worst >= max(limit[d], limit[e]) and (best is None or worst > best[0]):
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
        used[d] = used[e] = True
    return flips


def _remapped_arrays(points: MaterialPoints) -> list[tuple[str, np.ndarray]]:
    """The volume-weighted state a flip remaps, by name, in its columns' order.

    F first (so that :func:`_remapped` finds it), then the stress and the history by
    name in sorted order: :func:`_state`, :func:`_set_state` and :func:`_zones` read
    the columns in this order.
    """
    history = [(name, points.history[name]) for name in sorted(points.history)]
    return [("F", points.F), ("stress", points.stress), *history]


def _state(points: MaterialPoints, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The state that a flip remaps, of the points ``rows`` (k,).

    Returns (k, w) volume-weighted rows (:func:`_remapped_arrays`), and (k, 2g)
    mass-weighted rows: velocity and acceleration.
    """

    def flat(values: np.ndarray) -> np.ndarray:  # (k, size), also for k = 0
        return values[rows].reshape(len(rows), int(np.prod(values.shape[1:])))

    by_volume = [flat(array) for _, array in _remapped_arrays(points)]
    return np.hstack(by_volume), np.hstack([points.velocity[rows], points.acceleration[rows]])


def _set_state(points: MaterialPoints, row: int, by_volume: np.ndarray, by_mass: np.ndarray):
    """Write one point's remapped state (one row of each of :func:`_state`'s)."""
    start = 0
    for _, array in _remapped_arrays(points):
        size = int(np.prod(array.shape[1:]))
        array[row] = by_volume[start : start + size].reshape(array.shape[1:])
        start += size
    g = points.velocity.shape[1]
    points.velocity[row], points.acceleration[row] = by_mass[:g], by_mass[g:]


def _zones(points: MaterialPoints, rows: _Rows) -> np.ndarray | None:
    """Each row's law where the body has several (its ``"material"`` column), else None."""
    if MATERIAL not in points.history:
        return None
    start = 0
    for name, array in _remapped_arrays(points):
        if name == MATERIAL:
            return np.rint(rows.by_volume[:, start]).astype(np.int64)
        start += int(np.prod(array.shape[1:]))
    raise AssertionError("unreachable: MATERIAL is in the history")


@dataclass
class _Rows:
    """The candidates of every rank, one row each, in one order on every rank."""

    corners: np.ndarray  # (k, 3, 2) m
    quality: np.ndarray  # (k,)
    limit: np.ndarray  # (k,)
    volume: np.ndarray  # (k,)
    mass: np.ndarray  # (k,)
    rank: np.ndarray  # (k,) the rank that holds it
    index: np.ndarray  # (k,) its index there
    by_volume: np.ndarray  # (k, w), :func:`_state`
    by_mass: np.ndarray  # (k, 2g)


def _gathered_rows(comm, mine, corners, quality, limit, points, scale) -> _Rows:
    """This rank's candidates ``mine`` and every other rank's, sorted by centroid.

    Collective. The order depends on the domains' places only, not on the partition.
    """
    by_volume, by_mass = _state(points, mine)
    local = [
        corners[mine].reshape(-1, 6),
        quality[mine][:, None],
        limit[mine][:, None],
        points.volume[mine][:, None],
        points.mass[mine][:, None],
        np.full((len(mine), 1), comm.rank),
        mine[:, None],
        by_volume,
        by_mass,
    ]
    widths = np.cumsum([0] + [block.shape[1] for block in local])
    rows = parallel.gathered(comm, np.hstack(local).astype(float))
    centre = _keys(rows[:, :6].reshape(-1, 3, 2).mean(axis=1), scale)
    rows = rows[np.lexsort((centre[:, 1], centre[:, 0]))]
    column = [rows[:, widths[i] : widths[i + 1]] for i in range(len(local))]
    return _Rows(
        column[0].reshape(-1, 3, 2),
        column[1][:, 0],
        column[2][:, 0],
        column[3][:, 0],
        column[4][:, 0],
        column[5][:, 0].astype(int),
        column[6][:, 0].astype(int),
        column[7],
        column[8],
    )


def _remapped(flip: Flip, rows: _Rows, g: int):
    """The two new points' volumes, masses and state rows (each (2, ...)) of ``flip``."""
    pair = [flip.first, flip.second]
    # taken[i, k] of old domain k goes to new triangle i.
    parts_v, parts_m = flip.taken * rows.volume[pair], flip.taken * rows.mass[pair]
    volume, mass = parts_v.sum(axis=1), parts_m.sum(axis=1)
    by_volume = parts_v @ rows.by_volume[pair] / volume[:, None]
    by_mass = rows.by_mass[pair].copy()
    with_mass = mass > 0.0
    by_mass[with_mass] = (parts_m @ rows.by_mass[pair])[with_mass] / mass[with_mass, None]
    det_new = np.linalg.det(by_volume[:, : g * g].reshape(2, g, g))
    det_old = np.linalg.det(rows.by_volume[pair, : g * g].reshape(2, g, g))
    keeps_volume = bool(np.all(det_new >= MIN_DET_KEPT * det_old.min()))
    return volume, mass, by_volume, by_mass, keeps_volume


def flip_distorted(
    corners: np.ndarray,
    quality: np.ndarray,
    limit: np.ndarray,
    points: MaterialPoints,
    tracker: Tracker,
    scale: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Flip the domains whose shape quality is below ``limit``, where a flip helps.

    Collective.

    Args:
        corners: This rank's domains (n, 3, 2) in m.
        quality: Their shape qualities (n,) (:func:`~fe_mpm.tilings.shape_quality`).
        limit: The quality below which each is distorted (n,).
        points: Their points, updated here: those of flipped domains take their new
            triangle's share of the pair's volume, mass and state, and its centroid.
        tracker: The tracker the points' cells are looked for in.
        scale: The grid's extent (m), the same on every rank.

    Returns:
        The new corners (a new array where any domain flipped; ``corners`` itself
        otherwise) and which of this rank's domains flipped (n,).
    """
    comm, (n, _, g) = tracker.mesh.comm, corners.shape
    distorted = quality < limit
    flipped = np.zeros(n, dtype=bool)
    if not parallel.any_rank(comm, bool(distorted.any())):
        return corners, flipped
    # This rank's candidates: its distorted domains and those with two corners among
    # the distorted domains' of every rank (their neighbours, and a few more).
    keys = _keys(corners.reshape(-1, 2), scale)
    far = parallel.gathered(comm, keys.reshape(n, 3, 2)[distorted].reshape(-1, 2))
    ids = np.unique(np.vstack([far, keys]), axis=0, return_inverse=True)[1]
    shared = np.isin(ids[len(far) :], ids[: len(far)]).reshape(n, 3).sum(axis=1) >= 2
    mine = np.flatnonzero(distorted | shared)
    rows = _gathered_rows(comm, mine, corners, quality, limit, points, scale)
    bad = np.flatnonzero(rows.quality < rows.limit)
    bad = bad[np.argsort(np.round(rows.quality[bad], QUALITY_DIGITS), kind="stable")]
    new = corners.copy()
    zone = _zones(points, rows)
    for flip in choose_flips(rows.corners, rows.quality, rows.limit, bad, scale, zone):
        volume, mass, by_volume, by_mass, keeps_volume = _remapped(flip, rows, g)
        if not keeps_volume:
            continue  # the same on every rank: its domains are redrawn instead
        for i, member in enumerate([flip.first, flip.second]):
            if rows.rank[member] != comm.rank:
                continue
            row = rows.index[member]
            points.volume[row], points.mass[row] = volume[i], mass[i]
            _set_state(points, row, by_volume[i], by_mass[i])
            centroid = flip.corners[i].mean(axis=0)
            points.x0[row] += centroid - points.x[row]
            points.x[row] = centroid
            new[row] = flip.corners[i]
            flipped[row] = True
    if not flipped.any():
        return corners, flipped
    moved = np.flatnonzero(flipped)
    cells = tracker.locate(points.x[moved], points.cell[moved])
    # A point whose centroid lies past the grid's edge keeps its cell as a guess.
    points.cell[moved] = np.where(cells >= 0, cells, points.cell[moved])
    return new, flipped
