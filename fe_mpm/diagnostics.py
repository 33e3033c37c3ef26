"""Measures of solution quality that tests and users can assert on."""

from __future__ import annotations

import numpy as np

from fe_mpm.simulation import Simulation


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
