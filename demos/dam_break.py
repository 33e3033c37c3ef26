# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # Dam break (Mast 2013, §6.1.1) against Martin & Moyce (1952)
#
# A column of water l₀ wide and h₀ high stands against the left wall of a tank and
# collapses when the dam holding it is removed. Martin & Moyce filmed it and
# tabulated the surge front x against time, and the column's height at the wall;
# they are the classic check of a free-surface flow code. Mast ran it with his
# nearly incompressible Newtonian fluid (his Eq. 6.1) and volumetric averaging.
# This demo illustrates how to:
#
# - give a material a rate-dependent law: `fe_mpm.NewtonianFluid`, whose viscous
#   stress reads the step's length;
# - run a nearly incompressible flow with the u-p form and Bossak's dissipation
#   (`Simulation(bossak_alpha=)`), whose pressure waves the step cannot resolve;
# - measure a surge front and a height robustly, ignoring detached droplets.
#
# **Data** (Mast's Table 6.1 and §6.1): water, ρ₀ = 997.5 kg/m³, K = 2.0 GPa,
# μ_v = 1.0e-3 Pa·s; l₀ = 0.05715 m (Martin & Moyce's a = 2¼ in), h₀ = 2 l₀ (their
# n² = 2); cells of 8.75 mm; slip on every wall; g = 9.81 m/s². Mast's explicit code
# took steps of 0.5 µs; this implicit one takes 1 ms.
#
# **Reference.** Martin & Moyce (1952), Phil. Trans. R. Soc. A 244, 312–324, Tables 2
# and 6 for n² = 2, a = 2¼ in: the front Z = x/a at T = t √(2g/a) (at h₀ = 2l₀ this is
# Mast's scaling, his Eq. 6.3), and the height H = h/(n²a) at τ = t √(g/a). The
# numbers are those reproduced by Lethe's and other validation suites. For n² = 1
# (`--aspect 1`, h₀ = l₀) they are the square column's numbers that SPH validation
# suites credit to Martin & Moyce (as plotted, e.g., by Adami, Hu & Adams 2012),
# against the same T; Koshizuka & Oka's (1996) own square column agrees with their
# front within 7 %. Other aspects run unchecked.
#
# Usage: `python demos/dam_break.py --json`.

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
from fe_mpm.cli import nonnegative, positive
from fe_mpm.meshes import cell_centroids, rectangle_mesh
from fe_mpm.plotting import pyplot

#: Martin & Moyce (1952), by n² = h₀/l₀: the surge front Z = x/a at T = t √(n²g/a)
#: (Mast's T), and the height at the wall H = h/(n²a) at τ = t √(g/a), each as
#: (times, values). n² = 2, a = 2¼ in: their Tables 2 and 6. n² = 1: the square
#: column's numbers SPH validation suites credit to them (e.g. as Adami, Hu & Adams
#: 2012, J. Comput. Phys. 231, plot them), times on this T; Koshizuka & Oka's (1996)
#: own square column agrees with the front within 7 % (their 1.505, 2.241 and 3.003
#: at T = 0.815, 1.368 and 1.923 here).
REFERENCE = {
    2.0: {
        "front": (
            (0.41, 0.84, 1.19, 1.43, 1.63, 1.83, 1.98, 2.20, 2.32, 2.51, 2.65, 2.83, 2.98, 3.11,
             3.33),
            (1.11, 1.22, 1.44, 1.67, 1.89, 2.11, 2.33, 2.56, 2.78, 3.00, 3.22, 3.44, 3.67, 3.89,
             4.11),
        ),
        "height": (
            (0.56, 0.77, 0.93, 1.08, 1.28, 1.46, 1.66, 1.84, 2.00, 2.21, 2.45, 2.70),
            (0.94, 0.89, 0.83, 0.78, 0.72, 0.67, 0.61, 0.56, 0.50, 0.44, 0.39, 0.33),
        ),
    },
    1.0: {
        "front": (
            (0.43, 0.62, 0.80, 0.97, 1.14, 1.29, 1.45, 1.62, 1.76, 1.93, 2.07, 2.24, 2.40, 2.54,
             2.71, 2.87, 3.04, 3.21, 3.29, 3.32),
            (1.11, 1.22, 1.44, 1.67, 1.89, 2.11, 2.33, 2.56, 2.78, 3.00, 3.22, 3.44, 3.67, 3.89,
             4.11, 4.33, 4.56, 4.78, 4.89, 5.00),
        ),
        "height": (
            (0.80, 1.29, 1.74, 2.15, 2.57, 3.08, 4.27, 6.29),
            (0.89, 0.78, 0.67, 0.56, 0.44, 0.33, 0.22, 0.11),
        ),
    },
}  # fmt: skip
#: The check's bands, relative to the experiment. Every numerical run of this case
#: leads the film: the dam took time to lift, and the tank's floor was not
#: frictionless (Mast: his averaged runs "flow slightly faster than observed").
FRONT_BAND = (-0.10, 0.25)
HEIGHT_BAND = (-0.10, 0.10)


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="Dam break (Mast 2013, §6.1.1)")
    p.add_argument(
        "--aspect", type=positive(float), default=2.0, help="h0/l0: 2 or 1 (checked), or other"
    )
    p.add_argument("--formulation", choices=("up", "u", "u-nbva"), default="up")
    p.add_argument(
        "--h", type=float, default=0.00875, help="cell size (m), rounded to fit l0 whole"
    )
    p.add_argument("--points-per-cell", type=positive(int), default=12, help="points per triangle")
    p.add_argument("--dt", type=float, default=1.0e-3, help="time step (s)")
    p.add_argument("--T-end", type=float, default=3.4, help="end time T = t sqrt(g h0)/l0")
    p.add_argument("--bulk-modulus", type=positive(float), default=2.0e9, help="K (Pa)")
    p.add_argument("--viscosity", type=nonnegative(float), default=1.0e-3, help="mu_v (Pa s)")
    p.add_argument("--bossak-alpha", type=float, default=-0.3, help="Bossak's alpha")
    p.add_argument(
        "--ppp-alpha", type=float, default=0.0, help="PPP's alpha in u-p (0: off, see below)"
    )
    p.add_argument(
        "--shear-scale", type=float, default=None, help="G* (Pa) for PPP; 2 rho g h0 if unset"
    )
    p.add_argument("--output", default="dam_break_output", help="output folder")
    p.add_argument("--no-output", action="store_true", help="write no files")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
for name in ("h", "dt", "T_end"):
    if not getattr(args, name) > 0.0:
        sys.exit(f"dam_break.py: --{name.replace('_', '-')} must be > 0, got {getattr(args, name)}")
rank0 = parallel.print_on_rank_zero()
rho, g, l0 = 997.5, 9.81, 0.05715
h0 = args.aspect * l0
across = max(1, round(l0 / args.h))  # cells across the column: its sides are grid lines
h = l0 / across
# Mast's T = t √(g h₀)/l₀ (his Eq. 6.3): Martin & Moyce's t √(n² g/a), √(2g/a) at h₀ = 2a.
time_scale = math.sqrt(g * h0) / l0
t_end = args.T_end / time_scale
# -

# ## Scene
#
# The tank is 7 l₀ long and two cells higher than the column, with slip walls (the
# normal displacement held) on the left, the right and the floor. The cell size is
# Mast's 8.75 mm rounded so that the column is a whole number of cells (l₀/7 = 8.16
# mm), and the points fill those cells. The mass is lumped, as for the sand
# column: the thin surge carries no stress, and only its mass holds its nodes.
#
# The u-p form runs without its pressure stabilisation (PPP; `Simulation`'s default for
# a fluid, passed here as `ppp_alpha=args.ppp_alpha` with `--ppp-alpha` 0). PPP
# penalises the pressure's variation inside each cell at the scale of a shear
# modulus, which water lacks (`NewtonianFluid(shear_scale=)` stands in for it), and it
# resists the hydrostatic gradient too: with it, water at rest in a tank churns
# (`fe_mpm.materials.fluid` has the measurements). Without it, and with the fluid's
# points keeping the volume their pressure says, water at rest stays at rest.
# `--ppp-alpha 1` gives the thesis's stabilisation, with G* = 2ρ₀gh₀ (the surge's
# stagnation pressure ρ₀v² with Ritter's speed scale v = √(2gh₀), 2.2 kPa here).

# +
nx, ny = 7 * across, math.ceil(h0 / h - 1e-9) + 2
width = nx * h
grid = rectangle_mesh((0.0, 0.0), (width, ny * h), (nx, ny))
centroids = cell_centroids(grid)  # each rank seeds the cells it owns
column = np.flatnonzero((centroids[:, 0] < l0) & (centroids[:, 1] < h0))
try:
    points = fe_mpm.seed(grid, args.points_per_cell, density=rho, cells=column)
    water = fe_mpm.NewtonianFluid(
        args.bulk_modulus,
        args.viscosity,
        shear_scale=args.shear_scale or 2.0 * rho * g * h0,
        density=rho,
    )
    sim = fe_mpm.Simulation(
        grid,
        points,
        water,
        args.formulation,
        dirichlet=[
            fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0), component=0),
            fe_mpm.Dirichlet(lambda x: np.isclose(x[0], width), component=0),
            fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0), component=1),
        ],
        body_force=(0.0, -g),
        dynamic=True,
        mass="lumped",
        bossak_alpha=args.bossak_alpha,
        ppp_alpha=args.ppp_alpha,
        output_dir=None if args.no_output else args.output,
        output_every=max(1, round(t_end / args.dt) // 40),
    )
except ValueError as err:
    sys.exit(f"dam_break.py: {err}")
# -

# ## Front and height
#
# The surge front is the farthest point within one cell of the floor that the water
# reaches without a gap: walking along the floor from the wall, the first gap wider
# than a cell ends it, so a droplet thrown ahead does not count. The height is the
# same walk up the left wall.

# +
history = []


def reach(coordinates: np.ndarray) -> float:
    """The end of the water's unbroken run along a wall (m), from 0 outwards."""
    run = np.sort(coordinates)
    gaps = np.flatnonzero(np.diff(run) > h)
    return float(run[gaps[0]] if gaps.size else run[-1])


def record(report: fe_mpm.StepReport) -> None:
    """Front Z = x/l₀ and height h/h₀ after a step."""
    x = parallel.gathered(grid.comm, points.x)
    front = reach(x[x[:, 1] < h, 0]) / l0
    height = reach(x[x[:, 0] < h, 1]) / h0
    history.append((report.t, front, height))


try:
    reports = sim.run(t_end, max(1, round(t_end / args.dt)), progress=not args.json, on_step=record)
except (fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError, ValueError) as err:
    sys.exit(f"dam_break.py: {err}")
t, Z, H = np.array(history).T
T = t * time_scale
# -

# ## Against the experiment
#
# The run is interpolated at the film's times. Martin & Moyce's height is h/(n²a)
# with n²a = h₀, so it is H here, at τ = t √(g/a) = T/n.

# +
wall = time.perf_counter() - START
iterations = [r.newton_iterations for r in reports]
n_points = int(parallel.total(grid.comm, len(points)))
reference = next((r for a, r in REFERENCE.items() if abs(args.aspect - a) < 1e-12), None)
none = ((), ())  # no tabulated times for another aspect
front_T, front_Z = map(np.array, reference["front"] if reference else none)
height_tau, height_H = map(np.array, reference["height"] if reference else none)
height_T = np.sqrt(args.aspect) * height_tau
in_front, in_height = front_T <= T[-1], height_T <= T[-1]
front_error = np.interp(front_T[in_front], T, Z) / front_Z[in_front] - 1.0
height_error = np.interp(height_T[in_height], T, H) / height_H[in_height] - 1.0
# Only h₀ = 2 l₀ and h₀ = l₀ have a reference, once the run reaches its first time.
# Martin & Moyce's water: a Reynolds number ρ √(g h₀) h₀ / μ_v far above 1e4 (a
# fluid a thousand times more viscous spread 25.7 % short and failed, 2026-12-06).
reynolds = rho * math.sqrt(g * h0) * h0 / max(args.viscosity, 1e-300)
checked = reference is not None and front_error.size > 0 and reynolds >= 1e4


def span(errors: np.ndarray) -> str:
    """The range of relative errors in per cent, or that the run reached none."""
    if errors.size == 0:
        return "none reached"
    return f"{100 * errors.min():+.1f} … {100 * errors.max():+.1f} %"


print(
    f"Dam break, {args.formulation}, h0/l0 = {args.aspect:g}: {n_points} points, "
    f"{len(reports)} steps of up to {args.dt:g} s, h = {h:g} m, wall time {wall:.1f} s"
)
print(
    f"  front Z = x/l0 at T = {T[-1]:.2f}: {Z[-1]:.3f}; height h/h0 {H[-1]:.3f}; "
    f"Newton per step mean {np.mean(iterations):.2f}, max {max(iterations)}"
)
if checked:
    print(
        f"  against Martin & Moyce: front {span(front_error)}, height "
        f"{span(height_error)} over their {front_error.size} and {height_error.size} points"
    )
if not args.no_output and rank0:
    out = Path(args.output)
    np.savetxt(
        out / "front.csv",
        np.column_stack([t, T, Z, H]),
        delimiter=",",
        header="t,T,Z,H",
        comments="",
    )
    plt = pyplot()
    if plt is not None:
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.6))
        ax1.plot(T, Z, label=f"fe-mpm ({args.formulation})")
        ax2.plot(T / np.sqrt(args.aspect), H, label=f"fe-mpm ({args.formulation})")
        if checked:
            ax1.plot(front_T, front_Z, "ko", ms=4, label="Martin & Moyce (1952)")
            ax2.plot(height_tau, height_H, "ko", ms=4, label="Martin & Moyce (1952)")
        ax1.set_xlabel("T = t √(n²g/a)")
        ax1.set_ylabel("front Z = x/a")
        ax2.set_xlabel("τ = t √(g/a)")
        ax2.set_ylabel("height H = h/(n²a)")
        ax1.legend()
        fig.tight_layout()
        fig.savefig(out / "dam_break.png", dpi=120)
    print(f"  wrote {out}/particles.pvd, front.csv" + (" and dam_break.png" if plt else ""))
# -

# ## Check against the reference
#
# Measured (2026-12-05, u-p without PPP, the starting pressure by parts, the
# defaults: 2352 points, 186 steps, 3.0 Newton iterations per step, 5 s; re-run on
# 2026-12-06: 189 steps, the height −4.6 to +0.6 %): the front
# runs −3.9 to +15.5 % ahead of the film (behind only at its first point, T = 0.41),
# the height lies −4.5 to +0.3 % about it, as Mast found with averaging ("slightly
# faster than observed"); with Δt halved, −3.9 to +15.2 % and −4.7 to +0.5 %. With
# h₀ = l₀ (`--aspect 1`: 1176 points, 262 steps) the front leads by +3.6 to +24.5 %
# and the height lies −4.7 to +9.5 % about the film's; on another 2-core machine
# (2026-12-05, 261 steps, the same code) the height at τ = 3.08, where the film's H
# is 0.33, came out 10.1 % high and the check failed there: the last height point
# lies on the band's edge, and round-off decides. On cells of half the size
# (`--h 0.0041`) n² = 2 stays in the band (front −1.7 … +20.6 %, height −4.2 …
# +0.7 %); n² = 1 leaves it at the front's last point (+7.7 … +25.7 %, height −4.5 …
# +6.3 %). With the pressure's force in the usual form alone
# (`Simulation(pressure_by_parts=False)`, as until 2026-12-05) the fronts were
# −3.9 … +14.7 % and +3.5 … +23.6 %, on the finer cells −1.8 … +19.8 % and +7.5 …
# +24.7 %, the heights −3.9 … +1.7 %, −4.2 … +8.6 %, −4.1 … +0.9 % and −4.3 …
# +6.3 %: the split changes the surge by about a per cent, where it keeps a vortex's
# energy (`benchmarks/fluid_energy.py`). With PPP (`--ppp-alpha 1`,
# as until 2026-12-05, when the fluid's points still kept their own volume) the
# heights fell to −9.5 % and −13.7 % on the finer cells, the latter outside the band;
# with PPP and the points' volume from their pressure the front runs +25.1 % ahead and
# fails. The displacement form (`--formulation u`) keeps the column taller, +1.2 to
# +9.1 %, its front −6.8 to +17 %: the locking of the pressure shows in the height.
# Mast's anti-locking, `--formulation u-nbva` (node-based volumetric averaging; its
# fluid points take the averaged volume after each step and its starting pressure
# is taken by parts, as in u-p): front −3.9 … +15.4 %, height −4.2 … +1.1 % (184
# steps, 3 Newton iterations each, 3 s); n² = 1 +3.6 … +24.4 % and −5.1 … +9.9 %; on
# cells of half the size n² = 2 stays in the band (−1.7 … +20.6 %, −3.6 … +2.5 %) and
# n² = 1 leaves it at the front's last point, as u-p does (+7.7 … +25.7 %). Until
# 2026-12-05, with each point's own volume, its pressures grew tenfold every few
# steps from T ≈ 0.6 and at T ≈ 1.3 a point was thrown out of the tank, whatever the
# step (1, 0.5 or 0.25 ms).
# The check asks the front to lie within −10 … +25 % and the height within ±10 % at
# every tabulated time the run reaches; the u form lies inside these bands too.

# +
passed = bool(
    np.all((FRONT_BAND[0] <= front_error) & (front_error <= FRONT_BAND[1]))
    and np.all((HEIGHT_BAND[0] <= height_error) & (height_error <= HEIGHT_BAND[1]))
)
if checked:
    verdict = "PASS" if passed else "FAIL"
    line = (
        f"front {span(front_error)} in [{100 * FRONT_BAND[0]:+.0f}, "
        f"{100 * FRONT_BAND[1]:+.0f}] % and height {span(height_error)} in "
        f"[{100 * HEIGHT_BAND[0]:+.0f}, {100 * HEIGHT_BAND[1]:+.0f}] % of Martin & Moyce"
    )
else:
    passed, verdict = None, "not checked"
    if reference is None:
        line = f"h0/l0 = {args.aspect:g}: no tabulated experiment"
    elif reynolds < 1e4:
        line = f"Reynolds number {reynolds:.3g} < 1e4: not Martin & Moyce's water"
    else:
        line = f"the run ends at T = {T[-1]:.2f}, before Martin & Moyce's first time"
print(f"check: {line}: {verdict}")
if args.json:
    print(
        json.dumps(
            {
                "formulation": args.formulation,
                "ppp_alpha": args.ppp_alpha,
                "aspect": args.aspect,
                "T": T.tolist(),
                "front_Z": Z.tolist(),
                "height_H": H.tolist(),
                "reference_front": [front_T.tolist(), front_Z.tolist()] if reference else None,
                "reference_height": [height_tau.tolist(), height_H.tolist()] if reference else None,
                "front_relative_error": front_error.tolist() if checked else None,
                "height_relative_error": height_error.tolist() if checked else None,
                "points": n_points,
                "steps": len(reports),
                "h": h,
                "dt": args.dt,
                "newton_iterations_mean": float(np.mean(iterations)),
                "newton_iterations_max": int(max(iterations)),
                "wall_time_s": wall,
                "ranks": grid.comm.size,
                "check_passed": passed,
            }
        )
    )
if passed is False:
    sys.exit("dam_break.py: the run lies outside the experiment's bands")
# -
