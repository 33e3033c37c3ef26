# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # The Taylor bar: a rod hitting a rigid wall (Mast 2013, §7.1)
#
# A copper rod, L₀ = 32.4 mm long with a radius of R₀ = 3.2 mm, hits a rigid,
# frictionless wall end-on at 227 m/s and flattens into a mushroom within 80 µs
# (`--case copper`, the default). Taylor's impact test, in this set-up after
# Wilkins & Guinan, is the classic check of finite-strain plasticity codes, and
# Mast (§7.1) used it, with an aluminium bar of his own (`--case mast`), to compare
# his anti-locking variants of MPM. This demo illustrates how to:
#
# - run a 3D scene: a quarter of the rod with two symmetry planes, seeded from a
#   gmsh cylinder of its own (`fe_mpm.meshes.cylinder`) on a box grid of
#   tetrahedra;
# - stop a body with a frictionless rigid wall (`fe_mpm.RigidWall`) and read the
#   force on it;
# - choose the formulation against volumetric locking in isochoric plastic flow:
#   the mixed `"up"` (the default here) or `"u-nbva"` (Mast's node-based volumetric
#   averaging). The plain `"u"` form stiffens, as Mast found: a longer bar with a
#   smaller footprint (below). On finer grids, and on Mast's own bar, only u-p runs
#   to the end (below);
# - check a wall's force: its impulse is the momentum the rod loses.
#
# **Data.** Copper (the finite element benchmark, e.g. Simo 1992): E = 117 GPa,
# ν = 0.35, ρ = 8930 kg/m³, J2 plasticity with σ_Y = 0.4 GPa and linear isotropic
# hardening H = 0.1 GPa (`fe_mpm.J2Plasticity`), v₀ = 227 m/s, t_end = 80 µs; a
# grid of h = 1 mm (`--full`: 0.5 mm). Mast's bar (his Table 7.1): H₀ = 28 cm,
# R₀ = 4 cm, v₀ = 150 m/s, ρ = 2710 kg/m³, K = 68.6 GPa, G = 23.3 GPa, σ_Y = 61 MPa,
# isotropic hardening slope 0.2 with no unit given, read here as MPa like his other
# entries (`fe_mpm.HenckyJ2`, his §3.5 law), t_end = 1 ms, his grid of 1 cm
# (`--full`: 0.5 cm).
#
# Usage: `python demos/taylor_bar.py --case copper --json`.

# +
import time

START = time.perf_counter()

import argparse
import json
import math
import sys

import numpy as np

import fe_mpm
from fe_mpm import parallel
from fe_mpm.cli import positive
from fe_mpm.meshes import cylinder, rectangle_mesh


def bulk_shear(K: float, G: float) -> tuple[float, float]:
    """Young's modulus (Pa) and Poisson's ratio from the bulk and shear moduli (Pa)."""
    return 9 * K * G / (3 * K + G), (3 * K - 2 * G) / (2 * (3 * K + G))


#: The two bars: length and radius (m), impact speed (m/s), density (kg/m³), the law,
#: duration (s), grid cell (m) and its --full refinement, steps, and how far the grid
#: reaches sideways (in R₀: the mushroom must stay on it).
CASES = {
    "copper": dict(
        length=32.4e-3,
        radius=3.2e-3,
        velocity=227.0,
        density=8930.0,
        law=lambda: fe_mpm.J2Plasticity(117e9, 0.35, 0.4e9, 0.1e9, density=8930.0),
        t_end=80e-6,
        h=(1.0e-3, 0.5e-3),
        steps=160,
        reach=2.75,
    ),
    "mast": dict(
        length=0.28,
        radius=0.04,
        velocity=150.0,
        density=2710.0,
        law=lambda: fe_mpm.HenckyJ2(
            *bulk_shear(68.6e9, 23.3e9), 61e6, hardening=0.2e6, density=2710.0
        ),
        t_end=1e-3,
        h=(1.0e-2, 0.5e-2),
        steps=200,
        reach=4.0,
    ),
}


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="The Taylor bar (copper rod on a rigid wall)")
    p.add_argument("--case", choices=tuple(CASES), default="copper", help="which bar")
    p.add_argument("--formulation", choices=("u", "u-nbva", "up"), default="up")
    p.add_argument("--full", action="store_true", help="the finer grid (half the cell)")
    p.add_argument(
        "--h", type=positive(float), default=None, help="grid cell size (m), over --full"
    )
    p.add_argument(
        "--steps", type=positive(int), default=None, help="time steps (default: the case's)"
    )
    p.add_argument("--t-end", type=positive(float), default=None, help="duration (s; the case's)")
    p.add_argument(
        "--line-search",
        choices=("basic", "bt", "l2", "auto"),
        default="basic",
        help="Newton's SNES line search (default: basic, full steps; auto gives bt)",
    )
    p.add_argument("--output", default="taylor_bar_output", help="output folder")
    p.add_argument("--no-output", action="store_true", help="write no files")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
parallel.print_on_rank_zero()  # every rank runs this script; one prints
case = CASES[args.case]
LENGTH, RADIUS, VELOCITY, DENSITY = (case[k] for k in ("length", "radius", "velocity", "density"))
h = case["h"][1 if args.full else 0] if args.h is None else args.h
t_end = case["t_end"] if args.t_end is None else args.t_end
steps = case["steps"] * (2 if args.full else 1) if args.steps is None else args.steps
# -

# ## Scene: a quarter of the rod on a box grid
#
# The rod's points come from a quarter cylinder of tetrahedra half the grid's size,
# one point each. The grid reaches 2.75 R₀ sideways for the copper bar (its
# mushroom's radius is about 2.2 R₀), 4 R₀ for Mast's softer one, and one cell above
# the rod. Its base z = 0 is the wall, and the planes
# x = 0 and y = 0 are symmetry planes: the normal displacement is held there.

# +
n_side, n_up = math.ceil(case["reach"] * RADIUS / h), math.ceil(LENGTH / h) + 1
grid = rectangle_mesh((0.0, 0.0, 0.0), (n_side * h, n_side * h, n_up * h), (n_side, n_side, n_up))
rod = cylinder(RADIUS, LENGTH, h / 2, sector=math.pi / 2, comm=grid.comm).mesh
points = fe_mpm.seed(rod, 1, density=DENSITY)  # each rank seeds its part of the rod
points.velocity[:, 2] = -VELOCITY
anvil = fe_mpm.RigidWall("wall", lambda x: np.isclose(x[2], 0.0))
try:
    sim = fe_mpm.Simulation(
        grid,
        points,
        case["law"](),
        args.formulation,
        dirichlet=[
            fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0), component=0),
            fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0), component=1),
        ],
        walls=[anvil],
        dynamic=True,
        # The trapezoidal rule, as the published runs: the bar hits the anvil and stays
        # (its rebound is not measured; the plastic work takes the energy).
        bossak_alpha=0.0,
        mass="lumped",
        output_dir=None if args.no_output else args.output,
        output_every=max(1, steps // 8),
        # Full Newton steps, not the backtracking of "auto" (a law with history): on
        # Mast's bar (h = 2 cm, 200 steps) 50 s against 84 s (backtracking crawled at
        # λ ≈ 0.1 for up to 25 iterations; 79 s with PETSc's l2), the same answer to
        # 1e-10; on the copper bar (h = 1.33 mm) 70 s against 80 s (76 s).
        line_search=args.line_search,
        # A step whose full steps cycle (a few nodes at the mushroom's rim) is retried
        # with backtracking from the iterate that came closest, not from rest: on Mast's
        # bar (1 cm, to 0.2 ms) 55 s against 75 s, and no step cut.
        fallback_from_best=True,
    )
    sim.add_marker("top", (0.0, 0.0, LENGTH))
    sim.add_marker("edge", (RADIUS, 0.0, 0.0))
except ValueError as err:
    sys.exit(f"taylor_bar.py: {err}")
# -

# ## Impact
#
# The rod's length is the top marker's height; the footprint's radius is Mast's
# (his Eqs. 7.3–7.4): the centroid x̄ of the points within half a cell of the wall,
# as the centroid of a quarter disk, R = 3π x̄ / 4.

# +
history = []


def footprint_radius() -> float:
    """Mast's footprint radius (m) from the points touching the wall."""
    near = points.x[:, 2] < 0.5 * h
    moment = parallel.total(grid.comm, points.mass[near] @ points.x[near, 0])
    mass = parallel.total(grid.comm, points.mass[near].sum())
    return 3.0 * math.pi / 4.0 * moment / mass if mass > 0 else float("nan")


def outer_radius() -> float:
    """The footprint's outer edge (m): the farthest point touching the wall, plus its half-width."""
    near = points.x[:, 2] < 0.5 * h
    r = np.hypot(points.x[near, 0], points.x[near, 1]) + 0.5 * points.volume[near] ** (1 / 3)
    return parallel.largest(grid.comm, float(r.max(initial=0.0)))


def record(report: fe_mpm.StepReport) -> None:
    """The rod's length, its footprint's radii (centroid, edge; m) and the wall's push (N)."""
    history.append(
        (
            report.t,
            float(sim.marker("top")[2]),
            footprint_radius(),
            outer_radius(),
            4.0 * report.walls["wall"].normal,
        )
    )


def momentum() -> float:
    """The whole rod's momentum along z (N s; four quarters)."""
    return 4.0 * parallel.total(grid.comm, float(points.mass @ points.velocity[:, 2]))


start_momentum = momentum()


try:
    reports = sim.run(t_end, steps, on_step=record)
except (fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"taylor_bar.py: {err}")
t, length, radius, edges, push = np.array(history).T
iterations = [r.newton_iterations for r in reports]
# The wall's impulse, by the trapezoidal rule of Newmark's average acceleration
# (the force at the start is zero), against the momentum the rod lost.
impulse = float(np.sum(np.diff(t, prepend=0.0) * 0.5 * (push + np.r_[0.0, push[:-1]])))
momentum_lost = momentum() - start_momentum
wall = time.perf_counter() - START
print(
    f"Taylor bar ({args.case}, {args.formulation}, h = {h * 1e3:g} mm, "
    f"{parallel.total(grid.comm, len(points))} points of a quarter rod, {len(reports)} steps)"
)
print(
    f"  final length {length[-1] * 1e3:.2f} mm; footprint radius {outer_radius() * 1e3:.2f} mm "
    f"at its edge, {radius[-1] * 1e3:.2f} mm by Mast's centroid (edge marker at "
    f"{sim.marker('edge')[0] * 1e3:.2f} mm); peak push {push.max() / 1e6:.2f} MN"
)
print(f"  wall impulse {impulse:.4f} N s, momentum lost by the rod {momentum_lost:.4f} N s")
print(
    f"  Newton per step: mean {np.mean(iterations):.1f}, max {max(iterations)}; "
    f"wall time {wall:.0f} s"
)
# -

# ## Check against the reference
#
# The finite element literature gives the footprint's outer radius R_f and the
# final length L_f of this bar at 80 µs. Radii: 7.12 mm (Simo 1992, CMAME 99),
# 7.11 mm (Zienkiewicz, Rojek, Taylor & Pastor 1998, IJNME 43) and 7.22 mm (Foulk et
# al. 2021, converged hexahedra), as quoted beside runs of two further codes
# (Sierra/SM's composite tetrahedron and Carina.jl: L_f = 21.42–21.43 mm, R_f =
# 7.23 mm) in the Carina.jl repository's Taylor benchmark; the primary tables were
# not checked here. The footprint's edge is resolved to about half a cell (the
# wall acts through grid nodes h apart), so the check asks for R_f within h/2 of
# the published 7.11–7.23 mm and L_f within 1 % of 21.42 mm.
#
# Measured on three grids (`--h 0.00133`, the default 1 mm, `--h 0.00075`; 4801,
# 10 451 and 23 638 points in the quarter, 161–169 steps; 2026-12-04, two runs
# sharing the machine):
#
# | h | u-p: L_f, R_f, Mast's centroid radius | u-nbva: L_f, R_f |
# |---|---|---|
# | 1.33 mm | 21.72, 7.25, 6.77 mm (48 s) | 21.65, 7.44 mm (63 s) |
# | 1 mm | 21.59, 7.46, 6.67 mm (189 s) | 21.40, 7.51 mm (197 s) |
# | 0.75 mm | 21.51, 7.00, 6.43 mm (378 s) | stops at 63 µs |
#
# In u-p the length falls monotonically (+1.42, +0.81, +0.40 % over 21.42 mm; the
# differences 0.131 and 0.088 mm give an observed order of 1.4 and a limit near
# 21.33 mm, 21.24 mm at first order). The footprint's outer radius, read from the
# outermost point on the wall, moves by up to 0.46 mm from grid to grid (within h/2
# of the published range on each) while the centroid radius falls steadily. With
# node-based averaging a sheet of points two cells above the wall jets past the
# grid's edge (9 mm out) on the finest grid from 63 µs on. The plain u form gives
# 21.70 and 7.00 mm on the default grid, failing on the length (an earlier
# measurement).

#
# Mast's bar has no published numbers: his results (Figs. 7.1–7.2) are curves of
# H/H₀ and R/R₀ against t/t_f, and the `history` of the JSON summary gives the same;
# its check line says `not checked`. On his 1 cm grid (`--case mast`: 13 798 points,
# 200 steps of 5 µs) u-p runs to 1 ms in 8.3 minutes (one step cut, Newton's mean
# 10.6 a step, most 39): H/H₀ = 0.671, the footprint's outer R/R₀ = 2.18 (by Mast's
# centroid 1.78), the wall's impulse the momentum lost to 1e-15; on a 2 cm grid
# (`--h 0.02`, 27 s) 0.690 and 2.27 (centroid 2.06). With node-based averaging the
# 1 cm run cut its steps from 0.37 ms on and stopped near 0.52 ms.

# +
#: Published range of the footprint's outer radius (m), and the final length (m).
RADIUS_RANGE, FINAL_LENGTH = (7.11e-3, 7.23e-3), 21.42e-3
LENGTH_TOLERANCE = 0.01
r_f, l_f = outer_radius(), float(length[-1])
radius_off = max(RADIUS_RANGE[0] - r_f, r_f - RADIUS_RANGE[1], 0.0)
length_off = abs(l_f / FINAL_LENGTH - 1.0)
passed = bool(radius_off <= 0.5 * h and length_off <= LENGTH_TOLERANCE)
verdict = "PASS" if passed else "FAIL"
if args.case != "copper":
    passed, verdict = None, "not checked (Mast's bar: his results are figures)"
elif not math.isclose(t_end, 80e-6):  # the reference is the mushroom at 80 µs
    passed, verdict = None, f"not checked (t_end = {t_end:g} s, the reference's is 8e-05 s)"
if args.case == "copper":
    print(
        f"check: R_f {r_f * 1e3:.2f} mm vs 7.11–7.23 mm (off by {radius_off * 1e3:.2f} mm, "
        f"tolerance h/2 = {0.5 * h * 1e3:g} mm), L_f {l_f * 1e3:.2f} mm vs 21.42 mm "
        f"({100 * length_off:.2f} %, tolerance {100 * LENGTH_TOLERANCE:g} %): {verdict}"
    )
else:
    print(f"check: H/H₀ {l_f / LENGTH:.3f}, R/R₀ {r_f / RADIUS:.3f} at t_f: {verdict}")
if args.json:
    print(
        json.dumps(
            {
                "case": args.case,
                "formulation": args.formulation,
                "h": h,
                "final_length_ratio": l_f / LENGTH,
                "final_radius_ratio": r_f / RADIUS,
                "history": [
                    [float(a), b / LENGTH, c / RADIUS] for a, b, c in zip(t, length, edges)
                ],
                "final_length_mm": length[-1] * 1e3,
                "footprint_radius_mm": outer_radius() * 1e3,
                "centroid_radius_mm": radius[-1] * 1e3,
                "edge_radius_mm": float(sim.marker("edge")[0]) * 1e3,
                "steps": len(reports),
                "newton_iterations_mean": float(np.mean(iterations)),
                "n_particles": parallel.total(grid.comm, len(points)),
                "wall_time_s": wall,
                "impulse_Ns": impulse,
                "momentum_lost_Ns": momentum_lost,
                "check_passed": passed,
            }
        )
    )
if passed is False:
    sys.exit("taylor_bar.py: the mushroom is off the published one")
# -
