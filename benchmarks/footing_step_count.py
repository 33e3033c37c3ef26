"""Strip footing (thesis §6.2): how few load steps give the same curve to s/B = 2.

Runs u-p on one grid with each step count and prints, per run, the window means
of q/c_u over s/B ± 0.1 (single steps jitter as points cross cells), the Newton
iterations per step, the steps that were cut or retried with the points held in
their last cells, and the wall time. A run that stops says where.

Usage: ``./run python benchmarks/footing_step_count.py [--h 0.2] [--h-far 0.5]
[--steps 25 50 100 200]``. Not a test.
"""

import argparse
import time

import numpy as np

import fe_mpm
from fe_mpm import scenes

CENTRES = (0.5, 1.0, 1.5, 1.9)


def footing_curve(h: float, h_far: float | None, steps: int) -> dict:
    """Run to s/B = 2 in ``steps`` nominal steps; s/B, q/c_u and what the steps did."""
    sim = scenes.strip_footing("up", h=h, h_far=h_far, settlement=2.0)
    t0 = time.perf_counter()
    stopped = None
    try:
        sim.run(1.0, steps, progress=False)
    except fe_mpm.ConvergenceError as err:
        stopped = str(err).split(";")[0]
    reports = sim.history
    sim.close()
    return {
        "s": np.array([2.0 * r.t for r in reports]),  # B = 1 m
        "q": np.array([-r.reactions["footing"][1] / 0.5 / 100.0 for r in reports]),
        "newton": np.array([r.newton_iterations for r in reports]),
        "cut": sum(r.dt < 0.999 / steps for r in reports),
        "held": sum(r.held_points > 0 for r in reports),
        "wall": time.perf_counter() - t0,
        "stopped": stopped,
    }


def main() -> None:
    """Print one row per step count."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--h", type=float, default=0.2)
    p.add_argument("--h-far", type=float, default=0.5)
    p.add_argument("--steps", type=int, nargs="+", default=[25, 50, 100, 200])
    args = p.parse_args()
    print(f"h = {args.h}, h_far = {args.h_far}: window means of q/c_u at s/B = "
          + ", ".join(f"{c}" for c in CENTRES))
    print(f"{'steps':>6}" + "".join(f"{c:>8}" for c in CENTRES)
          + f"{'Newton':>8}{'max':>5}{'cut':>5}{'held':>5}{'wall s':>8}")
    for n in args.steps:
        r = footing_curve(args.h, args.h_far, n)
        means = [r["q"][np.abs(r["s"] - c) <= 0.1 + 1e-9].mean()
                 if r["s"].size and r["s"][-1] >= c + 0.1 - 1e-9 else np.nan for c in CENTRES]
        print(f"{n:>6}" + "".join(f"{m:>8.2f}" for m in means)
              + f"{r['newton'].mean():>8.1f}{r['newton'].max():>5}{r['cut']:>5}{r['held']:>5}"
              + f"{r['wall']:>8.0f}")
        if r["stopped"]:
            reached = r["s"][-1] if r["s"].size else 0.0
            print(f"        stopped at s/B = {reached:.2f}: {r['stopped']}")


if __name__ == "__main__":
    main()
