"""Strip footing (thesis §6.2): how few load steps give the same curve to s/B = 2.

Runs u-p on one grid with each step count and prints, per run, the window means
of q/c_u over s/B ± 0.1 (single steps jitter as points cross cells), the Newton
iterations per step, how many steps were shorter than nominal (a cut step is
taken in two or more) or retried with the points held in their last cells, and
the wall time. A run that stops says where.

Usage: ``./run python benchmarks/footing_step_count.py [--h 0.2] [--h-far 0.5]
[--steps 25 50 100 200]``. Not a test.
"""

import argparse

import numpy as np
from footing_grids import run_grid, window_means

CENTRES = (0.5, 1.0, 1.5, 1.9)


def main() -> None:
    """Print one row per step count."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--h", type=float, default=0.2)
    p.add_argument("--h-far", type=float, default=0.5)
    p.add_argument("--steps", type=int, nargs="+", default=[25, 50, 100, 200])
    args = p.parse_args()
    print(
        f"h = {args.h}, h_far = {args.h_far}: window means of q/c_u at s/B = "
        + ", ".join(f"{c}" for c in CENTRES)
    )
    print(
        f"{'steps':>6}"
        + "".join(f"{c:>8}" for c in CENTRES)
        + f"{'Newton':>8}{'max':>5}{'short':>6}{'held':>5}{'wall s':>8}"
    )
    for n in args.steps:
        rows = run_grid(args.h, n, args.h_far, progress=False)
        newton = np.array([r["newton"] for r in rows])
        print(
            f"{n:>6}"
            + "".join(f"{m:>8.2f}" for m in window_means(rows, CENTRES))
            + f"{newton.mean():>8.1f}{newton.max():>5}{sum(r['short'] for r in rows):>6}"
            + f"{sum(r['held'] for r in rows):>5}{rows[0]['wall_s']:>8.0f}"
        )


if __name__ == "__main__":
    main()
