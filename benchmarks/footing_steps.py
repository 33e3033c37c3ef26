"""Strip footing (thesis §6.2): wall time per load step, split by phase.

Runs ``--steps`` steps of 1 mm settlement (the thesis's step) on the footing grid
of cell size ``--h`` (0.05 m is the thesis's, 107 976 points with 12 per cell
near the footing and 3 elsewhere). The first step (JIT, matrix and solver set-up)
is not timed; the table gives the median of the others, per phase of
``Simulation.timings``, and per Newton iteration.

Usage: ``./run python benchmarks/footing_steps.py [--h 0.05 0.1] [--steps 6]
[--formulation up]``. Not a test.
"""

import argparse

from step_timing import PHASES, median_steps

from fe_mpm import scenes


def step_times(h: float, formulation: str, steps: int, solver: str) -> dict:
    """Median wall time of steps 2…steps and of its phases."""
    sim = scenes.strip_footing(formulation, h=h, settlement=0.001 * steps, linear_solver=solver)
    row = {"points": len(sim.points), **median_steps(sim, steps)}
    sim.close()
    return row


def main() -> None:
    """Print the time per step for each grid."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--h", type=float, nargs="+", default=[0.1, 0.05])
    p.add_argument("--steps", type=int, default=6)
    p.add_argument("--formulation", choices=("u", "up"), default="up")
    p.add_argument("--solver", choices=("direct", "iterative"), default="direct")
    args = p.parse_args()
    print(
        f"{'h':>6}{'points':>9}{'Newton':>7}{'step s':>8}{'s/iter':>8}  "
        + "".join(f"{ph:>11}" for ph in PHASES)
    )
    for h in args.h:
        r = step_times(h, args.formulation, args.steps, args.solver)
        print(
            f"{h:>6}{r['points']:>9}{r['newton']:>7g}{r['step_s']:>8.2f}"
            f"{r['step_s'] / r['newton']:>8.2f}  " + "".join(f"{r[ph]:>11.3f}" for ph in PHASES),
            flush=True,
        )


if __name__ == "__main__":
    main()
