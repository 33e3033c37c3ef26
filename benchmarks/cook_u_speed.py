"""Cook's membrane, u formulation: wall time and where it goes.

Prints, for each n, the median over repeated runs of

- the in-process solve after JIT (mesh, seeding, simulation set-up and one
  load step), split into tracking, packing, assembly, linear solve and the rest;
- the whole process (``python demos/cook_membrane.py --no-output --json``),
  imports and gmsh included.

Usage: ``./run python benchmarks/cook_u_speed.py [--n 32 64 128] [--repeat 5]``.
Not a test: it prints numbers.
"""

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import fe_mpm
from fe_mpm import meshes

DEMO = Path(__file__).resolve().parents[1] / "demos" / "cook_membrane.py"


def solve_once(n: int, nu: float) -> dict:
    """Mesh, seed, set up and solve one load step in this process; return the timings."""
    t0 = time.perf_counter()
    scene = meshes.cook_membrane(n=n)
    t_mesh = time.perf_counter() - t0
    points = fe_mpm.seed(scene.mesh, per_cell=1)
    sim = fe_mpm.Simulation(
        scene.mesh,
        points,
        fe_mpm.NeoHookean(E=70.0, nu=nu),
        facet_tags=scene.facet_tags,
        dirichlet=[fe_mpm.Dirichlet(meshes.COOK_CLAMPED)],
        tractions=[fe_mpm.Traction(meshes.COOK_LOADED, (0.0, 1 / 16))],
    )
    sim.add_marker("A", meshes.COOK_POINT_A)
    report = sim.step(1.0)
    total = time.perf_counter() - t0
    tm = dict(sim.timings)
    sim.close()
    linear = tm["newton"] - tm["assembly"]
    split = {
        "mesh": t_mesh,
        "tracking": tm["tracking"],
        "packing": tm["packing"],
        "assembly": tm["assembly"],
        "linear_solve": linear,
        "update": tm["update"],
    }
    split["rest"] = total - sum(split.values())
    return {
        "total": total,
        "split": split,
        "newton": report.newton_iterations,
        "u_A_y": sim.marker("A")[1] - 60.0,
    }


def whole_process(n: int, nu: float) -> float:
    """Wall time of the demo as a fresh process (imports included)."""
    t0 = time.perf_counter()
    out = subprocess.run(
        [sys.executable, str(DEMO), "--n", str(n), "--nu", str(nu), "--no-output", "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    wall = time.perf_counter() - t0
    json.loads(out.stdout.strip().splitlines()[-1])
    return wall


def main() -> None:
    """Run the sweep and print the table."""
    p = argparse.ArgumentParser()
    p.add_argument("--n", type=int, nargs="+", default=[32, 64, 128])
    p.add_argument("--nu", type=float, default=0.499)
    p.add_argument("--repeat", type=int, default=5)
    args = p.parse_args()
    print(f"Cook's membrane, u, nu = {args.nu}, 1 point per cell; medians of {args.repeat} runs")
    for n in args.n:
        solve_once(n, args.nu)  # JIT and caches
        runs = [solve_once(n, args.nu) for _ in range(args.repeat)]
        med = {k: statistics.median(r["split"][k] for r in runs) for k in runs[0]["split"]}
        total = statistics.median(r["total"] for r in runs)
        procs = [whole_process(n, args.nu) for _ in range(args.repeat)]
        print(
            f"\nn = {n:4d}: {2 * n * n} points, Newton {runs[0]['newton']}, "
            f"u_A,y = {runs[0]['u_A_y']:.5f}"
        )
        print(f"  after JIT: {total:.3f} s = " + ", ".join(f"{k} {v:.3f}" for k, v in med.items()))
        print(
            f"  whole process (imports, gmsh, solve): median {statistics.median(procs):.2f} s "
            f"(min {min(procs):.2f}, max {max(procs):.2f})"
        )


if __name__ == "__main__":
    main()
