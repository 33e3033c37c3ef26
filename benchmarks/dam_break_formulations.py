"""The dam break in three formulations: u-p, Mast's anti-locking (NB-VA) and the u form.

Runs ``demos/dam_break.py --formulation F --aspect A --json --no-output`` for each
formulation and aspect (one process at a time), prints the errors of the surge
front and of the height against Martin & Moyce's film at their tabulated times,
with the run's steps, Newton iterations and wall time, and plots the front and
the height against the film (``--plot``). Mast (2013, §6.1.1) ran the dam break
with his volumetric averaging; the plain u form locks, which shows in the
column's height. Not a test: the demo checks each run against its bands.

Usage: ``./run python benchmarks/dam_break_formulations.py [--formulations up u-nbva u]
[--aspects 2 1] [--h 0.00875] [--plot docs/dam_break_formulations.png]``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from fe_mpm.plotting import pyplot

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "demos" / "dam_break.py"


#: The demo's check_passed in words (None: the run was not checked).
VERDICTS = {True: "passes", False: "fails", None: "not checked"}


def run(formulation: str, aspect: float, h: float) -> dict:
    """One dam break in a subprocess: the demo's JSON summary (its last line)."""
    cmd = [sys.executable, str(DEMO), "--formulation", formulation, "--aspect", f"{aspect:g}"]
    cmd += ["--h", f"{h:g}", "--json", "--no-output"]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    lines = done.stdout.strip().splitlines()
    try:
        return json.loads(lines[-1])
    except (IndexError, json.JSONDecodeError):
        sys.exit(f"{' '.join(cmd)} printed no summary:\n{done.stdout}{done.stderr}")


def span(errors: list | None) -> str:
    """The range of relative errors in per cent."""
    if not errors:
        return "none"
    return f"{100 * min(errors):+.1f} … {100 * max(errors):+.1f} %"


def main() -> None:
    """Run, print the table, plot."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--formulations", nargs="+", default=["up", "u-nbva", "u"])
    parser.add_argument("--aspects", nargs="+", type=float, default=[2.0, 1.0])
    parser.add_argument("--h", type=float, default=0.00875, help="cell size (m)")
    parser.add_argument("--plot", metavar="PNG", help="front and height against the film")
    args = parser.parse_args()
    runs = {}
    print("| formulation | h0/l0 | front | height | steps | Newton mean | wall (s) | check |")
    print("|---|---|---|---|---|---|---|---|")
    for aspect in args.aspects:
        for formulation in args.formulations:
            out = runs[formulation, aspect] = run(formulation, aspect, args.h)
            print(
                f"| {formulation} | {aspect:g} | {span(out['front_relative_error'])} | "
                f"{span(out['height_relative_error'])} | {out['steps']} | "
                f"{out['newton_iterations_mean']:.2f} | {out['wall_time_s']:.1f} | "
                f"{VERDICTS[out['check_passed']]} |",
                flush=True,
            )
    plt = pyplot() if args.plot else None
    if plt is None:
        return
    fig, axes = plt.subplots(2, len(args.aspects), figsize=(4.5 * len(args.aspects), 6.4))
    axes = axes.reshape(2, -1)
    styles = ("-", "--", ":", "-.")
    for column, aspect in enumerate(args.aspects):
        front_ax, height_ax = axes[:, column]
        for formulation, style in zip(args.formulations, styles * 3):
            out = runs[formulation, aspect]
            T, tau = out["T"], [x / aspect**0.5 for x in out["T"]]
            front_ax.plot(T, out["front_Z"], style, label=formulation)
            height_ax.plot(tau, out["height_H"], style, label=formulation)
        height_ax.set_xlim(0.0, 1.1 * tau[-1])
        reference = runs[args.formulations[0], aspect]
        if reference["reference_front"]:
            front_ax.plot(*reference["reference_front"], "ko", ms=3, label="Martin & Moyce")
            height_ax.plot(*reference["reference_height"], "ko", ms=3, label="Martin & Moyce")
        front_ax.set(title=f"h0 = {aspect:g} l0", xlabel="T = t √(n²g/a)", ylabel="front Z = x/a")
        height_ax.set(xlabel="τ = t √(g/a)", ylabel="height H = h/(n²a)")
        front_ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.plot, dpi=110)
    print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
