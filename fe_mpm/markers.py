"""Markers: points that move with the body but carry no volume or mass.

A marker follows its host, the material point nearest to it when it was added,
with the host's affine motion in every step: the grid increment of the host's
cell, extended linearly to the marker. Demos measure displacements this way
(Cook's point A), because a marker never reads an empty cell.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np

from fe_mpm import parallel
from fe_mpm.errors import PointsOutsideError

#: Distances within this relative margin of the nearest count as equally near.
TIE = 1e-12


class Markers:
    """Named markers, each a position (g,) in m and the index of its host point.

    Under MPI every rank knows every marker's position; the host lives on one rank
    (the others hold host −1), which moves the marker and shares its new position.

    Args:
        comm: The communicator of the grid (one rank by default).
    """

    def __init__(self, comm: MPI.Comm = MPI.COMM_SELF):
        self.comm = comm
        self._entries: dict[str, tuple[np.ndarray, int]] = {}

    @property
    def names(self) -> list[str]:
        """The markers' names, in the order they were added."""
        return list(self._entries)

    def add(self, name: str, x: np.ndarray, points_x: np.ndarray) -> float:
        """Add a marker at ``x`` (g,), hosted by the nearest of the points ``points_x`` (n, g).

        Returns the distance to its host (m), the same on every rank.
        """
        distance = np.linalg.norm(points_x - x, axis=1)
        nearest = parallel.smallest(self.comm, float(distance.min(initial=np.inf)))
        # Points as near as the nearest to round-off (a symmetric seeding has many): the
        # one at the lowest position, lexicographically, so that the host is the same
        # whatever the points' order and their ranks.
        tied = np.flatnonzero(distance <= nearest * (1 + TIE))
        host = int(tied[np.lexsort(points_x[tied].T[::-1])[0]]) if tied.size else -1
        if self.comm.size > 1:
            mine = None if host < 0 else tuple(points_x[host].tolist())
            offers = self.comm.allgather(mine)
            rank = min((p, r) for r, p in enumerate(offers) if p is not None)[1]
            host = host if rank == self.comm.rank else -1
        self._entries[name] = (x.copy(), host)  # a copy: the caller's array must not move
        return nearest

    def remove(self, name: str) -> None:
        """Forget the marker ``name``."""
        del self._entries[name]

    def position(self, name: str) -> np.ndarray:
        """Current position of the marker ``name``, a copy, shape (g,)."""
        return self._entries[name][0].copy()

    def positions(self) -> dict[str, np.ndarray]:
        """Every marker's position, name -> copy (g,)."""
        return {name: xm.copy() for name, (xm, _) in self._entries.items()}

    def move(self, points_x: np.ndarray, du: np.ndarray, dF: np.ndarray) -> None:
        """``x_m += Δu_p + (ΔF_p − I)(x_m − x_p)`` with p the host, before the points move.

        Args:
            points_x: The points' positions at the start of the step (n, g) in m.
            du: Their displacement increments (n, g) in m.
            dF: Their deformation gradient increments (n, g, g).
        """
        identity = np.eye(points_x.shape[1])
        for xm, host in self._entries.values():
            move = np.zeros_like(xm)
            if host >= 0:
                move = du[host] + (dF[host] - identity) @ (xm - points_x[host])
            xm += parallel.total(self.comm, move)

    def keep_hosts(self, keep: np.ndarray, moved_away: bool = False) -> None:
        """Renumber the hosts after the points where ``keep`` (n,) is False are removed.

        Args:
            keep: Which of this rank's points stay (n,).
            moved_away: The removed points went to another rank (migration), which
                takes over their markers; False: they left the grid.

        Raises:
            PointsOutsideError: A marker's host left the grid.
        """
        new_index = np.cumsum(keep) - 1
        for name, (xm, host) in self._entries.items():
            if host < 0:
                continue
            if not keep[host]:
                if not moved_away:
                    raise PointsOutsideError(f"the host point of marker {name!r} left the grid")
                self._entries[name] = (xm, -1)
            else:
                self._entries[name] = (xm, int(new_index[host]))

    def hosts(self) -> dict[str, int]:
        """The markers hosted by this rank's points, name -> the host's index."""
        return {name: host for name, (_, host) in self._entries.items() if host >= 0}

    def place(self, name: str, x: np.ndarray, host: int) -> None:
        """Put the marker ``name`` at ``x`` (g,), as a checkpoint had it.

        ``host`` is this rank's host point, or −1 where another rank hosts it.
        """
        self._entries[name] = (np.array(x, dtype=np.float64), int(host))

    def set_host(self, name: str, host: int) -> None:
        """Host the marker ``name`` by this rank's point ``host`` (it arrived here)."""
        xm, _ = self._entries[name]
        self._entries[name] = (xm, int(host))
