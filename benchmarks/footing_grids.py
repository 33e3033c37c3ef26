"""Strip footing (thesis §6.2), u-p: the load–settlement curve on three grids.

Runs the footing to s/B = 2 in ``--steps`` steps on each cell size ``--h`` (near
the footing; 0.05 m is the thesis's grid, about 25 minutes), and prints the
window means of q/c_u over s/B ± 0.1 with the change from one grid to the next,
the ratio of successive changes, and the limit ``q_h − (q_2h − q_h)`` that first-
order convergence would give. Measured with 200 steps: the ratios are 1.7–3.1 at
s/B ≥ 1, where that estimate is a fair guess, and 0.3–1.5 at s/B ≤ 0.5, where the
grids are not yet in the asymptotic range and it means little. For scale it prints
Skempton's (1951) factor for a strip footing *embedded* to depth D,
``N_c = 5 (1 + 0.2 D/B) ≤ 7.5``: a design value for a backfilled footing, not
for one pushed into weightless soil that leaves an open trench.

Writes ``footing_grids.csv`` (every step of every grid; ``held`` is 1 for a step
retried with the points held in their last cells, ``short`` for one shorter than
nominal after a cut) and ``footing_grids.png``
into ``--output``; ``--replot CSV`` redraws both from a saved CSV without running.
Not a test.

Usage: ``./run python benchmarks/footing_grids.py [--h 0.2 0.1 0.05] [--steps 200]
[--output out_bench] [--replot out_bench/footing_grids.csv]``.
"""

import argparse
import csv
import time
from pathlib import Path

import numpy as np

import fe_mpm
from fe_mpm import scenes

#: Far-field cell size used with each near-field one (the demo's default for others).
H_FAR = {0.2: 0.5, 0.1: 0.4}
CENTRES = (0.25, 0.5, 1.0, 1.5, 1.9)


def skempton(depth_over_B: np.ndarray) -> np.ndarray:
    """Skempton's (1951) N_c of an embedded strip footing (his surface value is 5)."""
    return np.minimum(5.0 * (1.0 + 0.2 * np.asarray(depth_over_B)), 7.5)


def run_grid(h: float, steps: int, h_far: float | None = None, progress: bool = True) -> list[dict]:
    """Every step of the u-p footing to s/B = 2, or to where it stops (printed).

    ``h`` is the cell size near the footing; ``h_far`` the far one, by default
    from :data:`H_FAR`.
    """
    sim = scenes.strip_footing("up", h=h, h_far=h_far or H_FAR.get(h), settlement=2.0)
    t0 = time.perf_counter()
    try:
        sim.run(1.0, steps, progress=progress)
    except fe_mpm.ConvergenceError as err:
        print(
            f"h = {h}, {steps} steps: stopped at s/B = {2.0 * sim.t:.2f}: {str(err).split(';')[0]}"
        )
    wall = time.perf_counter() - t0
    rows = [
        {
            "h": h,
            "points": len(sim.points),
            "step": r.step,
            "s_over_B": 2.0 * r.t,
            "q_over_cu": scenes.footing_pressure(r) / 100.0,
            "newton": r.newton_iterations,
            "failed": r.failed_iterations,
            "held": int(r.held_points > 0),
            "short": int(r.dt < 0.999 / steps),
            "wall_s": wall,
        }
        for r in sim.history
    ]
    sim.close()
    return rows


def window_means(rows: list[dict], centres=CENTRES) -> list[float]:
    """Mean q/c_u of ``rows`` (one run) over s/B ± 0.1 around each centre (NaN past the end)."""
    s = np.array([r["s_over_B"] for r in rows])
    q = np.array([r["q_over_cu"] for r in rows])
    return [
        q[np.abs(s - c) <= 0.1 + 1e-9].mean() if s.size and s[-1] >= c + 0.1 - 1e-9 else np.nan
        for c in centres
    ]


def report(rows: list[dict]) -> None:
    """Print the window means per grid, the changes, and the first-order estimate."""
    grids = sorted({r["h"] for r in rows}, reverse=True)
    print("window means of q/c_u at s/B = " + ", ".join(map(str, CENTRES)))
    print(
        f"{'h':>6}{'points':>8}"
        + "".join(f"{c:>8}" for c in CENTRES)
        + f"{'Newton':>8}{'failed':>8}{'held':>6}{'wall s':>8}"
    )
    means = {}
    for h in grids:
        mine = [r for r in rows if r["h"] == h]
        means[h] = np.array(window_means(mine))
        print(
            f"{h:>6}{mine[0]['points']:>8}"
            + "".join(f"{m:>8.2f}" for m in means[h])
            + f"{np.mean([r['newton'] for r in mine]):>8.1f}"
            + f"{sum(r.get('failed', 0) for r in mine):>8d}"
            + f"{sum(r['held'] > 0 for r in mine):>6}{mine[0]['wall_s']:>8.0f}"
        )
    for coarse, fine in zip(grids, grids[1:]):
        change = 100 * (means[fine] / means[coarse] - 1)
        print(f"{coarse} -> {fine}: " + "".join(f"{c:>7.1f}%" for c in change))
    if len(grids) >= 3:
        a, b, c = (means[h] for h in grids[-3:])
        print("ratio of changes: " + "".join(f"{x:>8.2f}" for x in (a - b) / (b - c)))
        print("first-order limit:" + "".join(f"{x:>8.2f}" for x in 2 * c - b))
    print("Skempton embedded: " + "".join(f"{x:>8.2f}" for x in skempton(np.array(CENTRES))))


def plot(rows: list[dict], path: Path) -> None:
    """q/c_u against s/B for every grid, with 2 + π and Skempton's embedded factor."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for h in sorted({r["h"] for r in rows}, reverse=True):
        mine = [r for r in rows if r["h"] == h]
        ax.plot(
            [0] + [r["s_over_B"] for r in mine],
            [0] + [r["q_over_cu"] for r in mine],
            lw=1,
            label=f"fe-mpm u-p, h = {h} B ({mine[0]['points']} points)",
        )
    s = np.linspace(0, 2, 50)
    ax.plot(s, skempton(s), "k:", lw=1, label="Skempton (1951), embedded to D = s")
    ax.axhline(2 + np.pi, color="k", ls="--", lw=1, label="2 + π (small strain)")
    ax.set_xlabel("s / B")
    ax.set_ylabel("q / c_u")
    ax.set_ylim(0, None)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    """Run (or re-read) the grids, print the report, write the CSV and the plot."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--h", type=float, nargs="+", default=[0.2, 0.1, 0.05])
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--output", default="out_bench")
    p.add_argument("--replot", default=None, help="CSV of an earlier run: report and plot it")
    args = p.parse_args()
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    if args.replot:
        with open(args.replot) as f:
            rows = [
                {
                    k: float(v) if k in ("h", "s_over_B", "q_over_cu", "wall_s") else int(v)
                    for k, v in r.items()
                }
                for r in csv.DictReader(f)
            ]
    else:
        rows = [row for h in args.h for row in run_grid(h, args.steps)]
        with open(out / "footing_grids.csv", "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    report(rows)
    plot(rows, out / "footing_grids.png")
    print(f"wrote {out / 'footing_grids.csv'} and {out / 'footing_grids.png'}")


if __name__ == "__main__":
    main()
