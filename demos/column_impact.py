# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # A soil surge hitting a column or a wall, in 3D (Mast 2013, §7.4)
#
# A block of cohesionless soil, B_b = 6 m wide, L_b = 8 m long and H_b high, slides
# at v₀ = 1 m/s down a rough channel bed and hits a rigid column l_c = 2 m long and
# w_c wide that stands 1 m ahead of it; the channel repeats the column every 6 m,
# so a column of w_c = 6 m is a wall across it. Mast ran 180 such impacts and
# reported the force on the column's face against the static earth pressure of the
# soil piled against it: the peak reached 3 to 9 times it (R_pk), the steady state
# just above it (R_ss, his Eq. 7.19). This demo illustrates how to:
#
# - build a 3D grid with an obstacle cut out of it (`dolfinx.mesh.create_submesh`),
#   whose faces are rigid walls (`fe_mpm.RigidWall`) reporting their force;
# - run a dynamic 3D scene with Mast's smooth-cap Drucker–Prager law and his
#   node-based volumetric averaging (formulation `"u-nbva"`);
# - read the force history of a wall, its peak and steady state, and the height
#   of the soil pressing on it.
#
# **Data** (Mast Tables 7.9–7.10): ρ₀ = 1950.55 kg/m³, K = 8.33 MPa, G = 3.85 MPa,
# φ_F = 20° or 30° (his 5°–40°), μ = 10 Pa, ϱ_G/ϱ_F = 0.05, gravity 10 m/s²,
# l_c = 2 m, gap 1 m, B_b = 6 m, L_b = 8 m, H_b = 1.5–4 m, w_c = 1–6 m. Mast's grid
# had cells of 0.25 m with 8 points each and a time step of 0.5 ms (explicit); the
# default here is 0.5 m cubes of six tetrahedra with 4 points each and implicit
# steps of 50 ms (cut where Newton needs it). As Mast's, the points start with the
# static stress of a level layer at rest (`fe_mpm.geostatic_stress`, K₀ = 0.429);
# `--start unstressed` starts them from zero stress instead, and the block then
# settles under gravity in its first 0.2 s, during its approach.
#
# Usage: `python demos/column_impact.py --width 6 --height 2 --phi 30 --json`.

# +
import time

START = time.perf_counter()

import argparse
import json
import math
import sys
from pathlib import Path

# ruff: noqa: I001 - fe_mpm first: the PyPI wheel needs its bootstrap before dolfinx and mpi4py.
import fe_mpm
from fe_mpm import parallel
from fe_mpm.meshes import cell_centroids
from fe_mpm.cli import positive
from fe_mpm.plotting import pyplot
from fe_mpm.walls import write_wall_forces
import dolfinx
import numpy as np
from mpi4py import MPI

#: Mast's earth pressure coefficient at rest, ν/(1 − ν) of his K and G (Eq. 7.17).
K0 = 0.429
#: Mast's range of the peak force over the static one, R_pk (§7.4.3).
PEAK_RANGE = (3.0, 9.0)
#: The steady force over the static one, R_ss: Mast finds it "clustered just above
#: 1.0" and below 1 mostly for w_c ≲ 3 m (§7.4.3). The band is our reading of that.
STEADY_RANGE = (0.7, 1.3)


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="Soil surge hitting a column (Mast 2013, §7.4)")
    p.add_argument("--width", type=positive(), default=6.0, help="column width w_c (m); 6: wall")
    p.add_argument("--height", type=positive(), default=2.0, help="the block's height H_b (m)")
    p.add_argument("--phi", type=float, default=30.0, help="friction angle φ_F (degrees)")
    p.add_argument("--length", type=positive(), default=8.0, help="the block's length L_b (m)")
    p.add_argument("--h", type=positive(), default=0.5, help="cell size (m): cubes of 6 tetrahedra")
    p.add_argument("--dt", type=positive(), default=0.05, help="time step (s)")
    p.add_argument("--t-end", type=positive(), default=3.5, help="end time (s); Mast's t_f = 3.5 s")
    p.add_argument(
        "--bossak-alpha",
        type=float,
        default=-0.3,
        help="Bossak's alpha in [-1/3, 0]: damps the modes a step cannot resolve",
    )
    p.add_argument(
        "--start",
        choices=("geostatic", "unstressed"),
        default="geostatic",
        help="the points' stress at t = 0: at rest under gravity (Mast), or none",
    )
    p.add_argument(
        "--line-search",
        choices=("bt", "l2", "basic"),
        default="l2",
        help="Newton's line search (PETSc's); l2 takes fewer iterations here than bt",
    )
    p.add_argument(
        "--point-domains",
        action="store_true",
        help="point domains (point_domains=True): a steadier face force, 2-6 times the time",
    )
    p.add_argument("--output", default="column_impact_output", help="output folder")
    p.add_argument("--no-output", action="store_true", help="write no files")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
rank0 = parallel.print_on_rank_zero()
rho, K, G, g, v0 = 1950.55, 8.33e6, 3.85e6, 10.0, 1.0
E, nu = 9 * K * G / (3 * K + G), (3 * K - 2 * G) / (2 * (3 * K + G))
B_b, l_c, gap = 6.0, 2.0, 1.0
h, H_b, L_b, w_c = args.h, args.height, args.length, args.width
if not 0.0 < w_c <= B_b:
    sys.exit(f"column_impact.py: --width must lie in (0, {B_b:g}] m, got {w_c:g}")
for name, value in (("height", H_b), ("length", L_b), ("h", h), ("dt", args.dt)):
    if not value > 0.0:
        sys.exit(f"column_impact.py: --{name} must be > 0, got {value:g}")
wall = w_c >= B_b
lengths = {"2 + L_b + gap": 2.0 + L_b + gap, "l_c": l_c, "B_b / 2": B_b / 2, "w_c / 2": w_c / 2}
for name, value in lengths.items():  # the faces must lie on grid planes
    if not math.isclose(value / h, round(value / h), abs_tol=1e-9):
        sys.exit(f"column_impact.py: --h must divide {name} = {value:g} m, got {h:g}")
# -

# ## Scene
#
# Half the channel: the plane y = 0 through the column's middle and the plane
# y = B_b/2 midway to the next column are symmetry planes (rollers). For a wall
# nothing varies across the channel, so a slice two cells wide stands for it. The
# block starts 2 m from the grid's back, where its free rear face slumps; for a
# column the grid reaches 2 m past it, for the soil that flows around. Above the
# block the grid leaves 2 m for the soil piling up against the face. The bed
# z = 0 is rough (Coulomb, tan 65°, well above the soil's tan φ); the column's
# faces are smooth.

# +
x_face = 2.0 + L_b + gap  # the column's face, m
length = x_face if wall else x_face + l_c + 2.0
across = 2 * h if wall else B_b / 2
top = H_b + 2.0
n = [round(length / h), round(across / h), math.ceil(top / h)]
box = dolfinx.mesh.create_box(
    MPI.COMM_WORLD,
    [[0.0, 0.0, 0.0], [n[0] * h, n[1] * h, n[2] * h]],
    n,
    dolfinx.mesh.CellType.tetrahedron,
    ghost_mode=dolfinx.mesh.GhostMode.shared_facet,
)
tol = 1e-6 * h
grid = box
if not wall:  # the column's cells cut out of the box
    middle = cell_centroids(box)
    in_column = (middle[:, 0] > x_face) & (middle[:, 0] < x_face + l_c) & (middle[:, 1] < w_c / 2)
    keep = np.flatnonzero(~in_column).astype(np.int32)
    grid = dolfinx.mesh.create_submesh(box, 3, keep)[0]
centres = cell_centroids(grid)
block = np.flatnonzero((centres[:, 0] > 2.0) & (centres[:, 0] < 2.0 + L_b) & (centres[:, 2] < H_b))
points = fe_mpm.seed(grid, 4, density=rho, cells=block)
points.velocity[:, 0] = v0
soil = fe_mpm.SmoothCapDruckerPrager(
    E, nu, friction_angle=args.phi, deviatoric_strength=10.0, associativity=0.05, density=rho
)
face_width = across if wall else w_c / 2  # of the face in this model, m
walls = [
    fe_mpm.RigidWall("bed", lambda x: np.isclose(x[2], 0.0), friction=math.tan(math.radians(65))),
    fe_mpm.RigidWall("face", lambda x: np.isclose(x[0], x_face) & (x[1] < face_width + tol)),
]
if not wall:
    walls += [
        fe_mpm.RigidWall("side", lambda x: np.isclose(x[1], w_c / 2) & (x[0] > x_face - tol)),
        fe_mpm.RigidWall("back", lambda x: np.isclose(x[0], x_face + l_c) & (x[1] < w_c / 2 + tol)),
    ]
steps = max(1, round(args.t_end / args.dt))
try:
    sim = fe_mpm.Simulation(
        grid,
        points,
        soil,
        "u-nbva",
        dirichlet=[
            fe_mpm.Dirichlet(
                lambda x: np.isclose(x[1], 0.0) | np.isclose(x[1], n[1] * h), component=1
            )
        ],
        walls=walls,
        body_force=(0.0, 0.0, -g),
        dynamic=True,
        mass="lumped",
        bossak_alpha=args.bossak_alpha,
        points_leaving="drop",
        point_domains=args.point_domains,
        initial_stress=(
            fe_mpm.geostatic_stress(points, H_b, g, K0) if args.start == "geostatic" else None
        ),
        line_search=args.line_search,
        output_dir=None if args.no_output else args.output,
        output_every=max(1, steps // 35),
    )
except ValueError as err:
    sys.exit(f"column_impact.py: {err}")
# -

# ## Impact
#
# Each step records the face's push along v₀ and the height of the soil against
# it, Mast's H_act = Σ A_i / w_c (his Eq. 7.15) over the face's *massive* nodes,
# those of the cells that hold soil, with A_i = h² the node's share of the face
# (half of it on the face's edges across the channel).

# +
history = []


def massive_height() -> float:
    """Mast's H_act (m): the face area of the grid nodes with mass, over the face's width."""
    # sim.mesh, not grid: under mpiexec with point domains the Simulation rebuilt the
    # grid with more ghost cells, and the points' cells are the new grid's (read from
    # grid, 2 ranks gave H_act = 1.75 m where one gave 1.25 m, with the same forces).
    occupied = np.unique(points.cell[points.cell >= 0])
    mesh = sim.mesh
    nodes = mesh.geometry.x[np.unique(mesh.geometry.dofmaps[0][occupied])]
    x = np.unique(parallel.gathered(mesh.comm, nodes.reshape(-1)).reshape(-1, 3), axis=0)
    on_face = np.isclose(x[:, 0], x_face) & (x[:, 1] < face_width + tol)
    y = x[on_face, 1]
    on_edge = np.isclose(y, 0.0) | np.isclose(y, face_width)
    return float(np.where(on_edge, 0.5 * h, h).sum() * h) / face_width


def record(report: fe_mpm.StepReport) -> None:
    """The face's push (N, in this model), H_act (m) and the bed's push (N) after a step."""
    forces = report.walls["face"]
    history.append((report.t, forces.normal, massive_height(), report.walls["bed"].normal))


try:
    reports = sim.run(args.t_end, steps, progress=not args.json, on_step=record)
except (fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"column_impact.py: {err}")
t, force, height, bed_push = np.array(history).T
# -

# ## Peak and steady state
#
# Mast's coefficients (his Eqs. 7.17–7.19): the static force is that of the earth
# pressure at rest over the height of the soil against the face,
# f_st = ½ K₀ ρ₀ g H_act² w_c, and R_pk = f_pk / f_st, R_ss = f_ss / f_st. The peak is
# the largest force of any step, the steady state the mean over the last second
# (Mast: a running average), and H_act is its mean over that second too.

# +
last = t >= t[-1] - 1.0
H_act = float(height[last].mean())
reached = H_act > 0.0  # a run cut short may end before the soil reaches the face
f_pk, f_ss = float(force.max()), float(force[last].mean())
f_st = 0.5 * K0 * rho * g * H_act**2 * face_width if reached else math.nan
R_pk, R_ss = f_pk / f_st, f_ss / f_st
# Once the soil has come to rest the bed carries its weight (a momentum check).
weight = g * parallel.total(grid.comm, float(points.mass.sum()))
bed_share = float(bed_push[last].mean()) / weight
t_pk = float(t[np.argmax(force)])
# The peak is one step's force; a step that Newton cut short takes the same impulse
# in less time, so its length is reported with the peak.
dt_pk = float(np.diff(t, prepend=0.0)[np.argmax(force)])
# The same impulse spread over a nominal step: the largest mean force over any
# window of that length, with each step's force held over the step.
impulse = np.concatenate([[0.0], np.cumsum(force * np.diff(t, prepend=0.0))])
ends = np.concatenate([[0.0], t])
window = args.dt
f_pk_window = float(
    np.max((impulse[1:] - np.interp(t - window, ends, impulse)) / window, initial=0.0)
)
wall_time = time.perf_counter() - START
iterations = [r.newton_iterations for r in reports]
n_points = int(parallel.total(grid.comm, len(points)))
scale = w_c / face_width  # from this model's share of the face to the whole face
print(
    f"Soil surge on a {'wall' if wall else f'column {w_c:g} m wide'}, H_b = {H_b:g} m, "
    f"φ = {args.phi:g}°: {n_points} points on {grid.comm.size} rank(s), {len(reports)} steps "
    f"of up to {args.dt:g} s, h = {h:g} m, wall time {wall_time:.1f} s"
    + (f"; {sim.dropped} point(s) off the grid" if sim.dropped else "")
)
print(
    f"  peak {f_pk * scale / 1e3:.1f} kN at t = {t_pk:.2f} s (a step of {dt_pk * 1e3:.1f} ms; "
    f"{f_pk_window * scale / 1e3:.1f} kN over {window * 1e3:g} ms), "
    f"steady {f_ss * scale / 1e3:.1f} kN over the last second, "
    f"H_act = {H_act:.2f} m ({H_act / H_b:.2f} H_b), "
    f"static {f_st * scale / 1e3:.1f} kN"
)
print(
    f"  R_pk = {R_pk:.2f} (Mast: {PEAK_RANGE[0]:g} to {PEAK_RANGE[1]:g}), R_ss = {R_ss:.2f} "
    f"(Mast: just above 1); the bed carries {bed_share:.3f} of the weight over the last "
    f"second; Newton per step mean {np.mean(iterations):.2f}, max {max(iterations)}"
)
if not args.no_output and rank0:
    out = Path(args.output)
    np.savetxt(
        out / "face_force.csv",
        np.column_stack([t, force * scale, height]),
        delimiter=",",
        header="t,face_force_N,H_act_m",
        comments="",
    )
    write_wall_forces(reports, out / "walls.csv")
    plt = pyplot()
    if plt is not None:
        fig, ax = plt.subplots(figsize=(5.5, 3.6))
        ax.plot(t, force / f_st, label="face force / f_st")
        ax.axhline(R_ss, color="k", ls=":", lw=0.8, label="steady state")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("f / f_st")
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "face_force.png", dpi=120)
    print(
        f"  wrote {out}/particles.pvd, face_force.csv, walls.csv" + (" and a plot" if plt else "")
    )
# -

# ## Check against the reference
#
# Mast's R_pk lay between 3 and 9 over his runs, and R_ss clustered just above 1
# (below 1 mostly for columns up to 3 m wide). Both are read after the soil has
# come to rest against the face; a run cut short is not checked. Measured on the
# default grid from the geostatic start on preloaded bed springs (2026-12-06
# evening, after the walls' NaN fix; a wall, H_b = 2 m;
# `docs/results/column_impact.md`): φ = 30°, 3072 points, 133 steps: R_pk = 5.49
# and R_ss = 0.48, so the check fails; φ = 20°: 3.79 and 0.78, it passes. The
# steady force moves less than the ratios but more than was thought (37–70 kN on
# the 6 m wall at φ = 30° however the run is started and integrated, on 0.5 m and
# on Mast's 0.25 m cells); H_act counts the face's nodes in rows of a cell, so the
# static force moves by a factor of 1.4–1.8 with one row of 0.5 m cells, and the
# peak is one step's force, higher where Newton cut that step (hence
# `R_pk_over_nominal_step`). One run's verdict says little: with `--dt` scaled by
# 0.9 to 1.1 the same scene gave R_pk 4.7–16.8 and R_ss 0.41–1.51 and failed all
# seven times (2026-12-06, night); judge several steps' runs together. With
# `--point-domains` (2026-12-07, five of those step lengths, 0.9–1.1 × nominal) the
# steady force stays at 28.2–31.7 kN, R_pk at 3.56–6.83 and R_ss at 0.80–0.81 where
# H_act is 1.25 m, and the check passes in four runs of five (at 0.9 × the pile ends
# a row higher, H_act = 1.5 m, and R_ss = 0.50); each run takes 2–6 times as long.

# +
settled = args.t_end >= 3.5 and reached
passed = bool(PEAK_RANGE[0] <= R_pk <= PEAK_RANGE[1] and STEADY_RANGE[0] <= R_ss <= STEADY_RANGE[1])
verdict = "PASS" if passed else "FAIL"
if not settled:
    why = "cut short" if reached else "no soil at the face in the last second"
    passed, verdict = None, f"not checked ({why} at t = {t[-1]:.2f} s)"
print(
    f"check: R_pk {R_pk:.2f} in [{PEAK_RANGE[0]:g}, {PEAK_RANGE[1]:g}] and R_ss {R_ss:.2f} in "
    f"[{STEADY_RANGE[0]:g}, {STEADY_RANGE[1]:g}] (Mast §7.4.3): {verdict}"
)
if args.json:
    print(
        json.dumps(
            {
                "width": w_c,
                "height": H_b,
                "phi": args.phi,
                "R_pk": R_pk,
                "R_ss": R_ss,
                "t_pk": t_pk,
                "peak_step_s": dt_pk,
                "R_pk_over_nominal_step": f_pk_window / f_st,
                "H_act": H_act,
                "face_force_peak_N": f_pk * scale,
                "face_force_steady_N": f_ss * scale,
                "bed_push_over_weight": bed_share,
                "points": n_points,
                "steps": len(reports),
                "h": h,
                "dt": args.dt,
                "start": args.start,
                "newton_iterations_mean": float(np.mean(iterations)),
                "newton_iterations_max": int(max(iterations)),
                "dropped_points": sim.dropped,
                "point_domains": args.point_domains,
                "wall_time_s": wall_time,
                "ranks": grid.comm.size,
                "check_passed": passed,
                # null for the ratios of a run whose soil never reached the face
                **{key: None for key in ("R_pk", "R_ss", "R_pk_over_nominal_step") if not reached},
            }
        )
    )
if passed is False:
    sys.exit("column_impact.py: the forces lie outside Mast's ranges")
# -
