# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # A vibrating cantilever near incompressibility (Mast 2013, §6.2.1)
#
# An elastic cantilever, L = 10 m long and H = 1 m deep, clamped at x = 0, is set
# swinging in its first mode and left alone. Beam theory gives its period and, from
# the initial velocity, its amplitude. Mast used it to show volumetric locking: as
# Poisson's ratio approaches ½ (his Table 6.4, E = 70 GPa held), the plain
# displacement form of MPM stiffens, its amplitude falls and its period shortens,
# while an anti-locking form keeps both. This demo illustrates how to:
#
# - give the points an initial velocity field (`points.velocity`), here the first
#   bending mode;
# - choose the formulation against locking: `"u"` (plain, locks), `"u-nbva"` (the
#   displacement form with Mast's node-based volumetric averaging,
#   `fe_mpm.forms.volume_average`) or `"up"` (the pressure field with PPP);
# - fit a sine to a marker's history, Mast's Eq. 6.5, and compare it with Eq. 6.6.
#
# **Data** (Mast §6.2–6.2.1): ρ = 2710 kg/m³, E = 70 GPa, ν from Table 6.4 (0 to
# 0.49), plane strain, cells of h = 0.125 m (8 across the depth), one period. Mast
# gave no amplitude; here the tip swings by H/100, so the motion stays linear. Mast
# ran an explicit code with Δt = 5 µs; the implicit Newmark rule takes 100 steps a
# period (its period error, (ωΔt)²/12, is 3e-4).
#
# **Reference.** Euler–Bernoulli theory for the clamped-free beam in plane strain:
# ω₁ = (β₁L)² √(E' I / (ρ A)) / L², with β₁L = 1.8751, E' = E/(1 − ν²), I/A = H²/12;
# the tip's amplitude is v₀/ω₁ for an initial tip velocity v₀ in the mode
# φ₁(x) = cosh β₁x − cos β₁x − σ₁ (sinh β₁x − sin β₁x). The theory neglects shear
# deformation and rotary inertia, which lengthen the period slightly at L/H = 10.
#
# Usage: `python demos/locking_beam.py --nu 0.49 --formulation u-nbva --json`, or
# `--sweep` for Table 6.4 in the three formulations (about two minutes).

# +
import time

START = time.perf_counter()

import argparse
import json
import math
import sys
from pathlib import Path

from mpi4py import MPI

import numpy as np

import fe_mpm
from fe_mpm import parallel
from fe_mpm.cli import positive
from fe_mpm.meshes import cell_centroids, rectangle_mesh
from fe_mpm.plotting import pyplot

#: Mast's Table 6.4: Poisson's ratios at E = 70 GPa held.
TABLE_6_4 = (0.0, 0.15, 0.30, 0.40, 0.45, 0.49)
FORMULATIONS = ("u", "u-nbva", "up")
LENGTH, DEPTH, E, DENSITY = 10.0, 1.0, 70e9, 2710.0
BETA_L = 1.8751040687119611  # first root of cos βL cosh βL = −1


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="A vibrating cantilever (Mast 2013, §6.2.1)")
    p.add_argument("--nu", type=float, default=0.49, help="Poisson's ratio, in [0, 0.5)")
    p.add_argument("--formulation", choices=FORMULATIONS, default="u-nbva")
    p.add_argument("--sweep", action="store_true", help="Table 6.4 in all three formulations")
    p.add_argument("--h", type=positive(float), default=0.125, help="cell size (m)")
    p.add_argument("--points-per-cell", type=positive(int), default=3, help="points per triangle")
    p.add_argument("--steps", type=positive(int), default=100, help="time steps in the period")
    p.add_argument("--output", default="locking_beam_output", help="output folder (plot)")
    p.add_argument("--no-output", action="store_true", help="write no files")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
parallel.print_on_rank_zero()  # every rank runs this script; one prints
# The beam is the cells whose centres lie within it: a cell that does not divide the
# depth and length makes another beam than theory's (h = 0.3 m: 0.96 m deep, period
# +4.3 %, which the check charged to the method until 2026-12-06).
for extent, name in ((DEPTH, "depth"), (LENGTH, "length")):
    cells = extent / args.h
    if abs(cells - round(cells)) > 1e-9 * cells:
        sys.exit(
            f"locking_beam.py: --h {args.h} must divide the beam's {name} {extent:g} m "
            "(e.g. 0.25, 0.125, 0.0625)"
        )
# -

# ## Beam theory

# +
beta = BETA_L / LENGTH
sigma = (math.cosh(BETA_L) + math.cos(BETA_L)) / (math.sinh(BETA_L) + math.sin(BETA_L))


def mode(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The first mode φ₁(x) and its slope φ₁'(x) (1/m), scaled to φ₁(L) = 1."""
    b = beta * x
    scale = math.cosh(BETA_L) - math.cos(BETA_L) - sigma * (math.sinh(BETA_L) - math.sin(BETA_L))
    phi = np.cosh(b) - np.cos(b) - sigma * (np.sinh(b) - np.sin(b))
    slope = beta * (np.sinh(b) + np.sin(b) - sigma * (np.cosh(b) - np.cos(b)))
    return phi / scale, slope / scale


def beam_theory(nu: float) -> tuple[float, float]:
    """The first circular frequency ω₁ (rad/s) and the tip amplitude A (m) of the swing."""
    stiffness = E / (1.0 - nu**2) * DEPTH**3 / 12.0  # E'I per unit width (N m)
    omega = BETA_L**2 * math.sqrt(stiffness / (DENSITY * DEPTH)) / LENGTH**2
    return omega, DEPTH / 100.0


# -

# ## The swing in MPM
#
# The grid has one row of empty cells above, below and beyond the beam; its
# left edge is clamped. The points start undeformed with the mode's velocity:
# v_y = v₀ φ₁(x), and v_x = −y v₀ φ₁'(x) from the rotation of the sections.


# +
def fit_sine(t: np.ndarray, y: np.ndarray, omega: float) -> tuple[float, float]:
    """Least-squares A sin(ω t) through (t, y) (Mast's Eq. 6.5): (A, ω) near ``omega``.

    For a given ω the best A is linear; ω is searched on ±50 %, then refined.
    """

    def best(w: float) -> tuple[float, float]:
        s = np.sin(w * t)
        a = float(s @ y / (s @ s))
        return a, float(np.sum((a * s - y) ** 2))

    w, span = omega, 0.5
    for _ in range(4):
        trial = w * np.linspace(1.0 - span, 1.0 + span, 1001)
        w = float(trial[np.argmin([best(v)[1] for v in trial])])
        span /= 250.0
    return best(w)[0], w


def swing(nu: float, formulation: str) -> dict:
    """One period of the swing: the fitted amplitude and period against beam theory."""
    omega, amplitude = beam_theory(nu)
    period, h = 2.0 * math.pi / omega, args.h
    n = (round(LENGTH / h) + 1, round(DEPTH / h) + 2)
    grid = rectangle_mesh((0.0, -0.5 * DEPTH - h), (LENGTH + h, 0.5 * DEPTH + h), n)
    centroids = cell_centroids(grid)  # each rank seeds the cells it owns
    beam = np.flatnonzero((centroids[:, 0] < LENGTH) & (np.abs(centroids[:, 1]) < 0.5 * DEPTH))
    points = fe_mpm.seed(grid, args.points_per_cell, density=DENSITY, cells=beam)
    phi, slope = mode(points.x[:, 0])
    v0 = amplitude * omega
    points.velocity[:, 0] = -points.x[:, 1] * v0 * slope
    points.velocity[:, 1] = v0 * phi
    sim = fe_mpm.Simulation(
        grid,
        points,
        fe_mpm.NeoHookean(E, nu),
        formulation,
        dynamic=True,
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0))],
    )
    sim.add_marker("tip", (LENGTH, 0.0))
    t0 = time.perf_counter()
    history = [(0.0, 0.0)]
    for k in range(1, args.steps + 1):
        sim.step(k * period / args.steps)
        history.append((sim.t, float(sim.marker("tip")[1])))
    t, y = np.array(history).T
    fitted_amplitude, fitted_omega = fit_sine(t, y, omega)
    return {
        "nu": nu,
        "formulation": formulation,
        "amplitude_ratio": fitted_amplitude / amplitude,  # Mast's Eq. 6.6
        "period_ratio": omega / fitted_omega,
        "period_s": period,
        "n_particles": parallel.total(grid.comm, len(points)),
        "run_time_s": time.perf_counter() - t0,
        "tip": (t.tolist(), y.tolist()),
    }


if args.sweep:
    cases = [(nu, f) for nu in TABLE_6_4 for f in FORMULATIONS]
else:
    cases = [(args.nu, args.formulation)]
try:
    if not 0.0 <= args.nu < 0.5:
        raise ValueError(f"--nu must lie in [0, 0.5), got {args.nu}")
    runs = []
    for nu, formulation in cases:
        runs.append(swing(nu, formulation))
        r = runs[-1]
        print(
            f"ν = {nu:<5} {formulation:7} amplitude ratio {r['amplitude_ratio']:.4f}, "
            f"period ratio {r['period_ratio']:.4f} ({r['n_particles']} points, "
            f"{args.steps} steps, {r['run_time_s']:.1f} s)"
        )
except (ValueError, fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"locking_beam.py: {err}")
# -

# ## Check against the reference
#
# Mast's criterion (his Fig. 6.11): both ratios within 5 % of 1. Measured on
# h = 0.125 m with three points per triangle: with node-based averaging the
# ratios are 0.993/0.996 at ν = 0.3 and 0.983/0.984 at ν = 0.49 (amplitude/period);
# with u-p 1.007/1.010 and 1.019/1.021; the plain displacement form gives
# 0.975/0.978 at ν = 0.3 and locks at ν = 0.49, 0.78/0.78, which fails. With
# `--sweep` the check is on the two anti-locking forms at every ν of Table 6.4, and
# the plain form's ratios are printed beside them, unchecked.

# +
#: Largest distance of either ratio from 1 that passes (Mast's 5 %).
TOLERANCE = 0.05
checked = [r for r in runs if not args.sweep or r["formulation"] != "u"]
worst = max(checked, key=lambda r: max(abs(r["amplitude_ratio"] - 1), abs(r["period_ratio"] - 1)))
error = max(abs(worst["amplitude_ratio"] - 1.0), abs(worst["period_ratio"] - 1.0))
passed = bool(error <= TOLERANCE)
print(
    f"check: amplitude and period ratios vs beam theory ({len(checked)} run(s); worst "
    f"{worst['formulation']}, ν = {worst['nu']}): error {100 * error:.2f} % "
    f"{'<=' if passed else '>'} {100 * TOLERANCE:g} % tolerance: {'PASS' if passed else 'FAIL'}"
)
if not args.no_output and parallel.on_rank_zero(MPI.COMM_WORLD):
    plt = pyplot()
    if plt is not None:
        out = Path(args.output)
        out.mkdir(parents=True, exist_ok=True)
        panels = 2 if args.sweep else 1
        fig, axes = plt.subplots(1, panels, figsize=(4.5 * panels, 3.5), constrained_layout=True)
        if args.sweep:
            for formulation in FORMULATIONS:
                mine = [r for r in runs if r["formulation"] == formulation]
                for ax, key in zip(axes, ("amplitude_ratio", "period_ratio")):
                    ax.plot(
                        [r["nu"] for r in mine], [r[key] for r in mine], "o-", label=formulation
                    )
            for ax, name in zip(axes, ("amplitude", "period")):
                ax.axhspan(1 - TOLERANCE, 1 + TOLERANCE, color="0.9")
                ax.set(xlabel="Poisson's ratio ν", ylabel=f"{name} / beam theory")
            axes[0].legend()
        else:
            t, y = (np.array(v) for v in runs[0]["tip"])
            omega, amplitude = beam_theory(args.nu)
            axes.plot(t, y, "o", ms=3, label=f"MPM ({args.formulation})")
            axes.plot(t, amplitude * np.sin(omega * t), label="beam theory")
            axes.set(xlabel="t (s)", ylabel="tip deflection (m)", title=f"ν = {args.nu}")
            axes.legend()
        fig.savefig(out / "locking_beam.png", dpi=120)
        print(f"  wrote {out}/locking_beam.png")
if args.json:
    summary = [{k: v for k, v in r.items() if k != "tip"} for r in runs]
    print(
        json.dumps(
            {
                "runs": summary,
                "error": error,
                "wall_time_s": time.perf_counter() - START,
                "check_passed": passed,
            }
        )
    )
if passed is False:
    sys.exit(f"locking_beam.py: a ratio is {100 * error:.2f} % from beam theory")
# -
