"""Time per step against the number of material points, 2D, from 1e4 to 1e6.

Scene: an elastic block (Neo-Hookean, E = 1 MPa, ν = 0.3, ρ = 1000 kg/m³) on a
fixed base between two rollers, filling the lower 5/6 of a structured grid, with three points per
triangle, loaded by its weight in ``--steps`` static steps (a ramp). Every step
tracks, packs, assembles, solves and convects every point. The first step
(JIT, creating the matrix and the solver) is left out; the table gives the
median of the others, split into the phases of ``Simulation.timings``.

The target is linear growth outside the linear solve: the ``µs/point`` column
of that part should stay flat. ``--solver`` compares the linear solvers of
:data:`fe_mpm.newton.LINEAR_SOLVERS`.

Writes ``scaling.csv`` and ``scaling.png`` (time per step against points,
log-log, per phase) into ``--output``. Not a test.

Usage: ``./run python benchmarks/scaling.py [--points 1e4 1e5 1e6] [--formulation u up]
[--solver direct iterative] [--output out_bench]``.
"""

import argparse
import csv
import math
from pathlib import Path

import numpy as np
from step_timing import PHASES, median_steps

import fe_mpm
from fe_mpm.meshes import cell_centroids, rectangle_mesh


def block(points_wanted: float, formulation: str, solver: str):
    """The gravity-loaded block with about ``points_wanted`` points, set up."""
    per_cell = 3
    n = max(2, round(math.sqrt(points_wanted / (2 * per_cell))))
    grid = rectangle_mesh((0.0, 0.0), (1.0, 1.2), (n, round(1.2 * n)))
    centroids = cell_centroids(grid)
    points = fe_mpm.seed(
        grid, per_cell, cells=np.flatnonzero(centroids[:, 1] < 1.0), density=1000.0
    )
    return fe_mpm.Simulation(
        grid,
        points,
        fe_mpm.NeoHookean(1.0e6, 0.3, 1000.0),
        formulation,
        dirichlet=[
            fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0)),
            fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0) | np.isclose(x[0], 1.0), component=0),
        ],
        body_force=(0.0, -9.81),
        body_force_scale=lambda t: t,
        linear_solver=solver,
    )


def time_steps(points_wanted: float, formulation: str, solver: str, steps: int) -> dict:
    """Median time per step after the first, and its split by phase."""
    sim = block(points_wanted, formulation, solver)
    timed = median_steps(sim, steps)
    sim.close()
    row = {
        "points": len(sim.points),
        "dofs": sim.w.x.array.size,
        "formulation": formulation,
        "solver": solver,
        **timed,
    }
    row["outside_solve_us_per_point"] = 1e6 * (row["step_s"] - row["solve"]) / row["points"]
    return row


def main() -> None:
    """Run the sizes, print the table, write the CSV and the plot."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--points", type=float, nargs="+", default=[1e4, 3e4, 1e5, 3e5, 1e6])
    p.add_argument("--formulation", nargs="+", default=["u", "up"])
    p.add_argument("--solver", nargs="+", default=["direct"])
    p.add_argument("--steps", type=int, default=4, help="steps per run (the first is not timed)")
    p.add_argument("--output", type=Path, default=Path("out_bench"))
    p.add_argument(
        "--replot",
        type=Path,
        default=None,
        metavar="CSV",
        help="only redraw the plot of an earlier run's CSV",
    )
    args = p.parse_args()
    if args.replot is not None:
        with open(args.replot) as f:
            rows = [
                {k: v if k in ("formulation", "solver") else float(v) for k, v in r.items()}
                for r in csv.DictReader(f)
            ]
        plot(rows, args.replot.with_suffix(".png"))
        return
    args.output.mkdir(parents=True, exist_ok=True)
    rows = []
    print(
        f"{'form':<5}{'solver':<10}{'points':>9}{'dofs':>9}{'Newton':>7}{'step s':>8}  "
        + "".join(f"{ph:>11}" for ph in PHASES)
        + "  µs/point outside the solve"
    )
    for formulation in args.formulation:
        for solver in args.solver:
            for n in args.points:
                r = time_steps(n, formulation, solver, args.steps)
                rows.append(r)
                print(
                    f"{formulation:<5}{solver:<10}{r['points']:>9}{r['dofs']:>9}"
                    f"{r['newton']:>7g}{r['step_s']:>8.3f}  "
                    + "".join(f"{r[ph]:>11.3f}" for ph in PHASES)
                    + f"  {r['outside_solve_us_per_point']:.2f}",
                    flush=True,
                )
    with open(args.output / "scaling.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    plot(rows, args.output / "scaling.png")
    print(f"wrote {args.output}/scaling.csv and scaling.png")


def plot(rows: list[dict], path: Path) -> None:
    """Time per step and its linear-solve and other parts against points, log-log."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = sorted({(r["formulation"], r["solver"]) for r in rows})
    columns = min(2, len(keys))
    rows_ = -(-len(keys) // columns)
    fig, axes = plt.subplots(
        rows_, columns, figsize=(5.5 * columns, 4 * rows_), squeeze=False, sharex=True, sharey=True
    )
    for ax, (formulation, solver) in zip(axes.flat, keys):
        mine = sorted(
            (r for r in rows if (r["formulation"], r["solver"]) == (formulation, solver)),
            key=lambda r: r["points"],
        )
        n = np.array([r["points"] for r in mine], dtype=float)
        ax.loglog(n, [r["step_s"] for r in mine], "ko-", label="whole step")
        ax.loglog(n, [r["solve"] for r in mine], "s--", label="linear solve")
        ax.loglog(n, [r["step_s"] - r["solve"] for r in mine], "^--", label="all but the solve")
        outside = mine[0]["step_s"] - mine[0]["solve"]
        ax.loglog(n, n * outside / n[0], ":", color="grey", label="linear growth")
        ax.set_title(f"{formulation}, {solver} solver")
        ax.set_xlabel("material points")
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("time per step (s)")
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
