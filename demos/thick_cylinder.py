# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # A thick-walled cylinder under internal pressure
#
# A long tube of inner radius a and outer radius b is pressurised from inside: the
# classic check of an elastic–plastic code (Hill 1950, *The Mathematical Theory of
# Plasticity*, the thick-walled tube; Lamé for the elastic tube). This demo illustrates how to:
#
# - load a curved face with a normal pressure (`fe_mpm.Pressure`: −p n on each
#   grid facet, which one traction vector cannot do),
# - build a grid of your own shape with a margin around the body
#   (`meshes.quarter_ring`: the circle r = b is a grid line, empty cells beyond it),
# - hold symmetry lines and read their reactions, and
# - follow a point of the body with a marker.
#
# **References.** Plane strain, a quarter of the tube. For an incompressible,
# elastic–perfectly plastic von Mises solid with k = σ_Y/√3 and shear modulus G,
# the tube yields first at r = a under p_e = k (1 − a²/b²), and with the plastic
# zone reaching r = c (a ≤ c ≤ b)
#
#   p(c) = k (1 − c²/b² + 2 ln(c/a)),    u(a) = k c² / (2 G a),
#
# up to the limit pressure p_lim = 2 k ln(b/a) when c = b; below p_e, u(a) = p a b²
# / (2 G (b² − a²)). The elastic tube of any ν (`--law elastic`) follows Lamé:
# u(r) = (1 + ν) a² p / (E (b² − a²)) ((1 − 2ν) r + b²/r). Small strains: the load
# stops at `--load` × p_lim (0.95), where u(a)/a is a few σ_Y/E.
#
# Usage: `python demos/thick_cylinder.py --formulation up --json`.

# +
import time

START = time.perf_counter()

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import fe_mpm
from fe_mpm import meshes, parallel
from fe_mpm.plotting import pyplot


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="Thick-walled cylinder under internal pressure")
    p.add_argument("--formulation", choices=("u", "up", "u-nbva", "up-p2p1"), default="up")
    p.add_argument("--law", choices=("j2", "elastic"), default="j2")
    p.add_argument("--inner", type=float, default=0.1, help="inner radius a (m)")
    p.add_argument("--outer", type=float, default=0.2, help="outer radius b (m)")
    p.add_argument("--E", type=float, default=200e9, help="Young's modulus (Pa)")
    p.add_argument("--nu", type=float, default=0.4999, help="Poisson's ratio")
    p.add_argument("--yield-stress", type=float, default=250e6, help="σ_Y (Pa)")
    p.add_argument("--load", type=float, default=0.95, help="last pressure / p_lim")
    p.add_argument("--h", type=float, default=None, help="cell size (m); default a/10")
    p.add_argument("--points-per-cell", type=int, default=3)
    p.add_argument("--steps", type=int, default=20, help="load steps")
    p.add_argument("--point-domains", action="store_true", help="point_domains=True")
    p.add_argument("--output", default="thick_cylinder_output", help="output folder")
    p.add_argument("--no-output", action="store_true", help="write no files")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
rank0 = parallel.print_on_rank_zero()  # every rank runs this script; one prints
if not 0.0 < args.load < 1.0:  # Hill's tube expands without bound at p_lim
    sys.exit(f"thick_cylinder.py: --load must lie in (0, 1), got {args.load}")
if args.h is not None and not 0.0 < args.h <= args.outer - args.inner:
    sys.exit(f"thick_cylinder.py: --h must lie in (0, b - a], got {args.h}")
a, b = args.inner, args.outer
k = args.yield_stress / np.sqrt(3.0)
G = args.E / (2.0 * (1.0 + args.nu))
p_lim = 2.0 * k * np.log(b / a)
p_end = args.load * p_lim
# -

# ## The references
#
# Hill's curve is parametrised by the plastic radius c; a pressure's c is found by
# bisection (p(c) rises monotonically from p_e to p_lim).


# +
def hill_expansion(p: float) -> float:
    """Inner-face displacement u(a) (m) of the incompressible tube under pressure p (Pa)."""
    if p <= k * (1.0 - a**2 / b**2):
        return p * a * b**2 / (2.0 * G * (b**2 - a**2))
    lo, hi = a, b
    for _ in range(200):
        c = 0.5 * (lo + hi)
        if k * (1.0 - c**2 / b**2 + 2.0 * np.log(c / a)) < p:
            lo = c
        else:
            hi = c
    return k * c**2 / (2.0 * G * a)


def lame_expansion(p: float) -> float:
    """Inner-face displacement u(a) (m) of the elastic tube under pressure p (Pa)."""
    return (1 + args.nu) * a**2 * p / (args.E * (b**2 - a**2)) * ((1 - 2 * args.nu) * a + b**2 / a)


reference = hill_expansion if args.law == "j2" else lame_expansion
# -

# ## Scene and simulation
#
# The pressure acts on the grid's inner arc; the symmetry lines hold the normal
# displacement. The load rises linearly in the pseudo-time t ∈ [0, 1].

# +
try:
    scene = meshes.quarter_ring(a, b, a / 10 if args.h is None else args.h)
    if args.law == "j2":
        material = fe_mpm.J2Plasticity(args.E, args.nu, args.yield_stress, 0.0, 7800.0)
    else:
        material = fe_mpm.NeoHookean(args.E, args.nu, 7800.0)
    points = fe_mpm.seed(
        scene.mesh, per_cell=args.points_per_cell, cells=scene.cell_tags.find(meshes.RING_BODY)
    )
    sim = fe_mpm.Simulation(
        scene.mesh,
        points,
        material,
        args.formulation,
        facet_tags=scene.facet_tags,
        tractions=[fe_mpm.Pressure(meshes.RING_INNER, p_end, scale=lambda t: t)],
        dirichlet=[
            fe_mpm.Dirichlet(meshes.RING_X_AXIS, component=1),
            fe_mpm.Dirichlet(meshes.RING_Y_AXIS, component=0),
        ],
        reactions={"x_axis": meshes.RING_X_AXIS},
        point_domains=args.point_domains,
        output_dir=None if args.no_output else args.output,
        output_every=max(1, args.steps // 10),
    )
    # On the inner face, between the symmetry lines: its radial displacement is u(a).
    sim.add_marker("inner", (a * np.cos(np.pi / 8), a * np.sin(np.pi / 8)))
    reports = sim.run(t_end=1.0, n_steps=args.steps, progress=not args.json)
except (ValueError, fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"thick_cylinder.py: {err}")
# -

# ## Pressure against expansion
#
# The reaction on the line y = 0 balances the pressure's pull on the quarter:
# exactly p a for any polygon of the arc between (a, 0) and (0, a).

# +
pressure = np.array([p_end * r.t for r in reports])
expansion = np.array([np.linalg.norm(r.markers["inner"]) - a for r in reports])
expected = np.array([reference(p) for p in pressure])
errors = expansion / expected - 1.0
balance = max(abs(-r.reactions["x_axis"][1] / (p_end * r.t * a) - 1.0) for r in reports)
iterations = [r.newton_iterations for r in reports]
wall = time.perf_counter() - START
name = "Hill" if args.law == "j2" else "Lamé"
print(
    f"Thick cylinder, {args.law}, {args.formulation}, ν = {args.nu}: "
    f"{parallel.total(scene.mesh.comm, len(points))} points, {len(reports)} steps"
)
print(f"  p_lim = 2 k ln(b/a) = {p_lim:.6g} Pa; last pressure {pressure[-1] / p_lim:.3f} p_lim")
print(f"  u(a) at the last step {expansion[-1]:.6g} m; {name} {expected[-1]:.6g} m")
print(f"  largest error against {name} over the steps {np.abs(errors).max():.2%}")
print(f"  reaction on y = 0 against p a: largest relative difference {balance:.1e}")
print(
    f"  Newton iterations per step: max {max(iterations)}, mean {np.mean(iterations):.2f}; "
    f"wall time {wall:.2f} s"
)

if not args.no_output and rank0:
    plt = pyplot()  # None without matplotlib (the plots extra)
    out = Path(args.output)
    np.savetxt(
        out / "pressure_expansion.csv",
        np.column_stack([pressure, expansion, expected]),
        delimiter=",",
        header=f"pressure_Pa,inner_displacement_m,{name.lower()}_m",
        comments="",
    )
    if plt is not None:
        fig, ax = plt.subplots(figsize=(5, 3.5))
        fine = np.linspace(0.0, pressure[-1], 200)
        scale = 2.0 * G / (k * a)  # u(a) in units of k a / (2 G)
        ax.plot([reference(p) * scale for p in fine], fine / p_lim, "k-", lw=1, label=name)
        ax.plot(expansion * scale, pressure / p_lim, "o", ms=4, label=f"fe-mpm {args.formulation}")
        ax.set_xlabel("2 G u(a) / (k a)")
        ax.set_ylabel("p / p_lim")
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "pressure_expansion.png", dpi=120)
        print(f"  wrote {out}/particles.pvd, pressure_expansion.csv and .png")
# -

# ## Check against the reference
#
# Every step's u(a) must lie within `TOLERANCE` of the reference. Measured with the
# defaults (h = a/10, 3 points per cell, 20 steps; 2026-12-06): u-p 0.72 % (0.74 and
# 0.71 % with 10 and 40 steps, 0.16 % on h = a/20, the same on two ranks), largest
# just past the first yield; `u-nbva` 0.87 %; the u form locks (65 %). Taylor–Hood
# (`up-p2p1`) is 30 % too soft near p_lim once its points have left their Gauss
# positions, and 0.61 % with `--point-domains --points-per-cell 1` (see
# docs/cell_crossing.md on P2/P1). The elastic tube (`--law elastic`): u-p 0.38 %, u
# at ν = 0.3 0.65 %, u at ν = 0.4999 48 % (locked). Hill's curve is for an
# incompressible solid, so it is checked for ν ≥ 0.499 only.

# +
#: Largest relative error of u(a) over the steps that passes.
TOLERANCE = 0.01

check_error = float(np.abs(errors).max())
if args.law == "j2" and args.nu < 0.499:
    passed = None  # not checked
    print("check: Hill's curve is for an incompressible tube (ν ≥ 0.499): not checked")
else:
    passed = bool(check_error <= TOLERANCE)
    print(
        f"check: u(a) against {name} ({args.formulation}): largest error "
        f"{100 * check_error:.2f} % {'<=' if passed else '>'} {100 * TOLERANCE:g} % "
        f"tolerance: {'PASS' if passed else 'FAIL'}"
    )
if args.json:
    print(
        json.dumps(
            {
                "inner_displacement": float(expansion[-1]),
                "reference_inner_displacement": float(expected[-1]),
                "largest_relative_error": check_error,
                "limit_pressure": p_lim,
                "last_pressure": float(pressure[-1]),
                "reaction_balance": balance,
                "newton_iterations": iterations,
                "wall_time_s": wall,
                "steps": len(reports),
                "n_particles": parallel.total(scene.mesh.comm, len(points)),
                "formulation": args.formulation,
                "law": args.law,
                "nu": args.nu,
                "check_passed": passed,
            }
        )
    )
if passed is False:
    sys.exit(f"thick_cylinder.py: u(a) is {100 * check_error:.2f} % from {name}")
# -
