"""Matsuoka–Nakai (Mast 2013, §3.7) at single points, on Mast's paths, in an assembled step.

Closed forms (tension positive, Kirchhoff stresses, no cohesion): the Matsuoka–Nakai
cone passes through all six corners of Mohr-Coulomb's, so on a triaxial compression
path (τ_xx = τ_yy = −p₀ held) and on a triaxial extension path (τ_zz = −p₀ held, the
lateral pair compressed together) the major stress ends at Mohr-Coulomb's

    τ_major = −k p₀,   k = (1 + sin φ)/(1 − sin φ).

With the angles held constant (a₄ = 0: φ_F = φ_cs = a₀, ψ_G = 0) the flow is
isochoric with either potential.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from law_checks import assert_step_is_consistent, finite_difference_error
from test_drucker_prager import region_states
from test_mohr_coulomb import P0, confined_compression, k_of
from test_taylor import _simulation

import fe_mpm
from fe_mpm.material_driver import MaterialDriver, mixed_control
from fe_mpm.materials.cone_return import CONE, CORNER, ELASTIC
from fe_mpm.materials.drucker_prager import MAST_TABLE_3_5

POTENTIALS = ("drucker-prager", "matsuoka-nakai")


def law(potential, E=1.0e4, sand="dense", apex_stress=1.0):
    return fe_mpm.MatsuokaNakai(
        E, 0.3, **MAST_TABLE_3_5[sand], apex_stress=apex_stress, potential=potential
    )


def constant_angle(potential, phi=30.0):
    """φ_F = φ_cs = φ at every λ (a₄ = 0), so ψ_G = 0; no cohesion."""
    return fe_mpm.MatsuokaNakai(
        1.0e4, 0.3, a0=phi, a1=0.0, a2=0.0, a3=0.0, a4=0.0, a5=0.0, potential=potential
    )


def mobilised_states(law, g, n=600, seed=5):
    """region_states with λ ≥ 0.005 (φ_F ≈ 26–33°): at λ = 0 and these stresses the
    dense sand's cone has no width."""
    dF, history = region_states(law, g, n=n, seed=seed)
    history["plastic_shear"] = np.maximum(history["plastic_shear"], 0.005)
    return dF, history


@pytest.mark.parametrize("gdim", [2, 3])
@pytest.mark.parametrize("potential", POTENTIALS)
def test_tangent_matches_finite_differences_in_every_region(gdim, potential):
    mn = law(potential)
    dF, history = mobilised_states(mn, gdim)
    result = mn.return_map(dF, history)
    assert set(np.unique(result.region)) == {ELASTIC, CONE, CORNER}
    error, same = finite_difference_error(mn, dF, history, result.tangent)
    assert same.mean() > 0.95
    assert set(np.unique(result.region[same])) == {ELASTIC, CONE, CORNER}
    assert error[same].max() < 1e-7 * mn.E


@pytest.mark.parametrize("potential", POTENTIALS)
def test_returned_stresses_lie_on_the_cone_inside_the_octant(potential):
    mn = law(potential)
    dF, history = mobilised_states(mn, 3, n=2000, seed=9)
    result = mn.return_map(dF, history)
    F, I1 = mn.yield_functions(result.tau, history)
    scale = np.abs(result.tau).max()
    region = result.region
    # Each point to its own size: near the apex a returned stress is far below the
    # trial, and τ = τ^tr − Δγ a g cancels the trial's digits (F ∝ own² × trial's size).
    own = np.linalg.norm(result.tau - mn.apex_stress * np.eye(3), axis=(1, 2))
    strain = 0.5 * np.log(np.linalg.eigvalsh(dF @ history["be"] @ np.swapaxes(dF, 1, 2)))
    volume = strain.sum(axis=1, keepdims=True)
    trial = mn.bulk_modulus * volume + 2 * mn.mu * (strain - volume / 3) - mn.apex_stress
    size = own**2 * (own + np.linalg.norm(trial, axis=1))
    assert np.abs(F[region == CONE] / size[region == CONE]).max() < 1e-13
    assert F[region == ELASTIC].max() <= 1e-12 * scale**3
    shifted = np.linalg.eigvalsh(result.tau) - mn.apex_stress
    assert shifted.max() < 1e-12 * scale  # the cone lies in the negative octant of τ − c_F 1
    assert np.allclose(shifted[region == CORNER], 0.0, atol=1e-12 * scale)
    increment = result.history["plastic_shear"] - history["plastic_shear"]
    assert np.all(increment[region != ELASTIC] > 0.0) and np.all(increment[region == ELASTIC] == 0)


@pytest.mark.parametrize("potential", POTENTIALS)
@pytest.mark.parametrize("path", ["triaxial compression", "triaxial extension"])
def test_triaxial_paths_end_at_mohr_coulombs_corners(path, potential):
    mn = constant_angle(potential)
    limit = -k_of(30.0) * P0
    if path == "triaxial compression":
        regions, taus, _ = confined_compression(mn, 3, held=[0, 1], compressed=[2])
        major = taus[-1][2, 2]
    else:
        regions, taus, _ = confined_compression(mn, 3, held=[2], compressed=[0, 1])
        major = taus[-1][0, 0]
    assert regions[0] == ELASTIC and regions[-1] == CONE
    assert abs(major - limit) < 1e-9 * abs(limit)


@pytest.mark.parametrize("potential", POTENTIALS)
def test_flow_without_dilatancy_keeps_the_volume(potential):
    """ψ_G = 0: the plastic strain ε^tr − εᵉ (principal) has no trace. For the
    Matsuoka–Nakai potential this holds because it is attached at the stress (the
    thesis's §3.7): its normal tends to the deviator as ψ_G → 0. With ψ_G > 0 the
    volume grows."""
    rng = np.random.default_rng(2)
    n = 1000
    dF = np.eye(3) + rng.uniform(0.002, 0.01, (n, 1, 1)) * rng.normal(size=(n, 3, 3))
    dF -= 0.01 * np.eye(3)  # confined: away from the apex
    for mn, expect_dilation in ((constant_angle(potential), False), (law(potential), True)):
        history = {"be": np.tile(np.eye(3), (n, 1, 1)), "plastic_shear": np.full(n, 0.01)}
        result = mn.return_map(dF, history)
        on_cone = result.region == CONE
        assert on_cone.sum() > 50
        trial = 0.5 * np.log(np.linalg.eigvalsh(dF @ np.swapaxes(dF, 1, 2)))
        elastic = 0.5 * np.log(np.linalg.eigvalsh(result.history["be"]))
        volume = (trial - elastic).sum(axis=1)[on_cone]
        if expect_dilation:
            _, psi = mn.state_angles(history)
            assert np.all(volume[psi[on_cone] > 1.0] > 0.0)
        else:
            assert np.abs(volume).max() < 1e-13


def test_the_drucker_prager_potential_follows_n_plus_rho_g():
    """MN with DP G: the plastic strain is Δλ (n + ϱ_G 1), n the trial deviator's direction."""
    from fe_mpm.materials.drucker_prager import cone_slope

    mn = law("drucker-prager")
    dF, history = mobilised_states(mn, 3, n=500, seed=4)
    result = mn.return_map(dF, history)
    on_cone = result.region == CONE
    trial = 0.5 * np.log(np.linalg.eigvalsh(dF @ history["be"] @ np.swapaxes(dF, 1, 2)))
    elastic = 0.5 * np.log(np.linalg.eigvalsh(result.history["be"]))
    plastic = (trial - elastic)[on_cone]
    dlam = (result.history["plastic_shear"] - history["plastic_shear"])[on_cone]
    deviator = trial[on_cone] - trial[on_cone].mean(axis=1, keepdims=True)
    n = deviator / np.linalg.norm(deviator, axis=1, keepdims=True)
    _, psi = mn.state_angles({k: v[on_cone] for k, v in history.items()})
    expected = dlam[:, None] * (n + cone_slope(psi)[:, None])
    assert np.abs(plastic - expected).max() < 1e-12


def _biaxial(material, steps=100, strain=0.3):
    """Mast's biaxial path: ε₂₂ driven, σ₁₁ = σ₃₃ = −150 kPa, from the hydrostatic start."""
    driver = MaterialDriver(material, n=1, gdim=3)
    F, p0 = np.eye(3), -150e3
    diagonal = [(0, 0), (1, 1), (2, 2)]
    for fraction in np.linspace(0.0, 1.0, 6)[1:]:
        F, _ = mixed_control(driver, F, diagonal, {ij: fraction * p0 for ij in diagonal})
        driver.step(F[None])
    F0, J0 = F.copy(), np.linalg.det(F)
    q, volume = [], []
    for e in np.linspace(0.0, strain, steps + 1)[1:]:
        target = F.copy()
        target[1, 1] = F0[1, 1] * math.exp(-e)
        F, result = mixed_control(driver, target, [(0, 0), (2, 2)], {(0, 0): p0, (2, 2): p0})
        driver.step(F[None])
        s = result["sigma"] - np.trace(result["sigma"]) / 3 * np.eye(3)
        q.append(math.sqrt(1.5) * np.linalg.norm(s))
        volume.append(math.log(np.linalg.det(F) / J0))
    return np.array(q), np.array(volume)


def test_biaxial_compression_matches_the_drucker_prager_cone():
    """Mast §3.8.2: in biaxial compression the two yield surfaces coincide, so the
    modified Drucker–Prager law and MN with DP G give the same q and ε_v (measured:
    to 2e-14)."""
    E, nu = 75e6, 0.33
    dp = fe_mpm.ModifiedDruckerPrager(E, nu, **MAST_TABLE_3_5["dense"])
    mn = fe_mpm.MatsuokaNakai(E, nu, **MAST_TABLE_3_5["dense"])
    q_dp, v_dp = _biaxial(dp)
    q_mn, v_mn = _biaxial(mn)
    assert np.abs(q_mn - q_dp).max() < 1e-10 * q_dp.max()
    assert np.abs(v_mn - v_dp).max() < 1e-10 * np.abs(v_dp).max()
    assert v_dp.min() < 0.0 < v_dp[-1]  # contraction, then dilation


@pytest.mark.parametrize("potential", POTENTIALS)
@pytest.mark.parametrize("dim", [2, 3])
def test_step_residual_and_jacobian_are_consistent(dim, potential):
    """Taylor test of an assembled step (u form), points at λ = 0.01 in several regions."""
    mn = fe_mpm.MatsuokaNakai(
        10.0, 0.3, **MAST_TABLE_3_5["dense"], apex_stress=0.05, potential=potential
    )
    rng, sim = _simulation(dim, "u", material=mn)
    sim.points.history["plastic_shear"][:] = 0.01
    assert_step_is_consistent(sim, rng, 2)


def test_a_cone_of_no_width_keeps_a_compressed_point_on_its_axis():
    """φ_F = 0 (loose sand at λ = 0): the axis, as for the Drucker–Prager cone."""
    mn = law("matsuoka-nakai", E=75e6, sand="loose", apex_stress=0.0)
    dF = np.diag([0.999, 0.999, 0.999])[None].repeat(2, axis=0)
    dF[1, 0, 1] = 1e-4
    history = {"be": np.tile(np.eye(3), (2, 1, 1)), "plastic_shear": np.zeros(2)}
    result = mn.return_map(dF, history)
    mean = np.trace(result.tau, axis1=1, axis2=2) / 3
    assert np.allclose(mean, mn.bulk_modulus * 3 * math.log(0.999), rtol=1e-6)
    assert np.abs(result.tau - mean[:, None, None] * np.eye(3)).max() < 1e-9 * abs(mean[0])


@pytest.mark.parametrize("cls", [fe_mpm.MatsuokaNakai, fe_mpm.ModifiedDruckerPrager])
def test_the_constant_friction_law_reaches_mohr_coulombs_compression_corner_with_cohesion(cls):
    """``constant(E, ν, φ, c)``: φ_F = φ_cs = φ and ψ_G = 0 at any state, and the apex at
    c cot φ, so triaxial compression ends at Mohr-Coulomb's τ_major = −(k p₀ + 2c√k)
    (both cones pass through the compression corners)."""
    phi, c = 30.0, 0.2 * P0
    law = cls.constant(1.0e4, 0.3, phi, cohesion=c)
    assert law.apex_stress == pytest.approx(c / math.tan(math.radians(phi)), rel=1e-15)
    phi_F, phi_cs, psi = law.angles(np.array([-10 * P0, 0.0, law.apex_stress]), np.r_[0, 0.1, 1])
    assert np.all(phi_F == phi) and np.all(phi_cs == phi) and np.all(psi == 0.0)
    regions, taus, _ = confined_compression(law, 3, held=[0, 1], compressed=[2])
    k = k_of(phi)
    limit = -(k * P0 + 2 * c * math.sqrt(k))
    assert regions[0] == ELASTIC and regions[-1] == CONE
    assert abs(taus[-1][2, 2] - limit) < 1e-9 * abs(limit)


@pytest.mark.parametrize("angle", [0.0, 90.0, -5.0])
def test_the_constant_friction_law_names_a_bad_angle_or_cohesion(angle):
    with pytest.raises(ValueError, match=r"MatsuokaNakai.constant: friction_angle must be in"):
        fe_mpm.MatsuokaNakai.constant(1e4, 0.3, angle)
    with pytest.raises(ValueError, match=r"ModifiedDruckerPrager.constant: cohesion must be"):
        fe_mpm.ModifiedDruckerPrager.constant(1e4, 0.3, 30.0, cohesion=-1.0)


def test_an_unknown_potential_is_named():
    with pytest.raises(ValueError, match="MatsuokaNakai: potential must be one of"):
        law("mohr-coulomb")
    with pytest.raises(ValueError, match=r"MatsuokaNakai: a0 must lie in \[20, 90\)"):
        fe_mpm.MatsuokaNakai(1e4, 0.3, **{**MAST_TABLE_3_5["dense"], "a0": 10.0})
