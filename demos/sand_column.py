# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # Planar sand column collapse (Mast 2013, §7.2)
#
# A column of moderately dense sand, l₀ = 5 cm wide (half of it: the left side is a
# symmetry plane) and h₀ = a·l₀ high, stands on a rough bed and collapses under
# gravity when released. Mast ran 180 such collapses with his two sand laws and
# fitted the final run-out and height to power laws of the aspect ratio a, with
# lower and upper bounds over his ten friction-angle curves (his Tables 7.3–7.6).
# This demo illustrates how to:
#
# - put a frictional bed under a flow: a rigid wall with Coulomb friction,
#   θ_fr = 65° (`fe_mpm.RigidWall`), and read its force on the sand;
# - use Mast's laws with evolving friction angles (`fe_mpm.ModifiedDruckerPrager`,
#   `fe_mpm.MatsuokaNakai` with the Drucker–Prager potential);
# - measure the collapse as Mast does (his Eqs. 7.7–7.9).
#
# **Data** (Mast §7.2): K = 29.5 MPa, G = 13.6 MPa, ρ = 2200 kg/m³, c = 0, the
# baseline curve of his Table 7.2 (case 0: a₀ = 35°, a₁ = a₂ = 0, a₃ = 0.2,
# a₄ = 10°, so the friction angle hardens from 25° to 35° with the plastic shear
# strain). Mast does not list a₅; a₅ = a₃ keeps the critical-state angle equal to
# the friction angle, so ψ_G = 0, as he states for these runs. Gravity 9.81 m/s².
# His grid had square cells of 5 mm (`--full`); the default is 1 cm.
#
# **Form.** Mast's code used volumetric averaging against locking on quadrilaterals.
# On triangles the displacement form locks in this isochoric flow: at a = 2 on the
# 1 cm grid the column barely moved (H_f = 1.94 against Mast's 1.07–1.25). The
# mixed u-p form with its pressure field is fe-mpm's answer to locking, and the law
# returns at that pressure's mean stress.
#
# Usage: `python demos/sand_column.py --law dp --aspect 2 --json`.

# +
import time

START = time.perf_counter()

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

import fe_mpm
from fe_mpm import parallel
from fe_mpm.cli import positive
from fe_mpm.meshes import cell_centroids, rectangle_mesh
from fe_mpm.plotting import pyplot
from fe_mpm.walls import plot_wall_forces, write_wall_forces

#: Mast's Table 7.2, case 0, in degrees (a₂ in 1/Pa); a₅ = a₃, see above.
ANGLES = dict(a0=35.0, a1=0.0, a2=0.0, a3=0.2, a4=10.0, a5=0.2)
#: Mast's bounds on the final run-out L_f = A a^B (Table 7.4) and height H_f = C a^D
#: (Table 7.6), as (A, B) lower and upper, for a ≲ 1.5 / a ≳ 1.5 (L_f) and a ≳ 1 (H_f).
RUNOUT_BOUNDS = {
    "dp": {"short": ((0.621, 1.578), (0.960, 1.520)), "tall": ((0.778, 0.725), (1.235, 0.754))},
    "mn-dp": {"short": ((0.851, 1.471), (1.165, 1.551)), "tall": ((1.089, 0.742), (1.518, 0.760))},
}
HEIGHT_BOUNDS = {"dp": ((0.820, 0.381), (0.911, 0.461)), "mn-dp": ((0.741, 0.353), (0.860, 0.450))}
#: Below a ≈ 1 Mast's columns keep their height (H_f = a); this much either side
#: allows for the seeded top, ragged by a point spacing (H = 0.507 after the first
#: step at a = 0.5 on 1 cm cells).
HEIGHT_TOLERANCE = 0.02


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="Planar sand column collapse (Mast 2013, §7.2)")
    p.add_argument("--law", choices=("dp", "mn-dp"), default="dp", help="Mast's sand law")
    p.add_argument("--aspect", type=positive(float), default=2.0, help="aspect ratio a = h0/l0")
    p.add_argument("--full", action="store_true", help="Mast's grid: cells of 5 mm")
    p.add_argument(
        "--h", type=positive(float), default=None, help="cell size (m); 0.01, or 0.005 --full"
    )
    p.add_argument("--points-per-cell", type=positive(int), default=3, help="points per triangle")
    p.add_argument("--dt", type=positive(float), default=2.5e-3, help="time step (s)")
    p.add_argument(
        "--bossak-alpha",
        type=float,
        default=0.0,
        help="Bossak's alpha in [-1/3, 0]: numerical damping of the deposit's ringing",
    )
    p.add_argument("--t-end", type=positive(float), default=None, help="end time (s)")
    p.add_argument("--output", default="sand_column_output", help="output folder")
    p.add_argument("--no-output", action="store_true", help="write no files")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
rank0 = parallel.print_on_rank_zero()
l0, g, rho = 0.05, 9.81, 2200.0
K, G = 29.5e6, 13.6e6
E, nu = 9 * K * G / (3 * K + G), (3 * K - 2 * G) / (2 * (3 * K + G))
a, h = args.aspect, (0.005 if args.full else 0.01) if args.h is None else args.h
h0 = a * l0
# Long enough to fall and spread: measured at a = 2, it settled at 0.28 s of 0.46 s.
full_time = 0.1 + 2.5 * math.sqrt(2.0 * h0 / g)
t_end = full_time if args.t_end is None else args.t_end


def bound(coefficients: tuple[float, float]) -> float:
    """Mast's power law A a^B at this aspect ratio."""
    return coefficients[0] * a ** coefficients[1]


runout_range = [bound(c) for c in RUNOUT_BOUNDS[args.law]["short" if a <= 1.5 else "tall"]]
# Mast's Table 7.6 bounds H_f for a ≲ 1 (H_f = a) and for a ≳ 1 (C a^D): at a = 1,
# where his two fits meet (0.82–0.91 and 1.0 for dp), the check takes the range
# that spans both.
short_height = [a * (1.0 - HEIGHT_TOLERANCE), a * (1.0 + HEIGHT_TOLERANCE)]
tall_height = [bound(c) for c in HEIGHT_BOUNDS[args.law]]
if math.isclose(a, 1.0):
    height_range = [min(short_height[0], tall_height[0]), max(short_height[1], tall_height[1])]
else:
    height_range = short_height if a < 1.0 else tall_height
# -

# ## Scene
#
# The grid spans the column's height plus three cells, and 1.3 times the farthest
# run-out Mast bounds plus four cells. The symmetry plane x = 0 holds the
# horizontal displacement (a roller); the bed y = 0 is a rigid wall with Coulomb
# friction μ = tan 65°, which the sand presses on and slides along, and may leave.
# The mass is lumped: sand flying apart carries no stress, and only its mass holds
# its nodes (see `demos/column_collapse.py`).

# +
widest = l0 * (1.0 + 1.3 * runout_range[1])
nx, ny = math.ceil((widest + 4 * h) / h), math.ceil((h0 + 3 * h) / h)
grid = rectangle_mesh((0.0, 0.0), (nx * h, ny * h), (nx, ny))
centroids = cell_centroids(grid)  # each rank seeds the cells it owns
column = np.flatnonzero((centroids[:, 0] < l0) & (centroids[:, 1] < h0))
points = fe_mpm.seed(grid, args.points_per_cell, density=rho, cells=column)
if args.law == "dp":
    sand = fe_mpm.ModifiedDruckerPrager(E, nu, **ANGLES, density=rho)
else:
    sand = fe_mpm.MatsuokaNakai(E, nu, **ANGLES, density=rho, potential="drucker-prager")
bed = fe_mpm.RigidWall("bed", lambda x: np.isclose(x[1], 0.0), friction=math.tan(math.radians(65)))
try:
    sim = fe_mpm.Simulation(
        grid,
        points,
        sand,
        "up",
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0), component=0)],
        walls=[bed],
        body_force=(0.0, -g),
        dynamic=True,
        mass="lumped",
        bossak_alpha=args.bossak_alpha,
        points_leaving="drop",
        # Measured at a = 2: 287 steps and 15.6 Newton iterations per step with
        # PETSc's l2 line search, 915 and 28 with the default backtracking (5.7x the
        # time; docs/dynamics.md compares the searches on other dynamic scenes).
        line_search="l2",
        output_dir=None if args.no_output else args.output,
        output_every=max(1, round(t_end / args.dt) // 40),
    )
except ValueError as err:
    sys.exit(f"sand_column.py: {err}")
# -

# ## Collapse
#
# Mast's measures (his Eq. 7.8): the height h is twice the mass-weighted mean height
# of the sand touching the symmetry plane, and the run-out l twice the mass-weighted
# mean distance of the sand touching the bed, as if each were spread evenly over its
# contact. "Touching" here: within one cell of the plane. Then H = h/l₀ and
# L = (l − l₀)/l₀ (Eq. 7.7).

# +
history = []


def mast_measures() -> tuple[float, float]:
    """(H, L): Mast's normalised height and run-out of the points now."""
    x = parallel.gathered(grid.comm, points.x)
    m = parallel.gathered(grid.comm, points.mass)
    side, bed_ = x[:, 0] < h, x[:, 1] < h
    height = 2.0 * (m[side] @ x[side, 1]) / m[side].sum()
    length = 2.0 * (m[bed_] @ x[bed_, 0]) / m[bed_].sum()
    return height / l0, (length - l0) / l0


def record(report: fe_mpm.StepReport) -> None:
    """Mast's H and L, and the kinetic energy (J/m), after a step."""
    H, L = mast_measures()
    energy = parallel.total(grid.comm, points.kinetic_energy())
    history.append((report.t, H, L, energy))


try:
    reports = sim.run(t_end, max(1, round(t_end / args.dt)), progress=not args.json, on_step=record)
except (fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"sand_column.py: {err}")
t, H, L, energy = np.array(history).T
# -

# ## Final state
#
# Mast stops at t_f, when l changes by less than 0.01 % between steps. On this grid
# l, a mean over the few points within a cell of the bed, moves in jumps as points
# enter and leave that strip, and stands still between them while the sand still
# flows (that rule stopped a = 2 at 0.20 s, with L at 0.93 of its later 1.22). Here
# t_f is the first time after its peak that the kinetic energy falls below 5 % of
# it, and H_f and L_f are taken there. The points' energy then stays near 0.015 J/m
# at a = 2 (2 % of the peak) for good, while the grid's falls to 2e-6 J/m
# (`StepReport.grid_kinetic_energy`, measured 2026-12-07): the points keep velocity
# that the projection averages to zero at every node, which moves nothing
# (docs/dynamics.md, "Energy"). l keeps drifting with points crossing the strip
# (1.22 to 1.38 from 0.36 to 0.61 s) while the front stands.

# +
peak = int(np.argmax(energy))
settled = np.flatnonzero((np.arange(t.size) > peak) & (energy < 0.05 * energy[peak]))
final = int(settled[0]) if settled.size else t.size - 1
t_f, H_f, L_f = float(t[final]), float(H[final]), float(L[final])
wall = time.perf_counter() - START
iterations = [r.newton_iterations for r in reports]
n_points = int(parallel.total(grid.comm, len(points)))
print(
    f"Sand column, {args.law}, a = {a:g}: {n_points} points, {len(reports)} steps of up to "
    f"{args.dt:g} s, h = {h:g} m, wall time {wall:.1f} s"
    + (f"; {sim.dropped} point(s) thrown off the grid" if sim.dropped else "")
)
print(f"  L_f = {L_f:.3f}   Mast's bounds [{runout_range[0]:.3f}, {runout_range[1]:.3f}]")
print(f"  H_f = {H_f:.3f}   Mast's bounds [{height_range[0]:.3f}, {height_range[1]:.3f}]")
print(
    f"  {'settled' if settled.size else 'not settled'} at t_f = {t_f:.3f} s of {t[-1]:.3f} s; "
    f"kinetic energy at the end "
    f"{energy[-1]:.3g} J/m (peak {energy.max():.3g}); Newton per step mean "
    f"{np.mean(iterations):.2f}, max {max(iterations)}"
)
bed_force = reports[-1].walls["bed"]
weight = g * parallel.total(grid.comm, float(points.mass.sum()))
# The bed's push over the last 30 steps: it rings where nothing damps the deposit.
bed_push = np.array([r.walls["bed"].normal for r in reports[-30:]]) / weight
print(
    f"  the bed carries {bed_force.normal / weight:.3f} of the sand's weight at the end "
    f"({bed_push.min():.3f} to {bed_push.max():.3f} over the last {bed_push.size} steps), "
    f"with friction {np.linalg.norm(bed_force.tangential) / weight:.3f} of it"
)
if not args.no_output and rank0:
    out = Path(args.output)
    np.savetxt(
        out / "collapse.csv",
        np.column_stack([t, H, L, energy]),
        delimiter=",",
        header="t,H,L,kinetic_energy",
        comments="",
    )
    write_wall_forces(reports, out / "walls.csv")
    plt = pyplot()
    if plt is not None:
        plot_wall_forces(reports, out / "walls.png", plt)
        fig, ax = plt.subplots(figsize=(5, 3.6))
        ax.plot(t, H, label="H = h / l₀")
        ax.plot(t, L, label="L = (l − l₀) / l₀")
        for value in (*runout_range, *height_range):
            ax.axhline(value, color="k", ls=":", lw=0.8)
        ax.set_xlabel("t (s)")
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "collapse.png", dpi=120)
    print(f"  wrote {out}/particles.pvd, collapse.csv, walls.csv" + (" and plots" if plt else ""))
# -

# ## Check against the reference
#
# Mast's bounds are over his ten friction-angle curves, on his 5 mm grid; the
# baseline curve must lie inside them. Measured on the 1 cm grid (2026-12-03, 300
# points, 333 steps, 17.6 Newton iterations per step, 168 s): DP, a = 2, L_f = 1.272
# and H_f = 1.239 at t_f = 0.28 s, against [1.286, 2.083] and [1.068, 1.254]: the
# height is inside, the run-out 1.1 % short of the lower bound, so the check fails.
# (Before the bed's springs waited for the sand by a gap, L_f was 1.236, and the
# front, the farthest point, ended at L = 1.66, next to Mast's best fit 1.687.) On
# this grid Mast's l, the mean over a one-cell strip along the bed (two rows of
# points), reads the toe short. On Mast's 5 mm grid (`--full`; 1200 points, 1076
# steps, 18.6 Newton iterations per step, 29 min) both are inside: L_f = 1.430 and
# H_f = 1.244, and the check passes.

# +
passed = bool(
    runout_range[0] <= L_f <= runout_range[1] and height_range[0] <= H_f <= height_range[1]
)
verdict = "PASS" if passed else "FAIL"
if not settled.size and t_end < full_time:  # Mast's bounds are on the deposit at rest
    passed, verdict = None, f"not checked (cut short at t = {t[-1]:.3f} s, still moving)"
print(
    f"check: L_f {L_f:.3f} in [{runout_range[0]:.3f}, {runout_range[1]:.3f}] and H_f "
    f"{H_f:.3f} in [{height_range[0]:.3f}, {height_range[1]:.3f}] (Mast's Tables 7.4, 7.6, "
    f"{'DP' if args.law == 'dp' else 'MN with DP G'}): {verdict}"
)
if args.json:
    print(
        json.dumps(
            {
                "law": args.law,
                "aspect": a,
                "L_f": L_f,
                "H_f": H_f,
                "t_f": t_f,
                "L_f_bounds": runout_range,
                "H_f_bounds": height_range,
                "points": n_points,
                "steps": len(reports),
                "h": h,
                "dt": args.dt,
                "newton_iterations_mean": float(np.mean(iterations)),
                "newton_iterations_max": int(max(iterations)),
                "bossak_alpha": args.bossak_alpha,
                "bed_push_last_steps": [float(bed_push.min()), float(bed_push.max())],
                "dropped_points": sim.dropped,
                "wall_time_s": wall,
                "ranks": grid.comm.size,
                "check_passed": passed,
            }
        )
    )
if passed is False:
    sys.exit("sand_column.py: the deposit lies outside Mast's bounds")
# -
