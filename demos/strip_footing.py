# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # Rigid strip footing on undrained (Tresca) soil, to a settlement of 2B
#
# Iaconeta (2019) §6.2. Half model of a plane-strain rigid footing of width B
# pushed into weightless Tresca soil by displacement control. The small-strain
# (Prandtl) bearing capacity is q = (2 + π) c_u; at large settlement the soil
# heaves beside the footing and q/c_u keeps rising. This demo illustrates how to:
#
# - use Tresca plasticity (`fe_mpm.MohrCoulomb.tresca`) in the u and u-p forms,
# - impose a moving rigid boundary the grid does not follow (`fe_mpm.PointDirichlet`,
#   boundary points with a penalty, as Kratos MPM does), and read its force,
# - seed a zone of the grid more densely (`fe_mpm.seed(..., cells=)`, `fe_mpm.merge`).
#
# **Data.** c_u = 100 Pa, E = 10 kPa, ν = 0.495 (K_u = 3.33e5 Pa, K_u/c_u = 3.33e3
# as in the thesis; E and ν are Kardani et al.'s set scaled to c_u = 100 Pa, the
# thesis omits them). Domain 5B x 5B with rollers on the sides and a fixed base;
# rough footing (no horizontal motion under it) unless `--smooth`.
#
# **Robustness.** After every step the grid is reset and the points are re-binned,
# so the next step starts out of balance. On a perfectly plastic body Newton can
# then fail whatever the step length. For a plastic law Newton backtracks on ‖R‖²
# (`line_search="auto"` gives `"bt"`): full steps make the active set chatter.
# `Simulation.run` retries a failed step with full Newton steps, then with the points
# held in their last cells (no re-binning, `Simulation.step(rebin=False)`), and only
# then cuts it.
#
# Usage: `python demos/strip_footing.py --formulation up --steps 100 --json`. Under
# `mpiexec -n 2 python -m mpi4py demos/strip_footing.py` the grid, its points and the
# footing's boundary points are shared among the ranks and the answer is the serial
# one; rank 0 prints and writes the files.

# +
import time

START = time.perf_counter()

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import fe_mpm
from fe_mpm import parallel, scenes
from fe_mpm.cli import positive
from fe_mpm.diagnostics import stress_oscillation
from fe_mpm.plotting import pyplot


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="Rigid strip footing on Tresca soil")
    p.add_argument("--formulation", choices=("u", "up"), default="up")
    p.add_argument("--steps", type=positive(int), default=200, help="load steps")
    p.add_argument("--settlement", type=positive(float), default=2.0, help="final settlement (m)")
    p.add_argument("--B", type=positive(float), default=1.0, help="footing width B (m)")
    p.add_argument("--cu", type=positive(float), default=100.0, help="undrained strength c_u (Pa)")
    p.add_argument("--E", type=positive(float), default=1.0e4, help="Young's modulus (Pa)")
    p.add_argument("--nu", type=float, default=0.495, help="Poisson's ratio")
    p.add_argument("--h", type=positive(float), default=0.05, help="cell size near the footing (m)")
    p.add_argument("--h-far", type=positive(float), default=None, help="cell size far away (m)")
    p.add_argument(
        "--edge-size",
        type=positive(float),
        default=None,
        help="cell size around the footing's edge and its path (m); h by default",
    )
    p.add_argument(
        "--near-width", type=positive(float), default=None, help="refined zone width (m)"
    )
    p.add_argument(
        "--near-depth", type=positive(float), default=None, help="refined zone depth (m)"
    )
    p.add_argument("--points-near", type=positive(int), default=12, help="points per cell near it")
    p.add_argument("--points-far", type=positive(int), default=3, help="points per cell elsewhere")
    p.add_argument("--smooth", action="store_true", help="smooth footing (vertical only)")
    p.add_argument(
        "--footing-thickness",
        type=float,
        default=None,
        help="height of the footing body above its base, filled with penalty points "
        "(m); 2h by default, 0 for the base only",
    )
    p.add_argument(
        "--penalty",
        type=positive(float),
        default=None,
        help="footing penalty β (Pa/m); 1e3 E/h by default",
    )
    p.add_argument(
        "--line-search",
        choices=("auto", "basic", "bt", "l2"),
        default="auto",
        help="SNES line search (auto: bt for a plastic law; basic: full Newton steps); "
        "a failed step is retried with the other of bt and basic before it is cut",
    )
    p.add_argument("--output", default="strip_footing_output", help="output folder")
    p.add_argument("--no-output", action="store_true", help="write no files")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
rank0 = parallel.print_on_rank_zero()  # every rank runs this script; one prints
# -

# ## Scene
#
# The grid holds the soil and an empty strip B high above it. The footing is a
# set of boundary points, two per cell width: a row on the soil surface under
# x ∈ [0, B/2] and a lattice filling the footing body two cells high above it.
# They are pulled down by `settlement · t`, and their reaction is the footing
# load per unit length of the half model. The body points matter: with the base
# row alone, the cells the base crosses have upper nodes held only by the few
# soil points under it, and once that soil is plastic those cells collapse
# (u-p stopped at s/B = 0.33 on a grid of h = 0.2; with the body it reaches 2B).

#
# `fe_mpm.scenes.strip_footing` builds the grid (`meshes.strip_footing`: soil, the
# empty strip, a refined zone seeded with `--points-near` points per cell, the rest
# with `--points-far`, merged with `fe_mpm.merge`), the Tresca soil
# (`fe_mpm.MohrCoulomb.tresca`), the footing points (`meshes.footing_points`, as a
# `fe_mpm.PointDirichlet`, whose penalty the scene sets to 1e3 E/h unless told; the
# class itself takes no default) and the rollers.

# +
try:
    B = args.B
    sim = scenes.strip_footing(
        args.formulation,
        B=B,
        cu=args.cu,
        E=args.E,
        nu=args.nu,
        h=args.h,
        h_far=args.h_far,
        edge_size=args.edge_size,
        near_width=args.near_width,
        near_depth=args.near_depth,
        points_near=args.points_near,
        points_far=args.points_far,
        settlement=args.settlement,
        smooth=args.smooth,
        footing_thickness=args.footing_thickness,
        penalty=args.penalty,
        line_search=args.line_search,
        output_dir=None if args.no_output else args.output,
        output_every=max(1, args.steps // 20),
    )
    points = sim.points
    reports = sim.run(t_end=1.0, n_steps=args.steps, progress=not args.json)
except (ValueError, fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"strip_footing.py: {err}")
# -

# ## Load against settlement
#
# q is the footing force over the half-width: q = −F_y / (B/2).

# +
settlement = np.array([args.settlement * r.t for r in reports])
q = np.array([scenes.footing_pressure(r, B) for r in reports])
s_over_B, q_over_cu = settlement / B, q / args.cu
iterations = [r.newton_iterations for r in reports]
# Vertical stress in the soil under the footing, within B/2 of its base (each rank
# holds the points of its cells: gather them).
x, sigma = (parallel.gathered(sim.mesh.comm, a) for a in (points.x, points.stress[:, 1, 1]))
below = (x[:, 0] < B / 2) & (x[:, 1] > -args.settlement - B / 2)
sigma_yy = sigma[below] / args.cu
oscillation = stress_oscillation(x[below], sigma[below]) / args.cu
n_points = len(x)
wall = time.perf_counter() - START
print(
    f"Strip footing, {args.formulation}: {n_points} points, {len(reports)} steps, "
    f"wall time {wall:.1f} s"
)
for target in (0.05, 0.1, 0.25, 0.5, 1.0, 1.5, 2.0):
    if s_over_B[-1] >= target - 1e-12:  # between steps, and from the unloaded start
        q = np.interp(target, np.r_[0.0, s_over_B], np.r_[0.0, q_over_cu])
        print(f"  s/B = {target:<5}  q/c_u = {q:.3f}")
print(
    f"  σ_yy/c_u under the footing: [{sigma_yy.min():.2f}, {sigma_yy.max():.2f}]; "
    f"oscillation {oscillation:.3f}"
)
failed = sum(r.failed_iterations for r in reports)
print(
    f"  Newton iterations per step: max {max(iterations)}, mean {np.mean(iterations):.2f}; "
    f"{failed} more in attempts that failed (StepReport.failed_iterations)"
)
held = [r.step for r in reports if r.held_points]
if held:
    print(f"  steps retried without re-binning (Simulation.step): {held}")
if sim.mesh.comm.size > 1:  # each rank integrates its own points
    imbalance = [r.point_imbalance for r in reports]
    print(f"  points per rank, most over mean: {imbalance[0]:.2f} first, {max(imbalance):.2f} max")

if not args.no_output and rank0:
    plt = pyplot()  # None without matplotlib (the plots extra)
    out = Path(args.output)
    np.savetxt(
        out / "load_settlement.csv",
        np.column_stack([s_over_B, q_over_cu]),
        delimiter=",",
        header="settlement_over_B,q_over_cu",
        comments="",
    )
    if plt is not None:
        fig, ax = plt.subplots(figsize=(5, 3.5))
        ax.plot(np.r_[0, s_over_B], np.r_[0, q_over_cu], "-", label=f"fe-mpm {args.formulation}")
        ax.axhline(2 + np.pi, color="k", ls="--", lw=1, label="2 + π (small strain)")
        ax.set_xlabel("s / B")
        ax.set_ylabel("q / c_u")
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "load_settlement.png", dpi=120)
        print(
            f"  wrote {out}/particles.pvd (stress, pressure, plastic_strain), "
            "load_settlement.csv and .png"
        )

# -

# ## Check against the reference
#
# On weightless Tresca soil the small-strain bearing capacity is q = (2 + π) c_u
# (Prandtl; the same for a rough and a smooth footing, Hill). With E/c_u = 100 the
# soil is soft: q/c_u reaches 2 + π near s/B = 0.1 on the thesis grid, and the
# footing then embeds and q keeps rising. The check takes the mean of q/c_u over the
# steps with 0.1 ≤ s/B ≤ 0.15, where the capacity is mobilised and the footing has
# embedded by at most 0.15 B (Skempton's embedded factor: +3 %). Measured (u-p, 200
# steps to 2B): +1.9 % on the thesis grid (h = 0.05 B, as by default), +5.0 % on
# h = 0.1 B and +9.6 % on h = 0.2 B, falling with h. (Over 0.08–0.1, the window
# used before the footing's body points stopped stiffening the soil, the thesis grid
# is still mobilising: −5.3 %.) The u form locks and overshoots by about 65 %.
# Softer soil (E/c_u < 100) reaches 2 + π later, and a run with no step in the
# window cannot show it; those are not
# checked. Stiff soil shows the collapse load itself: with E/c_u = 3000,
# `benchmarks/footing_prandtl.py` measures 1.125 × (2 + π) on h = 0.1 B and 1.003
# with cells of h/4 at the footing's edge, where the stresses are singular
# (`--edge-size`).

# +
#: Window of settlements s/B over which q/c_u is averaged.
WINDOW = (0.1, 0.15)
#: Band for that mean over 2 + π: from 5 % below (the soil's elastic share on fine
#: grids) to 15 % above (embedment and the coarse grid's overestimate).
LOWER, UPPER = -0.05, 0.15

in_window = (s_over_B >= WINDOW[0] - 1e-9) & (s_over_B <= WINDOW[1] + 1e-9)
if args.E / args.cu < 100 or not in_window.any():
    plateau, check_error, passed = None, None, None  # not checked
    print(
        f"check: 2 + π needs E/c_u ≥ 100 and steps with {WINDOW[0]} ≤ s/B ≤ {WINDOW[1]}: "
        "not checked"
    )
else:
    plateau = float(q_over_cu[in_window].mean())
    check_error = plateau / (2 + np.pi) - 1
    passed = bool(LOWER <= check_error <= UPPER)
    print(
        f"check: mean q/c_u over {WINDOW[0]} ≤ s/B ≤ {WINDOW[1]} = {plateau:.3f} vs Prandtl "
        f"2 + π = {2 + np.pi:.3f} ({args.formulation}): error {100 * check_error:+.1f} % "
        f"{'within' if passed else 'outside'} [{100 * LOWER:+.0f} %, {100 * UPPER:+.0f} %]: "
        f"{'PASS' if passed else 'FAIL'}"
    )
if args.json:
    print(
        json.dumps(
            {
                "settlement_over_B": s_over_B.tolist(),
                "q_over_cu": q_over_cu.tolist(),
                "wall_time_s": wall,
                "n_particles": n_points,
                "point_imbalance": max(r.point_imbalance for r in reports),
                "steps": len(reports),
                "newton_iterations_max": max(iterations),
                "newton_iterations": iterations,
                "failed_iterations": failed,
                "steps_with_held_points": held,
                "residual_norms": [r.residual_norms for r in reports],
                "sigma_yy_over_cu_range": [float(sigma_yy.min()), float(sigma_yy.max())],
                "stress_oscillation": float(oscillation),
                "formulation": args.formulation,
                "timings": sim.timings,
                "check_q_over_cu": plateau,
                "check_error": check_error,
                "check_passed": passed,
            }
        )
    )
if passed is False:
    sys.exit(f"strip_footing.py: q/c_u over s/B = 0.1–0.15 is {100 * check_error:+.1f} % off 2 + π")
# -
