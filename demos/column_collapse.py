# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # Granular column collapse (Lube et al. 2005)
#
# Iaconeta (2019) §6.1. A column of dry sand, d_i wide and h_i = a·d_i high,
# stands against a wall on a rough base. The gate on its other side is removed
# at t = 0, and it collapses and spreads along the channel under gravity. Lube
# et al. measured the final run-out d∞, the final height h∞ and the duration t∞,
# and fitted laws in the aspect ratio a. This demo illustrates how to:
#
# - run a dynamic analysis (implicit Newmark, `dynamic=True`) with a
#   cohesionless Mohr-Coulomb law (`fe_mpm.MohrCoulomb`),
# - add mass-proportional Rayleigh damping (`damping=`), as the thesis does (α_R =
#   1.5 1/s by default; undamped, `--damping 0`, the a = 3 flow runs 36 % too far on
#   the thesis grid and the check fails),
# - follow a quantity of the point cloud over time (`Simulation.run(on_step=)`),
# - try the mixed u-p form (`--formulation up`: the law returns at the pressure
#   field's mean stress). Measured undamped (the default then) on h = 0.01 m with 3
#   points per cell: run-out +11.9 %, final height −22.8 % (u: +9.6 %, −3.5 %), so
#   the check fails; the u-p deposit ends lower and still creeping (kinetic energy
#   0.20 J/m against 0.08).
#
# **Data** (thesis Table 6.1): E = 0.84 MPa, ν = 0.3, ρ = 2600 kg/m³, φ = 31°,
# ψ = 1°, c = 0. The thesis omits d_i; its Table 6.5 implies d_i = 0.0905 m.
# The wall is a roller (u_x = 0), the base is rough (fixed). The column starts
# unstressed and gravity acts from t = 0.
#
# Usage: `python demos/column_collapse.py --aspect 3 --json`. Under `mpiexec -n 2
# python -m mpi4py demos/column_collapse.py` the points are shared among the ranks
# (the measures below gather them) and rank 0 prints and writes the files.

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
from fe_mpm.cli import nonnegative, positive
from fe_mpm.diagnostics import contiguous_front
from fe_mpm.plotting import pyplot
from fe_mpm.references import lube_height, lube_runout, lube_time


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="Granular column collapse (Lube et al. 2005)")
    p.add_argument("--aspect", type=positive(float), default=3.0, help="aspect ratio a = h_i/d_i")
    p.add_argument(
        "--d-i", type=positive(float), default=0.0905, help="initial column width d_i (m)"
    )
    p.add_argument("--h", type=positive(float), default=0.0065, help="cell size (m); thesis 0.0065")
    p.add_argument("--points-per-cell", type=positive(int), default=6, help="points per triangle")
    p.add_argument("--dt", type=positive(float), default=2.5e-3, help="time step (s)")
    p.add_argument(
        "--t-end",
        type=positive(float),
        default=None,
        help="end time (s); 1.6 times the empirical duration by default",
    )
    p.add_argument(
        "--damping",
        type=nonnegative(float),
        default=1.5,
        help="mass-proportional Rayleigh damping α (1/s); the thesis's 1.5 by default, 0: none",
    )
    p.add_argument("--E", type=positive(float), default=0.84e6, help="Young's modulus (Pa)")
    p.add_argument("--nu", type=float, default=0.3, help="Poisson's ratio")
    p.add_argument("--density", type=positive(float), default=2600.0, help="kg/m³")
    p.add_argument("--friction", type=float, default=31.0, help="friction angle φ (deg)")
    p.add_argument("--dilatancy", type=float, default=1.0, help="dilatancy angle ψ (deg)")
    p.add_argument("--gravity", type=positive(float), default=9.81, help="m/s²")
    p.add_argument(
        "--mass",
        choices=("consistent", "lumped"),
        default="lumped",
        help="mass matrix of the points (the thesis: consistent)",
    )
    p.add_argument(
        "--point-domains",
        action="store_true",
        help="convected point domains (docs/cell_crossing.md: they stop this flow short)",
    )
    p.add_argument(
        "--rebalance-above",
        type=lambda s: None if s == "none" else float(s),
        default=None,
        help="under MPI, repartition the grid by its points past this imbalance (e.g. 1.25)",
    )
    p.add_argument(
        "--law",
        choices=("mohr-coulomb", "drucker-prager", "matsuoka-nakai"),
        default="mohr-coulomb",
        help="the sand's law: Mohr-Coulomb (the thesis's), the Drucker-Prager cone through "
        "its plane-strain limit, or Matsuoka-Nakai with constant angles (Mast §3.7)",
    )
    p.add_argument(
        "--formulation",
        choices=("u", "up"),
        default="u",
        help="u (the thesis's), or u-p, where the law returns at the pressure field's mean stress",
    )
    p.add_argument("--output", default="column_collapse_output", help="output folder")
    p.add_argument("--no-output", action="store_true", help="write no files")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
rank0 = parallel.print_on_rank_zero()  # every rank runs this script; one prints
a, d_i, g = args.aspect, args.d_i, args.gravity
h_i = a * d_i
runout_law, height_law = lube_runout(d_i, a), lube_height(d_i, a)
time_law = lube_time(d_i, a, g)
t_end = 1.6 * time_law if args.t_end is None else args.t_end
# -

# ## Scene
#
# The grid covers the channel to 1.6 times the empirical run-out; a point thrown
# beyond it is dropped, with a warning, and counted in the summary. The points
# fill the column's cells; the rest of the channel is empty grid, which costs
# nothing until material reaches it.
#
# The mass matrix is lumped by default. Sand carries no tension, so points that
# fly apart have zero stress and zero stiffness; only the mass holds their grid
# nodes. A consistent mass m N Nᵀ from a lone point in a cell has rank one, and
# with it the a = 3 run stopped at t = 0.26 s on a singular matrix; the lumped
# mass m N_I is positive on every node such a point touches.

# +
try:
    scene = meshes.granular_column(d_i, a, h=args.h)
    points = fe_mpm.seed(
        scene.mesh,
        args.points_per_cell,
        density=args.density,
        cells=scene.cell_tags.find(meshes.COLLAPSE_COLUMN),
    )
    strength = dict(cohesion=0.0, friction_angle=args.friction, dilatancy_angle=args.dilatancy)
    if args.law == "mohr-coulomb":
        sand = fe_mpm.MohrCoulomb(args.E, args.nu, **strength, density=args.density)
    elif args.law == "drucker-prager":  # the cone through Mohr-Coulomb's plane-strain limit
        sand = fe_mpm.DruckerPrager(
            args.E, args.nu, **strength, density=args.density, match="plane strain"
        )
    else:  # Mast's law with its angles held (a₄ = 0): φ_F = φ_cs = φ, so ψ_G = 0
        sand = fe_mpm.MatsuokaNakai(
            args.E,
            args.nu,
            a0=args.friction,
            a1=0.0,
            a2=0.0,
            a3=0.0,
            a4=0.0,
            a5=0.0,
            density=args.density,
        )
    sim = fe_mpm.Simulation(
        scene.mesh,
        points,
        sand,
        args.formulation,
        facet_tags=scene.facet_tags,
        dirichlet=[
            fe_mpm.Dirichlet(meshes.COLLAPSE_WALL, component=0),
            fe_mpm.Dirichlet(meshes.COLLAPSE_BASE),
        ],
        body_force=(0.0, -g),
        dynamic=True,
        damping=args.damping,
        mass=args.mass,
        # A point domain cannot leave the grid; no point has left it in these runs.
        points_leaving="raise" if args.point_domains else "drop",
        point_domains=args.point_domains,
        # The column fills a corner of the grid: under MPI, --rebalance-above 1.25
        # partitions the grid by its points (docs/limitations.md: here it does not pay).
        rebalance_above=args.rebalance_above,
        output_dir=None if args.no_output else args.output,
        output_every=max(1, int(round(t_end / args.dt)) // 40),
    )
except ValueError as err:
    sys.exit(f"column_collapse.py: {err}")
# -

# ## Collapse
#
# After every step we record the front, the height (the highest point) and the
# kinetic energy. The front is the farthest point of the material that hangs
# together: a few points thrown ahead of the flow, a band of two cells or more
# clear of the rest, do not count. With the farthest point instead, the a = 3
# run-out error jumped about with the time step (+6 %, +16 %, +7 % for 2.5, 5
# and 10 ms); with this front it moves steadily (+7 %, +11 %, +17 %).

# +
history = []


def record(report: fe_mpm.StepReport) -> None:
    """Front d (m), height h (m) and kinetic energy (J/m) after a step."""
    x = parallel.gathered(scene.mesh.comm, points.x)  # each rank holds its cells' points
    energy = parallel.total(scene.mesh.comm, points.kinetic_energy())
    history.append((report.t, contiguous_front(x, 2 * args.h), x[:, 1].max(), energy))


try:
    reports = sim.run(
        t_end=t_end, n_steps=max(1, round(t_end / args.dt)), progress=not args.json, on_step=record
    )
except (fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"column_collapse.py: {err}")
t, front, height, energy = np.array(history).T
# -

# ## Run-out, height and duration
#
# d∞ and h∞ are the front and height at the end; t∞ is the first time the front
# comes within 1 % of d∞ (Lube et al. time the flow to the moment it stops). The
# front creeps at the end, so that time is ill-conditioned: at a = 3 on h = 0.015 m,
# three runs whose E differs by 1e-12 gave t∞ from +9.9 % to +22 %. The first time
# the front comes within one cell of d∞ (which the grid cannot resolve further),
# `t_inf_cell`, moved by 3 % in the same runs (−4.3 % to −1.1 %).

# +
runout, final_height = float(front[-1]), float(height[-1])
t_inf = float(t[np.argmax(front >= 0.99 * runout)])
t_inf_cell = float(t[np.argmax(front >= runout - args.h)])
wall = time.perf_counter() - START
errors = {
    "runout": runout / runout_law - 1,
    "final_height": final_height / height_law - 1,
    "t_inf": t_inf / time_law - 1,
    "t_inf_cell": t_inf_cell / time_law - 1,
}
iterations = [r.newton_iterations for r in reports]
print(
    f"Granular collapse, a = {a}: {parallel.total(scene.mesh.comm, len(points))} points, "
    f"{len(reports)} steps of "
    f"{args.dt:g} s, damping {args.damping:g} 1/s, wall time {wall:.1f} s"
    + (f"; {sim.dropped} point(s) thrown off the channel's end" if sim.dropped else "")
)
for name, value, law in (
    ("d∞ (m)", runout, runout_law),
    ("h∞ (m)", final_height, height_law),
    ("t∞ (s)", t_inf, time_law),
):
    print(f"  {name:7s} {value:.4f}   Lube et al. {law:.4f}   ({100 * (value / law - 1):+.1f} %)")
print(
    f"  kinetic energy at the end {energy[-1]:.3g} J/m (peak {energy.max():.3g}); "
    f"Newton iterations per step: max {max(iterations)}, mean {np.mean(iterations):.2f}"
)
if scene.mesh.comm.size > 1:  # each rank integrates the points of the cells it owns
    imbalance = [r.point_imbalance for r in reports]
    print(
        f"  points per rank, most over mean: {imbalance[0]:.2f} first, {max(imbalance):.2f} "
        f"max; the grid was repartitioned by its points {sim.repartitions} time(s)"
    )

x_final = parallel.gathered(scene.mesh.comm, points.x)
if not args.no_output and rank0:
    plt = pyplot()  # None without matplotlib (the plots extra)
    out = Path(args.output)
    np.savetxt(
        out / "front.csv",
        np.column_stack([t, front, height, energy]),
        delimiter=",",
        header="t,front,height,kinetic_energy",
        comments="",
    )
    # The deposit: the highest point in each column of cell width.
    bins = np.arange(0.0, x_final[:, 0].max() + args.h, args.h)
    which = np.digitize(x_final[:, 0], bins)
    top = np.array(
        [x_final[which == k, 1].max() if np.any(which == k) else 0.0 for k in range(1, bins.size)]
    )
    if plt is not None:
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.6))
        ax1.plot(t / time_law, front / runout_law, label=f"fe-mpm, a = {a:g}")
        ax1.axhline(1.0, color="k", ls="--", lw=1, label="Lube et al. d∞")
        ax1.set_xlabel("T = t / (3.3 √(h_i/g))")
        ax1.set_ylabel("d / d∞ (Lube et al.)")
        ax1.legend()
        ax2.fill_between(bins[:-1], top, step="post", alpha=0.5, label="deposit")
        ax2.plot([0, d_i, d_i], [h_i, h_i, 0], "k:", label="initial column")
        ax2.plot([runout_law], [0], "kv", label="Lube et al. d∞")
        ax2.plot([0], [height_law], "k>", label="Lube et al. h∞")
        ax2.set_xlabel("x (m)")
        ax2.set_ylabel("y (m)")
        ax2.set_aspect("equal")
        ax2.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "collapse.png", dpi=120)
    np.savetxt(
        out / "deposit.csv",
        np.column_stack([bins[:-1], top]),
        delimiter=",",
        header="x,surface_height",
        comments="",
    )
    print(
        f"  wrote {out}/particles.pvd, front.csv, deposit.csv"
        + (" and collapse.png" if plt is not None else "")
    )

# -

# ## Check against the reference
#
# Lube et al.'s laws are empirical fits to experiments, and MPM with Mohr-Coulomb
# reproduces them only so far: the thesis's own twelve runs (a = 1.2, 3, 5 and 7 on
# three grids, Tables 6.2–6.4) lie up to +25.6 % from the run-out law (a = 1.2),
# −13.7 % from the height law (a = 7) and +35.4 % from the duration law (a = 1.2).
# Each quantity here must lie within those. The duration is `t_inf_cell`, the time
# the front comes within one cell of d∞ (above: t∞ hinges on round-off). Measured,
# in that order: at a = 3, −11.2 %, −3.8 %, −5.6 % (h = 0.015 m, 3 points per
# triangle, α_R = 1.5: the test's scene) and +12.6 %, −3.5 %, −6.6 % (h = 0.01 m,
# undamped); at a = 1.2 on h = 0.01 m, −8.3 %, −7.0 %, +5.9 % (α_R = 1.5) and
# +0.1 %, −9.4 %, +2.7 % (undamped). The check covers the thesis's aspect ratios,
# 1.2 ≤ a ≤ 7, outside the laws' transition 1.8 < a < 2.8.

# +
#: Largest relative errors that pass: the thesis's own largest, rounded up.
TOLERANCES = {"runout": 0.26, "final_height": 0.14, "t_inf_cell": 0.36}

if 1.2 <= a <= 7.0 and not 1.8 <= a <= 2.8:
    passed = all(abs(errors[k]) <= tol for k, tol in TOLERANCES.items())
    print(
        f"check: d∞ {100 * errors['runout']:+.1f} %, h∞ {100 * errors['final_height']:+.1f} %, "
        f"t∞ (front within a cell of d∞) {100 * errors['t_inf_cell']:+.1f} % vs Lube et al. "
        f"(a = {a:g}); tolerances ±{100 * TOLERANCES['runout']:.0f}, "
        f"±{100 * TOLERANCES['final_height']:.0f}, ±{100 * TOLERANCES['t_inf_cell']:.0f} % "
        f"(the thesis's largest): {'PASS' if passed else 'FAIL'}"
    )
else:
    passed = None  # not checked
    print(
        f"check: the thesis's errors against Lube et al. are for a = 1.2 to 7 outside "
        f"1.8–2.8, not a = {a:g}: not checked"
    )
if args.json:
    print(
        json.dumps(
            {
                "aspect": a,
                "runout": runout,
                "final_height": final_height,
                "t_inf": t_inf,
                "t_inf_cell": t_inf_cell,
                "wall_time_s": wall,
                "runout_lube": runout_law,
                "final_height_lube": height_law,
                "t_inf_lube": time_law,
                "relative_errors": errors,
                "damping": args.damping,
                "n_particles": int(parallel.total(scene.mesh.comm, len(points))),
                "steps": len(reports),
                "dt": args.dt,
                "newton_iterations_max": max(iterations),
                "newton_iterations": iterations,
                "times": [r.t for r in reports],
                "dropped_points": sim.dropped,
                "point_domain_resets": None
                if sim.domains is None
                else int(parallel.total(scene.mesh.comm, sim.domains.resets)),
                "point_domain_flips": None
                if sim.domains is None
                else int(parallel.total(scene.mesh.comm, sim.domains.flips)),
                "timings": sim.timings,
                "point_imbalance": reports[-1].point_imbalance,
                "point_imbalance_max": max(r.point_imbalance for r in reports),
                "repartitions": sim.repartitions,
                "check_passed": passed,
            }
        )
    )
if passed is False:
    sys.exit(
        "column_collapse.py: the deposit is further from Lube et al.'s laws than the "
        "thesis's own runs"
    )
# -
