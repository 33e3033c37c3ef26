# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # Cook's membrane with the implicit MPM
#
# A tapered plane-strain panel, clamped on the left, bends under a vertical
# shear load on its right edge (Iaconeta 2019, §5.4.1; Kratos MPM's
# `cooks_membrane` tests). This demo illustrates how to:
#
# - build a background grid with gmsh (`fe_mpm.meshes.cook_membrane`),
# - seed material points at Gauss points of its cells (`fe_mpm.seed`),
# - set a Neo-Hookean material, grid Dirichlet conditions and grid tractions,
# - follow a material marker (point A) through several load steps, and
# - choose the irreducible (u) or the mixed u-p form (PPP-stabilised, unstabilised,
#   or Taylor-Hood P2/P1), and
# - write the points and the grid for ParaView.
#
# The panel is the trapezoid (0,0), (48,44), (48,60), (0,44) with E = 70 and
# ν = 0.33 (compressible) or 0.499 (quasi-incompressible). The right edge
# carries a traction of 1/16 per unit length (1 N in total). The output is the
# vertical displacement of A = (48, 60).
#
# **How A is measured.** A is a marker: a point that moves with the grid
# increment of every step, exactly like a material point, but has no volume. In a
# single load step A sits on a grid node, so its displacement is that node's.
# With several steps the grid is reset after each, and the marker carries A's
# position from step to step.
#
# Usage: `python demos/cook_membrane.py --n 32 --nu 0.499 --steps 4 --json`. Under
# `mpiexec -n 2` the grid and its points are shared among the ranks and the answer is
# the serial one; rank 0 prints and writes the files.

# +
import time

START = time.perf_counter()  # the wall time reported includes the imports

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import fe_mpm
from fe_mpm import meshes, parallel
from fe_mpm.plotting import pyplot
from fe_mpm.references import cook_reference


def parse_args(argv=None):
    """The command-line contract of the demo (later issues extend it)."""
    p = argparse.ArgumentParser(description=__doc__ or "Cook's membrane with fe-mpm")
    p.add_argument("--n", type=int, default=16, help="elements per side (structured mesh)")
    p.add_argument("--h", type=float, default=None, help="element size (unstructured mesh)")
    p.add_argument("--nu", type=float, default=0.33, help="Poisson's ratio")
    p.add_argument("--E", type=float, default=70.0, help="Young's modulus")
    p.add_argument(
        "--formulation",
        default="u",
        choices=["u", "u-nbva", "up", "up-nostab", "up-p2p1"],
        help="u: irreducible; u-nbva: irreducible with node-based volumetric averaging; "
        "up: mixed P1/P1 with PPP; up-nostab: without it; up-p2p1: mixed Taylor-Hood",
    )
    p.add_argument(
        "--ppp-alpha",
        type=float,
        default=1.0,
        help="PPP α of the thesis (times 8 in 2D, as in Kratos)",
    )
    p.add_argument(
        "--mp-per-cell",
        type=int,
        default=None,
        help="material points per triangle (default 1; 3 for up-p2p1)",
    )
    mesh = p.add_mutually_exclusive_group()
    mesh.add_argument("--structured", dest="structured", action="store_true", default=True)
    mesh.add_argument("--unstructured", dest="structured", action="store_false")
    p.add_argument("--steps", type=int, default=1, help="load steps")
    p.add_argument(
        "--output", type=Path, default=Path("out_cook_membrane"), help="folder for ParaView output"
    )
    p.add_argument("--no-output", action="store_true", help="write no files")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p.parse_args(argv)


args = parse_args()
rank0 = parallel.print_on_rank_zero()  # every rank runs this script; one prints
if args.mp_per_cell is None:
    args.mp_per_cell = 3 if args.formulation == "up-p2p1" else 1
# -

# ## The scene
#
# The structured grid has n x n quadrilaterals, each cut from its lower-left to
# its upper-right corner (the meshes of Table 5.1; the other diagonal locks much
# less at ν = 0.499). One material point per triangle at its centroid
# reproduces the thesis set-up.

# +
# Several steps move the body out of a grid that fits it, so the grid then gets
# rows of empty cells above and below (about one length unit: the top-right
# corner rises by about 0.3). Empty cells cost nothing: they are not assembled.
margin = 0 if args.steps == 1 else max(1, -(-args.n // 16))
try:
    scene = meshes.cook_membrane(n=args.n, structured=args.structured, h=args.h, margin=margin)
    points = fe_mpm.seed(
        scene.mesh, per_cell=args.mp_per_cell, density=1000.0, cells=meshes.body_cells(scene)
    )
    material = fe_mpm.NeoHookean(E=args.E, nu=args.nu, density=1000.0)
except ValueError as err:
    sys.exit(f"cook_membrane.py: {err}")
load = np.array([0.0, 1.0 / 16.0])
# -

# ## The simulation
#
# The left edge is clamped on the grid and the traction acts on the grid facets
# of the right edge. It ramps linearly with the pseudo-time t ∈ [0, 1].

# +
try:
    sim = fe_mpm.Simulation(
        scene.mesh,
        points,
        material,
        formulation=args.formulation,
        facet_tags=scene.facet_tags,
        dirichlet=[fe_mpm.Dirichlet(meshes.COOK_CLAMPED)],
        tractions=[fe_mpm.Traction(meshes.COOK_LOADED, load, scale=lambda t: t)],
        output_dir=None if args.no_output else args.output,
        ppp_alpha=args.ppp_alpha if args.formulation == "up" else None,  # only u-p has PPP
    )
except (ValueError, NotImplementedError) as err:
    sys.exit(f"cook_membrane.py: {err}")
sim.add_marker("A", meshes.COOK_POINT_A)
try:
    reports = sim.run(t_end=1.0, n_steps=args.steps, progress=not (args.quiet or args.json))
except (ValueError, fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"cook_membrane.py: {err}")
finally:
    sim.close()
# -

# ## Results
#
# The Kratos MPM 10.4.4 values on the same structured meshes are the anchor
# (`fe_mpm.references`).

# +
u_A = sim.marker("A") - np.array(meshes.COOK_POINT_A)
iterations = [r.newton_iterations for r in reports]
wall = time.perf_counter() - START
n_points = parallel.total(scene.mesh.comm, len(points))  # each rank holds those of its cells
# The published numbers are for structured meshes with one point per triangle, E = 70
# and (UP+PPP) the PPP factor 1.
kratos_setup = (
    args.structured
    and args.mp_per_cell == 1
    and args.E == 70.0
    and (args.formulation != "up" or args.ppp_alpha == 1.0)
)
reference = cook_reference(args.formulation, args.nu, args.n) if kratos_setup else None

print(
    f"Cook's membrane: n = {args.n} ({'structured' if args.structured else 'unstructured'}), "
    f"nu = {args.nu}, formulation {args.formulation}, {n_points} material points"
)
print(f"  u_A = ({u_A[0]:.6f}, {u_A[1]:.6f})", end="")
if reference is not None:
    source, value = reference
    print(f"   {source}: u_A,y = {value:.4f} ({100 * (u_A[1] / value - 1):+.2f} %)")
else:
    print()
print(f"  Newton iterations per step: {iterations}")
if scene.mesh.comm.size > 1:  # each rank integrates its own points
    print(f"  points per rank, most over mean: {max(r.point_imbalance for r in reports):.2f}")
print(f"  wall time {wall:.2f} s; " + ", ".join(f"{k} {v:.3f} s" for k, v in sim.timings.items()))

if not args.no_output and rank0:
    history = np.array(
        [[0.0, 0.0]] + [[r.t, r.markers["A"][1] - meshes.COOK_POINT_A[1]] for r in reports]
    )
    np.savetxt(
        args.output / "load_deflection.csv",
        history,
        delimiter=",",
        header="load_factor,u_A_y",
        comments="",
    )
    print(f"  ParaView: {args.output / 'particles.pvd'} (points), {args.output / 'grid.bp'} (grid)")
    plt = pyplot() if args.steps > 1 else None  # None without matplotlib (plots extra)
    if plt is not None:
        fig, ax = plt.subplots(figsize=(4.5, 3.2))
        ax.plot(history[:, 1], history[:, 0] * load[1] * 16, "o-")
        ax.set_xlabel("vertical displacement of A")
        ax.set_ylabel("total load (N)")
        ax.set_title(f"Cook's membrane, n = {args.n}, ν = {args.nu}")
        fig.tight_layout()
        fig.savefig(args.output / "load_deflection.png", dpi=120)
        print(f"  load-deflection curve: {args.output / 'load_deflection.png'}")

summary = {
    "tip_displacement_x": float(u_A[0]),
    "tip_displacement_y": float(u_A[1]),
    "newton_iterations": int(sum(iterations)),
    "newton_iterations_per_step": iterations,
    "wall_time_s": wall,
    "timings": sim.timings,  # seconds by phase
    "point_imbalance": max(r.point_imbalance for r in reports),
    "n_particles": n_points,
    "n": args.n,
    "nu": args.nu,
    "formulation": args.formulation,
    "mp_per_cell": args.mp_per_cell,
    "structured": args.structured,
    "steps": args.steps,
    "reference": None
    if reference is None
    else {"source": reference[0], "tip_displacement_y": reference[1]},
}
# -

# ## Check against the reference
#
# The demo exits with an error when u_A,y is further than `TOLERANCE` from the
# published value for its set-up. Kratos's and the thesis's values carry four
# decimals, up to 0.07 % of the smallest (0.0724). fe-mpm's one-step answers match
# every Kratos value within 0.04 % and the thesis's compressible "UP no stab" column
# within 0.1 % (0.45 % at n = 2); several load steps move u_A,y by under 0.1 %
# (n = 4, 8, 16). On finer grids they move it more, and the check then fails, as
# it should: with four steps at ν = 0.33, −0.52 % at n = 32 (where the last step
# loses 1.6 % of the load, the loaded edge's lowest node having no material left:
# a grid traction stays on the grid) and −1.9 % at n = 64 (2026-12-06; at ν = 0.499
# and n = 32, 0.02 %). With a `PointTraction`, which follows the body, the same runs
# give +0.81 % and +0.93 %: the steps' own cell-crossing error
# (`docs/cell_crossing.md`). A value exists only for Kratos's
# set-up (above) at a tabulated n and ν. The thesis's quasi-incompressible "UP no
# stab" column is not checked: it lies 0.3–2.9 % from ν = 0.499 and seems to have
# been run at another ν.

# +
#: Largest relative difference from the published u_A,y that passes (the suite's
#: tolerance, tests/test_cook.py): seven times the tables' rounding.
TOLERANCE = 0.005

if reference is None:
    not_checked = (
        f"no published u_A,y for formulation {args.formulation}, n = {args.n}, "
        f"ν = {args.nu}, E = {args.E:g}, "
        f"{'structured' if args.structured else 'unstructured'} grid, "
        f"{args.mp_per_cell} point(s) per triangle"
        + (f", PPP α = {args.ppp_alpha:g}" if args.formulation == "up" else "")
    )
elif args.formulation == "up-nostab" and args.nu != 0.33:
    not_checked = "the thesis's quasi-incompressible UP no stab column fits another ν"
else:
    not_checked = None
if not_checked:
    passed, check_error = None, None  # null in the JSON: nothing was checked
    print(f"check: {not_checked}: not checked")
else:
    source, value = reference
    check_error = float(abs(u_A[1] / value - 1))
    passed = bool(check_error <= TOLERANCE)
    print(
        f"check: u_A,y = {u_A[1]:.5f} vs {source} {value:.4f} (n = {args.n}, ν = {args.nu}): "
        f"error {100 * check_error:.2f} % {'<=' if passed else '>'} {100 * TOLERANCE:.1f} % "
        f"tolerance: {'PASS' if passed else 'FAIL'}"
    )
if args.json:
    summary.update(check_error=check_error, check_passed=passed)
    sys.stdout.flush()
    print(json.dumps(summary))
if passed is False:
    sys.exit(f"cook_membrane.py: u_A,y is {100 * check_error:.2f} % from {source}")
# -
