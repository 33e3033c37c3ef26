"""Wall time per step and its split by phase, from ``Simulation.timings``.

Shared by the benchmarks (not a benchmark itself).
"""

import statistics
import time

#: The phases of a step, as the benchmarks report them.
PHASES = ("tracking", "packing", "return_map", "assembly", "solve", "update")


def phases(timings: dict, before: dict | None = None) -> dict:
    """Seconds per phase in ``timings`` (since ``before``, if given).

    Packing includes binding the step's forms (``compile``); the linear solve is
    Newton's time less assembly and the return map, which Newton calls.
    """
    before = before or {}
    d = {key: timings.get(key, 0.0) - before.get(key, 0.0) for key in timings}
    return {
        "tracking": d.get("tracking", 0.0),
        "packing": d.get("packing", 0.0) + d.get("compile", 0.0),
        "return_map": d.get("return_map", 0.0),
        "assembly": d.get("assembly", 0.0),
        "solve": d.get("newton", 0.0) - d.get("assembly", 0.0) - d.get("return_map", 0.0),
        "update": d.get("update", 0.0),
    }


def median_steps(sim, steps: int) -> dict:
    """Run ``steps`` equal steps to t = 1 and return medians over steps 2…steps.

    The first step (JIT, the solver's set-up) is left out. The medians are of
    ``step_s`` (wall time), ``newton`` (iterations) and each phase.
    """
    walls, splits, iterations = [], [], []
    for k in range(1, steps + 1):
        before = dict(sim.timings)
        t0 = time.perf_counter()
        report = sim.step(k / steps)
        wall = time.perf_counter() - t0
        if k > 1:
            walls.append(wall)
            splits.append(phases(sim.timings, before))
            iterations.append(report.newton_iterations)
    row = {"step_s": statistics.median(walls), "newton": statistics.median(iterations)}
    row.update({ph: statistics.median(s[ph] for s in splits) for ph in PHASES})
    return row
