"""Measures of solution quality that tests and users can assert on."""

from __future__ import annotations

import numpy as np

from fe_mpm.simulation import Simulation

#: Point pairs whose distances :func:`stress_oscillation` holds at once (about 16 MB).
PAIRS_PER_BLOCK = 2**21


def pressure_oscillation(sim: Simulation) -> float:
    """Mean jump of the nodal pressure between neighbouring nodes over its range.

    The range is the 5–95 % percentile spread. A smooth P1 field gives O(h)
    (here about 0.03–0.08 on Cook with n = 8–32), while a checkerboard gives O(1)
    (about 2/3 for the unstabilised P1/P1 form). Only occupied cells count.

    Args:
        sim: A simulation with a pressure field (mixed formulation), after a step.
    """
    if not sim.spec.pressure:
        raise ValueError(f"pressure_oscillation: formulation {sim.formulation!r} has no pressure")
    Q = sim.fields.Q[0]
    p = sim.fields.pressure_values()
    occupied = np.unique(sim.points.cell)
    cells = Q.dofmap.list[occupied]
    n = cells.shape[1]
    jumps = np.concatenate(
        [np.abs(p[cells[:, a]] - p[cells[:, b]]) for a in range(n) for b in range(a + 1, n)]
    )
    lo, hi = np.percentile(p[np.unique(cells)], [5, 95])
    return float(np.mean(jumps) / (hi - lo))


def stress_oscillation(x: np.ndarray, values: np.ndarray, neighbours: int = 8) -> float:
    """RMS deviation of a per-point field from the mean of each point's nearest neighbours.

    A field that varies smoothly over the points gives a small value (of the order
    of its gradient times the point spacing); point-to-point scatter, e.g. the
    locked stress of the u form at near incompressibility, gives a value of the
    order of the scatter. Same units as ``values``.

    Args:
        x: Point positions (n, g).
        values: One value per point (n,).
        neighbours: How many nearest points make the local mean.
    """
    n = x.shape[0]
    if n <= neighbours:
        raise ValueError(f"stress_oscillation: need more than {neighbours} points, got {n}")
    local_mean = np.empty(n)
    # The distances of a block of points to all points at a time: a whole n x n
    # matrix would take 8 n² bytes (80 GB for 10⁵ points).
    rows = max(1, PAIRS_PER_BLOCK // n)
    for start in range(0, n, rows):
        block = slice(start, min(start + rows, n))
        d2 = np.sum((x[block, None, :] - x[None, :, :]) ** 2, axis=2)
        d2[np.arange(d2.shape[0]), np.arange(block.start, block.stop)] = np.inf
        nearest = np.argpartition(d2, neighbours, axis=1)[:, :neighbours]
        local_mean[block] = values[nearest].mean(axis=1)
    return float(np.sqrt(np.mean((values - local_mean) ** 2)))


def contiguous_front(x: np.ndarray, gap: float) -> float:
    """Farthest x-coordinate (m) of the material that hangs together, from x = min.

    The points are sorted by x; the front is the last point before the first
    empty band wider than ``gap`` (m). Single points thrown ahead of a granular
    flow therefore do not count, as in an experiment's run-out.

    Args:
        x: Point positions (n, g), m.
        gap: Widest empty band (m) that still counts as the same deposit; about two
            cell sizes.
    """
    xs = np.sort(np.asarray(x)[:, 0])
    breaks = np.flatnonzero(np.diff(xs) > gap)
    return float(xs[breaks[0]] if breaks.size else xs[-1])
