"""Strip footing: the step-to-step jitter of q/c_u as points cross cells.

The u-p footing of ``benchmarks/footing_step_count.py`` (h = 0.2 B near the footing,
0.5 B far from it, 100 steps of 20 mm to s/B = 2), with standard MPM, with point
domains without the ghost penalty, and with point domains and their default
ghost penalty; with the footing's default two base points per cell width and with
more (``strip_footing(base_points_per_cell=...)``), and without the footing's body
points (``footing_thickness=0``), and with a softer footing penalty (50 E/h instead of
the default 1e3 E/h, "soft"). The jitter is the mean
absolute second difference of q/c_u over the steps (a smooth curve has almost
none); the window means of q/c_u over s/B ± 0.1 show what the curve does.

Usage: ``./run python benchmarks/footing_jitter.py [--h 0.2] [--steps 100]``. Not a test.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from footing_grids import window_means

import fe_mpm
from fe_mpm import scenes

CENTRES = (0.5, 1.0, 1.5, 1.9)
#: The footing's penalty points without its body points, and a twentieth of the
#: default penalty (50 E/h instead of 1e3 E/h, with E/c_u = 100: "soft"): still
#: 50 times the stiffness of a cell, its gap is 2 % of a 20 mm step. ``h`` is set
#: in :func:`run`.
SOFT = {"footing_thickness": 0.0, "penalty_factor": 50.0}
CASES = [
    ("standard MPM", {}),
    ("standard, 8 base/cell", {"base_points_per_cell": 8}),
    ("standard, 32 base/cell", {"base_points_per_cell": 32}),
    ("domains, γ = 0", {"point_domains": True, "ghost_penalty": 0.0}),
    ("domains (γ = 0.1)", {"point_domains": True}),
    ("domains, 32 base/cell", {"point_domains": True, "base_points_per_cell": 32}),
    (
        "domains, 32, no body",
        {"point_domains": True, "base_points_per_cell": 32, "footing_thickness": 0.0},
    ),
    ("standard, 32, no body, soft", {**SOFT, "base_points_per_cell": 32}),
    ("domains, 32, no body, soft", {**SOFT, "base_points_per_cell": 32, "point_domains": True}),
]


def run(h: float, h_far: float, steps: int, options: dict) -> tuple[list[dict], float]:
    """Every step's s/B and q/c_u, and the wall time."""
    options = dict(options)
    if "penalty_factor" in options:  # penalty = factor E / h, E = strip_footing's 1e4 Pa
        options["penalty"] = options.pop("penalty_factor") * 1.0e4 / h
    sim = scenes.strip_footing("up", h=h, h_far=h_far, settlement=2.0, **options)
    t0 = time.perf_counter()
    try:
        sim.run(1.0, steps, progress=False)
    except fe_mpm.ConvergenceError as err:
        print(f"  stopped at s/B = {2.0 * sim.t:.2f}: {str(err).split(';')[0]}")
    rows = [
        {"s_over_B": 2.0 * r.t, "q_over_cu": scenes.footing_pressure(r) / 100.0}
        for r in sim.history
    ]
    wall = time.perf_counter() - t0
    if sim.domains is not None:
        print(f"  {sim.domains.flips} domains flipped, {sim.domains.resets} redrawn")
    sim.close()
    return rows, wall


def main() -> None:
    """Print one row per case."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--h", type=float, default=0.2)
    p.add_argument("--h-far", type=float, default=0.5)
    p.add_argument("--steps", type=int, default=100)
    args = p.parse_args()
    print(f"h = {args.h}, h_far = {args.h_far}, {args.steps} steps to s/B = 2")
    print(f"{'case':<30}{'jitter':>8}" + "".join(f"{c:>8}" for c in CENTRES) + f"{'wall s':>8}")
    for label, options in CASES:
        rows, wall = run(args.h, args.h_far, args.steps, options)
        q = np.array([r["q_over_cu"] for r in rows])
        jitter = np.abs(np.diff(q, 2)).mean()
        means = "".join(f"{m:>8.2f}" for m in window_means(rows, CENTRES))
        print(f"{label:<30}{jitter:>8.3f}{means}{wall:>8.0f}", flush=True)


if __name__ == "__main__":
    main()
