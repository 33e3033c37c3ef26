# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # An elastic column under its own weight
#
# A plane-strain column of height L on a rigid base, laterally confined (rollers
# on the sides), ν = 0. This demo illustrates how to:
#
# - build a column grid with gmsh (`fe_mpm.meshes.column`),
# - ramp gravity over quasi-static load steps (`body_force_scale`),
# - run the same scene as an implicit Newmark dynamic analysis (`dynamic=True`),
# - read the base reaction every step (`reactions=`), and
# - measure the error against closed-form solutions.
#
# **Quasi-static.** Equilibrium gives σ_yy = −ρ₀ g (L − Y) exactly, for any
# material law (Y is the initial height). The error is AMPLE's measure,
# Σ_p |σ_yy,p − σ(Y_p)| V_p / (ρ₀ g L Σ_p V_p).
#
# **Dynamic.** Gravity is applied suddenly at t = 0. Small-strain theory gives the
# top displacement
# u(L, t) = −(16 g L²/(c² π³)) Σ_n (−1)ⁿ (1 − cos ω_n t)/(2n+1)³, with
# c = √(E/ρ) and ω_n = (2n+1)π c/(2L) (Tielen et al.). The error is the largest
# deviation over the run, relative to the static top displacement ρ g L²/(2E).
#
# With many load steps the points cross cells and the stress error of standard MPM
# stalls near 5 %; `--point-domains` makes it converge at first order
# (`docs/cell_crossing.md`).
#
# Usage: `python demos/elastic_column.py --ny 32 --steps 10 [--point-domains] --json`, or
# `--dynamic --steps 80` (40 steps a period; with fewer than 10 a period only
# boundedness is checked).

# +
import time

START = time.perf_counter()

import argparse
import json
import sys

import numpy as np

import fe_mpm
from fe_mpm import meshes, parallel
from fe_mpm.cli import nonnegative, positive


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="Elastic column under self-weight")
    p.add_argument("--ny", type=positive(int), default=32, help="cells over the height")
    p.add_argument("--steps", type=positive(int), default=1, help="load steps (or time steps)")
    # Defaults: quasi-static, AMPLE's column at 10 % base strain (the stress
    # reference holds at any strain); dynamic, Tielen et al.'s column at 0.25 %
    # strain, where the small-strain series applies.
    p.add_argument(
        "--height", type=positive(float), default=None, help="L (m): 50 static, 25 dynamic"
    )
    p.add_argument("--E", type=positive(float), default=None, help="Pa: 4e5 static, 5e4 dynamic")
    p.add_argument(
        "--density", type=positive(float), default=None, help="kg/m³: 80 static, 1 dynamic"
    )
    p.add_argument(
        "--gravity", type=positive(float), default=None, help="m/s²: 10 static, 9.81 dynamic"
    )
    p.add_argument("--dynamic", action="store_true", help="sudden self-weight, Newmark")
    p.add_argument(
        "--periods", type=positive(float), default=2.0, help="dynamic: first-mode periods"
    )
    p.add_argument(
        "--mass",
        choices=("consistent", "lumped"),
        default="consistent",
        help="dynamic: mass matrix of the points",
    )
    p.add_argument(
        "--damping",
        type=nonnegative(float),
        default=0.0,
        help="dynamic: mass-proportional Rayleigh damping α (1/s)",
    )
    p.add_argument("--mp-per-cell", type=positive(int), default=1)
    p.add_argument(
        "--point-domains",
        action="store_true",
        help="spread each point over the cells its domain covers (docs/cell_crossing.md)",
    )
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
parallel.print_on_rank_zero()  # every rank runs this script; one prints
defaults = (25.0, 5e4, 1.0, 9.81) if args.dynamic else (50.0, 4e5, 80.0, 10.0)
L, E, ρ, g = (
    d if v is None else v
    for v, d in zip((args.height, args.E, args.density, args.gravity), defaults)
)
# -

# ## Scene and simulation

# +
try:
    scene = meshes.column(1.0, L, 1, args.ny, margin=0)
    points = fe_mpm.seed(scene.mesh, per_cell=args.mp_per_cell, density=ρ)
    sim = fe_mpm.Simulation(
        scene.mesh,
        points,
        fe_mpm.NeoHookean(E, 0.0, ρ),
        facet_tags=scene.facet_tags,
        dirichlet=[
            fe_mpm.Dirichlet(meshes.COLUMN_BASE, component=1),
            fe_mpm.Dirichlet(meshes.COLUMN_SIDES, component=0),
        ],
        body_force=(0.0, -g),
        body_force_scale=None if args.dynamic else (lambda t: t),
        dynamic=args.dynamic,
        **({"mass": args.mass, "damping": args.damping} if args.dynamic else {}),
        reactions={"base": meshes.COLUMN_BASE},
        point_domains=args.point_domains,
    )
except ValueError as err:
    sys.exit(f"elastic_column.py: {err}")
sim.add_marker("top", (0.5, L))
c = np.sqrt(E / ρ)
period = 4 * L / c  # first mode of a fixed-free bar
t_end = args.periods * period if args.dynamic else 1.0
reports = sim.run(t_end=t_end, n_steps=args.steps, progress=not args.json)
# -

# ## Error against the closed forms

# +
Y = points.x0[:, 1]
if args.dynamic:
    n = np.arange(200)
    ω = (2 * n + 1) * np.pi * c / (2 * L)
    t = np.array([r.t for r in reports])
    u_top = np.array([r.markers["top"][1] - L for r in reports])
    series = ((-1.0) ** n / (2 * n + 1) ** 3 * (1 - np.cos(np.outer(t, ω)))).sum(axis=1)
    exact = -16 * g * L**2 / (c**2 * np.pi**3) * series
    error = float(np.abs(u_top - exact).max() / (ρ * g * L**2 / (2 * E)))
else:
    σ_exact = -ρ * g * (L - Y)
    comm = scene.mesh.comm  # each rank holds its cells' points: sum over the ranks
    misfit = parallel.total(comm, np.sum(np.abs(points.stress[:, 1, 1] - σ_exact) * points.volume))
    error = float(misfit / (ρ * g * L * parallel.total(comm, points.volume.sum())))
wall = time.perf_counter() - START
print(
    f"Elastic column ({'dynamic' if args.dynamic else 'quasi-static'}): ny = {args.ny}, "
    f"{len(reports)} steps, {parallel.total(scene.mesh.comm, len(points))} points"
)
print(
    f"  error = {error:.3e}; base reaction {reports[-1].reactions['base'][1]:.6g} N "
    f"(weight {ρ * g * L:.6g} N)"
)
print(
    f"  Newton iterations per step: mean {np.mean([r.newton_iterations for r in reports]):.2f}; "
    f"wall time {wall:.2f} s"
)
# -

# ## Check against the reference
#
# The error must stay below a tolerance that follows the discretisation:
#
# - quasi-static, one load step: first order in the cell size h = L/ny (measured
#   0.166 h/L with one point per triangle, at its centroid, and 0.272–0.278 h/L with
#   three or six, spread over the cell; ny = 4 to 64);
# - quasi-static, several load steps: the points cross cells, and standard MPM's
#   cell-crossing error does not fall with h (measured 3.4–5.9 % for 2 to 20 steps,
#   ny = 16 to 64, one or three points per triangle);
# - dynamic: first order in the time step Δt over the first-mode period T (measured
#   2.9–3.8 Δt/T from 10 to 80 steps per period, ny = 8 to 32), plus the grid's share
#   (0.025 at ny = 32 with 160 steps per period). With fewer than 10 steps a period
#   the answer is only bounded (the largest deviation 1.81–2.01 static tops with 1
#   to 5 steps a period; 2026-12-07: the first-order tolerance failed at 3 and 5,
#   1.95 against 1.70 and 1.19 against 1.03), and so is the tolerance. The series is
#   for an undamped column: with `--damping` there is nothing to check against.

# +
#: Quasi-static, one load step: tolerance per h/L.
STATIC_PER_CELL = 0.35
#: Quasi-static, several load steps: tolerance for the cell-crossing error.
STATIC_CROSSING = 0.08
#: Dynamic: tolerance per Δt/T, and for the grid.
DYNAMIC_PER_STEP, DYNAMIC_GRID = 5.0, 0.03
#: Dynamic with fewer than 10 steps a period: the bound on the largest deviation.
DYNAMIC_BOUNDED, DYNAMIC_RESOLVED = 2.1, 10

if args.dynamic and args.damping != 0.0:
    tolerance = None
elif args.dynamic and args.steps < DYNAMIC_RESOLVED * args.periods:
    tolerance = DYNAMIC_BOUNDED
    basis = f"fewer than {DYNAMIC_RESOLVED} steps a period: only bounded"
elif args.dynamic:
    tolerance = float(DYNAMIC_PER_STEP * (t_end / args.steps) / period + DYNAMIC_GRID)
    basis = f"{DYNAMIC_PER_STEP:g} Δt/T + {DYNAMIC_GRID:g}"
elif args.steps == 1:
    tolerance = STATIC_PER_CELL / args.ny
    basis = f"{STATIC_PER_CELL:g} h/L"
else:
    tolerance = STATIC_CROSSING
    basis = "cell crossing over several steps"
passed = None if tolerance is None else bool(error <= tolerance)  # None: not checked
if tolerance is None:
    print("check: Tielen et al.'s series is for an undamped column: not checked")
else:
    print(
        f"check: error = {error:.3e} vs "
        f"{'Tielen et al.' if args.dynamic else 'σ_yy = −ρ₀g(L − Y)'} (ny = {args.ny}, "
        f"{args.steps} step{'s' * (args.steps > 1)}): {'<=' if passed else '>'} "
        f"{tolerance:.3e} tolerance ({basis}): {'PASS' if passed else 'FAIL'}"
    )
if args.json:
    print(
        json.dumps(
            {
                "error": error,
                "wall_time_s": wall,
                "steps": len(reports),
                "n_particles": parallel.total(scene.mesh.comm, len(points)),
                "dynamic": args.dynamic,
                "ny": args.ny,
                "newton_iterations": [r.newton_iterations for r in reports],
                "check_tolerance": tolerance,
                "check_passed": passed,
            }
        )
    )
if passed is False:
    sys.exit(f"elastic_column.py: error {error:.3e} over the tolerance {tolerance:.3e}")
# -
