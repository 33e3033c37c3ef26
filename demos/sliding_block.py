# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # A block sliding down a slope, without friction or with it
#
# The simpler variant of the thesis's rolling disk (Iaconeta 2019, §4.5.2). An
# elastic block (E = 200 MPa, ν = 0.3, ρ = 7800 kg/m³, as the thesis's disk) slides
# from rest down a frictionless slope of angle θ. The slope is the grid's
# horizontal base with gravity rotated by θ. The base constrains only the normal
# displacement (a slip condition), so friction is zero. This demo illustrates how to:
#
# - set up an implicit dynamic MPM run (`dynamic=True`, Newmark β = 1/4, γ = 1/2),
# - use a slip (normal-only) grid condition and read the plane's reaction, and
# - measure the thesis's error, Eq. 4.44: √(Σ_i (s(t_i) − s_h(t_i))²) over the
#   output instants. The exact slide is s = ½ g sin θ t², and s_h is taken at the
#   block's centre of mass.
#
# The points cross many cells. Rigid translation is an exact discrete solution
# once the start is in equilibrium (fe-mpm solves M a₀ = f at t = 0), so the
# error is round-off.
#
# With `--friction μ` the base is a rigid wall (`fe_mpm.RigidWall`) with Coulomb
# friction instead of the slip condition: the block then slides at
# a = g (sin θ − μ cos θ) when tan θ > μ, and stays put otherwise. μ = 0 gives the
# smooth wall, which must match the slip condition to round-off.
#
# Usage: `python demos/sliding_block.py --dt 0.01 --t-end 1 --json`, or
# `--friction 0.1` for the frictional wall.

# +
import time

START = time.perf_counter()

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import fe_mpm
from fe_mpm import parallel
from fe_mpm.cli import nonnegative, positive
from fe_mpm.meshes import cell_centroids, rectangle_mesh
from fe_mpm.plotting import pyplot
from fe_mpm.walls import SLIP_SCALE_FACTOR, plot_wall_forces, write_wall_forces


def parse_args(argv=None):
    """The command-line contract of the demo."""
    p = argparse.ArgumentParser(description="Frictionless block on a slope")
    p.add_argument("--dt", type=positive(float), default=0.01, help="time step (s)")
    p.add_argument("--t-end", type=positive(float), default=1.0, help="duration (s)")
    p.add_argument("--theta", type=float, default=30.0, help="slope angle (degrees)")
    p.add_argument("--h", type=positive(float), default=0.1, help="grid cell size (m)")
    p.add_argument(
        "--friction",
        type=nonnegative(float),
        default=None,
        help="Coulomb's μ of a rigid wall as the base (default: the slip condition); "
        "checked against the rigid block for μ ≤ 0.1 and μ ≥ 0.8 at θ = 30°",
    )
    p.add_argument(
        "--bossak-alpha",
        type=float,
        default=None,
        help="Bossak's α_B (default: 0 on the slip condition, −0.3 on a rigid wall)",
    )
    p.add_argument("--output", default="sliding_block_output", help="output folder (walls)")
    p.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    return p.parse_args(argv)


args = parse_args()
parallel.print_on_rank_zero()  # every rank runs this script; one prints
g, θ = 9.81, np.radians(args.theta)
μ = args.friction or 0.0
acceleration = max(g * (np.sin(θ) - μ * np.cos(θ)), 0.0)  # no slide once tan θ <= μ
length = 1.0 + 0.5 * acceleration * args.t_end**2 + 1.0  # room for the slide
# -

# ## Scene: a 1 m x 0.5 m block at the left end of a long grid

# +
n = (int(np.ceil(length / args.h)), int(np.ceil(1.0 / args.h)))
grid = rectangle_mesh((0.0, 0.0), (n[0] * args.h, n[1] * args.h), n)
centroids = cell_centroids(grid)  # each rank seeds the cells it owns
block = np.flatnonzero((centroids[:, 0] < 1.0) & (centroids[:, 1] < 0.5))
points = fe_mpm.seed(grid, per_cell=3, density=7800.0, cells=block)
on_plane = lambda x: np.isclose(x[1], 0.0)  # noqa: E731
if args.friction is None:  # slip: the normal displacement only, and its reaction
    base = dict(dirichlet=[fe_mpm.Dirichlet(on_plane, component=1)], reactions={"plane": on_plane})
else:  # a rigid wall the block presses on and slides along, against friction
    base = dict(walls=[fe_mpm.RigidWall("plane", on_plane, friction=args.friction)])
# Released unstressed, the block lands on the wall's springs and rings at a frequency
# no step resolves; Bossak's α_B damps that ringing (see the check below).
if args.bossak_alpha is not None:
    bossak_alpha = args.bossak_alpha
else:
    bossak_alpha = 0.0 if args.friction is None else -0.3
try:
    sim = fe_mpm.Simulation(
        grid,
        points,
        fe_mpm.NeoHookean(2e8, 0.3, 7800.0),
        dynamic=True,
        body_force=(g * np.sin(θ), -g * np.cos(θ)),
        bossak_alpha=bossak_alpha,
        **base,
    )

    # Step by hand to record the centre of mass after every step (a sum over the
    # ranks: each holds the points of its cells). run() to each output instant cuts a
    # step that Newton fails and retries it, where step() would stop.
    def slide() -> float:
        """Horizontal motion of the centre of mass (m)."""
        moment = points.mass @ (points.x - points.x0)[:, 0]
        return parallel.total(grid.comm, moment) / parallel.total(grid.comm, points.mass.sum())

    com = [(0.0, 0.0)]
    reports = []
    for k in range(1, max(1, round(args.t_end / args.dt)) + 1):
        reports.extend(sim.run(k * args.dt, 1, progress=False))
        com.append((reports[-1].t, slide()))
except (ValueError, fe_mpm.ConvergenceError, fe_mpm.PointsOutsideError) as err:
    sys.exit(f"sliding_block.py: {err}")
# -

# ## Error (thesis Eq. 4.44)
#
# The centre of mass was recorded after every step (the output instants).

# +
t, s_h = np.array(com).T
s_exact = 0.5 * acceleration * t**2
error = float(np.sqrt(np.sum((s_h - s_exact) ** 2)))  # Eq. 4.44
wall = time.perf_counter() - START
base_name = "slip condition" if args.friction is None else f"rigid wall, μ = {μ:g}"
print(
    f"Sliding block: θ = {args.theta}°, {base_name}, Δt = {args.dt}, {len(reports)} steps, "
    f"{parallel.total(grid.comm, len(points))} points"
)
print(
    f"  slide s = {s_h[-1]:.6f} m, exact {s_exact[-1]:.6f} m; "
    f"Eq. 4.44 error over {len(t)} instants: {error:.2e} m"
)
print(
    f"  Newton iterations per step: mean {np.mean([r.newton_iterations for r in reports]):.2f}; "
    f"wall time {wall:.2f} s ({1000 * wall / len(reports):.1f} ms per step incl. set-up)"
)
# -

# ## Check against the reference
#
# Rigid sliding is an exact discrete solution, so the error is round-off: at most
# 7e-15 m for Δt = 0.02, 0.01 and 0.005 s over a slide of about 2.5 m. A bug in the
# Newmark update, the initial acceleration or the slip condition shows as an error
# of the size of the slide or of g Δt², millimetres here. The smooth rigid wall
# (`--friction 0`) gives the same to round-off.
#
# With friction the wall's force rises to μ p over a slip of a few slip scales
# (10⁻³ h = 0.1 mm here), so the first step, which slides about 1.5 of them, gets
# about 90 % of the friction and the block ends slightly ahead: measured
# +3.1e-4 relative at θ = 30°, μ = 0.1 after 1 s (6.2e-4 after 0.5 s; Δt = 0.01 s;
# with Bossak α_B = 0, until 2026-12-06 the default, 2.3e-4 after 1 s with −0.3).
# It passes within 2e-3 of the slide; a friction off by 1 % of μ would show as 2.1e-3.
# Below the friction angle (tan θ ≤ μ) the block rocks on the wall's springs and
# must stay within 4 slip scales.
#
# The check holds where the undamped block does not rock off its base. Released at
# rest, it feels the friction at once, and the friction's moment about its centre
# (μ' m g cos θ · H/2, with μ' = μ sliding or tan θ at rest) moves the resultant of
# the base pressure forward by μ' H/2; the suddenly applied load overshoots twice.
# Past the edge of the base's middle third, 2 μ' H/2 > L/6 (μ' > 1/6 for this
# 1 m × 0.5 m block), the rear lifts and the block rocks, and with no damping it
# keeps rocking. Measured: μ = 0.3 at θ = 30° slides 1.2 % too far with its rear
# lifted by 3 mm after 0.5 s; μ = 0.7 at θ = 30° (at rest in statics) walks 2 cm
# down the slope in 1 s. A 0.25 m high block does not lift (16 μm) but still
# slides 1.2 % too far at μ = 0.3 (Δt = 0.01 s), 2.3 % with Δt = 5 ms: released
# unstressed, the block lands on the wall's springs in its first steps, and the wall
# pushes hardest then, while the block has slipped less than the slip scale and the
# friction is not yet mobilised (it takes about √(2 s / a) = 9 ms). With a slip scale
# of 0.03 mm instead of 0.1 mm the error falls to 0.86 %. μ = 0.1 and below pass.
#
# Measured 2026-12-06 with the wall's default Bossak α_B = −0.3 (until then 0) and the
# steps taken by `run` (a step Newton fails is cut and retried; `step` had stopped the
# run at μ = 0.7 in step 54), θ = 30°, Δt = 0.01 s, 1 s: μ = 0 round-off (4.6e-15 m),
# μ = 0.1 +2.3e-4 (3.1e-4 with α_B = 0), μ = 0.3 +5.1e-3 (5.9e-3), μ = 0.5 +6.3 %
# (+7.5 %), at rest μ = 0.7 at most 5.1 slip scales (4.9 cm with α_B = 0) and μ = 0.8
# at most 3.2 (9.1 mm). At μ = 0.5 the net acceleration is a sixth of that at
# μ = 0.1, and the first step, in which the block slides about one slip scale and
# gets two thirds of its friction, gives it a head start that the slow slide does
# not outgrow (its
# slide is 3.5 times the exact one after that step, 1.06 times after 1 s); with a
# slip scale of 1e-5 m, 1.7 %. So the check passes for μ ≤ 0.1 and for μ = 0.8; in
# between the rigid block's slide is not this block's, released unstressed on
# regularised friction, to 2e-3 (`docs/limitations.md`, rigid walls).

# +
#: Largest Eq. 4.44 error that passes without friction (m): round-off with four
#: orders to spare.
TOLERANCE = 1e-10
#: With friction: the largest relative error of the slide, and the largest slide
#: (in slip scales) when the block should stay.
FRICTION_TOLERANCE, REST_SLIPS = 2e-3, 4.0

slip_scale = SLIP_SCALE_FACTOR * args.h  # the wall's default, on facets of size h
if μ == 0.0:
    passed = bool(error <= TOLERANCE)
    verdict = f"Eq. 4.44 error {error:.2e} m {'<=' if passed else '>'} {TOLERANCE:g} m"
elif acceleration > 0.0:
    relative = abs(s_h[-1] / s_exact[-1] - 1.0)
    passed = bool(relative <= FRICTION_TOLERANCE)
    verdict = f"slide off by {relative:.2e} {'<=' if passed else '>'} {FRICTION_TOLERANCE:g}"
else:
    most = float(np.max(np.abs(s_h)))
    passed = bool(most <= REST_SLIPS * slip_scale)
    verdict = f"largest slide {most:.2e} m {'<=' if passed else '>'} {REST_SLIPS:g} slip scales"
print(
    f"check: vs s = ½ g (sin θ − μ cos θ) t² (θ = {args.theta}°, μ = {μ:g}, "
    f"Δt = {args.dt}): {verdict}: {'PASS' if passed else 'FAIL'}"
)
if args.friction is not None and parallel.on_rank_zero(grid.comm):
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    written = [write_wall_forces(reports, out / "walls.csv").name]
    plt = pyplot()
    if plt is not None:
        written.append(plot_wall_forces(reports, out / "walls.png", plt).name)
    print(f"  wrote {out}/{' and '.join(written)}")
if args.json:
    print(
        json.dumps(
            {
                "error": error,
                "wall_time_s": wall,
                "steps": len(reports),
                "n_particles": parallel.total(grid.comm, len(points)),
                "dt": args.dt,
                "slide_m": float(s_h[-1]),
                "exact_m": float(s_exact[-1]),
                "friction": args.friction,
                "check_passed": passed,
            }
        )
    )
if passed is False:
    note = ""
    # The note is the frictional wall's: on the slip base the slide is exact to round-off.
    if args.friction is not None and (0.1 < μ < 0.8 or bossak_alpha != -0.3):
        note = (
            " (the reference is a rigid block; this block, released unstressed on "
            "regularised friction, is checked to it for μ ≤ 0.1 and μ ≥ 0.8 at θ = 30° "
            "with Bossak's α_B = −0.3: see the demo's notes)"
        )
    sys.exit(f"sliding_block.py: {verdict}{note}")
# -
