"""Where a plastic step's Newton iterations go: the points that change region per iterate.

Runs the strip footing (u-p, Tresca) and, for the steps asked for, prints ‖R‖ at
every iterate and, after each return map, how many points changed their return's
region (elastic, plane, the two lines, apex) since the iterate before, and how many
lie in each. A step starts with every point elastic (its trial stress is its
stress), so its first iterate is an elastic solve; the later ones show how long the
plastic zone takes to settle::

    ./run python benchmarks/newton_regions.py --h 0.2 --report 10 20 30
"""

from __future__ import annotations

import argparse

import numpy as np

from fe_mpm import scenes
from fe_mpm.step_forms import ReturnMapAtIterate

REGIONS = ("elastic", "plane", "line 1", "line 2", "apex")


def main() -> None:
    """Run the footing and print the regions of the steps in ``--report``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--h", type=float, default=0.2, help="cell size near the footing (m)")
    parser.add_argument("--steps", type=int, default=100, help="load steps to s/B = 2")
    parser.add_argument("--report", type=int, nargs="+", default=[10, 20, 30])
    args = parser.parse_args()

    changes: list[tuple[int | None, list[int]]] = []
    refresh = ReturnMapAtIterate.refresh

    def recording(self, tangent: bool = True):
        before = None if self.result is None else self.result.region.copy()
        result = refresh(self, tangent)
        counts = np.bincount(result.region, minlength=len(REGIONS)).tolist()
        if before is None:
            changes.append((None, counts))
        elif not np.array_equal(before, result.region):
            changes.append((int(np.count_nonzero(before != result.region)), counts))
        return result

    ReturnMapAtIterate.refresh = recording
    sim = scenes.strip_footing("up", h=args.h, h_far=max(args.h, 0.5), settlement=2.0)
    print(f"{len(sim.points)} points; regions: {', '.join(REGIONS)}")
    for k in range(1, max(args.report) + 1):
        changes.clear()
        report = sim.step(k / args.steps)
        if k not in args.report:
            continue
        norms = " ".join(f"{r:.1e}" for r in report.residual_norms)
        print(f"step {k}: {report.newton_iterations} iterations, ‖R‖ {norms}")
        for changed, counts in changes:
            what = "first return" if changed is None else f"{changed:5d} changed"
            print(f"    {what:>14}: {counts}")


if __name__ == "__main__":
    main()
