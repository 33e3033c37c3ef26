"""Hencky J2 with isotropic and kinematic hardening (Mast 2013, §3.5).

Closed forms: along F = diag(e^γ, e^{−γ}, 1) the logarithmic strains are exact and
the principal axes fixed, so the return is the small-strain one in ε = (γ, −γ, 0):
the deviator is ‖s‖ = 2G√2 γ while elastic; once plastic it grows with slope

    d‖s‖/d(√2 γ) = 2G · ⅔(H + k) / (2G + ⅔(H + k)),

and after a reversal the point yields again when ‖s‖ has fallen by the diameter of
the current surface, 2√(2/3)(σ_Y + k α): with kinematic hardening only, the
Bauschinger effect (the surface moves; its size stays).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from law_checks import assert_step_is_consistent, finite_difference_error
from test_taylor import _simulation

import fe_mpm
from fe_mpm.material_driver import MaterialDriver, mixed_control

SQRT_2_3 = math.sqrt(2.0 / 3.0)


def law(k=500.0, H=2000.0):
    return fe_mpm.HenckyJ2(1.0e4, 0.3, 10.0, hardening=k, kinematic_hardening=H)


def shear(gamma: float) -> np.ndarray:
    return np.diag([math.exp(gamma), math.exp(-gamma), 1.0])


def states(g: int, n: int = 400, seed: int = 0):
    """Increments from elastic to far beyond yield on hardened, moved surfaces."""
    rng = np.random.default_rng(seed)
    dF = np.eye(g) + rng.uniform(0.0002, 0.006, (n, 1, 1)) * rng.normal(size=(n, g, g))
    A = np.eye(3) + 0.001 * rng.normal(size=(n, 3, 3))
    beta = rng.normal(scale=3.0, size=(n, 3, 3))
    beta = beta + np.swapaxes(beta, 1, 2)
    beta -= np.trace(beta, axis1=1, axis2=2)[:, None, None] / 3 * np.eye(3)
    if g == 2:
        A[:, 2, :2] = A[:, :2, 2] = beta[:, 2, :2] = beta[:, :2, 2] = 0.0
    history = {
        "be": A @ np.swapaxes(A, 1, 2),
        "back_stress": beta,
        "plastic_strain": rng.uniform(0.0, 0.01, n),
    }
    return dF, history


@pytest.mark.parametrize("gdim", [2, 3])
def test_tangent_matches_finite_differences(gdim):
    j2 = law()
    dF, history = states(gdim)
    result = j2.return_map(dF, history)
    assert set(np.unique(result.region)) == {0, 1}
    error, same = finite_difference_error(j2, dF, history, result.tangent)
    assert same.mean() > 0.95
    assert error[same].max() < 1e-7 * j2.E


def test_returned_stress_lies_on_the_moved_surface():
    j2 = law()
    dF, history = states(3, n=2000, seed=3)
    result = j2.return_map(dF, history)
    f = j2.yield_function(result.tau, {**history, **result.history})
    plastic = result.region == 1
    assert np.abs(f[plastic]).max() < 1e-12 * j2.yield_stress
    assert f[~plastic].max() <= 1e-12 * j2.yield_stress
    moved = result.history["back_stress"] - history["back_stress"]
    assert np.all(np.abs(moved[~plastic]) == 0.0)
    assert np.allclose(np.trace(moved, axis1=1, axis2=2), 0.0, atol=1e-12)


@pytest.mark.parametrize("k, H", [(0.0, 2000.0), (2000.0, 0.0), (500.0, 1500.0)])
def test_hardening_slope_and_the_bauschinger_effect(k, H):
    j2 = law(k, H)
    G = j2.mu
    driver = MaterialDriver(j2, n=1, gdim=3)
    onset = SQRT_2_3 * j2.yield_stress / (2 * G * math.sqrt(2))
    gammas = np.linspace(0.0, 5 * onset, 51)[1:]
    norms = []
    for gamma in gammas:
        tau = driver.step(shear(gamma)[None])[0]
        dev = tau - np.trace(tau) / 3 * np.eye(3)
        norms.append(np.linalg.norm(dev))
    plastic = gammas > onset * (1 + 1e-9)
    slope = np.diff(np.array(norms)[plastic]) / (math.sqrt(2) * np.diff(gammas[plastic]))
    c = 2.0 / 3.0 * (H + k)
    assert np.allclose(slope, 2 * G * c / (2 * G + c), rtol=1e-9)
    # reversal: elastic until ‖s‖ has fallen by the surface's diameter
    alpha = driver.history["plastic_strain"][0]
    diameter = 2 * SQRT_2_3 * (j2.yield_stress + k * alpha)
    back = diameter / (2 * G * math.sqrt(2))
    peak = gammas[-1]
    for factor, region in ((1 - 1e-9, 0), (1 + 1e-9, 1)):
        result = driver.evaluate(shear(peak - factor * back)[None])
        assert result["region"][0] == region
    if k == 0.0:  # the surface kept its size: the reversed yield stress is −s_peak + 2r
        assert diameter == pytest.approx(2 * SQRT_2_3 * j2.yield_stress, rel=1e-14)


def test_small_strains_agree_with_simos_j2():
    """Isotropic hardening only, simple shear to γ = 0.003 (yield near 0.0012): the
    Hencky and the b̄ᵉ forms of J2 differ at second order in the strain (measured:
    0.084 % of the largest stress, the same plastic strain to five digits)."""
    hencky = fe_mpm.HenckyJ2(1.0e4, 0.3, 10.0, hardening=500.0)
    simo = fe_mpm.J2Plasticity(1.0e4, 0.3, 10.0, hardening=500.0)
    taus = []
    for j2 in (hencky, simo):
        driver = MaterialDriver(j2, n=1, gdim=3)
        for gamma in np.linspace(0.0, 0.003, 31)[1:]:
            F = np.eye(3)
            F[0, 1] = gamma
            tau = driver.step(F[None])[0]
        taus.append(tau)
    assert np.abs(taus[0] - taus[1]).max() < 2e-3 * np.abs(taus[1]).max()


@pytest.mark.parametrize("formulation", ["u", "up", "u-nbva"])
@pytest.mark.parametrize("dim", [2, 3])
def test_step_residual_and_jacobian_are_consistent(dim, formulation):
    j2 = fe_mpm.HenckyJ2(10.0, 0.3, 0.5, hardening=2.0, kinematic_hardening=3.0)
    rng, sim = _simulation(dim, formulation, material=j2)
    assert_step_is_consistent(sim, rng, 2)


@pytest.mark.parametrize(
    "bad, match",
    [
        (dict(yield_stress=0.0), r"HenckyJ2: yield_stress must lie in \(0, inf\)"),
        (dict(hardening=-1.0), r"HenckyJ2: hardening must lie in \[0, inf\)"),
        (dict(kinematic_hardening=-1.0), r"HenckyJ2: kinematic_hardening must lie in \[0, inf\)"),
        (dict(nu=0.5), r"HenckyJ2: nu must lie in \(-1, 0.5\)"),
    ],
)
def test_bad_parameters_are_named(bad, match):
    with pytest.raises(ValueError, match=match):
        fe_mpm.HenckyJ2(**{**dict(E=1e4, nu=0.3, yield_stress=10.0), **bad})


def test_a_non_finite_iterate_gives_nan_at_its_point_and_no_exception():
    """A diverging Newton iterate (a NaN in ΔF at one point) must come back as NaN
    there, so that the residual is not finite and Newton stops with its own message;
    LAPACK's eigh raised instead ("Eigenvalues did not converge"), a traceback that
    ended a 3D Taylor bar run. The other points are returned as usual."""
    j2 = fe_mpm.HenckyJ2(10.0, 0.3, 0.5, hardening=2.0)
    dF = np.tile(np.eye(3), (3, 1, 1))
    dF[0, 0, 1] = 0.01
    dF[1, 2, 0] = np.nan
    dF[2, 0, 2] = 0.02
    history = {name: h.initial_values(3) for name, h in j2.history.items()}
    result = j2.return_map(dF, history)
    assert np.isnan(result.tau[1]).all()
    assert np.isfinite(result.tau[[0, 2]]).all()
    alone = j2.return_map(dF[[0, 2]], {k: v[[0, 2]] for k, v in history.items()})
    np.testing.assert_array_equal(result.tau[[0, 2]], alone.tau)


def test_mixed_control_meets_held_stresses_of_zero_at_its_default_tolerance():
    """A helper's uniaxial-stress compression (2026-12-07): with σ_xx = σ_yy = 0 held,
    the default tolerance was an absolute 1e-9 Pa, which the round-off of stresses of
    1e6 Pa missed (1.65e-8 Pa), so the first step failed. It now scales with the
    stresses in play, and the path meets the log-strain closed form of the law."""
    E, sigma_y, H = 1e8, 1e6, 1e7
    driver = MaterialDriver(fe_mpm.HenckyJ2(E, 0.3, sigma_y, hardening=H), n=1, gdim=3)
    F = np.eye(3)
    for stretch in np.linspace(0.975, 0.75, 10):
        F = F.copy()
        F[2, 2] = stretch
        held = {(0, 0): 0.0, (1, 1): 0.0}
        F, result = mixed_control(driver, F, [(0, 0), (1, 1)], held, measure="kirchhoff")
        driver.step(F[None])
    strain = -np.log(0.75)
    exact = sigma_y + H * (strain - sigma_y / E) * E / (E + H)
    assert -result["tau"][2, 2] == pytest.approx(exact, rel=1e-9)
