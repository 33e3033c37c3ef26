# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # Does a vibrating body keep its energy? The velocity projection's passes
#
# A benchmark, not a test: it prints how much energy an elastic body keeps where a
# finite element solve with the trapezoidal rule would keep all of it, against
# `Simulation(projection_passes=k)`. One pass is the thesis's mass-weighted
# projection of the points' velocity and acceleration (Iaconeta Eqs. 2.6–2.9);
# more passes approach the consistent-mass projection
# (`fe_mpm.transfer.consistent_projection`). The numbers are in `docs/dynamics.md`.
#
# **Scenes** (Neo-Hookean, E = 1 MPa, ν = 0.3, ρ = 1000 kg/m³, no gravity, three
# points per triangle, a 1 m square grid of `--n` cells a side, the trapezoidal rule):
#
# - `ring`: a free 0.4 m square started with the stretching velocity
#   v_x = 2 (x − 0.5) /s, which rings in the block's own modes (the first's period
#   is about 20 ms). Printed: its energy (kinetic plus Neo-Hookean, from the points'
#   F) over the start's, every 0.1 s.
# - `spin`: the same square spinning rigidly at 2 rad/s. Its angular momentum and
#   moment of inertia stay; printed: the kinetic energy of the points' velocities
#   about the rigid rotation that carries the same angular momentum (spurious
#   velocity the grid does not see), over the spin's energy.
#
# Usage: `python benchmarks/vibration_energy.py [--scene ring|spin] [--n 20 40 80]
# [--dt 1e-3] [--passes 1 2 4 8] [--formulation u] [--plot docs/vibration_energy.png]`;
# `--plot` draws the measure against time, one panel per grid.

# +
import argparse
import time

import numpy as np

import fe_mpm
from fe_mpm.meshes import rectangle_mesh
from fe_mpm.plotting import pyplot


def parse_args(argv=None):
    """The command line."""
    p = argparse.ArgumentParser(description="Energy of a vibrating or spinning block")
    p.add_argument("--scene", choices=["ring", "spin"], default="ring")
    p.add_argument("--n", type=int, nargs="+", default=[20, 40, 80], help="cells a side")
    p.add_argument("--dt", type=float, default=1e-3, help="time step (s)")
    p.add_argument("--t-end", type=float, default=0.4, help="duration (s)")
    p.add_argument("--passes", type=int, nargs="+", default=[1, 2, 4, 8])
    p.add_argument("--formulation", default="u")
    p.add_argument("--plot", default=None, help="PNG of the measure against time")
    return p.parse_args(argv)


def block(n: int, scene: str):
    """The grid and the block's points, moving as ``scene`` says."""
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (n, n))
    points = fe_mpm.seed(mesh, per_cell=3, density=1000.0)
    points.keep(np.all(np.abs(points.x - 0.5) < 0.2, axis=1))
    r = points.x - 0.5
    if scene == "ring":
        points.velocity[:, 0] = 2.0 * r[:, 0]
    else:
        points.velocity[:] = 2.0 * np.stack([-r[:, 1], r[:, 0]], axis=1)
    return mesh, points


def measure(points, material, scene: str) -> float:
    """Energy (ring) or spurious kinetic energy about the rigid spin (spin), in J/m."""
    if scene == "ring":
        elastic = (points.volume / np.linalg.det(points.F)) @ material.stored_energy(points.F)
        return points.kinetic_energy() + float(elastic)
    m, v = points.mass, points.velocity
    r = points.x - (m @ points.x) / m.sum()
    spin = (m @ (r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0])) / (m @ np.sum(r**2, axis=1))
    rigid = spin * np.stack([-r[:, 1], r[:, 0]], axis=1) + (m @ v) / m.sum()
    return 0.5 * float(m @ np.sum((v - rigid) ** 2, axis=1))


def run(n: int, passes: int, args) -> tuple[np.ndarray, np.ndarray, float]:
    """Times (s), the measure after every step and the wall time (s).

    The measure is over its start's (ring) or over the spin's energy (spin).
    """
    mesh, points = block(n, args.scene)
    material = fe_mpm.NeoHookean(1e6, 0.3, density=1000.0)
    sim = fe_mpm.Simulation(
        mesh, points, material, args.formulation, dynamic=True, projection_passes=passes
    )
    scale = measure(points, material, "ring") if args.scene == "spin" else None
    start = measure(points, material, args.scene)
    steps = round(args.t_end / args.dt)
    t0, values = time.perf_counter(), []
    for k in range(1, steps + 1):
        sim.step(k * args.dt)
        values.append(measure(points, material, args.scene) / (scale or start))
    return args.dt * np.arange(1, steps + 1), np.array(values), time.perf_counter() - t0


def plot(curves: dict, args) -> None:
    """The measure against time, one panel per grid, one curve per number of passes."""
    plt = pyplot()
    if plt is None:
        return
    sizes = sorted({n for n, _ in curves})
    fig, axes = plt.subplots(1, len(sizes), figsize=(4.2 * len(sizes), 3.6), sharey=True)
    for ax, n in zip(np.atleast_1d(axes), sizes, strict=True):
        for (size, passes), (t, values) in curves.items():
            if size == n:
                ax.plot(t, values, label=f"{passes} pass{'es' if passes > 1 else ''}")
        ax.set_title(f"{n * 2 // 5} cells across the block")
        ax.set_xlabel("t (s)")
    first = np.atleast_1d(axes)[0]
    first.set_ylabel("E / E₀" if args.scene == "ring" else "spurious KE / spin KE")
    first.legend()
    fig.tight_layout()
    fig.savefig(args.plot, dpi=110)
    print(f"wrote {args.plot}")


# -

if __name__ == "__main__":
    args = parse_args()
    what = "energy / start" if args.scene == "ring" else "spurious KE / spin KE"
    print(f"scene {args.scene}, {args.formulation}, dt = {args.dt} s: {what} every 0.1 s")
    curves = {}
    every = round(0.1 / args.dt)
    for n in args.n:
        for passes in args.passes:
            t, values, wall = run(n, passes, args)
            curves[n, passes] = (t, values)
            print(
                f"  n = {n:3d} ({n * 2 // 5} cells across), passes {passes}: "
                + " ".join(f"{v:.4f}" for v in values[every - 1 :: every])
                + f"  ({wall:.1f} s)"
            )
    if args.plot:
        plot(curves, args)
