"""Drucker–Prager (Mast 2013, §3.6) at single points and in an assembled step.

Closed forms (tension positive, Kirchhoff stresses): the cone matched to Mohr-Coulomb's
compression meridian, ϱ_F = √(2/3) 2 sin φ/(3 − sin φ) and κ = √(2/3) 6c cos φ/(3 − sin φ),
gives on a triaxial compression path (τ_xx = τ_yy = −p₀ held) Mohr-Coulomb's limit

    τ_zz = −(k p₀ + 2c√k),   k = (1 + sin φ)/(1 − sin φ),

and on a triaxial extension path (τ_zz = −p₀ held, the lateral pair compressed together)

    τ_xx = τ_yy = (κ + p₀(√(2/3) + ϱ_F))/(2ϱ_F − √(2/3)).

Isotropic tension ends at the apex I₁ = 3c cot φ with no stiffness left (no hardening),
or on the cutoff with the deviator kept (a hardened cone).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from law_checks import assert_step_is_consistent, finite_difference_error
from test_mohr_coulomb import P0, confined_compression, k_of
from test_taylor import _simulation

import fe_mpm
from fe_mpm.material_driver import MaterialDriver, mixed_control
from fe_mpm.materials.cone_return import CAP, CONE, CORNER, CUTOFF, ELASTIC
from fe_mpm.materials.drucker_prager import MAST_TABLE_3_5, cone_slope

SOIL = dict(E=1.0e4, nu=0.3, cohesion=10.0)
SQRT_2_3 = math.sqrt(2.0 / 3.0)


def hardened_law():
    return fe_mpm.DruckerPrager(**SOIL, friction_angle=30.0, dilatancy_angle=10.0, hardening=2e3)


def modified_law():
    return fe_mpm.ModifiedDruckerPrager(E=1.0e4, nu=0.3, **MAST_TABLE_3_5["dense"], apex_stress=1.0)


def region_states(law, g: int, n: int = 400, seed: int = 3):
    """ΔF and history at t_n reaching every region of the cone return.

    A quarter of the points are stretched isotropically with a small shear on a
    hardened state, so that the trial lies beyond the cutoff but inside the hardened
    cone (the cutoff alone); the rest go from elastic to far beyond the cone.
    """
    rng = np.random.default_rng(seed)
    A = np.eye(3) + rng.normal(0, 0.0005, (n, 3, 3))
    if g == 2:
        A[:, 2, :2] = A[:, :2, 2] = 0.0
    name = next(k for k in law.history if k != "be")
    history = {"be": A @ np.swapaxes(A, 1, 2), name: rng.uniform(0.0, 0.02, n)}
    size = rng.uniform(0.0002, 0.006, (n, 1, 1))
    dF = np.eye(g) + size * rng.normal(0, 1, (n, g, g))
    q = n // 4
    history[name][:q] = 0.5
    dF[:q] = (1.0 + rng.uniform(0.002, 0.004, (q, 1, 1))) * np.eye(g)
    dF[:q] += 1e-5 * rng.normal(0, 1, (q, g, g))
    return dF, history


@pytest.mark.parametrize("gdim", [2, 3])
@pytest.mark.parametrize("make", [hardened_law, modified_law], ids=["hardening", "modified"])
def test_tangent_matches_finite_differences_in_every_region(gdim, make):
    law = make()
    dF, history = region_states(law, gdim)
    result = law.return_map(dF, history)
    expected = {ELASTIC, CONE, CUTOFF, CORNER} if make is hardened_law else {ELASTIC, CONE, CORNER}
    assert set(np.unique(result.region)) == expected
    error, same = finite_difference_error(law, dF, history, result.tangent)
    assert same.mean() > 0.95
    assert set(np.unique(result.region[same])) == expected
    assert error[same].max() < 1e-7 * law.E


def test_the_finite_difference_check_can_fail():
    """Negative control: the elastic tangent in place of the consistent one is caught."""
    law = hardened_law()
    dF, history = region_states(law, 3)
    result = law.return_map(dF, history)
    # the elastic tangent of the state at t_n (ΔF = I starts inside the surface)
    wrong = law.return_map(np.tile(np.eye(3), (len(dF), 1, 1)), history).tangent
    error, same = finite_difference_error(law, dF, history, wrong)
    assert error[same & (result.region != ELASTIC)].min() > 1e-3 * law.E


@pytest.mark.parametrize("phi", [30.0, 0.0])
def test_triaxial_compression_reaches_mohr_coulombs_limit(phi):
    law = fe_mpm.DruckerPrager(**SOIL, friction_angle=phi, dilatancy_angle=phi / 3)
    regions, taus, driver = confined_compression(law, 3, held=[0, 1], compressed=[2])
    limit = -(k_of(phi) * P0 + 2 * SOIL["cohesion"] * np.sqrt(k_of(phi)))
    assert regions[0] == ELASTIC and regions[-1] == CONE
    assert abs(taus[-1][2, 2] - limit) < 1e-10 * abs(limit)
    assert np.allclose(taus[-1].diagonal()[:2], -P0, rtol=1e-10)
    assert driver.history["plastic_strain"][0] > 0.0


def test_triaxial_extension_reaches_the_cones_closed_form():
    phi = 30.0
    law = fe_mpm.DruckerPrager(**SOIL, friction_angle=phi, dilatancy_angle=phi / 3)
    regions, taus, _ = confined_compression(law, 3, held=[2], compressed=[0, 1])
    rho = cone_slope(phi)
    s = math.sin(math.radians(phi))
    kappa = SQRT_2_3 * 6 * SOIL["cohesion"] * math.cos(math.radians(phi)) / (3 - s)
    limit = (kappa + P0 * (SQRT_2_3 + rho)) / (2 * rho - SQRT_2_3)
    assert regions[-1] == CONE
    assert abs(taus[-1][0, 0] - limit) < 1e-10 * abs(limit)
    assert abs(taus[-1][1, 1] - limit) < 1e-10 * abs(limit)
    # the outer cone is Mohr-Coulomb's compression corner: stronger in extension
    mohr_coulomb = -(k_of(phi) * P0 + 2 * SOIL["cohesion"] * np.sqrt(k_of(phi)))
    assert limit < mohr_coulomb


def test_yield_onset_is_exact():
    """Pure shear at a fixed confinement: elastic just below the closed-form onset,
    plastic just above. With Hencky strains ε = (γ, −γ, 0) + ε_v/3 (1, 1, 1),
    ‖s‖ = 2G√2 γ and the cone is met at 2G√2 γ + ϱ_F 3K ε_v = κ."""
    law = fe_mpm.DruckerPrager(**SOIL, friction_angle=25.0, dilatancy_angle=5.0)
    G, K = law.mu, law.bulk_modulus
    ev = -0.002
    s = math.sin(math.radians(25.0))
    kappa = SQRT_2_3 * 6 * SOIL["cohesion"] * math.cos(math.radians(25.0)) / (3 - s)
    onset = (kappa - cone_slope(25.0) * 3 * K * ev) / (2 * G * math.sqrt(2))
    factors = np.array([1 - 1e-9, 1 + 1e-9])
    gammas = onset * factors
    stretch = np.exp(np.stack([gammas + ev / 3, -gammas + ev / 3, np.full(2, ev / 3)], axis=1))
    dF = np.stack([np.diag(v) for v in stretch])
    history = {"be": np.tile(np.eye(3), (2, 1, 1)), "plastic_strain": np.zeros(2)}
    result = law.return_map(dF, history)
    assert result.region.tolist() == [ELASTIC, CONE]


@pytest.mark.parametrize("make", [hardened_law, modified_law], ids=["hardening", "modified"])
def test_returned_stresses_satisfy_the_kkt_conditions_and_the_flow_rule(make):
    """F₁ ≤ 0 and F₂ ≤ 0 everywhere, = 0 on the active surfaces, Δγ ≥ 0, and the
    plastic strain ε^tr − εᵉ (principal, coaxial) is Δγ₁(n + ϱ_G 1) + Δγ₂ 1."""
    law = make()
    dF, history = region_states(law, 3, n=2000, seed=7)
    result = law.return_map(dF, history)
    name = next(k for k in law.history if k != "be")
    # the angles are those of t_n; the hardening that of t_{n+1}
    after = dict(history, **({name: result.history[name]} if make is hardened_law else {}))
    F1, F2 = law.yield_functions(result.tau, after)
    scale = np.abs(result.tau).max()
    region = result.region
    assert F1.max() < 1e-12 * scale and F2.max() < 1e-12 * scale
    assert np.abs(F1[(region == CONE) | (region == CORNER)]).max() < 1e-12 * scale
    assert np.abs(F2[(region == CUTOFF) | (region == CORNER)]).max() < 1e-12 * scale
    assert np.all(F1[region == ELASTIC] <= 1e-12 * scale)
    increment = result.history[name] - history[name]
    dgamma1 = increment / SQRT_2_3 if make is hardened_law else increment
    assert np.all(dgamma1 >= 0.0)
    assert np.all(dgamma1[(region == ELASTIC) | (region == CUTOFF)] == 0.0)
    # principal trial and elastic strains; the cone's flow n + ϱ_G 1
    F3 = np.tile(np.eye(3), (len(dF), 1, 1))
    F3[:, :3, :3] = dF
    trial = 0.5 * np.log(np.linalg.eigvalsh(F3 @ history["be"] @ np.swapaxes(F3, 1, 2)))
    elastic = 0.5 * np.log(np.linalg.eigvalsh(result.history["be"]))
    plastic = trial - elastic
    deviatoric = plastic - plastic.mean(axis=1, keepdims=True)
    assert np.allclose(np.linalg.norm(deviatoric, axis=1), dgamma1, rtol=0, atol=1e-12)
    rho_F, rho_G, *_ = law._cone_parameters(history)
    rho_G = np.broadcast_to(rho_G, dgamma1.shape)
    dgamma2 = (plastic.sum(axis=1) - 3 * rho_G * dgamma1) / 3
    assert np.all(dgamma2 >= -1e-14)
    assert np.all(np.abs(dgamma2[(region == ELASTIC) | (region == CONE)]) < 1e-14)
    assert np.all(dgamma2[region == CUTOFF] > 1e-6)


def test_isotropic_tension_ends_at_the_apex_or_on_the_cutoff():
    """No hardening: the apex (the corner), τ = c cot φ 1, no stiffness. A hardened
    cone: the cutoff, I₁ = 3c cot φ with the trial deviator kept."""
    phi = 30.0
    apex = SOIL["cohesion"] / math.tan(math.radians(phi))
    law = fe_mpm.DruckerPrager(**SOIL, friction_angle=phi, dilatancy_angle=phi)
    driver = MaterialDriver(law, n=3, gdim=3)
    F = np.array([(1 + e) * np.eye(3) for e in (1e-4, 1e-3, 1e-2)])
    result = driver.evaluate(F)
    assert result["region"].tolist() == [ELASTIC, CORNER, CORNER]
    assert np.allclose(result["tau"][1:], apex * np.eye(3), rtol=1e-13, atol=0)
    assert np.abs(result["tangent"][1:]).max() < 1e-9 * law.E
    hardened = hardened_law()
    dF = np.diag([1.003, 1.0031, 1.0029])[None]
    history = {"be": np.eye(3)[None], "plastic_strain": np.array([0.5])}
    result = hardened.return_map(dF, history)
    trial = 0.5 * np.log(np.diag(dF[0]) ** 2)
    deviator = 2 * hardened.mu * (trial - trial.mean())
    assert result.region.tolist() == [CUTOFF]
    tau = np.diag(result.tau[0])
    assert np.isclose(tau.sum(), hardened.apex, rtol=1e-12)
    assert np.allclose(tau - tau.mean(), deviator, rtol=1e-10)


def test_modified_angles_follow_masts_equations():
    """Eqs. 3.112–3.114 at a few (I₁, λ), and the state of t_n sets a step's cone."""
    law = modified_law()
    a = MAST_TABLE_3_5["dense"]
    I1 = np.array([-450e3, -450e3, -4.5e6, 0.0])
    lam = np.array([0.0, 0.0092, 0.02, 0.5])
    phi_F, phi_cs, psi = law.angles(I1, lam)
    expected_F = a["a0"] + (a["a1"] * lam - a["a4"]) * np.exp(a["a2"] * I1 - a["a3"] * lam)
    expected_cs = a["a0"] - a["a4"] * np.exp(-a["a5"] * lam)
    assert np.allclose(phi_F, expected_F, rtol=1e-14) and np.allclose(phi_cs, expected_cs)
    tan = np.tan(np.radians(psi))
    assert np.allclose(tan, np.tan(np.radians(phi_F)) - np.tan(np.radians(phi_cs)), rtol=1e-12)
    assert phi_F[0] == pytest.approx(20 - 20 * math.exp(-0.15), rel=1e-3)  # ≈ 2.8°, Mast §3.8
    # a cone from another state: the return lands on the cone of t_n
    dF, history = region_states(law, 3, n=200, seed=11)
    result = law.return_map(dF, history)
    F1, _ = law.yield_functions(result.tau, history)
    on_cone = result.region == CONE
    assert on_cone.sum() > 20
    assert np.abs(F1[on_cone]).max() < 1e-12 * np.abs(result.tau).max()
    moved = dict(history, plastic_shear=history["plastic_shear"] + 0.01)
    F1_moved, _ = law.yield_functions(result.tau, moved)
    assert np.abs(F1_moved[on_cone]).min() > 1e-6 * np.abs(result.tau).max()


@pytest.mark.parametrize(
    "formulation, law, regions_seen",
    [
        ("u", fe_mpm.DruckerPrager(10.0, 0.3, 0.05, 30.0, 10.0, hardening=2.0), 3),
        ("up", fe_mpm.DruckerPrager(10.0, 0.3, 0.5, hardening=2.0), 2),
        (
            "u",
            fe_mpm.ModifiedDruckerPrager(10.0, 0.3, **MAST_TABLE_3_5["dense"], apex_stress=0.05),
            3,
        ),
        ("u-nbva", fe_mpm.DruckerPrager(10.0, 0.3, 0.05, 30.0, 10.0, hardening=2.0), 3),
    ],
    ids=["dp-u", "von-mises-up", "modified-u", "dp-u-nbva"],
)
@pytest.mark.parametrize("dim", [2, 3])
def test_step_residual_and_jacobian_are_consistent(dim, formulation, law, regions_seen):
    """Taylor test of an assembled step with points in several return regions,
    ε small enough that no point changes region (asserted).

    The modified law's points start at λ = 0.01 (φ_F ≈ 33°): at λ = 0 and these
    stresses (≈ 1 Pa, against Table 3.5's kPa) its cone has no width, and every
    point sits on the boundary between the cone and the apex.
    """
    rng, sim = _simulation(dim, formulation, material=law)
    if "plastic_shear" in sim.points.history:
        sim.points.history["plastic_shear"][:] = 0.01
    assert_step_is_consistent(sim, rng, regions_seen)


def test_mixed_formulation_refuses_the_smooth_cap():
    """The cap's mean stress has no inverse at its top: u only (the cones run in u-p,
    ``tests/test_frictional_up.py``)."""
    law = fe_mpm.SmoothCapDruckerPrager(1e4, 0.3, 30.0, 1.0)
    with pytest.raises(ValueError, match="SmoothCapDruckerPrager: the u-p formulations"):
        law.check_formulation(pressure=True)
    law.check_formulation(pressure=False)


@pytest.mark.parametrize(
    "bad, match",
    [
        (dict(friction_angle=90.0), r"DruckerPrager: friction_angle must lie in \[0, 90\)"),
        (dict(friction_angle=-1.0), r"DruckerPrager: friction_angle must lie in \[0, 90\)"),
        (dict(dilatancy_angle=31.0), r"DruckerPrager: dilatancy_angle must lie in \[0, 30\]"),
        (dict(cohesion=-1.0), r"DruckerPrager: cohesion must lie in \[0, inf\)"),
        (dict(hardening=-1.0), r"DruckerPrager: hardening must lie in \[0, inf\)"),
        (dict(friction_angle=0.0, dilatancy_angle=0.0, cohesion=0.0), "cohesion must be > 0"),
    ],
)
def test_bad_drucker_prager_parameters_are_named(bad, match):
    base = dict(E=1e4, nu=0.3, cohesion=10.0, friction_angle=30.0)
    with pytest.raises(ValueError, match=match):
        fe_mpm.DruckerPrager(**{**base, **bad})


@pytest.mark.parametrize(
    "bad, match",
    [
        (dict(a4=25.0), r"ModifiedDruckerPrager: a0 must lie in \[25, 90\)"),
        (dict(a0=95.0), r"ModifiedDruckerPrager: a0 must lie in \[20, 90\)"),
        (dict(a3=0.0), "a3 must be > 0 when a1 > 0"),
        (dict(a1=-1.0), r"ModifiedDruckerPrager: a1 must lie in \[0, inf\)"),
        (dict(a5=-1.0), r"ModifiedDruckerPrager: a5 must lie in \[0, inf\)"),
        (dict(a1=1e6), "must stay below 90°"),
        (dict(apex_stress=-1.0), r"apex_stress must lie in \[0, inf\)"),
    ],
)
def test_bad_modified_parameters_are_named(bad, match):
    base = dict(E=1e4, nu=0.3, **MAST_TABLE_3_5["dense"])
    with pytest.raises(ValueError, match=match):
        fe_mpm.ModifiedDruckerPrager(**{**base, **bad})


def test_a_cone_of_no_width_keeps_a_compressed_point_on_its_axis():
    """Mast's loose sand at λ = 0 (a₂ = 0) has φ_F = 0 and its apex at the origin: a
    line, the hydrostatic axis. A compressive trial with a deviator returns onto the
    axis (τ = I₁/3 1, compressive), never to the apex τ = 0, however small the deviator
    (once found by a driver: round-off sent it to the apex, and Newton diverged)."""
    law = fe_mpm.ModifiedDruckerPrager(75e6, 0.33, **MAST_TABLE_3_5["loose"])
    n = 4
    shear = np.array([0.0, 1e-19, 1e-12, 1e-4])
    dF = np.tile(np.diag([0.999, 0.999, 0.999]), (n, 1, 1))
    dF[:, 0, 1] = shear
    history = {"be": np.tile(np.eye(3), (n, 1, 1)), "plastic_shear": np.zeros(n)}
    result = law.return_map(dF, history)
    mean = np.trace(result.tau, axis1=1, axis2=2) / 3.0
    expected = law.bulk_modulus * 3 * math.log(0.999)
    assert np.allclose(mean, expected, rtol=1e-6)
    deviator = result.tau - mean[:, None, None] * np.eye(3)
    assert np.abs(deviator).max() < 1e-9 * abs(expected)
    assert np.all(result.region[2:] == CONE)  # 1e-19 is lost in b = F Fᵀ: elastic


@pytest.mark.parametrize("phi", [30.0, 0.0])
def test_plane_strain_match_reaches_mohr_coulombs_plane_strain_limit(phi):
    """Associated flow in plane strain: once flowing at a steady stress, ε_zz = 0 holds
    the stress on the cone where it touches Mohr-Coulomb's plane-strain limit, so
    σ_yy = −(k p₀ + 2c√k) with σ_xx = −p₀ held (Tresca's −(p₀ + 2c) at φ = 0)."""
    law = fe_mpm.DruckerPrager(
        **SOIL, friction_angle=phi, dilatancy_angle=phi, match="plane strain"
    )
    regions, taus, _ = confined_compression(law, 2, held=[0], compressed=[1], strain=0.1)
    limit = -(k_of(phi) * P0 + 2 * SOIL["cohesion"] * np.sqrt(k_of(phi)))
    assert regions[-1] == CONE
    assert abs(taus[-1][1, 1] - limit) < 1e-10 * abs(limit)
    # the outer cone (the default) is stronger in plane strain
    outer = fe_mpm.DruckerPrager(**SOIL, friction_angle=phi, dilatancy_angle=phi)
    _, outer_taus, _ = confined_compression(outer, 2, held=[0], compressed=[1], strain=0.1)
    assert outer_taus[-1][1, 1] < 1.05 * limit


def test_an_unknown_match_is_named():
    with pytest.raises(ValueError, match="DruckerPrager: match must be one of 'compression'"):
        fe_mpm.DruckerPrager(**SOIL, friction_angle=30.0, match="plane-strain")


def cap_law(associativity=1.0):
    return fe_mpm.SmoothCapDruckerPrager(
        1.0e4, 0.3, 30.0, deviatoric_strength=10.0, associativity=associativity
    )


def cap_states(g, n=1500, seed=0):
    """From elastic to far beyond the cone, a third stretched toward the cap."""
    rng = np.random.default_rng(seed)
    dF = np.eye(g) + rng.uniform(0.0002, 0.004, (n, 1, 1)) * rng.normal(size=(n, g, g))
    dF[: n // 3] += rng.uniform(0.0, 0.004, (n // 3, 1, 1)) * np.eye(g)
    A = np.eye(3) + 0.0005 * rng.normal(size=(n, 3, 3))
    if g == 2:
        A[:, 2, :2] = A[:, :2, 2] = 0.0
    return dF, {"be": A @ np.swapaxes(A, 1, 2), "plastic_strain": np.zeros(n)}


@pytest.mark.parametrize("gdim", [2, 3])
@pytest.mark.parametrize("associativity", [1.0, 0.3])
def test_smooth_cap_tangent_and_surfaces_in_every_region(gdim, associativity):
    """Cone, cap and (non-associated flow only) the rim where they meet: the tangent
    against finite differences, the stress on its surface, inside where elastic."""
    law = cap_law(associativity)
    dF, history = cap_states(gdim)
    result = law.return_map(dF, history)
    expected = {ELASTIC, CONE, CAP} | ({CORNER} if associativity < 1.0 else set())
    assert set(np.unique(result.region)) == expected
    error, same = finite_difference_error(law, dF, history, result.tangent)
    assert same.mean() > 0.95 and set(np.unique(result.region[same])) == expected
    assert error[same].max() < 1e-7 * law.E
    F, I1 = law.yield_functions(result.tau, history)
    scale = np.abs(result.tau).max()
    assert np.abs(F[result.region != ELASTIC]).max() < 1e-12 * scale
    assert F.max() < 1e-12 * scale
    R, I_t, _ = law.cap
    assert np.all(I1[result.region == CAP] >= I_t * (1 - 1e-12))
    assert np.all(I1[result.region == CONE] <= I_t * (1 + 1e-12))
    assert np.allclose(I1[result.region == CORNER], I_t, rtol=1e-12)


def test_smooth_cap_closed_forms():
    """Isotropic tension ends on the cap's axis point I₁ = R_t = μ/√(1 + ϱ_F²); triaxial
    compression on the cone, Mohr-Coulomb's limit for the c with κ = μ (Eq. 3.107)."""
    law = cap_law()
    rho = cone_slope(30.0)
    R, I_t, s_t = law.cap
    assert R == pytest.approx(10.0 / math.sqrt(1 + rho**2), rel=1e-15)
    assert I_t**2 + s_t**2 == pytest.approx(R**2, rel=1e-14)
    dF = (1.0 + np.array([1e-4, 1e-3, 1e-2]))[:, None, None] * np.eye(3)
    history = {"be": np.tile(np.eye(3), (3, 1, 1)), "plastic_strain": np.zeros(3)}
    result = law.return_map(dF, history)
    assert result.region[1:].tolist() == [CAP, CAP]
    assert np.allclose(result.tau[1:], R / 3 * np.eye(3), rtol=1e-13, atol=0)
    s = math.sin(math.radians(30.0))
    cohesion = 10.0 * (3 - s) / (SQRT_2_3 * 6 * math.cos(math.radians(30.0)))
    regions, taus, _ = confined_compression(law, 3, held=[0, 1], compressed=[2])
    limit = -(k_of(30.0) * P0 + 2 * cohesion * np.sqrt(k_of(30.0)))
    assert regions[-1] == CONE and abs(taus[-1][2, 2] - limit) < 1e-10 * abs(limit)


@pytest.mark.parametrize("formulation", ["u", "u-nbva"])
@pytest.mark.parametrize("dim", [2, 3])
def test_smooth_cap_step_residual_and_jacobian_are_consistent(dim, formulation):
    """In u and with volumetric averaging, the law's own return (u-p refuses the cap)."""
    law = fe_mpm.SmoothCapDruckerPrager(10.0, 0.3, 30.0, 0.05, associativity=0.5)
    rng, sim = _simulation(dim, formulation, material=law)
    assert_step_is_consistent(sim, rng, 2)


@pytest.mark.parametrize(
    "bad, match",
    [
        (dict(friction_angle=0.0), r"friction_angle must lie in \(0, 90\)"),
        (dict(deviatoric_strength=0.0), r"deviatoric_strength must lie in \(0, inf\)"),
        (dict(associativity=1.5), r"associativity must lie in \[0, 1\]"),
    ],
)
def test_bad_smooth_cap_parameters_are_named(bad, match):
    base = dict(E=1e4, nu=0.3, friction_angle=30.0, deviatoric_strength=10.0)
    with pytest.raises(ValueError, match="SmoothCapDruckerPrager: " + match):
        fe_mpm.SmoothCapDruckerPrager(**{**base, **bad})


def test_mixed_control_names_a_wrong_stress_measure_or_count():
    driver = MaterialDriver(hardened_law(), n=1, gdim=3)
    with pytest.raises(ValueError, match="measure must be 'cauchy' or 'kirchhoff', got 'pk2'"):
        mixed_control(driver, np.eye(3), [(0, 0)], {(0, 0): -1.0}, measure="pk2")
    with pytest.raises(ValueError, match="as many held stresses as free entries"):
        mixed_control(driver, np.eye(3), [(0, 0), (1, 1)], {(0, 0): -1.0})
