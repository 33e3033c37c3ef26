"""Mast's planar sand column collapse (2013, §7.2) over aspect ratios: the power laws.

Runs ``demos/sand_column.py --law LAW --aspect A --json --no-output`` once per
aspect ratio and law, one process at a time, reads each JSON summary, and fits
Mast's power laws (his Eq. 7.10) by least squares in log–log: the run-out
L_f = A a^B separately for a ≤ 1.5 ("short") and a ≥ 1.5 ("tall"), and the
height H_f = C a^D for a ≥ 1. A branch with two runs is fitted exactly (no
residual: it says nothing about scatter). Each run is compared with Mast's lower
and upper bounds (Tables 7.4 and 7.6, read from the demo's ``RUNOUT_BOUNDS`` and
``HEIGHT_BOUNDS``) and each exponent with his best fit (Tables 7.3 and 7.5); the
target is an exponent within 0.1 of his. For a ≤ 1 Mast's height bound is
H_f = a itself, so a run counts as inside within ``--height-tol`` of it.

Mast's bounds are over ten friction-angle curves on a 5 mm grid with 16 points
per cell; the demo runs his baseline curve only (case 0), by default on a 1 cm
grid with 3 points per triangle.

Prints a table of the runs and one of the fits (numbers, not pass/fail), writes
all results as JSON (``--json-out``, rewritten after every run, so a sweep cut
short keeps what it has) and a log–log plot (``--plot``). ``--from-json`` reads
saved results (one or more files) and redraws without running anything.

Usage: ``./run python benchmarks/sand_column_sweep.py [--laws dp mn-dp]
[--aspects 0.5 1 2 4 8] [--h 0.01] [--points-per-cell 3] [--timeout 2400]
[--json-out sweep.json] [--plot sweep.png] [--from-json sweep.json ...]``.
Not a test.
"""

from __future__ import annotations

import argparse
import ast
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from fe_mpm.plotting import pyplot

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "demos" / "sand_column.py"
#: Mast's best fits (Tables 7.3 and 7.5) as (A, B): L_f short / tall, H_f for a ≳ 1.
BEST_FITS = {
    "dp": {"short": (0.791, 1.542), "tall": (1.007, 0.744), "height": (0.865, 0.425)},
    "mn-dp": {"short": (1.007, 1.516), "tall": (1.304, 0.753), "height": (0.825, 0.404)},
}
#: The fitted branches: (name, quantity, smallest a, largest a).
BRANCHES = (
    ("short", "L_f", 0.0, 1.5),
    ("tall", "L_f", 1.5, math.inf),
    ("height", "H_f", 1.0, math.inf),
)
TARGET = 0.1  # largest exponent difference from Mast's best fit counted as agreement
FLOOR = 0.05  # the plot draws smaller values (a column that did not collapse) at this floor


def demo_bounds() -> tuple[dict, dict, float]:
    """The demo's bounds, read from its source unexecuted.

    ``RUNOUT_BOUNDS`` and ``HEIGHT_BOUNDS`` (Mast's Tables 7.4, 7.6), and
    ``HEIGHT_TOLERANCE`` (on H_f = a for a ≤ 1).
    """
    found = {}
    names = ("RUNOUT_BOUNDS", "HEIGHT_BOUNDS", "HEIGHT_TOLERANCE")
    for node in ast.parse(DEMO.read_text()).body:
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name):
            if node.targets[0].id in names:
                found[node.targets[0].id] = ast.literal_eval(node.value)
    return tuple(found[name] for name in names)


RUNOUT_BOUNDS, HEIGHT_BOUNDS, HEIGHT_TOLERANCE = demo_bounds()


def power(coefficients: tuple[float, float], a: float | np.ndarray) -> float | np.ndarray:
    """A a^B."""
    return coefficients[0] * np.asarray(a, dtype=float) ** coefficients[1]


def mast_ranges(
    law: str, a: float, height_tol: float = HEIGHT_TOLERANCE
) -> tuple[list[float], list[float]]:
    """Mast's [lower, upper] bounds on L_f and H_f at aspect ratio ``a``, as the demo takes them.

    H_f = a within ``height_tol`` below a = 1, his fit's bounds above, and at a = 1,
    where both hold, the range that spans both.
    """
    runout = [float(power(c, a)) for c in RUNOUT_BOUNDS[law]["short" if a <= 1.5 else "tall"]]
    short = [a * (1.0 - height_tol), a * (1.0 + height_tol)]
    tall = [float(power(c, a)) for c in HEIGHT_BOUNDS[law]]
    if math.isclose(a, 1.0):
        return runout, [min(short[0], tall[0]), max(short[1], tall[1])]
    return runout, short if a < 1.0 else tall


def run_demo(law: str, a: float, h: float | None, per_cell: int, timeout: float | None) -> dict:
    """One collapse in a subprocess: the demo's JSON summary, with the sweep's own wall time."""
    cmd = [sys.executable, str(DEMO), "--law", law, "--aspect", f"{a:g}", "--json", "--no-output"]
    cmd += ["--points-per-cell", str(per_cell)] + (["--h", f"{h:g}"] if h else [])
    t0 = time.perf_counter()
    try:
        out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        wall = time.perf_counter() - t0
        return {"law": law, "aspect": a, "status": "timed out", "sweep_wall_s": wall}
    wall = time.perf_counter() - t0
    lines = [s for s in out.stdout.splitlines() if s.startswith("{")]
    if not lines:
        tail = (out.stderr or out.stdout).strip().splitlines()[-3:]
        return {
            "law": law,
            "aspect": a,
            "status": "failed: " + " | ".join(tail),
            "sweep_wall_s": wall,
        }
    result = json.loads(lines[-1])
    result.update(status="ran", demo_exit=out.returncode, sweep_wall_s=wall)
    return result


def power_fit(a: np.ndarray, y: np.ndarray) -> dict | None:
    """Least-squares fit of log y = log A + B log a; None with fewer than two usable runs."""
    keep = y > 0
    if keep.sum() < 2 or np.unique(a[keep]).size < 2:
        return None
    x, z = np.log(a[keep]), np.log(y[keep])
    B, logA = np.polyfit(x, z, 1)
    residual = z - (logA + B * x)
    return {
        "A": float(np.exp(logA)),
        "B": float(B),
        "runs": int(keep.sum()),
        "exact": bool(keep.sum() == 2),
        "rms_log_residual": float(np.sqrt(np.mean(residual**2))),
        "aspects": [float(v) for v in a[keep]],
    }


def fits(runs: list[dict], law: str) -> dict:
    """Each branch's fit for one law, with Mast's best fit and bound exponents beside it."""
    done = [r for r in runs if r["law"] == law and r.get("status") == "ran"]
    result = {}
    for name, quantity, lo, hi in BRANCHES:
        branch = [r for r in done if lo <= r["aspect"] <= hi]
        a = np.array([r["aspect"] for r in branch])
        fit = power_fit(a, np.array([r[quantity] for r in branch]))
        bounds = HEIGHT_BOUNDS[law] if name == "height" else RUNOUT_BOUNDS[law][name]
        mast = BEST_FITS[law][name]
        entry = {"quantity": quantity, "fit": fit, "mast_best": mast, "mast_bounds": bounds}
        if fit is not None:
            entry["exponent_difference"] = fit["B"] - mast[1]
            entry["within_target"] = abs(fit["B"] - mast[1]) <= TARGET
        result[name] = entry
    return result


def compare(run: dict, height_tol: float) -> dict:
    """Mast's bounds at the run's aspect ratio, and whether L_f and H_f lie inside."""
    runout, height = mast_ranges(run["law"], run["aspect"], height_tol)
    return {
        "mast_L_f": runout,
        "mast_H_f": height,
        "L_f_inside": runout[0] <= run["L_f"] <= runout[1],
        "H_f_inside": height[0] <= run["H_f"] <= height[1],
    }


def print_runs(runs: list[dict]) -> None:
    """The table of runs: L_f and H_f against Mast's bounds, and the cost."""
    print(
        f"{'law':<6}{'a':>5}{'L_f':>8}  {'Mast L_f':<16}{'in':<4}{'H_f':>7}  {'Mast H_f':<16}"
        f"{'in':<4}{'t_f':>6}{'points':>8}{'steps':>7}{'Newton':>8}{'wall s':>9}"
    )
    for r in runs:
        head = f"{r['law']:<6}{r['aspect']:>5g}"
        if r.get("status") != "ran":
            print(f"{head}  {r.get('status')} after {r.get('sweep_wall_s', math.nan):.0f} s")
            continue
        lo_L, hi_L = r["mast_L_f"]
        lo_H, hi_H = r["mast_H_f"]
        in_L, in_H = ("yes" if r[k] else "NO" for k in ("L_f_inside", "H_f_inside"))
        print(
            f"{head}{r['L_f']:8.3f}  [{lo_L:5.3f}, {hi_L:5.3f}]  {in_L:<4}"
            f"{r['H_f']:7.3f}  [{lo_H:5.3f}, {hi_H:5.3f}]  {in_H:<4}"
            f"{r['t_f']:6.3f}{r['points']:8d}{r['steps']:7d}{r['newton_iterations_mean']:8.2f}"
            f"{r['sweep_wall_s']:9.1f}"
        )


def print_fits(all_fits: dict) -> None:
    """The table of fits: exponents against Mast's best fit and bounds."""
    print(
        f"\n{'law':<6}{'fit':<22}{'runs':>5}{'A':>8}{'B':>8}   {'Mast best':<15}"
        f"{'Mast bounds B':<15}{'B - Mast':>9}"
    )
    for law, branches in all_fits.items():
        for name, e in branches.items():
            lo, hi = e["mast_bounds"]
            label = f"{e['quantity']} {name} ({'a <= 1.5' if name == 'short' else 'a >= 1.5'})"
            label = "H_f (a >= 1)" if name == "height" else label
            mast = f"{e['mast_best'][0]:.3f} a^{e['mast_best'][1]:.3f}"
            bounds = f"{lo[1]:.3f}-{hi[1]:.3f}"
            fit = e["fit"]
            if fit is None:
                print(f"{law:<6}{label:<22}  fewer than two runs   {mast:<15}{bounds:<15}")
                continue
            note = (
                " (2 runs: exact)"
                if fit["exact"]
                else f" (rms log residual {fit['rms_log_residual']:.3f})"
            )
            print(
                f"{law:<6}{label:<22}{fit['runs']:>5}{fit['A']:8.3f}{fit['B']:8.3f}   {mast:<15}"
                f"{bounds:<15}{e['exponent_difference']:+9.3f}{note}"
            )


def plot(runs: list[dict], all_fits: dict, path: str) -> None:
    """L_f and H_f against a, log–log: the runs, the fits and Mast's bound lines."""
    plt = pyplot()
    if plt is None:
        return
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    colours = {"dp": "C0", "mn-dp": "C3"}
    a_all = np.array([r["aspect"] for r in runs] or [1.0])
    span = (min(0.25, a_all.min()), max(10.0, a_all.max()))
    ranges = {"short": (span[0], 1.5), "tall": (1.5, span[1]), "height": (1.0, span[1])}
    for law, branches in all_fits.items():
        c = colours.get(law, "C2")
        done = [r for r in runs if r["law"] == law and r.get("status") == "ran"]
        a = np.array([r["aspect"] for r in done])
        for ax, key in zip(axes, ("L_f", "H_f"), strict=True):
            y = np.array([r[key] for r in done])
            ax.loglog(a, np.maximum(y, FLOOR), "o", color=c, label=f"{law}: runs")
            for ai, yi in zip(a[y < FLOOR], y[y < FLOOR], strict=True):  # no collapse
                ax.annotate(
                    f"{law}, a = {ai:g}: {key} = {yi:.3f}",
                    (ai, FLOOR),
                    fontsize=7,
                    xytext=(4, 4 + 10 * (law != "dp")),
                    textcoords="offset points",
                )
        for name, e in branches.items():
            ax = axes[1] if name == "height" else axes[0]
            x = np.geomspace(*ranges[name], 50)
            for bound in e["mast_bounds"]:
                ax.loglog(x, power(bound, x), ":", color=c, lw=1.0)
            ax.loglog(x, power(e["mast_best"], x), "--", color=c, lw=0.8, alpha=0.6)
            if e["fit"] is not None:  # over the runs it fits
                f = e["fit"]
                x = np.geomspace(min(f["aspects"]), max(f["aspects"]), 20)
                y = power((f["A"], f["B"]), x)
                ax.loglog(x, np.where(y < FLOOR, np.nan, y), "-", color=c, lw=1.2)
        x = np.geomspace(span[0], 1.0, 20)
        axes[1].loglog(x, x, ":", color=c, lw=1.0)
    axes[0].plot([], [], "k-", label="least-squares fit")
    axes[0].plot([], [], "k--", lw=0.8, alpha=0.6, label="Mast's best fit (Tables 7.3, 7.5)")
    axes[0].plot([], [], "k:", label="Mast's bounds (Tables 7.4, 7.6)")
    xlabel = "aspect ratio $a = h_0/l_0$"
    axes[0].set(xlabel=xlabel, ylabel="$L_f = (l_f - l_0)/l_0$", title="run-out")
    axes[1].set(xlabel=xlabel, ylabel="$H_f = h_f/l_0$", title="height")
    axes[0].set_ylim(bottom=0.8 * FLOOR)
    grids = ", ".join(sorted({f"{r['h']:g}" for r in runs if "h" in r}))
    fig.suptitle(f"Sand column collapse, Mast's case-0 angles, h = {grids} m", fontsize=10)
    axes[0].legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"plot: {path}")


def load(paths: list[str]) -> list[dict]:
    """The runs saved in one or more ``--json-out`` files, later files replacing earlier runs."""
    runs: dict[tuple[str, float], dict] = {}
    for path in paths:
        for r in json.loads(Path(path).read_text())["runs"]:
            runs[(r["law"], r["aspect"])] = r
    return list(runs.values())


def summary(runs: list[dict], args: argparse.Namespace) -> dict:
    """Everything the sweep knows, as one JSON-ready dict (runs compared, fits refitted)."""
    for r in runs:
        if r.get("status") == "ran":
            r.update(compare(r, args.height_tol))
    laws = list(dict.fromkeys(r["law"] for r in runs))
    return {
        "demo": "demos/sand_column.py",
        "height_tolerance_a_le_1": args.height_tol,
        "exponent_target": TARGET,
        "runs": runs,
        "fits": {law: fits(runs, law) for law in laws},
    }


def main() -> None:
    """Run (or read) the sweep, print the tables, write the JSON and the plot."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--laws", nargs="+", choices=("dp", "mn-dp"), default=["dp"])
    p.add_argument("--aspects", type=float, nargs="+", default=[0.5, 1.0, 2.0, 4.0, 8.0])
    p.add_argument("--h", type=float, default=None, help="cell size (m), passed to the demo")
    p.add_argument("--points-per-cell", type=int, default=3, help="passed to the demo")
    p.add_argument("--timeout", type=float, default=None, help="stop a run after this many s")
    p.add_argument(
        "--height-tol",
        type=float,
        default=HEIGHT_TOLERANCE,
        help="relative, on H_f = a, a <= 1 (the demo's check)",
    )
    p.add_argument("--json-out", default=None, help="write all results here (JSON)")
    p.add_argument("--plot", default=None, help="write the log-log plot here (PNG)")
    p.add_argument("--from-json", nargs="+", default=None, help="redraw from saved results")
    args = p.parse_args()
    if args.from_json:
        runs = load(args.from_json)
    else:
        runs = []
        for law in args.laws:
            for a in args.aspects:
                print(f"running {law}, a = {a:g} ...", flush=True)
                runs.append(run_demo(law, a, args.h, args.points_per_cell, args.timeout))
                status = runs[-1]["status"]
                print(f"  {status}, {runs[-1]['sweep_wall_s']:.1f} s", flush=True)
                if args.json_out:
                    Path(args.json_out).write_text(json.dumps(summary(runs, args), indent=1))
    result = summary(runs, args)
    print_runs(result["runs"])
    print_fits(result["fits"])
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(result, indent=1) + "\n")
        print(f"results: {args.json_out}")
    if args.plot:
        plot(result["runs"], result["fits"], args.plot)


if __name__ == "__main__":
    main()
