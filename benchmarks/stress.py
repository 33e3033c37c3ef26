"""Full-size stability stress runs (the suite's tests/test_stability.py at reduced size).

Prints, for each stress case, what a user would want to know: whether the run
finished, the answer, the Newton iterations and the step cuts.

1. **Near incompressibility:** Cook, u-p, n = 64, ν = 0.499 … 0.499999: u_A,y and the
   Newton history (bounded, converging, quadratic).
2. **Large deformation:** Cook, u-p, ν = 0.499, n = 32, load ×5 and ×10 on
   boundary points that follow the body, 1 against 40 and 160 steps, 3 and 6
   points per cell: the tip, the drift from the one-step (FEM) answer, steps cut.
3. **Cell crossing:** a free block translating through a 60 × 60 grid for 40
   steps with 1, 3 and 6 points per cell: the largest |σ|/E (zero in exact arithmetic).
4. **Time-step sweep:** the dynamic elastic column (demos/elastic_column.py, ny = 32)
   with 2 to 160 steps per period: the error against Tielen et al.'s series.

Usage: ``./run python benchmarks/stress.py [--only 1 2 3 4]``. About 10 minutes. Not a test.
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import fe_mpm
from fe_mpm import scenes
from fe_mpm.meshes import cell_centroids, rectangle_mesh

DEMOS = Path(__file__).resolve().parents[1] / "demos"


def near_incompressibility() -> None:
    """Cook u-p at n = 64 as ν → 1/2."""
    print("\n1. Near incompressibility: Cook, u-p, n = 64, one step")
    print(f"{'ν':>10}{'u_A,y':>10}{'Newton':>8}  ‖R‖ history")
    for nu in (0.499, 0.4999, 0.49999, 0.499999):
        sim = scenes.cook_membrane(64, nu, "up")
        (r,) = sim.run(progress=False)
        norms = " ".join(f"{x:.1e}" for x in r.residual_norms)
        print(f"{nu:>10}{scenes.tip_deflection(sim):>10.5f}{r.newton_iterations:>8}  {norms}")


def large_deformation() -> None:
    """Cook u-p under ×5 and ×10 the load, in 1, 40 and 160 steps."""
    print("\n2. Large deformation: Cook, u-p, ν = 0.499, n = 32, point load")
    print(
        f"{'load':>5}{'points':>7}{'steps':>6}{'taken':>6}{'tip':>9}{'vs 1 step':>10}"
        f"{'max Newton':>11}{'time s':>8}"
    )
    for factor in (5, 10):
        for per_cell in (3, 6):
            one_step = None
            for steps in (1, 40, 160):
                t0 = time.perf_counter()
                sim = scenes.cook_membrane(
                    32,
                    0.499,
                    "up",
                    traction=factor / 16,
                    margin=32,
                    load="points",
                    per_cell=per_cell,
                )
                try:
                    reports = sim.run(1.0, steps, progress=False)
                except fe_mpm.ConvergenceError as err:
                    print(f"{factor:>5}{per_cell:>7}{steps:>6}  stopped: {str(err)[:90]}")
                    continue
                tip = scenes.tip_deflection(sim)
                one_step = tip if steps == 1 else one_step
                drift = "" if one_step is None else f"{100 * (tip / one_step - 1):+.1f} %"
                print(
                    f"{factor:>5}{per_cell:>7}{steps:>6}{len(reports):>6}{tip:>9.4f}"
                    f"{drift:>10}{max(r.newton_iterations for r in reports):>11}"
                    f"{time.perf_counter() - t0:>8.1f}",
                    flush=True,
                )


def cell_crossing() -> None:
    """A free block moving at constant velocity: its stress should stay zero."""
    print("\n3. Cell crossing: free block, 60 x 60 grid, 40 dynamic steps")
    print(f"{'points/cell':>12}{'cells crossed':>15}{'max |σ|/E':>12}")
    E = 1e4
    for per_cell in (1, 3, 6):
        mesh = rectangle_mesh((0, 0), (3, 3), (60, 60))
        c = cell_centroids(mesh)
        block = np.flatnonzero(
            (c[:, 0] > 0.2) & (c[:, 0] < 1.0) & (c[:, 1] > 0.2) & (c[:, 1] < 1.0)
        )
        points = fe_mpm.seed(mesh, per_cell=per_cell, density=1.0, cells=block)  # kg/m³
        velocity = np.array([0.37, 0.23])
        points.velocity[:] = velocity
        sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(E, 0.3), dynamic=True)
        noise = 0.0
        for k in range(1, 41):
            sim.step(0.1 * k)
            noise = max(noise, np.abs(points.stress).max() / E)
        print(f"{per_cell:>12}{4.0 * 0.37 * 20:>15.0f}{noise:>12.1e}")


def time_step_sweep() -> None:
    """The dynamic elastic column at ny = 32 over two periods, 4 to 320 steps."""
    print("\n4. Time-step sweep: dynamic elastic column, ny = 32, two periods")
    print(f"{'steps':>6}{'per period':>11}{'max error / static deflection':>31}{'time s':>8}")
    with tempfile.TemporaryDirectory() as work:
        for steps in (4, 10, 20, 40, 80, 160, 320):
            t0 = time.perf_counter()
            out = subprocess.run(
                [
                    sys.executable,
                    str(DEMOS / "elastic_column.py"),
                    "--ny",
                    "32",
                    "--dynamic",
                    "--steps",
                    str(steps),
                    "--json",
                ],
                capture_output=True,
                text=True,
                cwd=work,
            )
            if out.returncode:
                print(f"{steps:>6}  stopped: {out.stderr.strip().splitlines()[-1][:90]}")
                continue
            error = json.loads(out.stdout.strip().splitlines()[-1])["error"]
            print(
                f"{steps:>6}{steps / 2:>11g}{error:>31.3f}{time.perf_counter() - t0:>8.1f}",
                flush=True,
            )


CASES = {1: near_incompressibility, 2: large_deformation, 3: cell_crossing, 4: time_step_sweep}


def main() -> None:
    """Run the chosen cases."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--only", type=int, nargs="+", choices=sorted(CASES), default=sorted(CASES))
    for case in p.parse_args().only:
        CASES[case]()


if __name__ == "__main__":
    main()
