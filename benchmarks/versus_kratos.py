"""fe-mpm against Kratos MPM on Cook's membrane, side by side in one run.

Cook's membrane, mixed u-p with PPP, ν = 0.499, one point per triangle, one load step
(Iaconeta 2019, Table 5.1), on the same structured grids. Each repeat runs, one after
the other, fe-mpm's demo and Kratos MPM 10.4.4 twice: with the tolerances of Kratos's
own Cook test (residual 1e-4 relative or 1e-9 absolute) and with fe-mpm's (1e-10 of
the force scale). Every run is a whole process (imports, grid, solve), timed from
outside, single-threaded (``OMP_NUM_THREADS=1``). The table gives medians, the
displacement of A each code reports, its Newton iterations and the ratio of times.

Kratos lives in its own venv (``--kratos-venv``, default ``.kratos-venv`` at the
repository root); ``--install`` creates it with pip (about 10 s and 210 MB)::

    ./run python benchmarks/versus_kratos.py --install
    ./run python benchmarks/versus_kratos.py --n 64 128 --repeat 5

The Kratos side is ``benchmarks/kratos/cook_membrane.py``. Not a test: it prints numbers.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FE_MPM_DEMO = ROOT / "demos" / "cook_membrane.py"
KRATOS_SCRIPT = ROOT / "benchmarks" / "kratos" / "cook_membrane.py"
KRATOS_PACKAGES = (
    "KratosMultiphysics==10.4.4",
    "KratosMPMApplication==10.4.4",
    "KratosLinearSolversApplication==10.4.4",
)
#: Kratos's convergence settings: its Cook test's, and the residual fe-mpm asks for.
KRATOS_TOLERANCES = {
    "Kratos (its test's tolerances)": ("1e-4", "1e-9"),
    "Kratos (fe-mpm's tolerance)": ("1e-10", "1e-14"),
}
NU = 0.499


def install(venv: Path) -> None:
    """Create ``venv`` with this Python's base interpreter and pip-install Kratos MPM."""
    base = (
        Path(sys.base_prefix) / "bin" / f"python{sys.version_info.major}.{sys.version_info.minor}"
    )
    t0 = time.perf_counter()
    subprocess.run([str(base), "-m", "venv", str(venv)], check=True)
    subprocess.run([str(venv / "bin" / "pip"), "install", "-q", *KRATOS_PACKAGES], check=True)
    print(f"installed {', '.join(KRATOS_PACKAGES)} into {venv} in {time.perf_counter() - t0:.0f} s")


def whole_process(cmd: list[str]) -> tuple[float, dict]:
    """Wall time (s) of one process and the JSON record on its last line."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    # pip compiled Kratos's modules to bytecode at install; fe-mpm, installed editable,
    # writes its own on the first import unless this is set (some machines set it),
    # and then compiles its 80 modules at every start (0.06 s measured).
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return wall, json.loads(done.stdout.strip().splitlines()[-1])


def runs(n: int, kratos_python: Path) -> dict[str, tuple[list[str], str, str]]:
    """The commands of one repeat, name -> (command, key of u_A,y, key of the iterations)."""
    fe_mpm = [sys.executable, str(FE_MPM_DEMO), "--formulation", "up", "--nu", str(NU)]
    fe_mpm += ["--n", str(n), "--no-output", "--json", "--quiet"]
    commands = {"fe-mpm": (fe_mpm, "tip_displacement_y", "newton_iterations")}
    for name, (rtol, atol) in KRATOS_TOLERANCES.items():
        cmd = [str(kratos_python), str(KRATOS_SCRIPT), "--n", str(n), "--nu", str(NU)]
        commands[name] = (cmd + ["--rtol", rtol, "--atol", atol], "u_A_y", "newton_iterations")
    return commands


def main() -> None:
    """Install on request, then time the codes alternately and print the table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, nargs="+", default=[64, 128], help="elements per side")
    p.add_argument("--repeat", type=int, default=3, help="runs of each code per n")
    p.add_argument("--kratos-venv", type=Path, default=ROOT / ".kratos-venv")
    p.add_argument("--install", action="store_true", help="create the Kratos venv and stop")
    p.add_argument("--json", type=Path, default=None, help="write every run's record here")
    args = p.parse_args()
    if args.install:
        install(args.kratos_venv)
        return
    kratos_python = args.kratos_venv / "bin" / "python"
    if not kratos_python.exists():
        sys.exit(f"no Kratos venv at {args.kratos_venv}: run with --install first")

    records = []
    for n in args.n:
        commands = runs(n, kratos_python)
        times: dict[str, list[float]] = {name: [] for name in commands}
        answers: dict[str, tuple[float, int]] = {}
        for _ in range(args.repeat):
            for name, (cmd, u_key, it_key) in commands.items():
                wall, record = whole_process(cmd)
                times[name].append(wall)
                answers[name] = (record[u_key], record[it_key])
                records.append({"n": n, "code": name, "wall_s": wall, **record})
        ours = statistics.median(times["fe-mpm"])
        print(f"\nCook u-p, ν = {NU}, n = {n}, whole process, median of {args.repeat}:")
        print(f"  {'code':32s} {'time (s)':>9s} {'u_A,y':>9s} {'Newton':>7s} {'fe-mpm ÷ it':>12s}")
        for name, values in times.items():
            median = statistics.median(values)
            u_a, iterations = answers[name]
            print(f"  {name:32s} {median:9.2f} {u_a:9.5f} {iterations:7d} {ours / median:12.2f}")
    if args.json is not None:
        args.json.write_text(json.dumps(records, indent=1))


if __name__ == "__main__":
    main()
