"""Cook's membrane: every formulation, tip displacement, Newton iterations, wall time.

For ν = 0.33 and 0.499 and n = 2…64 (128 for P1/P1), one load step:
U, UP-nostab and UP+PPP with one point per triangle (the thesis set-up), and
Taylor–Hood P2/P1 with 3 points per triangle. Wall time is the median of
``--repeat`` in-process runs after JIT (mesh, seeding, set-up, solve).

The error is measured against a reference extrapolated from our own finest
P1/P1+PPP and P2/P1 runs (geometric Richardson on the last three of each;
both agree to 1e-4): the finite-strain answer, which lies about 0.5 % below the
small-strain FEM value of shared/notes/benchmark_refs.md at ν = 0.499.

Writes ``cook_formulations.csv`` and ``cook_formulations.png`` (error against
time, log-log, one curve per method) into ``--output``. Not a test.

Usage: ``./run python benchmarks/cook_formulations.py [--repeat 3] [--output out_bench]``.
"""

import argparse
import csv
import statistics
import time
from pathlib import Path

import numpy as np

from fe_mpm import scenes
from fe_mpm.references import cook_reference

METHODS = [  # (label, formulation, points per cell, mesh sizes)
    ("U", "u", 1, (2, 4, 8, 16, 32, 64)),
    ("UP no stab", "up-nostab", 1, (2, 4, 8, 16, 32, 64)),
    ("UP+PPP", "up", 1, (2, 4, 8, 16, 32, 64, 128)),
    ("P2/P1", "up-p2p1", 3, (2, 4, 8, 16, 32, 64)),
]


def run(n: int, nu: float, formulation: str, per_cell: int) -> tuple[float, int]:
    """One Cook solve; returns (u_A,y, Newton iterations)."""
    sim = scenes.cook_membrane(n, nu, formulation, per_cell=per_cell)
    (report,) = sim.run(progress=False)
    sim.close()
    return scenes.tip_deflection(sim), report.newton_iterations


def richardson(values: list[float]) -> float:
    """Limit of a geometrically converging sequence from its last three terms."""
    a, b, c = values[-3:]
    ratio = (c - b) / (b - a)
    return c + (c - b) * ratio / (1 - ratio)


def main() -> None:
    """Run the sweep, print the table, write the CSV and the plot."""
    p = argparse.ArgumentParser()
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--output", type=Path, default=Path("out_bench"))
    args = p.parse_args()
    args.output.mkdir(parents=True, exist_ok=True)
    rows = []
    for nu in (0.33, 0.499):
        results = {}
        for label, formulation, per_cell, sizes in METHODS:
            for n in sizes:
                run(n, nu, formulation, per_cell)  # JIT and caches
                times, out = [], None
                for _ in range(args.repeat):
                    t0 = time.perf_counter()
                    out = run(n, nu, formulation, per_cell)
                    times.append(time.perf_counter() - t0)
                results[label, n] = (*out, statistics.median(times))
        limits = [richardson([results[m, n][0] for n in METHODS[i][3]]) for i, m in
                  ((2, "UP+PPP"), (3, "P2/P1"))]
        reference = float(np.mean(limits))
        print(f"\nν = {nu}: reference u_A,y = {reference:.5f} "
              f"(extrapolated UP+PPP {limits[0]:.5f}, P2/P1 {limits[1]:.5f})")
        print(f"{'method':<11}{'n':>5}{'points':>8}{'u_A,y':>10}{'error %':>9}{'Newton':>7}"
              f"{'time s':>8}  published")
        for label, formulation, per_cell, sizes in METHODS:
            for n in sizes:
                tip, its, wall = results[label, n]
                err = abs(tip / reference - 1)
                ref = cook_reference(formulation, nu, n) if per_cell == 1 else None
                pub = "" if ref is None else f"{ref[1]:.4f} ({ref[0]})"
                print(f"{label:<11}{n:>5}{per_cell * 2 * n * n:>8}{tip:>10.5f}{100 * err:>9.3f}"
                      f"{its:>7}{wall:>8.3f}  {pub}")
                rows.append({"nu": nu, "method": label, "n": n, "points": per_cell * 2 * n * n,
                             "u_A_y": tip, "error": err, "newton": its, "time_s": wall,
                             "reference": reference})
    with open(args.output / "cook_formulations.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    plot(rows, args.output / "cook_formulations.png")
    print(f"\nwrote {args.output}/cook_formulations.csv and .png")


def plot(rows: list[dict], path: Path) -> None:
    """Error against wall time, log-log, one curve per method and ν."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    for ax, nu in zip(axes, (0.33, 0.499)):
        for label, *_ in METHODS:
            mine = [r for r in rows if r["nu"] == nu and r["method"] == label]
            pts = [(r["time_s"], r["error"]) for r in mine]
            ax.loglog(*zip(*pts), "o-", label=label)
        ax.set_title(f"Cook's membrane, ν = {nu}")
        ax.set_xlabel("wall time after JIT (s)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("relative error of u_A,y")
    axes[1].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
