"""A dynamic plastic scene under each of Newton's line searches, one after another.

A Drucker–Prager block (1 m square, φ = 30°, c = 500 Pa, E = 5 MPa, u-p, 3 points
per triangle of h = 1/16 m) slumps under gravity against a smooth wall onto a floor
with Coulomb friction μ = 0.4, 0.8 s in 80 steps of Newmark: a scene of its own beside
the demos compared in docs/dynamics.md. Prints, per search, the steps taken (cut
steps count twice or more), Newton's mean and largest iterations per step, the
front's position and the wall time.

Usage: ``./run python benchmarks/line_search_block.py [--searches l2 bt basic]``.
Not a test.
"""

import argparse
import time

import numpy as np

import fe_mpm
from fe_mpm import meshes


def slump(line_search: str) -> dict:
    """One run with ``line_search``: steps, Newton's mean and max, front (m), time (s)."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (3.0, 1.5), (48, 24))
    centre = meshes.cell_centroids(mesh)
    block = np.flatnonzero((centre[:, 0] < 1.0) & (centre[:, 1] < 1.0))
    points = fe_mpm.seed(mesh, per_cell=3, density=1800.0, cells=block)
    soil = fe_mpm.DruckerPrager(
        E=5e6, nu=0.3, cohesion=500.0, friction_angle=30.0, dilatancy_angle=0.0, density=1800.0
    )
    floor = fe_mpm.RigidWall("floor", lambda x: np.isclose(x[1], 0.0), friction=0.4)
    wall = fe_mpm.RigidWall("wall", lambda x: np.isclose(x[0], 0.0))
    sim = fe_mpm.Simulation(
        mesh,
        points,
        soil,
        "up",
        dynamic=True,
        mass="lumped",
        walls=[floor, wall],
        body_force=(0.0, -9.81),
        line_search=line_search,
        points_leaving="drop",
    )
    start = time.perf_counter()
    reports = sim.run(0.8, 80, progress=False)
    iterations = [r.newton_iterations for r in reports]
    return {
        "steps": len(reports),
        "newton_mean": float(np.mean(iterations)),
        "newton_max": max(iterations),
        "front_m": float(points.x[:, 0].max()),
        "wall_time_s": time.perf_counter() - start,
    }


def main() -> None:
    """Print one row per line search."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--searches", nargs="+", default=["l2", "bt", "basic"])
    args = p.parse_args()
    print(f"{'search':>7}{'steps':>7}{'Newton':>8}{'max':>5}{'front m':>9}{'wall s':>8}")
    for search in args.searches:
        r = slump(search)
        print(
            f"{search:>7}{r['steps']:>7}{r['newton_mean']:>8.2f}{r['newton_max']:>5}"
            f"{r['front_m']:>9.4f}{r['wall_time_s']:>8.1f}"
        )


if __name__ == "__main__":
    main()
