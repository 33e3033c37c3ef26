"""AMPLE's convergence test: an elastic column under self-weight over many load steps.

The column of ``demos/elastic_column.py`` (L = 50 m, E = 400 kPa, ρ = 80 kg/m³,
g = 10 m/s², ν = 0, rollers on the sides, 10 % strain at the base), loaded in
quasi-static steps, so the points cross cells as the column settles. The error is
AMPLE's, Σ_p |σ_yy,p + ρ₀ g (L − Y_p)| V_p / (ρ₀ g L Σ_p V_p), against the exact
equilibrium stress. Standard MPM stalls as the grid is refined (the cell-crossing
error); with ``point_domains=True`` it should fall linearly, as AMPLE reports for
GIMP and CPDI (Coombs et al. 2020).

``--dim 3`` runs the column as a 1 m × 1 m prism of tetrahedra, gravity along z.

Usage: ``./run python benchmarks/column_convergence.py [--steps 20] [--dim 3]
[--plot column.png]``.
Prints the error and the observed rate per grid; with matplotlib, plots both curves.
Not a test.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from fe_mpm import scenes
from fe_mpm.plotting import pyplot


def stress_error(
    ny: int, steps: int, domains: bool, per_cell: int, dim: int = 2
) -> tuple[float, float]:
    """AMPLE's stress error of the column on ``ny`` cells over the height, and the wall time."""
    t0 = time.perf_counter()
    sim = scenes.elastic_column(ny, per_cell, dim=dim, point_domains=domains)
    sim.run(1.0, steps, progress=False)
    return scenes.column_stress_error(sim), time.perf_counter() - t0


def main() -> None:
    """Print the table and draw the plot."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--per-cell", type=int, default=1)
    p.add_argument("--ny", type=int, nargs="+", default=[8, 16, 32, 64])
    p.add_argument("--plot", default=None, help="write the error-against-h plot here (PNG)")
    p.add_argument("--dim", type=int, choices=(2, 3), default=2, help="3: on tetrahedra")
    args = p.parse_args()
    h = [scenes.COLUMN["L"] / ny for ny in args.ny]
    curves = {}
    for label, domains in (("standard MPM", False), ("point domains", True)):
        errors = []
        for ny in args.ny:
            error, wall = stress_error(ny, args.steps, domains, args.per_cell, args.dim)
            errors.append(error)
            rate = "" if len(errors) == 1 else f"  rate {np.log2(errors[-2] / errors[-1]):5.2f}"
            print(f"{label:<14} ny = {ny:3d}: error {error:.3e}{rate}  ({wall:.1f} s)", flush=True)
        curves[label] = errors
    plt = pyplot() if args.plot else None
    if plt is not None:
        fig, ax = plt.subplots(figsize=(5, 4))
        for label, errors in curves.items():
            ax.loglog(h, errors, "o-", label=label)
        ax.loglog(h, [curves["point domains"][0] * x / h[0] for x in h], "k:", label="slope 1")
        title = f"{args.steps} load steps" + (", tetrahedra" if args.dim == 3 else "")
        ax.set(xlabel="cell size h (m)", ylabel="stress error", title=title)
        ax.xaxis.set_minor_formatter(plt.NullFormatter())
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        print(f"plot: {args.plot}")


if __name__ == "__main__":
    main()
