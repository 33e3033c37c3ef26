"""The compiled return maps give the numpy route's numbers.

:mod:`fe_mpm.materials.compiled` runs the Mohr-Coulomb step and the spectral
tangent point by point; the numpy functions stay the reference. Every region of the
return (elastic, plane, both edge lines, apex), plane strain and 3D, and repeated
eigenvalues (a virgin point: b^tr = I) must agree to round-off. The measured
spread is below 2e-13 of each array's largest entry (the tangent's; stress and
history 1e-14); the bound is 1e-12.
"""

from __future__ import annotations

import numpy as np
import pytest

from fe_mpm.materials import MohrCoulomb, route
from fe_mpm.materials.principal_return import APEX, ELASTIC, LINE_1, LINE_2, PLANE

TOLERANCE = 1e-12

LAWS = {
    "tresca": MohrCoulomb.tresca(1.0e4, 0.49, 100.0),
    "non-associative": MohrCoulomb(1.0e5, 0.3, 50.0, 30.0, 5.0),
    "associative": MohrCoulomb(1.0e5, 0.3, 50.0, 30.0, 30.0),
}


def states(g: int, amplitude: float, n: int = 4000, seed: int = 0) -> tuple[np.ndarray, dict]:
    """Random increments ΔF and elastic b^e_n, the first 50 points virgin (ΔF = I, b = I)."""
    rng = np.random.default_rng(seed)
    dF = np.eye(g) + amplitude * rng.standard_normal((n, g, g))
    A = 0.01 * rng.standard_normal((n, 3, 3))
    if g == 2:  # plane strain: the third axis stays principal
        A[:, 2, :2] = A[:, :2, 2] = 0.0
    be = np.eye(3) + A + np.swapaxes(A, 1, 2)
    dF[:50], be[:50] = np.eye(g), np.eye(3)
    return dF, {"be": be, "plastic_strain": rng.uniform(0.0, 0.1, n)}


def both_routes(law, dF, history, monkeypatch):
    """The numpy route's result and the compiled one's, each with its tangent."""
    monkeypatch.setenv(route.ENVIRONMENT_VARIABLE, "0")
    reference = law.return_map(dF, history)
    assert route.compiled() is None
    monkeypatch.delenv(route.ENVIRONMENT_VARIABLE)
    assert route.compiled() is not None
    return reference, law.return_map(dF, history)


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.mark.parametrize("name", LAWS)
@pytest.mark.parametrize("g", [2, 3])
@pytest.mark.parametrize("amplitude", [0.002, 0.1])
def test_compiled_return_map_matches_numpy(name, g, amplitude, monkeypatch):
    dF, history = states(g, amplitude)
    reference, result = both_routes(LAWS[name], dF, history, monkeypatch)
    np.testing.assert_array_equal(result.region, reference.region)
    assert relative(result.tau, reference.tau) < TOLERANCE
    assert relative(result.history["be"], reference.history["be"]) < TOLERANCE
    increment = result.history["plastic_strain"] - history["plastic_strain"]
    expected = reference.history["plastic_strain"] - history["plastic_strain"]
    assert relative(increment, expected) < TOLERANCE
    assert relative(result.tangent, reference.tangent) < TOLERANCE


def test_every_region_is_compared():
    """The states above reach each region of the return (else the comparison is blind)."""
    seen = set()
    for law in LAWS.values():
        for g in (2, 3):
            for amplitude in (0.002, 0.1):
                dF, history = states(g, amplitude)
                seen |= set(np.unique(law.return_map(dF, history).region).tolist())
    assert seen == {ELASTIC, PLANE, LINE_1, LINE_2, APEX}


def test_compiled_tangent_is_the_derivative(monkeypatch):
    """Central differences of the compiled τ against its tangent, away from region changes."""
    monkeypatch.delenv(route.ENVIRONMENT_VARIABLE, raising=False)
    assert route.compiled() is not None
    law = LAWS["non-associative"]
    dF, history = states(2, 0.02, n=200, seed=3)
    result = law.return_map(dF, history)
    step = 1e-7
    for k, m in np.ndindex(2, 2):
        plus, minus = dF.copy(), dF.copy()
        plus[:, k, m] += step
        minus[:, k, m] -= step
        up, down = law.return_map(plus, history), law.return_map(minus, history)
        same = (up.region == result.region) & (down.region == result.region)
        difference = (up.tau - down.tau)[same] / (2 * step)
        scale = np.abs(result.tangent).max()
        assert np.abs(difference - result.tangent[same][..., k, m]).max() < 1e-5 * scale


@pytest.mark.parametrize("g", [2, 3])
def test_a_collapsed_or_nan_point_gives_nan_not_an_error(g):
    """ΔF = 0 or NaN (an inverted iterate) gives NaN stresses, for Newton to report."""
    law = LAWS["tresca"]
    dF = np.stack([np.zeros((g, g)), np.full((g, g), np.nan), np.eye(g)])
    history = {"be": np.tile(np.eye(3), (3, 1, 1)), "plastic_strain": np.zeros(3)}
    result = law.return_map(dF, history)
    assert np.isnan(result.tau[:2]).all() and np.isfinite(result.tau[2]).all()


def test_points_on_the_yield_surface_take_the_same_tangent_on_both_routes(monkeypatch):
    """A step starts where the last ended: ΔF = I on the returned bᵉ, f = 0 up to
    round-off. Within YIELD_TOLERANCE both routes call such a point elastic, so the
    first Jacobian of a step does not hang on the last bit of a logarithm."""
    law = LAWS["tresca"]
    dF, history = states(2, 0.02, n=4000, seed=5)
    returned = law.return_map(dF, history)
    assert np.count_nonzero(returned.region) > 1000
    start = {"be": returned.history["be"], "plastic_strain": returned.history["plastic_strain"]}
    identity = np.tile(np.eye(2), (len(dF), 1, 1))
    reference, result = both_routes(law, identity, start, monkeypatch)
    assert not reference.region.any() and not result.region.any()
    assert relative(result.tangent, reference.tangent) < TOLERANCE


def test_an_in_plane_3d_state_and_an_off_plane_history_match_too(monkeypatch):
    """3D increments that keep the third axis principal (the closed form on both
    routes, as the u-p forms' mixed return hands them to the law) and plane-strain
    increments on a bᵉ with off-plane entries (LAPACK in numpy, Jacobi compiled)."""
    law = LAWS["non-associative"]
    dF2, history = states(2, 0.05, seed=7)
    dF3 = np.tile(np.eye(3), (len(dF2), 1, 1))
    dF3[:, :2, :2] = dF2
    off_plane = dict(history, be=states(3, 0.05, seed=8)[1]["be"])
    for dF, hist in ((dF3, history), (dF2, off_plane)):
        reference, result = both_routes(law, dF, hist, monkeypatch)
        np.testing.assert_array_equal(result.region, reference.region)
        assert relative(result.tau, reference.tau) < TOLERANCE
        assert relative(result.tangent, reference.tangent) < TOLERANCE


def test_the_compiled_3d_eigen_decomposition_matches_lapack():
    """Jacobi rotations (``compiled._jacobi_eigen``, what 3D trials take) against
    LAPACK's ``eigh`` on random symmetric positive definite tensors, on tensors with
    two or three equal eigenvalues, and a NaN: the eigenvalues to 1e-14 of the
    largest, Q diag(x) Qᵀ = b and QᵀQ = I to 1e-14, and NaN for NaN."""
    from fe_mpm.materials.compiled import _jacobi_eigen

    rng = np.random.default_rng(11)
    A = rng.standard_normal((500, 3, 3))
    b = A @ np.swapaxes(A, 1, 2) + 0.01 * np.eye(3)
    R = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    b[:3] = [np.eye(3), R @ np.diag([2.0, 2.0, 0.5]) @ R.T, R @ np.diag([1.0, 3.0, 3.0]) @ R.T]
    b[3] = np.nan
    x, Q, work = np.zeros((len(b), 3)), np.zeros((len(b), 3, 3)), np.zeros((3, 3))
    for p in range(len(b)):
        _jacobi_eigen(b[p], x, Q, p, work)
    assert np.isnan(x[3]).all()
    ok = np.arange(len(b)) != 3
    x, Q, b = x[ok], Q[ok], b[ok]
    scale = np.abs(x).max(axis=1)
    reference = np.linalg.eigvalsh(b)[:, ::-1]
    assert (np.abs(x - reference).max(axis=1) / scale).max() < 1e-14
    assert np.all(np.diff(x, axis=1) <= 0.0)  # descending
    rebuilt = (Q * x[:, None, :]) @ np.swapaxes(Q, 1, 2)
    assert (np.abs(rebuilt - b).max(axis=(1, 2)) / scale).max() < 1e-14
    assert np.abs(np.swapaxes(Q, 1, 2) @ Q - np.eye(3)).max() < 1e-14
