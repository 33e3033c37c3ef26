# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # Rigid strip footing on a cohesive-frictional soil, in u-p and in u
#
# The strip footing of `demos/strip_footing.py` on weightless Mohr-Coulomb soil
# with cohesion and friction, c = 10 kPa and φ = 20°. Its small-strain bearing
# capacity is exact for associated flow (Prandtl 1921, Reissner 1924):
#
# q / c = N_c = (N_q − 1) cot φ,   N_q = e^{π tan φ} tan²(45° + φ/2),
#
# 14.83 at φ = 20°, rough and smooth alike. Plastic flow in the u form's linear
# triangles is held to a fixed ratio of volume change to shear, which locks them
# (the collapse load overshoots, as for Tresca soil). The u-p form runs the frictional
# law at the mean stress of its pressure field. This demo illustrates how to:
#
# - give `fe_mpm.scenes.strip_footing` a law of your own (`material=`),
# - run a pressure-dependent law in the u-p form (`fe_mpm.MohrCoulomb` with φ > 0,
#   or `fe_mpm.DruckerPrager` with `--law drucker-prager`): the law returns at the
#   field's pressure, with the plastic volume change in the pressure equation
#   (`fe_mpm.materials.mixed_return`),
# - compare a run with the closed-form collapse load.
#
# **Data.** c = 10 kPa, φ = ψ = 20° (associated; `--dilatancy-angle` changes ψ),
# E = 10 MPa (E/c = 1000, so the capacity is reached by s/B ≈ 0.05), ν = 0.3,
# footing B = 1 m, rough. Domain 5B × 5B, rollers on the sides, fixed base.
#
# Usage: `python demos/strip_footing_frictional.py [--formulation up|u] [--h 0.1]
# [--steps 10] [--settlement 0.1] [--law mohr-coulomb|drucker-prager] [--json]`.

# +
import time

START = time.perf_counter()

import argparse
import json
import math
import sys

import numpy as np

import fe_mpm
from fe_mpm import parallel, scenes


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="Rigid strip footing on c-φ soil")
    p.add_argument("--formulation", choices=("u", "up"), default="up")
    p.add_argument("--law", choices=("mohr-coulomb", "drucker-prager"), default="mohr-coulomb")
    p.add_argument("--steps", type=int, default=10, help="load steps")
    p.add_argument("--settlement", type=float, default=0.1, help="final settlement (m)")
    p.add_argument("--h", type=float, default=0.1, help="cell size near the footing (m)")
    p.add_argument("--points-near", type=int, default=6, help="points per cell near it")
    p.add_argument("--cohesion", type=float, default=10e3, help="c (Pa)")
    p.add_argument("--friction-angle", type=float, default=20.0, help="φ (degrees)")
    p.add_argument("--dilatancy-angle", type=float, default=None, help="ψ (degrees); φ by default")
    p.add_argument("--E", type=float, default=10e6, help="Young's modulus (Pa)")
    p.add_argument("--nu", type=float, default=0.3, help="Poisson's ratio")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
parallel.print_on_rank_zero()  # every rank runs this script; one prints
psi = args.friction_angle if args.dilatancy_angle is None else args.dilatancy_angle
# -

# ## The law and the scene
#
# `match="plane strain"` puts the Drucker–Prager cone through Mohr-Coulomb's
# plane-strain collapse stress for associated flow, so both laws have the same N_c.

# +
strength = dict(cohesion=args.cohesion, friction_angle=args.friction_angle, dilatancy_angle=psi)
try:
    if args.law == "mohr-coulomb":
        soil = fe_mpm.MohrCoulomb(args.E, args.nu, **strength)
    else:
        soil = fe_mpm.DruckerPrager(args.E, args.nu, **strength, match="plane strain")
    sim = scenes.strip_footing(
        args.formulation,
        E=args.E,
        nu=args.nu,
        h=args.h,
        points_near=args.points_near,
        settlement=args.settlement,
        material=soil,
        output_dir=None,
    )
    reports = sim.run(t_end=1.0, n_steps=args.steps, progress=not args.json)
except (ValueError, fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"strip_footing_frictional.py: {err}")
# -

# ## Load against settlement, and the check
#
# q is the footing force over the half-width. Once the capacity is mobilised, q/c
# stays near a plateau; its mean over 0.06 ≤ s/B ≤ 0.1 is compared with N_c.
# Measured (associated flow, 10 steps): u-p +7.4 % on h = 0.1 B and +16.2 % on
# h = 0.2 B, u +24.2 % and +38.5 % (the locking). The band, −5 % to +20 %, leaves
# room for the coarse grid's overestimate at the footing's edge, which fe-mpm's
# Tresca footing shows too (in u-p, +12 % on h = 0.1 and +35 % on h = 0.2 at small
# settlement: issue 20).

# +
B = 1.0
s_over_B = np.array([args.settlement * r.t for r in reports]) / B
q_over_c = np.array([scenes.footing_pressure(r, B) for r in reports]) / args.cohesion
t = math.tan(math.radians(args.friction_angle))
N_q = math.exp(math.pi * t) * math.tan(math.radians(45.0 + args.friction_angle / 2.0)) ** 2
N_c = (N_q - 1.0) / t if t > 0.0 else 2.0 + math.pi
iterations = [r.newton_iterations for r in reports]
wall = time.perf_counter() - START
print(
    f"Strip footing on c-φ soil ({args.law}, {args.formulation}): φ = {args.friction_angle:g}°, "
    f"ψ = {psi:g}°, {parallel.total(sim.mesh.comm, len(sim.points))} points, "
    f"{len(reports)} steps, wall time {wall:.1f} s"
)
for s, q in zip(s_over_B, q_over_c):
    print(f"  s/B = {s:6.4f}  q/c = {q:7.3f}")
print(
    f"  Newton iterations per step: max {max(iterations)}, mean {np.mean(iterations):.1f}; "
    f"return map {sim.timings.get('return_map', 0.0):.1f} s of {wall:.1f} s"
)

WINDOW, LOWER, UPPER = (0.06, 0.1), -0.05, 0.20
in_window = (s_over_B >= WINDOW[0] - 1e-9) & (s_over_B <= WINDOW[1] + 1e-9)
associated = psi == args.friction_angle
if not (in_window.any() and associated):
    plateau, error, passed = None, None, None  # not checked
    print(f"check: N_c holds for associated flow with steps in {WINDOW}: not checked")
else:
    plateau = float(q_over_c[in_window].mean())
    error = plateau / N_c - 1.0
    passed = bool(LOWER <= error <= UPPER)
    print(
        f"check: mean q/c over {WINDOW[0]} ≤ s/B ≤ {WINDOW[1]} = {plateau:.3f} vs N_c = "
        f"{N_c:.3f} ({args.formulation}): error {100 * error:+.1f} % "
        f"{'within' if passed else 'outside'} [{100 * LOWER:+.0f} %, {100 * UPPER:+.0f} %]: "
        f"{'PASS' if passed else 'FAIL'}"
    )
if args.json:
    print(
        json.dumps(
            {
                "formulation": args.formulation,
                "law": args.law,
                "friction_angle": args.friction_angle,
                "dilatancy_angle": psi,
                "settlement_over_B": s_over_B.tolist(),
                "q_over_c": q_over_c.tolist(),
                "N_c": N_c,
                "plateau": plateau,
                "check_error": error,
                "newton_iterations": iterations,
                "timings": sim.timings,
                "wall_time_s": wall,
                "check_passed": passed,
            }
        )
    )
# Only u-p is held to the band: u locks, which is what the demo shows.
if passed is False and args.formulation == "up":
    sys.exit(f"strip_footing_frictional.py: the plateau is {100 * error:+.1f} % off N_c")
# -
