# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # Plane-strain tension test with J2 plasticity
#
# Iaconeta (2019) §5.4.2, after Chiumenti et al. (2004). A plate of width W and
# height H is clamped at the bottom, and its top edge is pulled up by U (both
# edges are held horizontally as well). The material is Simo's finite-strain J2
# plasticity without hardening. This demo illustrates how to:
#
# - use an elastoplastic law (`fe_mpm.J2Plasticity`) in the u and u-p forms,
# - drive a test by a prescribed displacement (`Dirichlet(value=...)`),
# - read the pulling force every step (`reactions=`), and
# - compare the limit load with the plane-strain closed form.
#
# **Limit load.** In plane strain with free sides, the plastic flow is isochoric
# and σ_zz = σ_yy/2, so von Mises gives σ_yy = 2σ_Y/√3 across the section; a
# 45° shear band through the width gives the same load. Per unit thickness:
# F_lim = (2/√3) σ_Y W. In the incompressible case the u form locks, and the
# force overshoots F_lim; the u-p form does not.
#
# **Assumed data.** The thesis takes geometry and material from Chiumenti et al.
# (2004) and shows them only in a figure that was not available. Assumed here:
# W = 10 mm, H = 20 mm, cell size 1 mm (the thesis's), U = 0.1 mm (the thesis's
# total imposed displacement), steel-like E = 200 GPa and σ_Y = 250 MPa, and
# ν = 0.3 (compressible) or 0.4999 (incompressible). 3 points per triangle
# (the thesis uses 12): they sit far enough inside the cells that none crosses
# the pulled top line while h > 6 U (checked below).
#
# Usage: `python demos/tension_plate.py --formulation up --nu 0.4999 --json`.

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
    p = argparse.ArgumentParser(description="Plane-strain tension test, J2 plasticity")
    p.add_argument("--formulation", choices=("u", "up"), default="up")
    p.add_argument("--nu", type=float, default=0.4999, help="Poisson's ratio")
    p.add_argument("--E", type=float, default=200e9, help="Young's modulus (Pa)")
    p.add_argument("--yield-stress", type=float, default=250e6, help="σ_Y (Pa)")
    p.add_argument("--hardening", type=float, default=0.0, help="H (Pa)")
    p.add_argument("--width", type=positive(float), default=0.01, help="W (m)")
    p.add_argument("--height", type=positive(float), default=0.02, help="H (m)")
    p.add_argument("--h", type=float, default=0.001, help="cell size (m)")
    p.add_argument("--displacement", type=float, default=1e-4, help="U (m)")
    p.add_argument("--steps", type=int, default=40, help="load steps")
    p.add_argument("--output", default="tension_plate_output", help="output folder")
    p.add_argument("--no-output", action="store_true", help="write no files")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
rank0 = parallel.print_on_rank_zero()  # every rank runs this script; one prints
# -

# ## Scene and simulation
#
# The top grid line carries the prescribed displacement, ramped linearly in the
# pseudo-time t ∈ [0, 1]; its reaction is the pulling force.

# +
# The grid ends at the pulled line, and the points nearest it sit h/6 below it: a
# pull U ≥ h/6 carries them past it (h = 0.5 mm stopped in step 14, 2026-12-06).
if not args.h > 6.0 * args.displacement:
    sys.exit(
        f"tension_plate.py: --h {args.h:g} must exceed 6 U = {6.0 * args.displacement:g} m: "
        "the points nearest the pulled top line sit h/6 below it and would cross it"
    )
try:
    scene = meshes.tension_specimen(args.width, args.height, args.h)
    material = fe_mpm.J2Plasticity(args.E, args.nu, args.yield_stress, args.hardening, 7800.0)
    points = fe_mpm.seed(scene.mesh, per_cell=3, density=material.density)
    sim = fe_mpm.Simulation(
        scene.mesh,
        points,
        material,
        args.formulation,
        facet_tags=scene.facet_tags,
        dirichlet=[
            fe_mpm.Dirichlet(meshes.TENSION_BOTTOM),
            fe_mpm.Dirichlet(
                meshes.TENSION_TOP, value=lambda t: np.array([0.0, args.displacement * t])
            ),
        ],
        reactions={"top": meshes.TENSION_TOP},
        output_dir=None if args.no_output else args.output,
        output_every=max(1, args.steps // 10),
    )
    reports = sim.run(t_end=1.0, n_steps=args.steps, progress=not args.json)
except (ValueError, fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"tension_plate.py: {err}")
# -

# ## Force against displacement, and the limit load

# +
displacement = np.array([args.displacement * r.t for r in reports])
force = np.array([r.reactions["top"][1] for r in reports])  # N per m of thickness
limit_load = float(force.max())
analytical = 2.0 / np.sqrt(3.0) * args.yield_stress * args.width
iterations = [r.newton_iterations for r in reports]
wall = time.perf_counter() - START
print(
    f"Tension test, {args.formulation}, ν = {args.nu}: "
    f"{parallel.total(scene.mesh.comm, len(points))} points, {len(reports)} steps"
)
print(
    f"  limit load {limit_load:.6g} N/m; (2/√3) σ_Y W = {analytical:.6g} N/m "
    f"({limit_load / analytical - 1:+.2%})"
)
strain = parallel.largest(scene.mesh.comm, float(points.history["plastic_strain"].max(initial=0)))
print(f"  max equivalent plastic strain {strain:.4f}")
print(
    f"  Newton iterations per step: max {max(iterations)}, mean {np.mean(iterations):.2f}; "
    f"wall time {wall:.2f} s"
)

if not args.no_output and rank0:
    plt = pyplot()  # None without matplotlib (the plots extra)
    out = Path(args.output)
    np.savetxt(
        out / "force_displacement.csv",
        np.column_stack([displacement, force]),
        delimiter=",",
        header="displacement_m,force_N_per_m",
        comments="",
    )
    if plt is not None:
        fig, ax = plt.subplots(figsize=(5, 3.5))
        ax.plot(
            np.r_[0, displacement] * 1e3,
            np.r_[0, force] / 1e3,
            "o-",
            ms=3,
            label=f"fe-mpm {args.formulation}, ν = {args.nu}",
        )
        ax.axhline(analytical / 1e3, color="k", ls="--", lw=1, label="(2/√3) σ_Y W")
        ax.set_xlabel("imposed displacement (mm)")
        ax.set_ylabel("force (kN/m)")
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "force_displacement.png", dpi=120)
        print(
            f"  wrote {out}/particles.pvd (plastic_strain, stress, ...), "
            "force_displacement.csv and .png"
        )

# -

# ## Check against the reference
#
# The limit load must lie within `TOLERANCE` of (2/√3) σ_Y W. Measured with 10 and
# 40 steps: u-p +0.08 to +0.13 % (ν = 0.3 and 0.4999), u +0.8 % at ν = 0.3; the
# locking u form at ν = 0.4999 overshoots by 3.6 % and fails. The closed form is
# for a perfectly plastic plate pulled far enough: the force comes within 1 % of it
# once U/H reaches σ_Y/E, so the check needs no hardening and U/H ≥ 2 σ_Y/E
# (4 σ_Y/E by default).

# +
#: Largest relative difference from (2/√3) σ_Y W that passes: eight times what u-p
#: measures, and above the u form's +0.8 % at ν = 0.3 (the suite's tolerance).
TOLERANCE = 0.01

check_error = abs(limit_load / analytical - 1)
# A plate shorter than it is wide holds no free 45° band between its clamped ends,
# and carries more (H = W/2: +36 %, a helper's run, 2026-12-06).
if (
    args.hardening != 0.0
    or args.displacement / args.height < 2 * args.yield_stress / args.E
    or args.height < args.width
):
    passed = None  # not checked
    print(
        "check: (2/√3) σ_Y W is the limit of a perfectly plastic plate, H ≥ W, pulled to "
        "U/H ≥ 2 σ_Y/E: not checked"
    )
else:
    passed = bool(check_error <= TOLERANCE)
    print(
        f"check: limit load {limit_load:.6g} N/m vs (2/√3) σ_Y W {analytical:.6g} N/m "
        f"({args.formulation}, ν = {args.nu}): error {100 * check_error:.2f} % "
        f"{'<=' if passed else '>'} {100 * TOLERANCE:g} % tolerance: "
        f"{'PASS' if passed else 'FAIL'}"
    )
if args.json:
    print(
        json.dumps(
            {
                "limit_load": limit_load,
                "analytical_limit_load": analytical,
                "relative_error": limit_load / analytical - 1,
                "newton_iterations_max": max(iterations),
                "newton_iterations": iterations,
                "wall_time_s": wall,
                "steps": len(reports),
                "n_particles": parallel.total(scene.mesh.comm, len(points)),
                "formulation": args.formulation,
                "nu": args.nu,
                "check_passed": passed,
            }
        )
    )
if passed is False:
    sys.exit(f"tension_plate.py: the limit load is {100 * check_error:.2f} % from (2/√3) σ_Y W")
# -
