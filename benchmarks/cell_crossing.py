"""Cell-crossing error: Cook's membrane over many load steps, with and without point domains.

Cook's membrane at 5 N (Neo-Hookean, u-p with PPP, a dead load on points that follow
the body), 20 load steps, against the converged finite element answer: a Taylor–Hood
(P2/P1) solve in one load step with three points per triangle (a degree-2 rule) on
n = 16, 32, 64, extrapolated (geometric Richardson). One load step of the MPM is a
finite element solve with the points as Gauss points; over 20 steps the points cross
cells, and standard MPM drifts (issue 19). ``point_domains=True`` spreads each point's
volume over the cells its convected domain covers (:mod:`fe_mpm.domains`), with the
ghost penalty by default (γ = 0.1 for P1, 0.01 for P2, :mod:`fe_mpm.ghost`; the
γ = 0 rows leave it out).

Usage: ``./run python benchmarks/cell_crossing.py [--quick] [--nu 0.499 0.33]
[--formulations up up-p2p1] [--load 5] [--sizes 16 32 64] [--steps 20] [--hold K]
[--shared]``; above 5 N
the grid's margins are n rows instead of n / 2. P2/P1 rows: standard MPM needs three
points in every cell; the ghost penalty ties cells left with fewer
(:mod:`fe_mpm.ghost`); with domains each piece has three sub-points, so one point per
cell is enough.
``--dim 3`` runs the membrane extruded one cell deep into tetrahedra with
plane-strain rollers (``cook_membrane(thickness=44 / n)``), u-p only, with 1 and 4
points per cell (point domains on tetrahedra are P1 only); its answer converges to
the same 2D limit.
``--hold K`` then takes K more steps at the full load: at equilibrium such a step
has nothing to do, so whatever the tip moves is what the update of a step adds (with
point domains it moves; see ``docs/cell_crossing.md``).
``--shared`` runs point domains with the pieces' own increments against their
point's shared one (``shared_increment=True``, :mod:`fe_mpm.shared_increment`), with
and without PPP; ``--formulations u up`` adds the u form's rows.
Prints the tip displacement, its error against the converged answer and the wall time
of every case. Not a test.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import fe_mpm
from fe_mpm import scenes

#: Total load on the right edge (N) by default: large enough that points cross cells.
LOAD = 5.0
#: (label, formulation, points per cell, options of Simulation).
CASES = [
    ("standard, 1 point", "up", 1, {}),
    ("standard, 3 points", "up", 3, {}),
    ("domains γ=0, 1 point", "up", 1, {"point_domains": True, "ghost_penalty": 0.0}),
    ("domains, 1 point", "up", 1, {"point_domains": True}),
    ("domains, 3 points", "up", 3, {"point_domains": True}),
    ("P2 standard, 3 points", "up-p2p1", 3, {}),
    ("P2 standard γ=0.1, 3 pts", "up-p2p1", 3, {"ghost_penalty": 0.1}),
    ("P2 domains γ=0, 1 point", "up-p2p1", 1, {"point_domains": True, "ghost_penalty": 0.0}),
    ("P2 domains, 1 point", "up-p2p1", 1, {"point_domains": True}),
    ("P2 domains, 3 points", "up-p2p1", 3, {"point_domains": True}),
]
_DOMAINS = {"point_domains": True}
_SHARED = {"point_domains": True, "shared_increment": True}
#: ``--shared``: the pieces' own increments against their point's shared one.
CASES_SHARED = [
    ("u domains, 3 points", "u", 3, _DOMAINS),
    ("u shared, 3 points", "u", 3, _SHARED),
    ("domains, 1 point", "up", 1, _DOMAINS),
    ("shared, 1 point", "up", 1, _SHARED),
    ("domains, 3 points", "up", 3, _DOMAINS),
    ("shared, 3 points", "up", 3, _SHARED),
    ("domains, 3 pts, no PPP", "up", 3, {**_DOMAINS, "ppp_alpha": 0.0}),
    ("shared, 3 pts, no PPP", "up", 3, {**_SHARED, "ppp_alpha": 0.0}),
]
#: The same on tetrahedra (``--dim 3``): 4 points per cell is seed's degree-2 rule.
CASES_3D = [
    ("standard, 1 point", "up", 1, {}),
    ("standard, 4 points", "up", 4, {}),
    ("domains, 1 point", "up", 1, {"point_domains": True}),
    ("domains, 4 points", "up", 4, {"point_domains": True}),
]


def _cook(
    n: int,
    nu: float,
    formulation: str,
    per_cell: int,
    options: dict | None = None,
    load: str = "points",
    margin: int | None = None,
    force: float = LOAD,
    dim: int = 2,
) -> fe_mpm.Simulation:
    """Cook's membrane as the table runs it (see :func:`tip` for the arguments)."""
    return scenes.cook_membrane(
        n,
        nu,
        formulation,
        per_cell=per_cell,
        traction=force / 16,
        load=load,
        margin=n // 2 if margin is None else margin,
        thickness=None if dim == 2 else 44.0 / n,
        **(options or {}),
    )


def tip(
    n: int,
    nu: float,
    formulation: str,
    per_cell: int,
    steps: int,
    options: dict | None = None,
    load: str = "points",
    margin: int | None = None,
    force: float = LOAD,
    dim: int = 2,
) -> tuple[float, float]:
    """Cook's tip displacement (m; NaN if the run stops) and the wall time of the run (s).

    ``margin``: rows of empty cells above and below the body (default n / 2);
    ``force``: the total load on the right edge (N); ``dim`` 3: extruded one cell
    deep into tetrahedra.
    """
    t0 = time.perf_counter()
    sim = _cook(n, nu, formulation, per_cell, options, load, margin, force, dim)
    try:
        sim.run(1.0, steps, progress=False)
    except fe_mpm.ConvergenceError as err:
        print(f"  ({str(err).split(':')[0]})", flush=True)
        return float("nan"), time.perf_counter() - t0
    return scenes.tip_deflection(sim), time.perf_counter() - t0


def held_tips(
    n: int,
    nu: float,
    formulation: str,
    per_cell: int,
    steps: int,
    hold: int,
    options: dict | None = None,
    margin: int | None = None,
    force: float = LOAD,
) -> np.ndarray:
    """Cook's tip after its load and after each of ``hold`` further steps at that load.

    The tip (m) after the load is reached in ``steps`` steps, then after each of ``hold``
    more steps at the full load, shape ``(hold + 1,)`` (NaN from a failed step on).

    At equilibrium a step with no change of load has nothing to do: an elastic body
    should not move. Whatever it does move is what the step's own update adds.
    """
    sim = _cook(n, nu, formulation, per_cell, options, "points", margin, force)
    tips = np.full(hold + 1, np.nan)
    try:
        sim.run(1.0, steps, progress=False)
        tips[0] = scenes.tip_deflection(sim)
        for k in range(1, hold + 1):
            sim.run(1.0 + k / steps, 1, progress=False)  # the scene holds its load after t = 1
            tips[k] = scenes.tip_deflection(sim)
    except fe_mpm.ConvergenceError as err:
        print(f"  ({str(err).split(':')[0]})", flush=True)
    return tips


def converged_fem(nu: float, force: float = LOAD, sizes=(16, 32, 64)) -> float:
    """The Taylor–Hood finite element limit of the tip displacement (Richardson)."""
    a, b, c = (tip(n, nu, "up-p2p1", 3, 1, load="grid", force=force)[0] for n in sizes)
    ratio = (b - a) / (c - b)
    return c + (c - b) / (ratio - 1)


def main() -> None:
    """Print the table."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="n = 16 and 32 only")
    p.add_argument("--nu", type=float, nargs="+", default=[0.499, 0.33])
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--formulations", nargs="+", default=["up", "up-p2p1"])
    p.add_argument("--load", type=float, default=LOAD, help="total load (N)")
    p.add_argument("--sizes", type=int, nargs="+", default=None, help="grids n (16 32 64)")
    p.add_argument("--dim", type=int, choices=(2, 3), default=2, help="3: on tetrahedra")
    p.add_argument(
        "--hold",
        type=int,
        default=0,
        help="then this many steps at the full load: each cell gives the tip after the "
        "load, after the hold, and the change (2D only)",
    )
    p.add_argument(
        "--shared",
        action="store_true",
        help="the cases of point domains with and without shared_increment (2D; give "
        "--formulations u up for the u rows)",
    )
    args = p.parse_args()
    if args.hold and args.dim == 3:
        p.error("--hold runs the 2D membrane only; leave out --dim 3")
    if args.shared and args.dim == 3:
        p.error("--shared runs the 2D membrane only; leave out --dim 3")
    cases = CASES_SHARED if args.shared else CASES if args.dim == 2 else CASES_3D
    sizes = args.sizes or ((16, 32) if args.quick else (16, 32, 64))
    margin = {n: n // 2 if args.load <= LOAD else n for n in sizes}  # room to move
    for nu in args.nu:
        limit = converged_fem(nu, args.load)
        print(
            f"\nν = {nu}: converged Taylor–Hood FEM u_A,y = {limit:.4f} "
            f"(P2/P1, 3 points per triangle, one step, n = 16, 32, 64, Richardson)"
        )
        print(f"{'case':<24}" + "".join(f"{'n = ' + str(n):>22}" for n in sizes))
        one_step = [tip(n, nu, "up", 1, 1, force=args.load, dim=args.dim)[0] for n in sizes]
        print(
            f"{'one step (FEM at n)':<24}"
            + "".join(f"{u:>10.4f} {100 * (u / limit - 1):+6.1f} %    " for u in one_step)
        )
        for label, formulation, per_cell, options in cases:
            if formulation not in args.formulations:
                continue
            cells = []
            for n in sizes:
                if args.hold:
                    t = held_tips(
                        n, nu, formulation, per_cell, args.steps, args.hold, options,
                        margin[n], args.load,
                    )  # fmt: skip
                    cells.append(f"{t[0]:.4f} → {t[-1]:.4f} {100 * (t[-1] / t[0] - 1):+5.2f} %")
                    continue
                u, wall = tip(
                    n,
                    nu,
                    formulation,
                    per_cell,
                    args.steps,
                    options,
                    margin=margin[n],
                    force=args.load,
                    dim=args.dim,
                )
                cells.append(f"{u:>10.4f} {100 * (u / limit - 1):+6.1f} % {wall:4.0f}s")
            width = 30 if args.hold else 22
            print(f"{label:<24}" + "".join(f"{c:>{width}}" for c in cells), flush=True)


if __name__ == "__main__":
    main()
