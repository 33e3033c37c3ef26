# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # A cylindrical cavity expanded in clay: the pressuremeter test
#
# A borehole of radius a₀ in undrained clay is expanded by an inner pressure p, as a
# pressuremeter does, until it has grown by half its radius. The face moves out
# through about seven layers of cells and stretches by half its length, so a pressure on the
# grid's facets (`fe_mpm.Pressure`), which stays where the face was, would be left
# behind: the load must follow the body. This demo illustrates how to:
#
# - load a face with a pressure that follows it (`fe_mpm.PointPressure`: points on
#   the face, each carrying its piece of the face, which deforms with the body),
# - place those points on a tagged face (`meshes.facet_points`) with its normals,
# - grade a grid, fine at the cavity and coarse far off (`quarter_ring(h_outer=)`),
# - and take large strains across many cells with point domains.
#
# **Reference** (Gibson and Anderson 1961, "In situ measurement of soil properties
# with the pressuremeter", Civil Eng. Public Works Rev. 56; Yu 2000, *Cavity
# expansion methods in geomechanics*, §3): an incompressible Tresca clay of shear
# modulus G and undrained strength c_u, plane strain, no stress at rest. Every
# particle keeps r² − r₀² = a² − a₀²; the elastic zone outside the plastic radius R
# is at small strain, so R² = (G/c_u)(a² − a₀²), and equilibrium through the plastic
# zone at finite strain gives
#
#   p(a) = c_u [1 − R²/b² + ln(R²/a²)]  (R > a),    p(a) = G (a² − a₀²)(1/a² − 1/b²)  (R ≤ a),
#
# for a body of outer radius b with a free outer face (b → ∞: Gibson and Anderson's
# p = c_u [1 + ln(G/c_u) + ln(ΔV/V)], ΔV/V = 1 − a₀²/a²). With G/c_u = 100 the
# pressure approaches its limit c_u (1 + ln 100) = 5.6 c_u; the load stops at
# p(1.5 a₀).
#
# Usage: `python demos/cavity_expansion.py --json`.

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
from fe_mpm.cli import positive
from fe_mpm.plotting import pyplot


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="Cylindrical cavity expansion in Tresca clay")
    p.add_argument("--formulation", choices=("up", "u-nbva", "up-p2p1"), default="up")
    p.add_argument("--radius", type=positive(), default=0.05, help="cavity radius a₀ (m)")
    p.add_argument("--outer", type=positive(), default=50.0, help="body's radius b over a₀")
    p.add_argument("--strength", type=positive(), default=20e3, help="undrained strength c_u (Pa)")
    p.add_argument("--stiffness", type=positive(), default=100.0, help="G / c_u")
    p.add_argument("--nu", type=float, default=0.4999, help="Poisson's ratio")
    p.add_argument("--expansion", type=positive(), default=1.5, help="a / a₀ the load aims at")
    p.add_argument("--h", type=positive(), default=0.05, help="cell size at the cavity over a₀")
    p.add_argument("--steps", type=int, default=20, help="load steps")
    p.add_argument(
        "--load",
        choices=("points", "grid"),
        default="points",
        help="PointPressure (follows the face) or Pressure (on the grid)",
    )
    p.add_argument("--standard", action="store_true", help="standard MPM (no point domains)")
    p.add_argument("--output", default="cavity_expansion_output", help="output folder")
    p.add_argument("--no-output", action="store_true", help="write no files")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
rank0 = parallel.print_on_rank_zero()  # every rank runs this script; one prints
for name, value, low in (("outer", args.outer, 2.0), ("expansion", args.expansion, 1.0)):
    if not value > low:
        sys.exit(f"cavity_expansion.py: --{name} must be > {low:g}, got {value}")
if not 0.0 < args.h < 1.0:
    sys.exit(f"cavity_expansion.py: --h must lie in (0, 1) (cells per a₀), got {args.h}")
a0, b, c_u = args.radius, args.outer * args.radius, args.strength
G = args.stiffness * c_u
E = 2.0 * G * (1.0 + args.nu)
# -

# ## The reference
#
# p(a) as above; the radius a pressure p expands the cavity to is found by bisection
# where p(a) rises (it peaks where the plastic zone nears the outer face).


# +
def cavity_pressure(a: float) -> float:
    """The pressure (Pa) that holds the cavity at radius a (m)."""
    R2 = G / c_u * (a**2 - a0**2)
    if R2 <= a**2:
        return G * (a**2 - a0**2) * (1.0 / a**2 - 1.0 / b**2)
    return c_u * (1.0 - R2 / b**2 + np.log(R2 / a**2))


def cavity_radius(p: float) -> float:
    """The radius (m) at which the cavity holds pressure p (Pa), up to the aim."""
    lo, hi = a0, args.expansion * a0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if cavity_pressure(mid) < p else (lo, mid)
    return 0.5 * (lo + hi)


p_end = cavity_pressure(args.expansion * a0)
if p_end <= cavity_pressure(0.999 * args.expansion * a0):
    sys.exit(
        f"cavity_expansion.py: p(a) no longer rises at a = {args.expansion} a₀ in a body of "
        f"radius {args.outer} a₀: take a wider body (--outer) or a smaller --expansion"
    )
# -

# ## Scene and simulation
#
# A quarter of the body, on rollers along its symmetry lines, on a grid whose cells
# grow from h at the cavity to 5 a₀ at r = b. The cavity's points are the midpoints
# of the grid's facets on r = a₀, with the body's outward normal there, −x/|x|. The
# load rises linearly in the pseudo-time t ∈ [0, 1].

# +
try:
    scene = meshes.quarter_ring(a0, b, args.h * a0, 6.0 * a0, h_outer=5.0 * a0)
    points = fe_mpm.seed(scene.mesh, 3, cells=scene.cell_tags.find(meshes.RING_BODY))
    if args.load == "points":
        # P2 needs two points per facet: the midpoint alone loads its middle node only.
        degree = 2 if args.formulation == "up-p2p1" else 1
        cavity = scene.facet_tags.find(meshes.RING_INNER)
        x, weight = meshes.facet_points(scene.mesh, cavity, degree)
        normal = -x / np.linalg.norm(x, axis=1)[:, None]
        load = {
            "point_tractions": [
                fe_mpm.PointPressure("cavity", x, weight, normal, p_end, scale=lambda t: t)
            ]
        }
    else:
        load = {"tractions": [fe_mpm.Pressure(meshes.RING_INNER, p_end, scale=lambda t: t)]}
    sim = fe_mpm.Simulation(
        scene.mesh,
        points,
        fe_mpm.MohrCoulomb.tresca(E, args.nu, c_u, density=1800.0),
        args.formulation,
        facet_tags=scene.facet_tags,
        dirichlet=[
            fe_mpm.Dirichlet(meshes.RING_X_AXIS, component=1),
            fe_mpm.Dirichlet(meshes.RING_Y_AXIS, component=0),
        ],
        point_domains=not args.standard,
        output_dir=None if args.no_output else args.output,
        output_every=max(1, args.steps // 10),
        **load,
    )
    # On the cavity's face, between the symmetry lines: its distance from the axis is a.
    sim.add_marker("face", (a0 * np.cos(np.pi / 4), a0 * np.sin(np.pi / 4)))
    reports = sim.run(t_end=1.0, n_steps=args.steps, progress=not args.json)
except (ValueError, fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"cavity_expansion.py: {err}")
# -

# ## Pressure against expansion
#
# Each step's pressure is set; the cavity's radius is measured. The check compares
# the pressure with the one the reference gives at the measured radius (the curve is
# flat near the limit, where a small error in p is a large one in a); both are
# printed.

# +
pressure = np.array([p_end * r.t for r in reports])
radius = np.array([np.linalg.norm(r.markers["face"]) for r in reports])
expected = np.array([cavity_pressure(a) for a in radius])
errors = pressure / expected - 1.0
expected_radius = np.array([cavity_radius(p) for p in pressure])
radius_error = (radius[-1] - a0) / (expected_radius[-1] - a0) - 1.0
iterations = [r.newton_iterations for r in reports]
wall = time.perf_counter() - START
print(
    f"Cavity expansion, Tresca, G/c_u = {args.stiffness:g}, {args.formulation}, {args.load} load, "
    f"{'standard MPM' if args.standard else 'point domains'}: "
    f"{parallel.total(scene.mesh.comm, len(points))} points, {len(reports)} steps"
)
print(f"  last pressure {pressure[-1] / c_u:.4f} c_u; the cavity at a = {radius[-1] / a0:.4f} a₀")
print(
    f"  the reference at that radius {expected[-1] / c_u:.4f} c_u; its radius for that "
    f"pressure {expected_radius[-1] / a0:.4f} a₀ (expansion a − a₀ {radius_error:+.1%})"
)
print(f"  largest error of p against the reference over the steps {np.abs(errors).max():.2%}")
print(
    f"  Newton iterations per step: max {max(iterations)}, mean {np.mean(iterations):.2f}; "
    f"wall time {wall:.2f} s"
)

if not args.no_output and rank0:
    plt = pyplot()  # None without matplotlib (the plots extra)
    out = Path(args.output)
    np.savetxt(
        out / "pressure_expansion.csv",
        np.column_stack([pressure, radius, expected]),
        delimiter=",",
        header="pressure_Pa,cavity_radius_m,reference_pressure_Pa",
        comments="",
    )
    if plt is not None:
        fig, ax = plt.subplots(figsize=(5, 3.5))
        fine = np.linspace(a0, args.expansion * a0, 200)
        strain = lambda a: 1.0 - (a0 / a) ** 2  # noqa: E731  ΔV/V
        ax.plot(
            strain(fine),
            [cavity_pressure(a) / c_u for a in fine],
            "k-",
            lw=1,
            label="Gibson & Anderson",
        )
        ax.plot(strain(radius), pressure / c_u, "o", ms=4, label="fe-mpm")
        ax.set_xlabel("ΔV / V = 1 − a₀²/a²")
        ax.set_ylabel("p / c_u")
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "pressure_expansion.png", dpi=120)
        print(f"  wrote {out}/particles.pvd, pressure_expansion.csv and .png")
# -

# ## Check against the reference
#
# Every step's pressure must lie within `TOLERANCE` of the reference's at the
# measured radius. Measured with the defaults (cells of a₀/20 at the cavity, 20
# steps; 2026-12-06): 0.42 % (the cavity at 1.491 a₀ where the reference puts it at
# 1.5 a₀: 1.8 % short in a − a₀), 15 s; on cells of a₀/10 0.83 % (8.0 % short), on
# a₀/5 1.41 % (1.1 % long): first order. (Until 2026-12-06 a₀/10 gave 1.04 % and
# 9.9 % short, a₀/5 2.5 %: where the face had moved a sliver into the cells beyond,
# its pressure points loaded the filled cells behind it; in 10 steps on a₀/10 the
# cavity then grew 11.7 % short, now 0.6 % long.) `--formulation u-nbva` 0.46 % (1.525 a₀, 16 s) and
# `up-p2p1` 0.84 % (1.548 a₀, 157 s; its points two per facet); in P2/P1 on cells of
# a₀/10 in 10 steps Newton stalls at t = 0.975, near the limit. The same pressure on
# the grid's facets (`--load grid`)
# stays where the face was and ends 54 % off; standard MPM (`--standard`) stops at
# t = 0.9, Newton failing however short the step.

# +
#: Largest relative error of p over the steps that passes.
TOLERANCE = 0.02

check_error = float(np.abs(errors).max())
passed = bool(check_error <= TOLERANCE)
print(
    f"check: p against Gibson & Anderson: largest error {100 * check_error:.2f} % "
    f"{'<=' if passed else '>'} {100 * TOLERANCE:g} % tolerance: {'PASS' if passed else 'FAIL'}"
)
if args.json:
    print(
        json.dumps(
            {
                "cavity_radius_ratio": float(radius[-1] / a0),
                "reference_radius_ratio": float(expected_radius[-1] / a0),
                "last_pressure_over_strength": float(pressure[-1] / c_u),
                "largest_relative_error": check_error,
                "expansion_error": float(radius_error),
                "newton_iterations": iterations,
                "wall_time_s": wall,
                "steps": len(reports),
                "n_particles": parallel.total(scene.mesh.comm, len(points)),
                "load": args.load,
                "formulation": args.formulation,
                "point_domains": not args.standard,
                "check_passed": passed,
            }
        )
    )
if not passed:
    sys.exit(f"cavity_expansion.py: p is {100 * check_error:.2f} % from the reference")
# -
