# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: light
# ---

# # Does a fluid keep its energy? A gentle vortex and a small slosh
#
# A benchmark, not a test: it prints how the kinetic (or mechanical) energy of
# water in a tank evolves where it should stay constant, apart from Bossak's
# dissipation of the highest frequencies. It measures a defect of standard MPM on
# fluids: a fluid under pressure gains energy as its points cross cells
# (`--usual-pressure`), what `fe_mpm.pressure_by_parts` (the default for a
# fluid in u-p and in `--formulation u-nbva`) leaves of it, and what point domains
# (`--point-domains`, `Simulation(point_domains=True)`, the pressure's usual form)
# leave. The numbers are in `docs/limitations.md`.
#
# **Scenes** (water, ρ₀ = 1000 kg/m³, K = 2 GPa, μ_v = 1e-3 Pa·s, `NewtonianFluid`;
# a tank 1 m wide, slip walls; u-p without PPP, lumped mass, Bossak −0.3;
# `--n` cells across, 6 points per triangle, `seed(level_set=...)` for a free
# surface):
#
# - `closed`: the tank 0.5 m deep, full and closed by a slip lid, with the
#   divergence-free velocity of the stream function ψ = A (H/π) sin(πx/L) sin(πy/H),
#   A = 5 cm/s: one vortex filling the tank. Inviscid, its kinetic energy stays; the
#   pressure is hydrostatic plus the vortex's own (ρ A², 2.5 Pa).
# - `open`: the same vortex under a free surface (water 0.5 m deep in a grid
#   0.6 m tall); ψ gives no vertical velocity at the surface, so it stays flat.
# - `slosh`: water 0.5 m deep at rest with its surface raised by a cos(πx/L),
#   a = 1 cm: the first sloshing mode, period 2π/√(g k tanh kH), k = π/L (1.182 s).
#   The mechanical energy above the flat water at rest, ½ ρ g a² L / 2 = 0.245 J/m
#   (of which the level set's seeding gives 0.252), should stay.
#
# `--gravity 0` runs the vortices without gravity, so without pressure.
#
# Usage: `./run python benchmarks/fluid_energy.py --scene closed|open|slosh
# [--n 40] [--t-end 1] [--dt 0.01] [--formulation up] [--gravity 9.81]
# [--usual-pressure | --point-domains]`; `--plot docs/fluid_energy.png` runs all
# three scenes the three ways and plots the energies against time.

# +
import argparse
import math
import time
import warnings

import numpy as np

import fe_mpm
from fe_mpm.meshes import rectangle_mesh

RHO, K, VISCOSITY = 1000.0, 2.0e9, 1.0e-3
WIDTH, DEPTH, SWIRL, AMPLITUDE = 1.0, 0.5, 0.05, 0.01


#: The three ways of a run: the pressure's usual form, by parts (the default), and
#: point domains (with the usual form: the two do not combine).
WAYS = {"usual form": False, "by parts (default)": None, "point domains": "domains"}


def build(
    scene: str, n: int, gravity: float, formulation: str, by_parts: bool | None | str = None
) -> fe_mpm.Simulation:
    """The tank, its water and the simulation of one scene (``by_parts``: one of :data:`WAYS`)."""
    h = WIDTH / n
    top = DEPTH if scene == "closed" else DEPTH + 0.1
    mesh = rectangle_mesh((0.0, 0.0), (WIDTH, top), (n, round(top / h)))
    if scene == "slosh":
        surface = lambda x: DEPTH + AMPLITUDE * np.cos(np.pi * x[0] / WIDTH) - x[1]  # noqa: E731
    else:
        surface = lambda x: DEPTH - x[1]  # noqa: E731
    points = fe_mpm.seed(mesh, 6, density=RHO, level_set=surface)
    if scene != "slosh":
        x, y = points.x[:, 0] / WIDTH, points.x[:, 1] / DEPTH
        points.velocity = SWIRL * np.column_stack(
            [
                np.sin(np.pi * x) * np.cos(np.pi * y),
                -(DEPTH / WIDTH) * np.cos(np.pi * x) * np.sin(np.pi * y),
            ]
        )
    walls = [
        fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0) | np.isclose(x[0], WIDTH), component=0),
        fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0), component=1),
    ]
    if scene == "closed":
        walls.append(fe_mpm.Dirichlet(lambda x: np.isclose(x[1], DEPTH), component=1))
    water = fe_mpm.NewtonianFluid(
        K, VISCOSITY, shear_scale=2 * RHO * max(gravity, 1.0) * DEPTH, density=RHO
    )
    return fe_mpm.Simulation(
        mesh,
        points,
        water,
        formulation,
        dirichlet=walls,
        body_force=(0.0, -gravity),
        dynamic=True,
        mass="lumped",
        bossak_alpha=-0.3,
        pressure_by_parts=None if by_parts == "domains" else by_parts,
        point_domains=by_parts == "domains",
    )


def energy(sim: fe_mpm.Simulation, scene: str, gravity: float) -> float:
    """Kinetic energy (J/m), plus for the slosh the potential energy above flat water."""
    p = sim.points
    kinetic = 0.5 * p.mass @ np.sum(p.velocity**2, axis=1)
    if scene != "slosh":
        return kinetic
    flat = gravity * p.mass.sum() * DEPTH / 2.0
    return kinetic + gravity * p.mass @ p.x[:, 1] - flat


def history(
    scene: str, n: int, t_end: float, dt: float, gravity: float, formulation: str, by_parts
) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and energies over the start's of one run, printed as it goes."""
    sim = build(scene, n, gravity, formulation, by_parts)
    start = energy(sim, scene, gravity)
    steps = round(t_end / dt)
    form = next(name for name, way in WAYS.items() if way == by_parts)
    print(f"{scene}, {form}: {len(sim.points)} points, n = {n}, Δt = {dt} s")
    print("     t   E/E0   fastest (m/s)   points per occupied cell")
    wall = time.perf_counter()
    report_every = max(1, steps // 10)
    times, energies = [0.0], [1.0]
    for k in range(1, steps + 1):
        try:
            sim.run(k * dt, 1, progress=False)
        except fe_mpm.ConvergenceError as err:  # the usual form can end in a failed step
            print(f"stopped at t = {sim.t:.2f} s: {str(err).splitlines()[0][:100]}")
            break
        times.append(sim.t)
        energies.append(energy(sim, scene, gravity) / start)
        if k % report_every == 0 or k == steps:
            p = sim.points
            count = np.bincount(p.cell)
            count = count[count > 0]
            print(
                f"{sim.t:6.2f} {energies[-1]:6.3f} "
                f"{np.abs(p.velocity).max():11.3e}   {count.min()}–{count.max()}"
            )
    print(f"wall time {time.perf_counter() - wall:.0f} s")
    return np.array(times), np.array(energies)


def plot(curves: dict, path: str) -> None:
    """E/E0 against t, one panel per scene, one curve per way of :data:`WAYS`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    titles = {
        "closed": "vortex, closed tank",
        "open": "vortex, free surface",
        "slosh": "1 cm slosh (usual form: E < 0 from t = 0.22 s)",
    }
    fig, axes = plt.subplots(1, len(titles), figsize=(13, 3.8))
    for ax, scene in zip(axes, titles, strict=True):
        for (name, way), (t, e) in curves.items():
            if name == scene:
                ax.semilogy(t, np.abs(e), label=way)
        ax.axhline(1.0, color="grey", lw=0.8)
        ax.set_title(titles[scene])
        ax.set_xlabel("t (s)")
    axes[0].set_ylabel("|E / E₀|")
    axes[0].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main() -> None:
    """Run one scene (or, with --plot, all three both ways) and print its energy."""
    parser = argparse.ArgumentParser(description="Energy of water in a tank over time.")
    parser.add_argument("--scene", choices=("closed", "open", "slosh"), default="closed")
    parser.add_argument("--n", type=int, default=40, help="cells across the tank")
    parser.add_argument("--t-end", type=float, default=1.0, help="s")
    parser.add_argument("--dt", type=float, default=0.01, help="s")
    parser.add_argument("--gravity", type=float, default=9.81, help="m/s²")
    parser.add_argument("--formulation", default="up")
    parser.add_argument(
        "--usual-pressure",
        action="store_true",
        help="the pressure's force in the usual form only (pressure_by_parts=False)",
    )
    parser.add_argument(
        "--point-domains",
        action="store_true",
        help="point domains (point_domains=True), with the pressure's usual form",
    )
    parser.add_argument(
        "--plot", metavar="PNG", help="run all three scenes the three ways; plot E/E0 against t"
    )
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    options = (args.n, args.t_end, args.dt, args.gravity, args.formulation)
    if args.plot:
        curves = {
            (scene, way): history(scene, *options, by_parts)
            for scene in ("closed", "open", "slosh")
            for way, by_parts in WAYS.items()
        }
        plot(curves, args.plot)
        return
    if args.usual_pressure and args.point_domains:
        parser.error("--usual-pressure and --point-domains: choose one")
    way = "domains" if args.point_domains else (False if args.usual_pressure else None)
    history(args.scene, *options, way)
    if args.scene == "slosh":
        k = math.pi / WIDTH
        period = 2 * math.pi / math.sqrt(args.gravity * k * math.tanh(k * DEPTH))
        print(f"linear theory: period {period:.3f} s")


if __name__ == "__main__":
    main()
