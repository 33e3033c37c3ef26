"""How much each answer the suite asserts moves with nothing but round-off.

Every scene the suite checks is run as an ensemble: member 0 as written, the
others with the input perturbed at round-off level, alternately

- the point positions moved by ``1e-12`` of the body's size (a random
  direction per point, seeded by the member number), and
- the points listed in a random order (every per-point field and the history
  permuted alike).

Both leave the problem the same to round-off. The script prints, for each asserted
quantity, the ensemble's mean, its spread (sample standard deviation), min and max,
and the test's bound with its distance from the mean in spreads. A bound less than
three spreads from the mean hinges on round-off.

Each member runs in its own process (``--jobs`` at a time). The perturbation is
applied where every scene passes: when :class:`fe_mpm.Simulation` receives its
points, so the demos run unchanged. ``--blas-cores`` adds unperturbed members that
run OpenBLAS's kernels for other processors (as another machine would: the sums
in BLAS and MUMPS are ordered differently).

Usage: ``./run python benchmarks/roundoff_spread.py [--members 6] [--jobs 2]
[--scenes collapse_a3 cook_x5 ...] [--blas-cores Haswell Sandybridge] [--csv FILE]``. Not a test.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import io
import json
import os
import runpy
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEMOS = ROOT / "demos"

#: Relative size of the position perturbation (of the points' bounding box).
JITTER = 1e-12


@dataclass(frozen=True)
class Quantity:
    """An asserted quantity and the test's bound on it: ``low < value < high``."""

    name: str
    low: float
    high: float
    test: str


def perturb(points, member: int) -> None:
    """Perturb ``points`` in place at round-off level; member 0 is left as it is.

    Odd members move the points by :data:`JITTER` of the bounding box; even members
    permute the points.
    """
    if member == 0:
        return
    rng = np.random.default_rng(member)
    if member % 2:
        size = np.ptp(points.x, axis=0).max()
        shift = rng.standard_normal(points.x.shape)
        shift *= JITTER * size / np.linalg.norm(shift, axis=1, keepdims=True)
        points.x += shift
        points.x0 += shift
        return
    from fe_mpm.particles import PER_POINT_FIELDS

    order = rng.permutation(len(points))
    for name in PER_POINT_FIELDS:
        setattr(points, name, np.ascontiguousarray(getattr(points, name)[order]))
    points.history = {k: v[order] for k, v in points.history.items()}


def _install(member: int) -> None:
    """Make every Simulation perturb its points as ``member`` says before it starts."""
    import fe_mpm

    original = fe_mpm.Simulation.__init__

    def init(self, mesh, points, *args, **kwargs):
        perturb(points, member)
        original(self, mesh, points, *args, **kwargs)

    fe_mpm.Simulation.__init__ = init


def _demo(name: str, *args: str) -> dict:
    """Run ``demos/<name>`` in this process and return its JSON summary."""
    buffer = io.StringIO()
    argv = sys.argv
    sys.argv = [str(DEMOS / name), *args, "--json"]
    try:
        with contextlib.redirect_stdout(buffer):
            runpy.run_path(str(DEMOS / name), run_name="__main__")
    finally:
        sys.argv = argv
    return json.loads(buffer.getvalue().strip().splitlines()[-1])


def _window_means(out: dict, centres) -> list[float]:
    s, q = np.array(out["settlement_over_B"]), np.array(out["q_over_cu"])
    return [float(q[(s > c - 0.1) & (s <= c + 0.1)].mean()) for c in centres]


# --- the scenes: each returns the asserted quantities by name -------------------------

COLLAPSE_A3 = (
    "--aspect",
    "3",
    "--h",
    "0.015",
    "--points-per-cell",
    "3",
    "--dt",
    "2.5e-3",
    "--damping",
    "1.5",
    "--no-output",
)


def collapse_a3() -> dict:
    """test_demos.py::test_column_collapse_runout_a3."""
    errors = _demo("column_collapse.py", *COLLAPSE_A3)["relative_errors"]
    return {f"{k} error": errors[k] for k in ("runout", "final_height", "t_inf_cell", "t_inf")}


COLLAPSE_DT = (
    "--aspect",
    "1.2",
    "--h",
    "0.02",
    "--points-per-cell",
    "3",
    "--damping",
    "1.5",
    "--no-output",
)


def collapse_dt40() -> dict:
    """Δt = 40 ms: steps are cut (a test until its run-out was found to hinge on round-off)."""
    coarse = _demo("column_collapse.py", "--dt", "0.04", *COLLAPSE_DT)
    fine = _demo("column_collapse.py", "--dt", "0.01", *COLLAPSE_DT)
    return {
        "runout 40 ms / 10 ms": coarse["runout"] / fine["runout"],
        "height 40 ms / 10 ms": coarse["final_height"] / fine["final_height"],
        "accepted steps at 40 ms": coarse["steps"],
    }


def _footing(steps: int) -> dict:
    return _demo(
        "strip_footing.py",
        "--formulation",
        "up",
        "--steps",
        str(steps),
        "--settlement",
        "2.0",
        "--h",
        "0.2",
        "--h-far",
        "0.5",
        "--no-output",
    )


def footing() -> dict:
    """The footing test of test_demos.py (100 steps), and 25 steps against it.

    The 25-step comparison is ``benchmarks/footing_step_count.py``'s.
    """
    many = _footing(100)
    out = {
        f"q/c_u at s/B = {c}": m
        for c, m in zip((0.3, 0.8, 1.3, 1.9), _window_means(many, (0.3, 0.8, 1.3, 1.9)))
    }
    centres = (0.5, 1.0, 1.5, 1.9)
    few = _window_means(_footing(25), centres)
    out |= {
        f"25/100 steps at s/B = {c}": a / b
        for c, a, b in zip(centres, few, _window_means(many, centres))
    }
    return out


def _cook_tips(factor: int) -> dict:
    from fe_mpm import scenes

    tips = []
    for steps in (1, 40):
        sim = scenes.cook_membrane(
            16, 0.499, "up", traction=factor / 16, margin=16, load="points", per_cell=3
        )
        reports = sim.run(1.0, steps, progress=False)
        tips.append(scenes.tip_deflection(sim))
    return {
        f"x{factor}: 40 steps / 1 step": tips[1] / tips[0],
        f"x{factor}: steps taken": len(reports),
    }


def cook_x5() -> dict:
    """test_stability.py::test_cook_under_five_and_ten_times_the_load_over_many_steps[5]."""
    return _cook_tips(5)


def cook_x10() -> dict:
    """test_stability.py::test_cook_under_five_and_ten_times_the_load_over_many_steps[10]."""
    return _cook_tips(10)


def cook_plastic() -> dict:
    """test_plasticity_scenes.py::test_elastoplastic_cook_membrane_newton_stays_quadratic..."""
    import warnings

    import fe_mpm
    from fe_mpm import scenes

    material = fe_mpm.J2Plasticity(70.0, 0.499, 0.243, 0.135)
    sim = scenes.cook_membrane(16, formulation="up", material=material, traction=0.1125, margin=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reports = sim.run(1.0, 20, progress=False)
    return {
        "J2 Cook tip": scenes.tip_deflection(sim),
        "J2 Cook max Newton iterations": max(r.newton_iterations for r in reports),
        "J2 Cook max plastic strain": float(sim.points.history["plastic_strain"].max()),
    }


SCENES = {
    f.__name__: f for f in (collapse_a3, collapse_dt40, footing, cook_x5, cook_x10, cook_plastic)
}

#: The suite's bounds on each quantity (inf where the test sets none).
BOUNDS = [
    Quantity("runout error", -0.122, 0.122, "collapse a = 3"),
    Quantity("final_height error", -0.064, 0.064, "collapse a = 3"),
    Quantity("t_inf_cell error", -0.166, 0.166, "collapse a = 3"),
    Quantity("runout 40 ms / 10 ms", 0.75, 1.25, "Δt = 40 ms collapse (the old test)"),
    Quantity("height 40 ms / 10 ms", 0.95, 1.05, "Δt = 40 ms collapse (the old test)"),
    Quantity("q/c_u at s/B = 0.3", 2 + np.pi, np.inf, "footing, 100 steps"),
    Quantity("x5: 40 steps / 1 step", 1.0, 1.25, "Cook ×5"),
    Quantity("x10: 40 steps / 1 step", 1.0, 1.25, "Cook ×10"),
    Quantity("J2 Cook tip", 0.69987 * (1 - 1e-3), 0.69987 * (1 + 1e-3), "elastoplastic Cook"),
    Quantity("J2 Cook max Newton iterations", -np.inf, 8.5, "elastoplastic Cook"),
]


def run_member(scene: str, member: int) -> dict:
    """One member of one scene, in this process."""
    _install(member)
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)
        return SCENES[scene]()


def main() -> None:
    """Run the ensembles and print the table."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--members", type=int, default=6)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    p.add_argument(
        "--blas-cores",
        nargs="*",
        default=[],
        metavar="CORE",
        help="extra unperturbed members, each with OpenBLAS's kernels for "
        "another processor (OPENBLAS_CORETYPE, e.g. Haswell Sandybridge)",
    )
    p.add_argument("--csv", type=Path, help="write every member's values here")
    p.add_argument("--member", nargs=2, metavar=("SCENE", "K"), help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.member:
        print(json.dumps(run_member(args.member[0], int(args.member[1]))))
        return

    def launch(job):
        scene, k, core = job
        env = os.environ | ({"OPENBLAS_CORETYPE": core} if core else {})
        out = subprocess.run(
            [sys.executable, __file__, "--member", scene, str(k)],
            capture_output=True,
            text=True,
            env=env,
        )
        member = core or str(k)
        if out.returncode != 0:
            return scene, member, {"failed": out.stderr.strip().splitlines()[-1:]}
        return scene, member, json.loads(out.stdout.strip().splitlines()[-1])

    jobs = [(s, k, None) for s in args.scenes for k in range(args.members)]
    jobs += [(s, 0, core) for s in args.scenes for core in args.blas_cores]
    with ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(launch, jobs))
    values: dict[str, list[float]] = {}
    rows = []
    for scene, k, result in results:
        if "failed" in result:
            print(f"{scene} member {k} stopped: {result['failed']}")
            continue
        for name, v in result.items():
            values.setdefault(name, []).append(v)
            rows.append((scene, k, name, v))
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            csv.writer(f).writerows([("scene", "member", "quantity", "value"), *rows])
    bounds = {b.name: b for b in BOUNDS}
    print(
        f"{'quantity':<34}{'n':>3}{'mean':>10}{'spread':>10}{'min':>10}{'max':>10}"
        f"{'bound':>18} {'spreads':>9}"
    )
    for name, v in values.items():
        v = np.array(v, dtype=float)
        mean, spread = v.mean(), v.std(ddof=1) if v.size > 1 else 0.0
        line = f"{name:<34}{v.size:>3}{mean:>10.4g}{spread:>10.2g}{v.min():>10.4g}{v.max():>10.4g}"
        if name in bounds:
            b = bounds[name]
            gap = min(mean - b.low, b.high - mean)
            line += f"{f'({b.low:.3g}, {b.high:.3g})':>18}"
            line += f" {gap / spread:>9.3g}" if spread > 0 else f" {'exact':>9}"
        print(line)


if __name__ == "__main__":
    main()
