"""What empty grid cells cost: the same body in grids 1x, 2x and 4x its size.

Only occupied cells are assembled, so assembly time should not grow with the
empty part of the grid. The pinned dofs of empty cells are trivial rows: the
default solver (PCREDISTRIBUTE around MUMPS) removes them before factorising,
plain MUMPS LU factorises them along with the rest. Prints medians of
``--repeat`` static steps (after JIT) for a gravity-loaded block on a fixed base,
for both solvers.

Usage: ``./run python benchmarks/empty_cells.py [--n 64] [--repeat 5]``. Not a test.
"""

import argparse
import statistics
import time

import numpy as np

import fe_mpm
from fe_mpm.meshes import cell_centroids, rectangle_mesh

#: The solvers compared: fe-mpm's default, and MUMPS on the whole system.
SOLVERS = {
    "default (redistribute)": None,
    "plain LU": {"pc_type": "lu", "pc_factor_mat_solver_type": "mumps"},
}


def one_step(n: int, factor: int, options: dict | None = None) -> dict:
    """One static step of an n x n block in a grid ``factor`` times as wide."""
    grid = rectangle_mesh((0.0, 0.0), (float(factor), 1.0), (factor * n, n))
    centroids = cell_centroids(grid)
    points = fe_mpm.seed(grid, cells=np.flatnonzero(centroids[:, 0] < 1.0), density=1000.0)
    sim = fe_mpm.Simulation(
        grid,
        points,
        fe_mpm.NeoHookean(1e6, 0.3, 1000.0),
        petsc_options=options,
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))],
        body_force=(0.0, -9.81),
    )
    t0 = time.perf_counter()
    sim.step(1.0)
    total = time.perf_counter() - t0
    sim.close()
    tm = sim.timings
    return {
        "total": total,
        "assembly": tm["assembly"],
        "solve": tm["newton"] - tm["assembly"],
        "cells": sim.tracker.num_cells,
        "occupied": sim.history[-1].occupied_cells,
    }


def main() -> None:
    """Print the table."""
    p = argparse.ArgumentParser()
    p.add_argument("--n", type=int, default=64)
    p.add_argument("--repeat", type=int, default=5)
    args = p.parse_args()
    print(f"Block of {2 * args.n**2} points; grid 1x, 2x, 4x as wide (medians of {args.repeat})")
    for name, options in SOLVERS.items():
        print(f"\n{name}")
        print(
            f"{'grid':>5}{'cells':>8}{'occupied':>10}{'assembly s':>12}{'solve s':>9}{'step s':>8}"
        )
        for factor in (1, 2, 4):
            one_step(args.n, factor, options)  # JIT
            runs = [one_step(args.n, factor, options) for _ in range(args.repeat)]
            med = {k: statistics.median(r[k] for r in runs) for k in ("assembly", "solve", "total")}
            print(
                f"{factor:>4}x{runs[0]['cells']:>8}{runs[0]['occupied']:>10}"
                f"{med['assembly']:>12.4f}{med['solve']:>9.4f}{med['total']:>8.4f}"
            )


if __name__ == "__main__":
    main()
