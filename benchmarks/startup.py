"""What a run pays before its first step: imports, form compilation, and a new parameter set.

Prints, as medians over ``--repeat`` processes each:

- ``import fe_mpm`` (dolfinx included), and which optional heavy modules it pulled in;
- Cook's membrane, u-p, ν = 0.499, whole process (``demos/cook_membrane.py``), with
  an empty FFCx cache (everything compiled), with the cache warm, and warm but with a
  Young's modulus never run before. The material parameters are run-time constants of
  the forms (:mod:`fe_mpm.materials.runtime`), so the last costs what a warm run does.

Usage: ``./run python benchmarks/startup.py [--n 64] [--repeat 3]``. Not a test.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "demos" / "cook_membrane.py"
OPTIONAL = ("meshio", "matplotlib", "gmsh", "scipy", "h5py", "numba")

IMPORT_PROBE = f"""
import time, sys, json
t0 = time.perf_counter()
import fe_mpm
t1 = time.perf_counter()
print(json.dumps({{"seconds": t1 - t0, "loaded": [m for m in {OPTIONAL!r} if m in sys.modules]}}))
"""


def timed(cmd: list[str], env: dict) -> tuple[float, str]:
    """Wall time (s) of a process and its last line of output."""
    t0 = time.perf_counter()
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
    return time.perf_counter() - t0, out.strip().splitlines()[-1]


def main() -> None:
    """Time the imports and three Cook runs per repeat; print medians."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=64, help="Cook grid: elements per side")
    p.add_argument("--repeat", type=int, default=3, help="processes per measurement")
    args = p.parse_args()

    imports, loaded = [], []
    for _ in range(args.repeat):
        _, line = timed([sys.executable, "-c", IMPORT_PROBE], dict(os.environ))
        data = json.loads(line)
        imports.append(data["seconds"])
        loaded = data["loaded"]
    print(
        f"import fe_mpm: median {statistics.median(imports):.2f} s; optional modules loaded: "
        f"{', '.join(loaded) or 'none'}"
    )

    demo = [
        sys.executable,
        str(DEMO),
        "--formulation",
        "up",
        "--nu",
        "0.499",
        "--n",
        str(args.n),
        "--no-output",
        "--json",
        "--quiet",
    ]
    rows = {"empty cache": [], "warm cache": [], "warm, new E": []}
    for i in range(args.repeat):
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, XDG_CACHE_HOME=cache)
            rows["empty cache"].append(timed(demo, env)[0])
            rows["warm cache"].append(timed(demo, env)[0])
            # A modulus never run before (differs in each repeat, too).
            rows["warm, new E"].append(timed(demo + ["--E", f"{71.0 + i}"], env)[0])
    print(f"Cook u-p n = {args.n}, whole process (s), median of {args.repeat}:")
    for name, times in rows.items():
        each = ", ".join(f"{t:.2f}" for t in times)
        print(f"  {name:12s} {statistics.median(times):6.2f}   ({each})")


if __name__ == "__main__":
    main()
