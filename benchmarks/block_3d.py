"""A 3D elastic block of about a million material points settling under its weight.

The scene of the MPI issue's strong-scaling table: a cube of tetrahedra
(``create_box``, 6 tetrahedra per hexahedron), every cell seeded with the same
number of points, Neo-Hookean, gravity ramped over the steps, the base clamped.
The answer is the top centre's settlement (a marker), near the ρ g H² / (2 E)
of a free column under its own weight (the clamped base holds it back a little); the
run prints it with the points, steps, Newton iterations, rank 0's time split and
the points' imbalance over the ranks. Run it under ``mpiexec -n N`` to time N
ranks (``benchmarks/parallel.py --scenes block3d`` does, side by side).

Usage: ``./run python benchmarks/block_3d.py [--n 35] [--per-cell 4] [--steps 2]
[--formulation u] [--linear-solver direct] [--json]``. Not a test: it prints numbers.
"""

import argparse
import json
import time

from mpi4py import MPI

import numpy as np

import fe_mpm
from fe_mpm import meshes, parallel

HEIGHT, DENSITY, E, NU, GRAVITY = 1.0, 2000.0, 1e8, 0.3, 9.81


def main() -> None:
    """Build the block, run it and print the summary (rank 0)."""
    start = time.perf_counter()
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=35, help="hexahedra per edge (6 tetrahedra each)")
    p.add_argument("--per-cell", type=int, default=4, help="points per tetrahedron")
    p.add_argument("--steps", type=int, default=2, help="load steps (gravity ramped)")
    p.add_argument("--formulation", default="u", choices=("u", "up"))
    p.add_argument("--linear-solver", default="direct", choices=("direct", "iterative"))
    p.add_argument("--json", action="store_true", help="end with a one-line JSON summary")
    args = p.parse_args()
    comm = MPI.COMM_WORLD
    mesh = meshes.rectangle_mesh((0, 0, 0), (HEIGHT,) * 3, (args.n,) * 3, comm=comm)
    points = fe_mpm.seed(mesh, per_cell=args.per_cell, density=DENSITY)
    law = fe_mpm.NeoHookean(E=E, nu=NU, density=DENSITY)
    sim = fe_mpm.Simulation(
        mesh,
        points,
        law,
        formulation=args.formulation,
        linear_solver=args.linear_solver,
        body_force=(0.0, 0.0, -GRAVITY),
        body_force_scale=lambda t: t,
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[2], 0.0))],
    )
    top = (0.5 * HEIGHT, 0.5 * HEIGHT, HEIGHT * (1 - 0.5 / args.n))
    sim.add_marker("top", top)
    reports = sim.run(1.0, args.steps, progress=False)
    settlement = float(top[2] - sim.marker("top")[2])
    summary = {
        "points": int(parallel.total(comm, len(points))),
        "cells": 6 * args.n**3,
        "ranks": comm.size,
        "steps": len(reports),
        "newton_iterations": [r.newton_iterations for r in reports],
        "settlement_m": settlement,
        "column_estimate_m": DENSITY * GRAVITY * HEIGHT**2 / (2 * E),
        "point_imbalance": reports[-1].point_imbalance,
        "timings": {k: round(v, 2) for k, v in sim.timings.items()},
        "wall_time_s": round(time.perf_counter() - start, 2),
    }
    sim.close()
    if comm.rank == 0:
        print(
            f"3D block: {summary['points']} points in {summary['cells']} tetrahedra on "
            f"{comm.size} rank(s), {len(reports)} steps, Newton {summary['newton_iterations']}, "
            f"settlement {settlement:.4e} m (column estimate "
            f"{summary['column_estimate_m']:.4e} m), {summary['wall_time_s']} s"
        )
        if args.json:
            print(json.dumps(summary))


if __name__ == "__main__":
    main()
