"""What each law's return map costs at the points: microseconds per point.

Times ``return_map`` (τ, bᵉ and the history) and its tangent ∂τ/∂ΔF separately for
every law that returns at the points, on ``--points`` plane-strain increments about
a hydrostatic state of −150 kPa (Mast's sand; E = 75 MPa, ν = 0.33), of which 15–20 %
yield; the evolving-angle laws start at λ = 0.01. Then, for the laws the u-p forms
run at the pressure field's mean stress (``return_at_pressure``), that return and
its four tangent blocks, at the law's own mean stress times a factor within ±5 %
(a pressure field near, not at, the law's). Medians of ``--repeat`` calls after a
warm-up (numba compiles on a machine's first call and caches to disk).

Usage: ``./run python benchmarks/law_cost.py [--points 100000] [--repeat 3]``. Not a test.
"""

import argparse
import statistics
import time

import numpy as np

import fe_mpm
from fe_mpm.materials.drucker_prager import MAST_TABLE_3_5

E, NU, P0 = 75e6, 0.33, -150e3


def laws() -> dict:
    """The laws timed, by name."""
    dense = MAST_TABLE_3_5["dense"]
    return {
        "MohrCoulomb (φ 30°, ψ 5°)": fe_mpm.MohrCoulomb(E, NU, 0.0, 30.0, 5.0),
        "DruckerPrager (φ 30°, ψ 5°)": fe_mpm.DruckerPrager(E, NU, 0.0, 30.0, 5.0),
        "SmoothCapDruckerPrager": fe_mpm.SmoothCapDruckerPrager(E, NU, 30.0, 1e3, 0.2),
        "ModifiedDruckerPrager": fe_mpm.ModifiedDruckerPrager(E, NU, **dense),
        "MatsuokaNakai, DP flow": fe_mpm.MatsuokaNakai(E, NU, **dense),
        "MatsuokaNakai, MN flow": fe_mpm.MatsuokaNakai(E, NU, **dense, potential="matsuoka-nakai"),
        "HenckyJ2 (σ_Y 100 kPa)": fe_mpm.HenckyJ2(E, NU, 100e3, 1e6, 1e6),
    }


def _runs_in_up(law) -> bool:
    """Whether the u-p forms take the law (the smooth cap is refused)."""
    try:
        getattr(law, "check_formulation", lambda pressure: None)(True)
    except ValueError:
        return False
    return True


def main() -> None:
    """Print one row per law."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=100_000)
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args()
    n = args.points
    rng = np.random.default_rng(0)
    dF = np.eye(2) + 0.004 * rng.normal(size=(n, 2, 2)) - 0.004 * np.eye(2)
    K = E / (3 * (1 - 2 * NU))
    be = np.tile(np.exp(2 * P0 / (3 * K)) * np.eye(3), (n, 1, 1))
    print(f"{n} points; µs per point, medians of {args.repeat}")
    print(f"{'law':30s} {'return':>8s} {'tangent':>8s} {'plastic':>8s}")
    for name, law in laws().items():
        history = {key: field.initial_values(n) for key, field in law.history.items()}
        history["be"] = be.copy()
        if "plastic_shear" in history:
            history["plastic_shear"][:] = 0.01
        law.return_map(dF[:10], {k: v[:10] for k, v in history.items()}).tangent
        result = _row(name, lambda: law.return_map(dF, history), args.repeat, n)
        if getattr(law, "pressure_dependent", False) and _runs_in_up(law):
            mean = np.trace(result.tau, axis1=1, axis2=2) / 3.0
            mean *= 1.0 + rng.uniform(-0.05, 0.05, n)
            law.return_at_pressure(dF[:10], mean[:10], {k: v[:10] for k, v in history.items()})
            label = "  at the field pressure (u-p)"
            _row(label, lambda: law.return_at_pressure(dF, mean, history), args.repeat, n)


def _row(name: str, call, repeat: int, n: int):
    """Print the medians of ``repeat`` calls (µs per point) and the plastic share."""
    returns, tangents = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = call()
        t1 = time.perf_counter()
        result.tangent
        returns.append(t1 - t0)
        tangents.append(time.perf_counter() - t1)
    plastic = np.mean(result.region > 0)
    print(
        f"{name:30s} {1e6 * statistics.median(returns) / n:8.2f} "
        f"{1e6 * statistics.median(tangents) / n:8.2f} {plastic:8.2f}"
    )
    return result


if __name__ == "__main__":
    main()
