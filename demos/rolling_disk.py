# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # A disk rolling down a slope (Iaconeta 2019, §4.5.2)
#
# An elastic disk (E = 200 MPa, ν = 0.3, ρ = 7800 kg/m³, the thesis's) rests on a
# plane inclined at θ and is released. With enough friction (μ ≥ ⅓ tan θ) it rolls
# without slipping, and its centre accelerates at a = ⅔ g sin θ; without friction
# it would slide at g sin θ (`demos/sliding_block.py`). This demo illustrates how to:
#
# - seed a round body from a gmsh disk (`fe_mpm.meshes.disk`) on a grid of its own:
#   the body need not follow the grid's lines;
# - put it on a rigid wall with Coulomb friction (`fe_mpm.RigidWall`), the plane,
#   here the grid's base with gravity tilted by θ;
# - measure the thesis's error, Eq. 4.44: √(Σ_i (s(t_i) − s_h(t_i))²) over the
#   steps, with s = ½ a t² and s_h the centre of mass's slide.
#
# On a grid that sticks to the disk (every node of the plane fixed, the thesis's
# no-slip grid contact) the disk stays glued: the fixed nodes hold the cells around
# the contact, and with them the disk. A wall lets the disk leave the plane behind
# the contact. It still acts on a node before the disk reaches it (the node moves
# as soon as points of the cells around it do), so each node's spring waits until
# the disk has come within its own points' half-width (the wall's gap, see
# `fe_mpm.walls`): without that the disk rode on the nodes ahead of it, rolled 42 %
# short on h = R/10 and rose by 0.8 h.
#
# Usage: `python demos/rolling_disk.py --h 0.01 --json`.

# +
import time

START = time.perf_counter()

import argparse
import json
import math
import sys

import numpy as np

import fe_mpm
from fe_mpm import meshes, parallel
from fe_mpm.cli import between, nonnegative, positive


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="A disk rolling down a slope")
    p.add_argument("--theta", type=between(0.0, 90.0), default=30.0, help="slope angle (degrees)")
    p.add_argument("--radius", type=positive(float), default=0.2, help="disk radius R (m)")
    p.add_argument("--h", type=positive(float), default=0.01, help="cell size of grid and disk (m)")
    p.add_argument(
        "--friction", type=nonnegative(float), default=0.5, help="Coulomb's μ of the plane"
    )
    p.add_argument("--dt", type=positive(float), default=0.005, help="time step (s)")
    p.add_argument("--t-end", type=positive(float), default=0.4, help="duration (s)")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
parallel.print_on_rank_zero()
g, θ, R, h = 9.81, math.radians(args.theta), args.radius, args.h
a_roll = 2.0 / 3.0 * g * math.sin(θ)
if args.friction < math.tan(θ) / 3.0:
    sys.exit(f"rolling_disk.py: μ = {args.friction} < tan θ / 3: the disk would slip")
# -

# ## Scene
#
# The disk touches the plane y = 0 at x = 0.3 m. The grid covers the roll with room
# to spare; the disk's points are seeded in a disk mesh of the same cell size (three
# per triangle) on rank 0, and reach the ranks that own their cells at set-up.

# +
length = 0.3 + R + 0.5 * a_roll * args.t_end**2 + 0.2
nx, ny = math.ceil(length / h), math.ceil((2 * R + 0.1) / h)
grid = meshes.rectangle_mesh((0.0, 0.0), (nx * h, ny * h), (nx, ny))
body = meshes.disk((0.3, R), R, h)
points = fe_mpm.seed(body.mesh, per_cell=3, density=7800.0)
if grid.comm.rank != 0:
    points.keep(np.zeros(len(points), dtype=bool))
plane = fe_mpm.RigidWall("plane", lambda x: np.isclose(x[1], 0.0), friction=args.friction)
try:
    sim = fe_mpm.Simulation(
        grid,
        points,
        fe_mpm.NeoHookean(2e8, 0.3, 7800.0),
        dynamic=True,
        bossak_alpha=0.0,  # the thesis's trapezoidal rule: the disk starts on the plane
        walls=[plane],
        body_force=(g * math.sin(θ), -g * math.cos(θ)),
    )
except ValueError as err:
    sys.exit(f"rolling_disk.py: {err}")
total_mass = parallel.total(grid.comm, float(points.mass.sum()))
start = parallel.total(grid.comm, float(points.mass @ points.x[:, 0])) / total_mass
# -

# ## Roll
#
# After every step: the centre of mass's slide along the plane, and the disk's
# angular velocity ω = L / I about its centre of mass (rolling: ω = −v / R).

# +
history = []


def record(report: fe_mpm.StepReport) -> None:
    """Slide (m), angular and centre velocity after a step."""
    x = parallel.gathered(grid.comm, points.x)
    v = parallel.gathered(grid.comm, points.velocity)
    m = parallel.gathered(grid.comm, points.mass)
    centre = m @ x / m.sum()
    r = x - centre
    spin = np.sum(m * (r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0])) / np.sum(m * (r**2).sum(axis=1))
    history.append((report.t, centre[0] - start, spin, m @ v[:, 0] / m.sum()))


try:
    reports = sim.run(
        args.t_end, max(1, round(args.t_end / args.dt)), progress=not args.json, on_step=record
    )
except fe_mpm.ConvergenceError as err:
    sys.exit(f"rolling_disk.py: {err}")
t, s_h, spin, speed = np.array(history).T
s = 0.5 * a_roll * t**2
error = float(np.sqrt(np.sum((s - s_h) ** 2)))  # Eq. 4.44 over the steps
relative = float(s_h[-1] / s[-1] - 1.0)
rolling = float(-spin[-1] * R / speed[-1])  # 1 when it rolls without slipping
# The contact sticks and slips from step to step, so ωR/v at one instant swings (0.67
# to 1.27 over the second half on R/10): its mean over the second half judges the roll.
late = t >= 0.5 * t[-1]
rolling_mean = float(np.mean(-spin[late] * R / speed[late]))
wall = time.perf_counter() - START
iterations = [r.newton_iterations for r in reports]
n_points = int(parallel.total(grid.comm, len(points)))
print(
    f"Rolling disk: θ = {args.theta}°, R = {R} m, h = {h} m (R/{R / h:.0f}), μ = "
    f"{args.friction}, {n_points} points, {len(reports)} steps, wall time {wall:.1f} s"
)
print(
    f"  slide {s_h[-1]:.5f} m at t = {t[-1]:.3f} s; rolling {s[-1]:.5f} m "
    f"({100 * relative:+.1f} %), sliding {0.5 * g * math.sin(θ) * t[-1] ** 2:.5f} m; "
    f"ωR/v = {rolling:.3f}, its mean over the second half {rolling_mean:.3f}"
)
print(
    f"  Eq. 4.44 error over {t.size} instants: {error:.3g} m; Newton per step mean "
    f"{np.mean(iterations):.2f}, max {max(iterations)}"
)
# -

# ## Check against the reference
#
# The thesis's own MPM errors (Table 4.1: 2.34, 1.27 and 0.91 m of Eq. 4.44 for its
# three time steps) are for a geometry and output instants its text does not give,
# so only their trend compares: they fall with the time step, and ours falls with the
# grid. Measured (Δt = 5 ms, 0.4 s, μ = 0.5, θ = 30°, R = 0.2 m): on h = R/10 the
# disk rolls 11.7 % short of ½ a t², on h = R/20 5.6 % (first order in h). The check:
# within 10 % of the rolling distance on R/20 and finer, 15 % on coarser grids. A
# disk that slid would be 50 % ahead; one glued to the grid 100 % short. And it must
# roll: ωR/v, averaged over the second half of the run, ≥ 0.85 (measured 2026-12-07:
# 0.988 on R/10, 0.994 on R/20; with point domains 0.970–0.988, and 0.951 on R/20
# with their dynamic ghost penalty). Just above μ = tan θ / 3 a disk that slipped
# (μ = 0.2, θ = 30°, R/10: mean 0.723, never above 0.793) came within 2.1 % of the
# rolling distance, its slip making up for the grid's drag, and passed until
# 2026-12-06. Until 2026-12-07 the check took ωR/v at the last instant (≥ 0.8), which
# swings with the contact's stick and slip: 0.87 on R/10, and 0.805 on R/20 with
# domains, whose mean is 0.951.

# +
TOLERANCE = 0.10 if R / h >= 20 - 1e-9 else 0.15
MIN_SPIN = 0.85
passed = bool(abs(relative) <= TOLERANCE and rolling_mean >= MIN_SPIN)
print(
    f"check: slide vs ½ (⅔ g sin θ) t² (rolling without slip): {100 * relative:+.1f} % "
    f"({'<=' if abs(relative) <= TOLERANCE else '>'} {100 * TOLERANCE:.0f} %), mean ωR/v "
    f"= {rolling_mean:.3f} ({'>=' if rolling_mean >= MIN_SPIN else '<'} {MIN_SPIN}): "
    f"{'PASS' if passed else 'FAIL'}"
)
if args.json:
    print(
        json.dumps(
            {
                "error": error,
                "relative_error": relative,
                "slide_m": float(s_h[-1]),
                "rolling_m": float(s[-1]),
                "spin_ratio": rolling,
                "spin_ratio_mean": rolling_mean,
                "points": n_points,
                "steps": len(reports),
                "newton_iterations_mean": float(np.mean(iterations)),
                "wall_time_s": wall,
                "check_passed": passed,
            }
        )
    )
if passed is False:
    sys.exit(
        f"rolling_disk.py: the disk rolled {100 * relative:+.1f} % from ½ a t² with "
        f"ωR/v = {rolling_mean:.3f} over the second half"
    )
# -
