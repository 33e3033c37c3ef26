"""Mixed u-p form on Cook's membrane: Kratos/thesis columns, locking, pressure quality,
convergence, unstructured meshes (issue: mixed u-p with PPP)."""

from functools import cache

import numpy as np
import pytest
from newton_rates import quadratic

from fe_mpm import scenes
from fe_mpm.diagnostics import pressure_oscillation
from fe_mpm.references import (
    COOK_FINE_FEM_0499,
    COOK_FINITE_STRAIN_LIMIT,
    COOK_KRATOS_UP_PPP,
    COOK_THESIS_UP_NOSTAB,
)

TOL = 0.005
#: ν = 0.4999 limit of the small-strain Taylor–Hood FEM (0.2768 at n = 64, still rising).
COOK_LIMIT_04999 = 0.277


@cache
def cook(n, nu, formulation, structured=True, h=None, per_cell=1):
    sim = scenes.cook_membrane(n, nu, formulation, structured=structured, h=h, per_cell=per_cell)
    (report,) = sim.run(progress=False)
    return sim, scenes.tip_deflection(sim), report


@pytest.mark.parametrize("nu", [0.33, 0.499])
@pytest.mark.parametrize("n", [8, 16, 32])
def test_ppp_matches_kratos_up_column(n, nu):
    _, u_y, report = cook(n, nu, "up")
    reference = COOK_KRATOS_UP_PPP[nu][n]
    assert abs(u_y / reference - 1) < TOL, f"u_A,y = {u_y:.5f}, Kratos {reference}"
    assert report.newton_iterations <= 4 and quadratic(report.residual_norms)


@pytest.mark.parametrize("n", [8, 16, 32])
def test_unstabilised_matches_thesis_compressible_column(n):
    _, u_y, report = cook(n, 0.33, "up-nostab")
    reference = COOK_THESIS_UP_NOSTAB[0.33][n]
    assert abs(u_y / reference - 1) < TOL, f"u_A,y = {u_y:.5f}, thesis {reference}"
    assert report.newton_iterations <= 4


def test_u_locks_and_up_does_not_near_incompressibility():
    nu = 0.4999
    u_form = [cook(n, nu, "u")[1] for n in (8, 16, 32)]
    mixed = [cook(n, nu, "up")[1] for n in (8, 16, 32)]
    assert max(u_form) < 0.35 * COOK_LIMIT_04999  # measured 0.081 at n = 32
    assert abs(mixed[-1] / COOK_LIMIT_04999 - 1) < 0.02  # measured 0.2717 (-1.9 %)


def test_up_converges_monotonically_to_the_incompressible_limit():
    tips = [cook(n, 0.4999, "up")[1] for n in (4, 8, 16, 32)]
    errors = np.abs(COOK_LIMIT_04999 - np.array(tips))
    assert np.all(np.diff(errors) < 0), f"tips {tips}"
    # Each refinement more than halves the error (measured ratios 0.42, 0.37, 0.40).
    assert np.all(errors[1:] / errors[:-1] < 0.5)


@pytest.mark.parametrize("nu", [0.33, 0.499])
def test_ppp_removes_the_pressure_checkerboard(nu):
    unstabilised = pressure_oscillation(cook(16, nu, "up-nostab")[0])
    stabilised = pressure_oscillation(cook(16, nu, "up")[0])
    finer = pressure_oscillation(cook(32, nu, "up")[0])
    assert unstabilised > 0.5  # measured 0.67: neighbours jump across the whole range
    assert stabilised < 0.1  # measured 0.05
    assert finer < 0.6 * stabilised  # smooth: the jumps shrink with h (measured 0.027)


def test_unstructured_mesh_agrees_within_the_discretisation_error():
    """Unstructured h = 44/32 against structured n = 32: their difference is below the
    change of the structured answer from n = 16 to 32 (a first-order error estimate),
    and both lie within 2.5 % of the fine FEM value."""
    structured = {n: cook(n, 0.499, "up")[1] for n in (16, 32)}
    unstructured = cook(32, 0.499, "up", structured=False, h=44 / 32)[1]
    assert abs(unstructured - structured[32]) < abs(structured[32] - structured[16])
    for tip in (unstructured, structured[32]):
        assert abs(tip / COOK_FINE_FEM_0499 - 1) < 0.025


def test_pressure_projection_and_interpolation():
    """Eq. 5.21: the particle pressure is the grid pressure at the particle. Eq. 5.20:
    the mass-weighted projection back to the nodes reproduces a constant exactly."""
    sim, _, _ = cook.__wrapped__(8, 0.499, "up")  # its own: the test changes the grid fields
    pts = sim.points
    Q = sim.fields.Q[0]
    nodal = sim.fields.pressure_values()
    # One step from the initial state: the pressure was evaluated where the points were, x0.
    cells = sim.tracker.locate(pts.x0)
    at_points = np.sum(sim.tracker.barycentric(pts.x0, cells) * nodal[Q.dofmap.list[cells]], axis=1)
    p_points = -np.trace(pts.stress, axis1=1, axis2=2) / 3.0
    assert np.allclose(p_points, at_points, rtol=1e-10, atol=1e-12 * np.abs(nodal).max())

    saved = pts.stress.copy()
    try:
        pts.stress = np.tile(-7.5 * np.eye(3), (len(pts), 1, 1))
        layout = sim._track(step=99, t=9.0)
        bary = sim.tracker.barycentric(pts.x, layout.cell)
        sim.fields.start_from_rest(layout.cell, bary, pts.mass, pts.stress)
        assert np.allclose(sim.fields.pressure_values(), 7.5, rtol=1e-13)
    finally:
        pts.stress = saved


@pytest.mark.parametrize("nu", [0.33, 0.499])
def test_taylor_hood_needs_no_stabilisation_and_beats_p1p1(nu):
    """P2/P1 with 3 points per triangle: a smooth pressure without PPP (the same bound as
    for PPP, and the jumps shrink with h), and on an 8 x 8 grid it is closer to the limit
    than P1/P1+PPP on 16 x 16 (similar wall time, 0.03 s each; see
    benchmarks/cook_pareto.py)."""
    sim, tip_p2p1, report = cook(8, nu, "up-p2p1", per_cell=3)
    _, tip_p1p1, _ = cook(16, nu, "up")
    limit = COOK_FINITE_STRAIN_LIMIT[nu]
    smooth = pressure_oscillation(cook(16, nu, "up-p2p1", per_cell=3)[0])
    assert smooth < 0.1  # measured 0.06; the checkerboard gives 0.67
    assert pressure_oscillation(cook(32, nu, "up-p2p1", per_cell=3)[0]) < 0.6 * smooth
    assert abs(tip_p2p1 - limit) < 0.6 * abs(tip_p1p1 - limit)  # measured ratio 0.24 / 0.54
    assert report.newton_iterations <= 4 and quadratic(report.residual_norms)


def test_splitting_cells_into_entities_changes_nothing(monkeypatch):
    """Cook u-p (PPP), 6 points per triangle, with one entity per cell and with cells
    split into three entities of 2 slots: PPP is a cell term, so it must count each
    cell once however many copies the cell has (its fill is packed on the first copy
    only). The answers agree to round-off."""
    import fe_mpm.tracking

    tips = {}
    for nslot in (6, 2):
        monkeypatch.setattr(fe_mpm.tracking, "slot_count", lambda counts, current, comm, n=nslot: n)
        sim = scenes.cook_membrane(8, 0.499, "up", per_cell=6)  # not cook(): it is cached
        (report,) = sim.run(progress=False)
        assert report.nslot == nslot
        tips[nslot] = scenes.tip_deflection(sim)
    assert abs(tips[2] / tips[6] - 1) < 1e-12, tips


def test_ppp_against_a_soft_bodys_weight_warns():
    """A soft Neo-Hookean "water" (G = 1 kPa) 1 m deep on cells of 0.1 m under gravity:
    ρ g h / G ≈ 1, and PPP, which resists a linear pressure in proportion to 1/G, put
    its side thrust 60 % off ρ g H²/2 with every step converged (a helper's tank,
    2026-12-06). Set-up warns; without PPP, or with a stiff body, it does not."""
    import warnings

    import fe_mpm
    from fe_mpm.meshes import cell_centroids, rectangle_mesh

    mesh = rectangle_mesh((0.0, 0.0), (2.0, 1.0), (20, 10))
    points = fe_mpm.seed(mesh, 3, density=1000.0)
    soft = fe_mpm.NeoHookean(3e3, 0.4998)  # G = 1000 Pa, K = 2.5 MPa
    base = [fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))]
    with pytest.warns(UserWarning, match=r"ρ \|b\| h / G = 1\.\d+ .*ppp_alpha=0 or .*u-nbva"):
        fe_mpm.Simulation(mesh, points, soft, "up", dirichlet=base, body_force=(0.0, -9.81))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fe_mpm.Simulation(
            mesh, points, soft, "up", dirichlet=base, body_force=(0.0, -9.81), ppp_alpha=0.0
        )
        stiff = fe_mpm.NeoHookean(3e6, 0.3)
        fe_mpm.Simulation(mesh, points, stiff, "up", dirichlet=base, body_force=(0.0, -9.81))
        # Zone by zone: a light soft layer on a dense stiff base is no soft dense body
        # (ρ = 7850 with the gel's G gave 11, warned until 2026-12-08).
        c = cell_centroids(mesh)
        top = np.flatnonzero(c[:, 1] > 0.5)
        gel = fe_mpm.seed(mesh, 3, density=10.0, cells=top)
        steel = fe_mpm.seed(mesh, 3, density=7850.0, cells=np.flatnonzero(c[:, 1] < 0.5))
        steel.material[:] = 1
        laws = [soft, fe_mpm.NeoHookean(200e9, 0.3)]
        layered = fe_mpm.merge(gel, steel)
        fe_mpm.Simulation(mesh, layered, laws, "up", dirichlet=base, body_force=(0.0, -9.81))
    dense_gel = fe_mpm.merge(fe_mpm.seed(mesh, 3, density=1000.0, cells=top), steel)
    with pytest.warns(UserWarning, match=r"h / G = 1\.\d+ of the shear modulus \(ρ = 1000 kg"):
        fe_mpm.Simulation(mesh, dense_gel, laws, "up", dirichlet=base, body_force=(0.0, -9.81))
