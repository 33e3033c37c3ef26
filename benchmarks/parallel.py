"""Strong scaling: the demos on 1 and more MPI ranks, side by side in one run.

Each run is a whole process, ``mpiexec -n N python -m mpi4py demos/<demo>.py ... --json``,
timed from outside (imports, grid, forms and all steps) with ``OMP_NUM_THREADS=1``;
the table gives the median over ``--repeat`` runs, the speed-up against one rank, the
points' imbalance (the most points on a rank over the mean, ``StepReport.point_imbalance``),
rank 0's split of the run (``Simulation.timings``) and how far the answer moved from
the one-rank run (it should be round-off).

Scenes (``--scenes``):

- ``footing``: the thesis-grid strip footing (u-p, h = 0.05 B, 107 976 points), 20
  steps of 10 mm; the answer is q/c_u at the last step.
- ``cook``: Cook's membrane, u-p, n = 256, one point per triangle, one step; the
  answer is the tip displacement.
- ``block3d``: an elastic cube of 257 250 tetrahedra (35³ hexahedra) with 4 points
  each (1 029 000 points) settling under its weight in 2 steps
  (``benchmarks/block_3d.py``); the answer is the top's settlement.
  ``block3d-iterative`` is the same with ``linear_solver="iterative"`` (GAMG).
- ``collapse``: the granular column, a = 3, h = 5 mm, 3 points per cell (7140), the
  first 0.1 s (40 steps; its own check of the deposit then fails). The column starts
  in a corner of the grid, so on 2 ranks one holds every point;
  ``collapse-balanced`` is the same with the grid partitioned by its points
  (``--rebalance-above 1.25``). The answer is the run-out so far; the collapse is
  chaotic at round-off (docs/limitations.md), so it moves with the partition.
  ``collapse-domains`` runs it with point domains (``--point-domains``), whose grid
  is partitioned by its points at set-up, with two vertex layers of ghost cells.

On a machine with 2 cores, 2 ranks is the most that measures speed.

Usage: ``./run python benchmarks/parallel.py [--ranks 1 2] [--repeat 3] [--scenes footing cook]``.
Not a test: it prints numbers.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
COLLAPSE = [
    "demos/column_collapse.py", "--aspect", "3", "--h", "0.005", "--points-per-cell", "3",
    "--t-end", "0.1", "--damping", "0", "--no-output",
]  # fmt: skip
SCENES = {
    "footing": (
        ["demos/strip_footing.py", "--steps", "20", "--settlement", "0.2", "--no-output"],
        lambda out: out["q_over_cu"][-1],
        "q/c_u",
    ),
    "cook": (
        ["demos/cook_membrane.py", "--formulation", "up", "--n", "256", "--nu", "0.499"],
        lambda out: out["tip_displacement_y"],
        "u_A,y",
    ),
    "block3d": (["benchmarks/block_3d.py"], lambda out: out["settlement_m"], "settlement"),
    "block3d-iterative": (
        ["benchmarks/block_3d.py", "--linear-solver", "iterative"],
        lambda out: out["settlement_m"],
        "settlement",
    ),
    "collapse": (COLLAPSE, lambda out: out["runout"], "d_inf"),
    "collapse-balanced": (
        [*COLLAPSE, "--rebalance-above", "1.25"],
        lambda out: out["runout"],
        "d_inf",
    ),
    "collapse-domains": (
        [*COLLAPSE, "--point-domains"],
        lambda out: out["runout"],
        "d_inf",
    ),
}


def run_once(script: list[str], ranks: int) -> tuple[float, dict]:
    """Wall time (s) of one whole run on ``ranks`` ranks, and its JSON summary."""
    mpiexec = Path(sys.executable).parent / "mpiexec"
    command = [str(mpiexec), "-n", str(ranks), sys.executable, "-m", "mpi4py"]
    command += [*script, "--json", "--quiet"] if "cook" in script[0] else [*script, "--json"]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    start = time.perf_counter()
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - start
    summary = [line for line in done.stdout.splitlines() if line.startswith("{")]
    # A demo whose own check fails (a collapse cut short of its deposit) still ran.
    if not summary:
        sys.exit(f"parallel.py: {' '.join(command)} failed:\n{done.stdout}\n{done.stderr}")
    return wall, json.loads(summary[-1])


def main() -> None:
    """Run every scene on every rank count, interleaved, and print the table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--scenes", nargs="+", choices=sorted(SCENES), default=["footing", "cook"])
    args = p.parse_args()
    print(f"{os.cpu_count()} cores; medians of {args.repeat} runs, whole processes")
    columns = ["scene", "ranks", "run (s)", "speed-up", "imbalance", "answer", "vs 1 rank"]
    print("| " + " | ".join([*columns, "rank 0's split (s)"]) + " |")
    print("|---" * (len(columns) + 1) + "|")
    for name in args.scenes:
        script, answer, label = SCENES[name]
        times = {k: [] for k in args.ranks}
        last = {}
        for _ in range(args.repeat):  # interleaved, so drifts in machine load hit all alike
            for k in args.ranks:
                wall, out = run_once(script, k)
                times[k].append(wall)
                last[k] = out
        base = statistics.median(times[args.ranks[0]])
        reference = answer(last[args.ranks[0]])
        for k in args.ranks:
            median = statistics.median(times[k])
            value = answer(last[k])
            split = ", ".join(
                f"{phase} {seconds:.1f}"
                for phase, seconds in sorted(
                    last[k].get("timings", {}).items(), key=lambda item: -item[1]
                )[:4]
            )
            print(
                f"| {name} | {k} | {median:.1f} | {base / median:.2f} | "
                f"{last[k].get('point_imbalance', 1.0):.2f} | {label} = {value:.6g} | "
                f"{abs(value / reference - 1):.1e} | {split} |"
            )


if __name__ == "__main__":
    main()
