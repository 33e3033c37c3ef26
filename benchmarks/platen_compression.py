# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # A block squeezed to half its length between smooth platens: cell crossing with an exact answer
#
# A benchmark, not a test: it prints how far the platen's force lies from its closed
# form (`fe_mpm.scenes.platen_force_exact`) as the block is squeezed, with standard
# MPM and with point domains. The deformation is homogeneous, so every grid and every
# step count has the same exact answer, and whatever a run adds is the method's own
# error: mostly cell crossing, as the block widens through the empty cells beside it
# and shortens through the cells it leaves. The numbers are in `docs/cell_crossing.md`.
#
# **Scene** (`fe_mpm.scenes.platen_compression`): a quarter of a unit block (an eighth
# in 3D) on rollers, pushed by a smooth platen of penalty points to half its length in
# `--steps` equal steps; Neo-Hookean (E = 1000 Pa, ν = 0.3) in the u form, or perfectly
# plastic von Mises (σ_Y = 1 Pa) in u-p; `--n` cells per metre. Cases: `standard` (3
# points per triangle, 4 per tetrahedron), `dense` (standard with 12 and 24) and
# `domains` (`point_domains=True`, 3 and 4). Printed per case: the
# force's error at 25 % and 50 % shortening, the largest error of any step, steps
# taken (more than `--steps` where Newton cut some), Newton's iterations and the wall
# time, and the scatter of the points' own σ_xx about the exact (uniform) value where
# the run ended, rms over the points. A run that stops says where.
#
# Usage: `python benchmarks/platen_compression.py [--law neo-hookean j2] [--n 10 20 40]
# [--steps 20] [--dim 2] [--formulation up-p2p1] [--cases standard dense domains]
# [--plot docs/platen_compression.png]`; `--plot` draws the error against the
# shortening, one panel per law.

# +
import argparse
import time

import numpy as np

from fe_mpm import scenes
from fe_mpm.errors import ConvergenceError, PointsOutsideError
from fe_mpm.plotting import pyplot

FORMULATION = {"neo-hookean": "u", "j2": "up"}
# name, points per triangle, per tetrahedron (what fe_mpm.seed places), Simulation options
CASES = [
    ("standard", 3, 4, {}),
    ("dense", 12, 24, {}),  # standard MPM with more points per cell
    ("domains", 3, 4, {"point_domains": True}),
]


def parse_args(argv=None):
    """The command line."""
    p = argparse.ArgumentParser(description="A block squeezed between smooth platens")
    p.add_argument("--law", nargs="+", default=["neo-hookean", "j2"], choices=scenes.PLATEN_LAWS)
    p.add_argument("--n", type=int, nargs="+", default=[10, 20, 40], help="cells per metre")
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--dim", type=int, default=2, choices=[2, 3])
    names = [c[0] for c in CASES]
    p.add_argument("--cases", nargs="+", default=names, choices=names)
    p.add_argument(
        "--formulation", default=None, help="for every law (default: u for Neo-Hookean, up for J2)"
    )
    p.add_argument("--plot", default=None, help="PNG of the error against the shortening")
    return p.parse_args(argv)


def squeeze(
    law: str, formulation: str, n: int, steps: int, dim: int, per_cell: int, options: dict
) -> dict:
    """One run: the force's error at every accepted step, and what it cost."""
    sim = scenes.platen_compression(
        n, per_cell, law=law, dim=dim, formulation=formulation, **options
    )
    started, stopped = time.perf_counter(), None
    try:
        sim.run(1.0, steps, progress=False)
    except (ConvergenceError, PointsOutsideError) as failure:
        stopped = str(failure).split(";")[0]
    wall = time.perf_counter() - started
    # The points' own stresses, where the run ended: exactly uniform in the block.
    scatter = np.nan
    if sim.t > 0.0:
        exact = scenes.platen_stress_exact(law, 1.0 - 0.5 * sim.t, dim, formulation)
        scatter = np.sqrt(np.mean((sim.points.stress[:, 0, 0] / exact - 1.0) ** 2))
    shortening = np.array([0.5 * r.t for r in sim.history])
    error = np.array(
        [
            scenes.platen_force(r) / scenes.platen_force_exact(law, 1.0 - s, dim, formulation) - 1.0
            for r, s in zip(sim.history, shortening, strict=True)
        ]
    )
    return {
        "shortening": shortening,
        "error": error,
        "steps": len(sim.history),
        "newton": sim.newton_iterations_total,
        "wall": wall,
        "stopped": stopped,
        "scatter": scatter,
    }


def at(run: dict, shortening: float) -> str:
    """The error at the step nearest ``shortening``, in per cent, or '—' if not reached."""
    s = run["shortening"]
    if s.size == 0 or s[-1] < shortening - 1e-9:
        return "—"
    return f"{100 * run['error'][np.argmin(np.abs(s - shortening))]:+.2f} %"


def main(argv=None) -> None:
    """Run every case, print the table, and draw the plot if asked."""
    args = parse_args(argv)
    cases = [c for c in CASES if c[0] in args.cases]
    runs = {}
    print("| law | n | case | 25 % | 50 % | largest | σ_xx scatter | steps | Newton | wall |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for law in args.law:
        formulation = args.formulation or FORMULATION[law]
        for n in args.n:
            for name, per_triangle, per_tetrahedron, options in cases:
                per_cell = per_triangle if args.dim == 2 else per_tetrahedron
                run = squeeze(law, formulation, n, args.steps, args.dim, per_cell, options)
                name = f"standard, {per_cell} points" if name == "dense" else name
                runs[law, n, name] = run
                largest = f"{100 * np.max(np.abs(run['error'])):.2f} %" if run["steps"] else "—"
                print(
                    f"| {law} ({formulation}) | {n} | {name} | {at(run, 0.25)} | "
                    f"{at(run, 0.5)} | {largest} | {100 * run['scatter']:.1f} % | "
                    f"{run['steps']} | {run['newton']} | "
                    f"{run['wall']:.1f} s |" + (f" {run['stopped']}" if run["stopped"] else "")
                )
    plt = pyplot() if args.plot else None
    if args.plot and plt is None:
        print("no plot: matplotlib is not installed")
    elif args.plot:
        fig, axes = plt.subplots(1, len(args.law), figsize=(5.5 * len(args.law), 4), squeeze=False)
        for ax, law in zip(axes[0], args.law, strict=True):
            for (which, n, name), run in runs.items():
                if which == law:
                    style = "-" if name == "domains" else "--" if name == "standard" else ":"
                    ax.plot(run["shortening"], 100 * run["error"], style, label=f"{name}, n = {n}")
            ax.axhline(0.0, color="k", lw=0.5)
            ax.set(
                xlabel="shortening (1 − λ)",
                ylabel="platen force error (%)",
                title=f"{law} ({args.formulation or FORMULATION[law]}), {args.steps} steps",
            )
            ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
# -
