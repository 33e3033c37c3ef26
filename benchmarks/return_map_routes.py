"""The Mohr-Coulomb return map, compiled against numpy, in a whole plastic scene.

Runs the thesis-grid strip footing (u-p, h = 0.05 B, 107 880 points; ``--h`` to
change it) for ``--steps`` steps of 10 mm from rest, once per route, each in a fresh
process (``FE_MPM_COMPILED=0`` for numpy), and prints per Newton iteration the
seconds of each phase (every iteration counted, those of failed attempts too),
the return map's share of the run and the q/c_u of the last
step on both routes (they agree to round-off). Then times the compiled kernels'
first run on a machine: a process with an empty numba cache, against one with the
cache filled.

Usage: ``./run python benchmarks/return_map_routes.py [--h 0.05] [--steps 6]``. Not
a test.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

CHILD = r"""
import json, sys, time
import dolfinx_solver  # noqa: F401
from fe_mpm import scenes
h, steps = float(sys.argv[1]), int(sys.argv[2])
sim = scenes.strip_footing("up", h=h, settlement=2.0)
t0 = time.perf_counter()
reports = sim.run(0.005 * steps, steps, progress=False)
wall = time.perf_counter() - t0
print(json.dumps({
    "wall": wall,
    "points": len(sim.points.x),
    "iterations": sim.newton_iterations_total,
    "accepted": sum(r.newton_iterations for r in reports),
    "timings": sim.timings,
    "q": scenes.footing_pressure(reports[-1]) / 100.0,
}))
"""

FIRST_CALL = r"""
import time
import numpy as np
from fe_mpm.materials import MohrCoulomb
t0 = time.perf_counter()
law = MohrCoulomb.tresca(1.0e4, 0.49, 100.0)
dF = np.tile(np.eye(2) + 0.05 * np.array([[0.0, 1.0], [0.0, 0.0]]), (10, 1, 1))
result = law.return_map(dF, {"be": np.tile(np.eye(3), (10, 1, 1)), "plastic_strain": np.zeros(10)})
result.tangent
print(time.perf_counter() - t0)
"""


def run_child(code: str, args: list[str], env: dict) -> str:
    """The last line a fresh Python process running ``code`` prints."""
    out = subprocess.run(
        [sys.executable, "-c", code, *args], env=env, capture_output=True, text=True, check=True
    )
    return out.stdout.strip().splitlines()[-1]


def main() -> None:
    """Both routes on the footing, then the compiled kernels' first-run cost."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--h", type=float, default=0.05)
    p.add_argument("--steps", type=int, default=6)
    args = p.parse_args()
    rows = {}
    for name, flag in (("numpy", "0"), ("compiled", "1")):
        env = {**os.environ, "FE_MPM_COMPILED": flag}
        rows[name] = json.loads(run_child(CHILD, [str(args.h), str(args.steps)], env))
    print(f"strip footing, h = {args.h}, {rows['numpy']['points']} points, {args.steps} steps")
    print(
        "route      iterations (accepted placements)  s/iteration: return map  assembly  "
        "Newton other    run   return map share"
    )
    for name, r in rows.items():
        t, n = r["timings"], r["iterations"]
        other = t["newton"] - t["return_map"] - t["assembly"]
        print(
            f"{name:10s} {n:10d} ({r['accepted']:4d}){'':20s}{t['return_map'] / n:9.3f} "
            f"{t['assembly'] / n:9.3f} {other / n:12.3f} {r['wall']:7.1f} s "
            f"{100 * t['return_map'] / r['wall']:6.1f} %"
        )
    print(
        f"q/c_u after the last step: numpy {rows['numpy']['q']:.12f}, "
        f"compiled {rows['compiled']['q']:.12f}"
    )
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        t0 = time.perf_counter()
        cold = float(run_child(FIRST_CALL, [], env))
        warm = float(run_child(FIRST_CALL, [], env))
        print(
            f"first return map of a process: {cold:.1f} s with an empty numba cache "
            f"(compiling), {warm:.1f} s with it filled (numba's import and the cache's "
            f"load); both processes {time.perf_counter() - t0:.0f} s"
        )


if __name__ == "__main__":
    main()
