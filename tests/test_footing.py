"""The rigid strip footing against the one exact number it has: Prandtl's 2 + π.

On weightless Tresca soil the small-strain collapse load of a rigid strip is
q = (2 + π) c_u, rough (Prandtl) or smooth (Hill). Stiff soil (E/c_u = 3000)
reaches it after a settlement of s/B ≈ 0.01, where the geometry has barely changed,
so the mean q/c_u over s/B = 0.01–0.02 is the collapse load of the grid. The
stresses are singular at the footing's edge: on uniform P1 cells the load comes out
22.6 % high on h = 0.2 B, 12.5 % on h = 0.1 B and 5.1 % on h = 0.05 B
(``benchmarks/footing_prandtl.py``).
Cells of h/4 within 0.4 B of the edge (``edge_size``), as finite element analyses
of this footing refine there, bring h = 0.1 B within 3 %.

Newton: near the edge the Tresca corners make full Newton steps wander once the
residual is small, and the basic line search fails there before the run retries
with backtracking; these runs take backtracking from the start (same loads, half
the time).
"""

import numpy as np
import pytest

from fe_mpm import scenes

PRANDTL = 2 + np.pi
E_OVER_CU = 3000.0


def collapse_load(h: float, smooth: bool = False, E_factor: float = 1.0) -> float:
    """Mean q/(2 + π)c_u over s/B = 0.01–0.02 (20 steps), cells of h/4 at the edge.

    ``E_factor`` scales E, to see how far round-off moves the answer.
    """
    settlement = 0.02
    sim = scenes.strip_footing(
        "up",
        cu=100.0,
        E=100.0 * E_OVER_CU * E_factor,
        nu=0.49,
        h=h,
        h_far=0.2,
        near_depth=1.0,
        points_near=3,
        points_far=1,  # elastic there: the test's time, not its answer (1.0007 against 1.0030)
        settlement=settlement,
        smooth=smooth,
        edge_size=h / 4,
        petsc_options={"snes_linesearch_type": "bt"},
    )
    reports = sim.run(1.0, 20, progress=False)
    s = np.array([settlement * r.t for r in reports])
    q = np.array([scenes.footing_pressure(r) / 100.0 for r in reports]) / PRANDTL
    return float(q[s >= settlement / 2 - 1e-12].mean())


@pytest.mark.slow
def test_rough_footing_reaches_prandtls_load_within_3_percent_and_falls_as_h_halves():
    """Cells of h/4 within 0.4 B of the edge: 1.0559 × (2 + π) on h = 0.2 B and
    1.0007 on h = 0.1 B; 1.0559 and 1.0037 when E moves by 1e-7. Halving h must cut
    the error at least twofold (measured 80-fold)."""
    coarse, fine = collapse_load(0.2), collapse_load(0.1)
    assert 1.0 < coarse < 1.1, coarse
    assert 0.98 < fine < 1.03, fine
    assert abs(fine - 1) < 0.5 * (coarse - 1), (coarse, fine)


@pytest.mark.slow
def test_smooth_footing_reaches_prandtls_load_within_3_percent():
    """Hill's smooth footing, h = 0.1 B with cells of 0.025 B within 0.4 B of the
    edge: 1.0213 × (2 + π); 1.0203 when E moves by 1e-7."""
    q = collapse_load(0.1, smooth=True)
    assert 0.98 < q < 1.03, q
