"""Points that move into another rank's cells go to that rank, with everything they carry.

On a distributed grid each rank holds the points of the cells it owns. After a step
a point may lie in a cell of another rank; the tracker, which searches this rank's
cells, then does not find it. :func:`migrate` asks DOLFINx which rank owns the cell
of each such point (``dolfinx.geometry.determine_point_ownership``, collective) and
sends the point there: position, mass, volume, F, stress, velocity, acceleration,
its initial position, its history, and the markers it hosts. Received points are
appended in the order of the sending ranks, so a run is reproducible for a given
number of ranks. A point that no rank's cell holds stays lost (cell −1), for the
caller to report.
"""

from __future__ import annotations

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.markers import Markers
from fe_mpm.particles import PER_POINT_FIELDS, MaterialPoints
from fe_mpm.tracker import Tracker

#: Padding of the cells' bounding boxes in the ownership search, in cell sizes: a point
#: on a facet between ranks still finds a candidate.
PADDING = 1e-6


def migrate(
    points: MaterialPoints,
    markers: Markers,
    tracker: Tracker,
    cells: np.ndarray,
    carried: np.ndarray | None = None,
    ties: np.ndarray | None = None,
) -> tuple[np.ndarray, int, np.ndarray | None]:
    """Send the points this rank did not find (``cells < 0``) to the ranks that own them.

    Collective: every rank calls it at every tracking, even with nothing to send.

    Args:
        points: This rank's points, changed in place (sent ones removed, received
            ones appended).
        markers: Their hosts follow the points.
        tracker: This rank's point locator (it finds the received points' cells).
        cells: Each point's cell on this rank, or −1 (n,).
        carried: Rows of more per-point data that travel with the points (n, k).
        ties: The points found here whose first nudged position is not
            (:meth:`~fe_mpm.tracker.Tracker.locate_with_ties`): each goes to the lowest
            rank whose cell holds the first of its nudged positions that any rank's
            cell holds, and stays where none does.

    Returns:
        The cells of this rank's points after the exchange (−1: in no rank's cell),
        the number of points that moved between ranks (all ranks together), and
        ``carried`` for the points now here.
    """
    comm = tracker.mesh.comm
    lost = np.flatnonzero(cells < 0)
    ties = np.empty(0, dtype=np.int64) if ties is None else np.asarray(ties)
    if comm.size == 1:
        return cells, 0, carried
    moved = 0
    if parallel.any_rank(comm, lost.size > 0):
        owner = owning_ranks(tracker, points.x[lost])
        # A point owned here after all (on a facet the walk missed) is not sent.
        leaving = (owner >= 0) & (owner != comm.rank)
        sent = lost[leaving]
        kept = len(points) - sent.size
        cells, moved, carried = send(points, markers, tracker, cells, sent, owner[leaving], carried)
        # The points kept are renumbered (a tie is never sent: it has a cell here), and
        # those received took a cell of this rank, which may be a tie too.
        received = np.arange(kept, len(points))
        _, received_ties = tracker.locate_with_ties(points.x[received], cells[received])
        ties = np.concatenate([ties - np.searchsorted(sent, ties), received[received_ties]])
    if parallel.any_rank(comm, ties.size > 0):
        taker = _holders(tracker, points.x[ties])
        leaving = (taker >= 0) & (taker != comm.rank)
        cells, more, carried = send(
            points, markers, tracker, cells, ties[leaving], taker[leaving], carried
        )
        moved += more
    return cells, moved, carried


def owning_ranks(tracker: Tracker, x: np.ndarray) -> np.ndarray:
    """The rank whose cell holds each of this rank's points ``x`` (n, g), or −1 (n,).

    DOLFINx's ownership search with cells padded by :data:`PADDING` of the largest cell,
    so a point on a facet between ranks finds a candidate; a point just past the grid's
    edge may then be owned too. Collective.
    """
    comm = tracker.mesh.comm
    x3 = np.zeros((x.shape[0], 3))
    x3[:, : x.shape[1]] = x
    padding = PADDING * parallel.largest(comm, float(tracker.sizes.max(initial=0.0)))
    return dolfinx.geometry.determine_point_ownership(tracker.mesh, x3, padding).src_owner


def _holders(tracker: Tracker, x: np.ndarray) -> np.ndarray:
    """For each of this rank's points ``x`` (n, g) on a facet, the rank its tie gives it to.

    The first of :attr:`~fe_mpm.tracker.Tracker.nudges` that moves the point into some
    rank's cell decides, and the lowest rank whose cell holds the point so moved takes
    it: what one rank's :meth:`~fe_mpm.tracker.Tracker.locate` gives. −1 where no nudge
    moves it into a cell. Collective; every rank's points go to every rank (they are the
    few that lie on a facet between ranks or on the grid's edge).
    """
    comm = tracker.mesh.comm
    counts = comm.allgather(x.shape[0])
    everyone = parallel.gathered(comm, x).reshape(-1, x.shape[1])
    nudged = everyone[:, None, :] + tracker.nudges[None, :, :]  # (N, k, g)
    here = tracker.holding(nudged.reshape(-1, x.shape[1]), tol=0.0).reshape(nudged.shape[:2]) >= 0
    lowest = parallel.lowest_rank(comm, here)
    held = lowest < comm.size
    first = np.argmax(held, axis=1)  # the first nudge some rank holds
    taker = np.where(held.any(axis=1), lowest[np.arange(len(everyone)), first], -1)
    start = int(np.sum(counts[: comm.rank]))
    return taker[start : start + x.shape[0]]


def send(
    points: MaterialPoints,
    markers: Markers,
    tracker: Tracker,
    cells: np.ndarray,
    rows: np.ndarray,
    destination: np.ndarray,
    carried: np.ndarray | None = None,
) -> tuple[np.ndarray, int, np.ndarray | None]:
    """Send this rank's points ``rows`` to the ranks ``destination``; collective.

    Returns what :func:`migrate` returns; received points' cells are looked up here.
    """
    comm = tracker.mesh.comm
    hosted = markers.hosts()
    outgoing = []
    for rank in range(comm.size):
        to_rank = rows[destination == rank]
        data = None
        if to_rank.size:
            data = _pack(points, to_rank, hosted)
            data["carried"] = None if carried is None else carried[to_rank]
        outgoing.append(data)
    incoming = comm.alltoall(outgoing)
    keep = np.ones(len(points), dtype=bool)
    keep[rows] = False
    markers.keep_hosts(keep, moved_away=True)
    points.keep(keep)
    cells = cells[keep]
    carried = None if carried is None else carried[keep]
    for data in incoming:
        if data is not None:
            cells = _append(points, markers, tracker, cells, data)
            if carried is not None:
                carried = np.concatenate([carried, data["carried"]])
    return cells, int(parallel.total(comm, int(rows.size))), carried


def _pack(points: MaterialPoints, rows: np.ndarray, hosted: dict[str, int]) -> dict:
    """The data of the points ``rows``, with the markers they host (by position in ``rows``)."""
    data = {name: getattr(points, name)[rows] for name in PER_POINT_FIELDS}
    data["history"] = {name: values[rows] for name, values in points.history.items()}
    where = {int(row): i for i, row in enumerate(rows)}
    data["markers"] = {name: where[host] for name, host in hosted.items() if host in where}
    return data


def _append(
    points: MaterialPoints, markers: Markers, tracker: Tracker, cells: np.ndarray, data: dict
) -> np.ndarray:
    """Append received points; their cells are looked up here."""
    start = len(points)
    for name in PER_POINT_FIELDS:
        setattr(points, name, np.concatenate([getattr(points, name), data[name]]))
    for name in points.history:
        points.history[name] = np.concatenate([points.history[name], data["history"][name]])
    for name, i in data["markers"].items():
        markers.set_host(name, start + i)
    return np.concatenate([cells, tracker.locate(data["x"])])
