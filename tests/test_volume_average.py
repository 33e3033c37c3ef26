"""Node-based volumetric averaging (``formulation="u-nbva"``, Mast's NB-VA).

The Taylor tests (``test_taylor.py`` and the laws' own) check its tangent, the patch
test (``test_patch.py``) that a uniform deformation comes through untouched, and the
demo tests (``test_demos.py``) that it removes the locking of Mast's cantilever.
Here: what the average does to the points' volumes, and what it refuses.
"""

import numpy as np
import pytest

import fe_mpm
from fe_mpm import scenes
from fe_mpm.formulations import collapse


def _deformed_areas(sim: fe_mpm.Simulation, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Areas of triangles ``cells`` before and after the step's grid displacement (m²)."""
    U, to_parent = collapse(sim.fields.W.sub(0))
    x = U.tabulate_dof_coordinates()[:, :2]
    du = sim.w.x.array[to_parent].reshape(-1, 2)  # blocked: one row per node
    nodes = U.dofmap.list[cells]

    def area(y):
        e, f = y[nodes[:, 1]] - y[nodes[:, 0]], y[nodes[:, 2]] - y[nodes[:, 0]]
        return 0.5 * (e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0])

    return area(x), area(x + du)


def test_the_points_keep_the_grids_volume_and_share_it_over_each_nodes_patch():
    """Cook at ν = 0.499, one step on n = 8 (every cell full). The lumped projection
    keeps the volume, Σ_p V_p θ(x_p) = Σ_p V_p (ΔJ_p − 1): the points' total volume is
    the deformed grid's area to round-off (measured: equal to the last bit). And each
    point's volume change is an average of its cells' ΔJ: a convex combination, so
    within their range, and not its own cell's ΔJ (measured: 1.48e-3 apart at most,
    with cell changes up to 1.48e-3; without averaging 0)."""
    sim = scenes.cook_membrane(n=8, nu=0.499, formulation="u-nbva")
    volume = sim.points.volume.copy()
    sim.run(1.0, 1, progress=False)
    before, after = _deformed_areas(sim, sim.points.cell)
    cell_change = after / before  # ΔJ of each point's cell
    averaged = sim.points.volume / volume  # J̄ at the point
    assert averaged @ volume == pytest.approx(cell_change @ volume, rel=1e-12, abs=0)
    assert cell_change.min() - 1e-12 <= averaged.min()
    assert averaged.max() <= cell_change.max() + 1e-12
    spread = np.abs(cell_change - 1.0).max()
    assert np.abs(averaged - cell_change).max() > 0.3 * spread


def _cook(n: int, steps: int, domains: bool) -> fe_mpm.Simulation:
    sim = scenes.cook_membrane(
        n, 0.499, "u-nbva", traction=5 / 16, load="points", margin=n // 2, point_domains=domains
    )
    sim.initial_volume = sim.points.volume.copy()
    sim.run(1.0, steps, progress=False)
    return sim


def test_point_domains_take_the_average_piece_by_piece_and_converge_over_many_steps():
    """NB-VA with point domains: each piece of a domain is a point of the average, and
    the point keeps its corners' isochoric deformation with its pieces' mean volume
    change. One step, before any point has moved, is NB-VA without domains to round-off
    (the domains are the cells). Cook at 5 N, ν = 0.499, 20 steps, against the converged
    1.3542 (test_domains.py): NB-VA converges from the stiff side (one step: 1.2107 and
    1.2981 on n = 16 and 32), and with domains so do 20 steps (measured 1.2611 and
    1.3189: −6.9 % and −2.6 %, the error falling 2.6-fold), where standard MPM's points
    crossing cells push it past the answer and away from it (1.3310, then 1.4190: +4.8 %).
    The points' volumes stay det F V₀."""
    converged = 1.3542
    one = [scenes.tip_deflection(_cook(8, 1, domains)) for domains in (False, True)]
    assert one[1] == pytest.approx(one[0], rel=1e-10)
    errors = []
    for n in (16, 32):
        sim = _cook(n, 20, True)
        errors.append(scenes.tip_deflection(sim) / converged - 1)
        volume = np.linalg.det(sim.points.F) * sim.initial_volume
        assert np.allclose(sim.points.volume, volume, rtol=1e-12, atol=0)
    assert -0.03 < errors[1] < 0 and abs(errors[0]) > 2 * abs(errors[1])
    assert scenes.tip_deflection(_cook(32, 20, False)) / converged - 1 > 0.04
