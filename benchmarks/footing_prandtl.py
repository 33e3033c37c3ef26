"""Strip footing on stiff Tresca soil: the collapse load against the cell size.

The small-strain collapse load of a rigid strip on weightless Tresca soil is
q = (2 + π) c_u for a rough (Prandtl) and a smooth (Hill) footing alike. On stiff
soil the footing reaches it after a small settlement, where the geometry has barely
changed, so the mean q/c_u over the second half of a short push is the collapse
load of the grid. This runs ``scenes.strip_footing`` (u-p, 3 points per cell, a
refined zone B deep and 1.5 B wide, h_far = 0.2 B) for every E/c_u, footing, cell
size h near the footing, and for a grid with cells of h/4 around the footing's
edge (``edge_size``). The settlement is 60 c_u/E × B in 20 steps (s/B = 0.02 for
E/c_u = 3000), 2 base points per cell.

It prints q/(2 + π)c_u with the observed rate of its error, writes
``footing_prandtl.json`` and, with matplotlib, ``docs/footing_prandtl.png``. The
whole default set takes about an hour on one core.

Usage: ``./run python benchmarks/footing_prandtl.py [--E 3000 1000] [--footing
rough] [--h 0.2 0.1] [--edge-h 0.1] [--out F.json]``; ``--replot A.json B.json``
merges earlier runs into the plot. Not a test.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from fe_mpm import scenes
from fe_mpm.plotting import pyplot

PRANDTL = 2 + np.pi
STEPS = 20


def plateau(E_over_cu: float, h: float, smooth: bool, edge: bool) -> tuple[float, float, list]:
    """The mean q/(2 + π)c_u over the second half of the push, its wall time, and the curve."""
    settlement = 60.0 / E_over_cu
    sim = scenes.strip_footing(
        "up",
        cu=100.0,
        E=100.0 * E_over_cu,
        nu=0.49,
        h=h,
        h_far=max(h, 0.2),
        near_depth=1.0,
        points_near=3,
        settlement=settlement,
        smooth=smooth,
        edge_size=h / 4 if edge else None,
    )
    t0 = time.perf_counter()
    reports = sim.run(1.0, STEPS, progress=False)
    wall = time.perf_counter() - t0
    s = np.array([settlement * r.t for r in reports])
    q = np.array([scenes.footing_pressure(r) / 100.0 for r in reports]) / PRANDTL
    return float(q[s >= settlement / 2 - 1e-12].mean()), wall, np.column_stack([s, q]).tolist()


def rates(rows: list[dict], cases: list[tuple[int, bool]]) -> None:
    """Print each series' errors and the observed rates as h halves."""
    print("\nerrors |q/(2+π) − 1| and observed rates as h halves:")
    for E_over_cu, smooth in cases:
        for edge in (False, True):
            errors = [abs(r["q_over_prandtl"] - 1) for r in series(rows, E_over_cu, smooth, edge)]
            if not errors:
                continue
            observed = [np.log2(a / b) for a, b in zip(errors, errors[1:], strict=False) if b > 0]
            print(
                f"  E/c_u = {E_over_cu}, {'smooth' if smooth else 'rough'}, "
                f"{'edge h/4' if edge else 'uniform'}: "
                + ", ".join(f"{100 * e:.1f} %" for e in errors)
                + "; rates "
                + ", ".join(f"{r:.2f}" for r in observed)
            )


def series(rows: list[dict], E_over_cu: int, smooth: bool, edge: bool) -> list[dict]:
    """The rows of one E/c_u, footing and grid kind, coarsest first."""
    sel = [
        r
        for r in rows
        if r["E_over_cu"] == E_over_cu
        and r["footing"] == ("smooth" if smooth else "rough")
        and (r["edge_size"] < r["h"]) == edge
    ]
    return sorted(sel, key=lambda r: -r["h"])


def plot(rows: list[dict], cases: list[tuple[int, bool]], path: Path) -> None:
    """The error against h, one line per series (needs matplotlib)."""
    plt = pyplot()
    if plt is None:
        return
    fig, ax = plt.subplots(figsize=(8, 4))
    # A colour per E/c_u, a marker per footing, dashed on the grids refined at the edge.
    stiffnesses = sorted({E for E, _ in cases})
    colours = dict(zip(stiffnesses, plt.cm.viridis(np.linspace(0.0, 0.85, len(stiffnesses)))))
    for E_over_cu, smooth in cases:
        for edge in (False, True):
            sel = series(rows, E_over_cu, smooth, edge)
            if sel:
                ax.loglog(
                    [r["h"] for r in sel],
                    [max(abs(r["q_over_prandtl"] - 1), 1e-4) for r in sel],
                    marker="s" if smooth else "o",
                    ls="--" if edge else "-",
                    color=colours[E_over_cu],
                    label=f"E/c_u = {E_over_cu}, {'smooth' if smooth else 'rough'}"
                    + (", cells h/4 at the edge" if edge else ""),
                )
    ax.set_xlabel("h / B near the footing")
    ax.set_ylabel("|q / (2 + π) c_u − 1|")
    ax.axhline(0.03, color="k", lw=0.8, ls=":")
    ticks = [0.025, 0.05, 0.1, 0.2]
    ax.set_xticks(ticks, [str(t) for t in ticks])
    ax.minorticks_off()
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5))
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


def main() -> None:
    """Run the cases asked for, print the table and the rates, write the JSON and the plot."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--E", type=int, nargs="+", default=[3000, 1000, 300], help="E/c_u values")
    p.add_argument("--footing", nargs="+", default=["rough", "smooth"], help="rough, smooth")
    p.add_argument("--h", type=float, nargs="*", default=[0.2, 0.1, 0.05, 0.025])
    p.add_argument("--edge-h", type=float, nargs="*", default=[0.2, 0.1, 0.05])
    p.add_argument("--out", default="footing_prandtl.json")
    p.add_argument("--replot", nargs="+", help="JSON files of earlier runs: merge and plot them")
    args = p.parse_args()
    if args.replot:
        rows = [row for f in args.replot for row in json.loads(Path(f).read_text())]
    else:
        rows = []
        for E_over_cu in args.E:
            for footing in args.footing:
                grids = [(h, False) for h in args.h] + [(h, True) for h in args.edge_h]
                for h, edge in grids:
                    q, wall, curve = plateau(E_over_cu, h, footing == "smooth", edge)
                    rows.append(
                        {
                            "E_over_cu": E_over_cu,
                            "footing": footing,
                            "h": h,
                            "edge_size": h / 4 if edge else h,
                            "q_over_prandtl": q,
                            "wall_s": wall,
                            "curve": curve,
                        }
                    )
                    print(
                        f"E/c_u = {E_over_cu:5d} {footing:6s} h = {h:<6} "
                        f"edge {rows[-1]['edge_size']:<7g} q/(2+π)c_u = {q:.4f} "
                        f"({100 * (q - 1):+.1f} %)  {wall:.0f} s",
                        flush=True,
                    )
        Path(args.out).write_text(json.dumps(rows, indent=1))
    cases = sorted({(r["E_over_cu"], r["footing"] == "smooth") for r in rows}, reverse=True)
    rates(rows, cases)
    plot(rows, cases, Path(__file__).resolve().parents[1] / "docs" / "footing_prandtl.png")


if __name__ == "__main__":
    main()
