"""Mohr-Coulomb and Tresca (Hencky, principal-space return) at single points and in steps.

Closed forms used (tension positive, Kirchhoff stresses): with k = (1 + sin φ)/(1 − sin φ),
a confined compression path with the least compressive stress held at −p₀ ends on

    τ_major = −(k p₀ + 2c√k),

whether the third stress is free (plane strain: plane return), equal to the least
compressive one (triaxial compression: line 1) or equal to the major one (triaxial
extension: line 2). For Tresca (φ = 0, k = 1) that is τ_major = −(p₀ + 2c).
Isotropic tension ends on the apex, τ = c cot φ.
"""

import dataclasses
import itertools

import numpy as np
import pytest
import ufl
from law_checks import assert_step_is_consistent
from layouts import embed_3d
from test_taylor import _simulation

import fe_mpm
from fe_mpm.material_driver import MaterialDriver, mixed_control
from fe_mpm.materials.principal_return import (
    APEX,
    ELASTIC,
    LINE_1,
    LINE_2,
    PLANE,
    mohr_coulomb_return,
)
from fe_mpm.materials.spectral import spectral_decomposition
from fe_mpm.meshes import rectangle_mesh

SOIL = dict(E=1.0e4, nu=0.3, cohesion=10.0)  # kPa-like units
P0 = 20.0  # confining pressure


def k_of(phi_deg):
    s = np.sin(np.radians(phi_deg))
    return (1 + s) / (1 - s)


def held_diagonal(driver, F, controlled, target, tol=1e-12):
    """Adjust the diagonal entries ``controlled`` of F so that τ_ii = target.

    ``fe_mpm.material_driver.mixed_control`` on Kirchhoff stresses: Newton with the
    law's own tangent, least squares (on a line return the lateral pair moves
    together and the Jacobian is singular). Returns the new F and the law's result.
    """
    return mixed_control(
        driver,
        F,
        [(j, j) for j in controlled],
        {(i, i): target for i in controlled},
        tolerance=tol,
        measure="kirchhoff",
    )


def confined_compression(material, gdim, held, compressed, n_steps=40, strain=0.03):
    """Compress the axes ``compressed`` together while the ``held`` stresses stay at −P0."""
    driver = MaterialDriver(material, n=1, gdim=gdim)
    # Isotropic pre-compression to −P0 on every controlled axis first.
    F, _ = held_diagonal(driver, np.eye(gdim), list(held) + list(compressed), -P0)
    driver.step(F[None])
    regions, taus = [], []
    for e in np.linspace(0, strain, n_steps + 1)[1:]:
        target = F.copy()
        for axis in compressed:
            target[axis, axis] = F[axis, axis] * (1 - e)
        Fk, result = held_diagonal(driver, target, held, -P0)
        driver.step(Fk[None])
        regions.append(result["region"])
        taus.append(result["tau"])
    return np.array(regions), np.array(taus), driver


@pytest.mark.parametrize("phi", [30.0, 0.0])
def test_plane_strain_compression_reaches_the_analytical_limit_on_the_plane(phi):
    mat = fe_mpm.MohrCoulomb(**SOIL, friction_angle=phi, dilatancy_angle=phi / 3)
    regions, taus, driver = confined_compression(mat, 2, held=[0], compressed=[1])
    limit = -(k_of(phi) * P0 + 2 * SOIL["cohesion"] * np.sqrt(k_of(phi)))
    assert regions[0] == ELASTIC and regions[-1] == PLANE
    assert abs(taus[-1][1, 1] - limit) < 1e-10 * abs(limit)
    assert abs(taus[-1][0, 0] + P0) < 1e-10 * P0
    assert taus[-1][1, 1] < taus[-1][2, 2] < taus[-1][0, 0]  # τ_zz is the intermediate one
    assert driver.history["plastic_strain"][0] > 0.0


@pytest.mark.parametrize("phi", [30.0, 0.0])
@pytest.mark.parametrize(
    "path, line", [("triaxial compression", LINE_1), ("triaxial extension", LINE_2)]
)
def test_triaxial_paths_end_on_the_lines(path, line, phi):
    mat = fe_mpm.MohrCoulomb(**SOIL, friction_angle=phi, dilatancy_angle=phi / 3)
    limit = -(k_of(phi) * P0 + 2 * SOIL["cohesion"] * np.sqrt(k_of(phi)))
    if path == "triaxial compression":  # τ_xx = τ_yy = −P0, compress z
        regions, taus, _ = confined_compression(mat, 3, held=[0, 1], compressed=[2])
        major = taus[-1][2, 2]
    else:  # τ_zz = −P0 held, the lateral pair compressed together
        regions, taus, _ = confined_compression(mat, 3, held=[2], compressed=[0, 1])
        major = taus[-1][0, 0]
        assert abs(taus[-1][0, 0] - taus[-1][1, 1]) < 1e-10 * P0
    assert regions[-1] == line
    assert abs(major - limit) < 1e-10 * abs(limit)


def test_isotropic_tension_returns_to_the_apex():
    mat = fe_mpm.MohrCoulomb(**SOIL, friction_angle=30.0, dilatancy_angle=30.0)
    driver = MaterialDriver(mat, n=3, gdim=3)
    F = np.array([(1 + e) * np.eye(3) for e in (1e-4, 1e-3, 1e-2)])
    result = driver.evaluate(F)
    apex = SOIL["cohesion"] / np.tan(np.radians(30.0))
    assert result["region"][0] == ELASTIC
    assert np.all(result["region"][1:] == APEX)
    assert np.allclose(result["tau"][1:], apex * np.eye(3), rtol=1e-13, atol=0)
    assert np.all(result["tangent"][1:] == 0.0)


def _random_trials(surface, n, rng, scale):
    strain = rng.normal(0.0, scale, (n, 3))
    return -np.sort(-strain, axis=1)


@pytest.mark.parametrize("phi, c", [(30.0, 10.0), (0.0, 10.0), (31.0, 0.0)])
def test_associative_return_is_the_energy_closest_point(phi, c):
    """For ψ = φ the return is the projection onto the convex elastic domain in the a⁻¹ norm.

    So (τ^tr − τ)ᵀ a⁻¹ (τ' − τ) ≤ 0 for every admissible τ'. This checks the choice
    of region independently of how it is made. Every region must occur.
    """
    mat = fe_mpm.MohrCoulomb(E=1e4, nu=0.3, cohesion=c, friction_angle=phi, dilatancy_angle=phi)
    surface = mat.surface
    rng = np.random.default_rng(1)
    strain = _random_trials(surface, 4000, rng, 0.004)
    ret = mohr_coulomb_return(surface, strain)
    expected = {ELASTIC, PLANE, LINE_1, LINE_2} | ({APEX} if phi > 0 else set())
    assert set(np.unique(ret.region)) == expected
    plastic = ret.region != ELASTIC
    trial = strain @ surface.elastic
    f = surface.yield_function(ret.stress)
    assert np.abs(f[plastic]).max() < 1e-12 * surface.shear_modulus
    # Probes: points on the yield surface (returns of other trials) in every axis order,
    # since the admissible set is symmetric in the principal axes.
    others = mohr_coulomb_return(surface, _random_trials(surface, 500, rng, 0.004)).stress
    probes = np.vstack([others[:, perm] for perm in itertools.permutations(range(3))])
    d = (trial - ret.stress)[plastic] @ surface.compliance
    inner = d @ probes.T - np.einsum("ni,ni->n", d, ret.stress[plastic])[:, None]
    spread = np.linalg.norm(d, axis=1).max() * np.abs(probes).max()
    assert inner.max() <= 1e-12 * spread


def test_non_associative_plastic_strain_follows_the_active_potentials():
    """Δεᵖ = a⁻¹(τ^tr − τ) is a non-negative combination of the active ∂g (ψ < φ)."""
    mat = fe_mpm.MohrCoulomb(E=1e4, nu=0.3, cohesion=10.0, friction_angle=30.0, dilatancy_angle=5.0)
    surface = mat.surface
    m = surface.m
    strain = _random_trials(surface, 4000, np.random.default_rng(2), 0.004)
    ret = mohr_coulomb_return(surface, strain)
    dep = (strain @ surface.elastic - ret.stress) @ surface.compliance
    gradients = {
        PLANE: [[m, 0, -1]],
        LINE_1: [[m, 0, -1], [0, m, -1]],
        LINE_2: [[m, 0, -1], [m, -1, 0]],
    }
    for region, grads in gradients.items():
        mask = ret.region == region
        assert mask.sum() > 20
        G = np.array(grads, dtype=float).T
        gammas, *_ = np.linalg.lstsq(G, dep[mask].T, rcond=None)
        assert np.abs(G @ gammas - dep[mask].T).max() < 1e-12
        assert gammas.min() > -1e-14


@pytest.mark.parametrize("gdim", [2, 3])
@pytest.mark.parametrize("phi", [30.0, 0.0])
def test_tangent_matches_finite_differences_in_every_region(gdim, phi):
    mat = fe_mpm.MohrCoulomb(**SOIL, friction_angle=phi, dilatancy_angle=phi / 3)
    rng = np.random.default_rng(3)
    n = 300
    A = np.eye(3) + rng.normal(0, 0.0005, (n, 3, 3))  # an elastic state at t_n
    if gdim == 2:
        A[:, 2, :2] = A[:, :2, 2] = 0.0
    history = {"be": A @ np.swapaxes(A, 1, 2), "plastic_strain": np.zeros(n)}
    size = rng.uniform(0.0002, 0.006, (n, 1, 1))  # from elastic to far beyond yield
    dF = np.eye(gdim) + size * rng.normal(0, 1, (n, gdim, gdim))
    result = mat.return_map(dF, history)
    assert len(np.unique(result.region)) >= (5 if phi > 0 else 4)
    h = 1e-7
    for k, l in np.ndindex(gdim, gdim):
        E = np.zeros((gdim, gdim))
        E[k, l] = h
        fd = (mat.return_map(dF + E, history).tau - mat.return_map(dF - E, history).tau) / (2 * h)
        assert np.abs(fd - result.tangent[..., k, l]).max() < 1e-7 * mat.E


def test_virgin_tangent_is_linear_elasticity():
    """At b = I (all eigenvalues equal) the repeated-eigenvalue limit gives λ, 2G exactly."""
    mat = fe_mpm.MohrCoulomb(**SOIL, friction_angle=30.0)
    D = MaterialDriver(mat, n=1, gdim=3).evaluate(np.eye(3)[None])["tangent"][0]
    lam = mat.bulk_modulus - 2 * mat.mu / 3
    I = np.eye(3)
    C = lam * np.einsum("ij,kl->ijkl", I, I) + mat.mu * (
        np.einsum("ik,jl->ijkl", I, I) + np.einsum("il,jk->ijkl", I, I)
    )
    assert np.allclose(D, C, rtol=0, atol=1e-10 * mat.E)


def _plane_tensors(n: int) -> np.ndarray:
    """Symmetric positive tensors (n, 3, 3) with the third axis principal; every 5th is
    I (three equal eigenvalues), every 5th + 1 has b_33 equal to an in-plane eigenvalue,
    and b_33 falls above, between and below the in-plane pair."""
    rng = np.random.default_rng(11)
    F = np.tile(np.eye(3), (n, 1, 1))
    F[:, :2, :2] += 0.3 * rng.normal(size=(n, 2, 2))
    F[:, 2, 2] = 1.0 + 0.4 * rng.normal(size=n)
    b = F @ np.swapaxes(F, 1, 2)
    b[::5] = np.eye(3)
    b[1::5, :2, :2] = np.diag([2.0, 0.5])
    b[1::5, 2, 2] = 0.5
    return b


def test_plane_spectral_decomposition_is_lapacks_in_closed_form():
    """Plane-strain tensors take the closed form; it must give eigh's eigenvalues in
    descending order with an orthonormal basis that rebuilds the tensor."""
    b = _plane_tensors(400)
    x, Q = spectral_decomposition(b)
    reference = np.linalg.eigvalsh(b)[:, ::-1]
    assert np.abs(x - reference).max() < 1e-14 * np.abs(reference).max()
    assert np.all(np.diff(x, axis=1) <= 0.0)
    assert np.abs(np.swapaxes(Q, 1, 2) @ Q - np.eye(3)).max() < 1e-15
    assert np.abs((Q * x[:, None, :]) @ np.swapaxes(Q, 1, 2) - b).max() < 1e-14 * np.abs(b).max()
    assert np.all(np.sort(np.abs(Q[:, 2]), axis=1) == [0.0, 0.0, 1.0])  # e_3 stays principal
    # an out-of-plane coupling takes LAPACK's general path, with the same contract; like
    # eigh, the decomposition reads the lower triangle, so a coupling there alone counts
    b[:, 2, 0] = 0.1
    x, Q = spectral_decomposition(b)
    assert np.abs(x - np.linalg.eigvalsh(b)[:, ::-1]).max() < 1e-14 * np.abs(b).max()
    symmetric = np.tril(b) + np.swapaxes(np.tril(b, -1), 1, 2)
    rebuilt = (Q * x[:, None, :]) @ np.swapaxes(Q, 1, 2)
    assert np.abs(rebuilt - symmetric).max() < 1e-14 * np.abs(b).max()


@pytest.mark.parametrize(
    "formulation, phi", [("u", 30.0), ("u", 0.0), ("up", 0.0), ("u-nbva", 30.0)]
)
@pytest.mark.parametrize("dim", [2, 3])
def test_step_residual_and_jacobian_are_consistent(dim, formulation, phi):
    """Taylor test of an assembled step with points in several return regions.

    The return map is piecewise smooth, so ε is kept small enough that no point
    changes region, and that is asserted.
    """
    mat = fe_mpm.MohrCoulomb(10.0, 0.3, 0.05, friction_angle=phi, dilatancy_angle=phi / 3)
    rng, sim = _simulation(dim, formulation, material=mat)
    assert_step_is_consistent(sim, rng, 3)


def test_a_step_runs_the_return_map_once_per_residual_and_the_tangent_once_per_jacobian():
    """The tangent costs more than the return; the converged state is not recomputed.

    A solve of k iterations assembles k + 1 residuals and k Jacobians. Before the
    tangent was computed lazily, every residual paid for a tangent, and the
    converged iterate was returned twice (once more for the reactions).
    """
    calls = {"return_map": 0, "tangent": 0}

    class Counted(fe_mpm.MohrCoulomb):
        def return_map(self, dF, history):
            calls["return_map"] += 1
            result = super().return_map(dF, history)

            def counted():
                calls["tangent"] += 1
                return result.derivative()

            return dataclasses.replace(result, derivative=counted)

    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (4, 4))
    sim = fe_mpm.Simulation(
        mesh,
        fe_mpm.seed(mesh, 3),
        Counted(**SOIL, friction_angle=30.0),
        "u",
        dirichlet=[
            fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0)),
            fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 1.0), lambda t: (0.0, -0.01 * t)),
        ],
    )
    report = sim.step(1.0)
    assert np.any(sim._current.return_map.result.region != ELASTIC)
    k = report.newton_iterations
    assert k >= 3  # plastic points: a real Newton solve
    assert calls == {"return_map": k + 1, "tangent": k}


def test_a_prescribed_displacement_is_lifted_with_the_laws_own_tangent():
    """Newton's first iterate of a displacement-driven step is the elastic predictor.

    The residual at the start carries the lifting −A (g − Δu) of the prescribed
    increment; for a pointwise law its tangent must be packed before that assembly.
    It once was not (the lifting read a zero tangent): the first iteration only moved
    the supported nodes, and an elastic Mohr-Coulomb step took 5 iterations where the
    Neo-Hookean solid takes 3. At this strain (1 %) the two laws agree to 1e-2, so
    both start from the same imbalance and converge alike.
    """
    runs = {}
    for law in (
        fe_mpm.NeoHookean(E=1e7, nu=0.3),
        fe_mpm.MohrCoulomb(E=1e7, nu=0.3, cohesion=1e9),  # elastic throughout
    ):
        mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (4, 4))
        sim = fe_mpm.Simulation(
            mesh,
            fe_mpm.seed(mesh, 3),
            law,
            "u",
            dirichlet=[
                fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0)),
                fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 1.0), lambda t: (0.0, -0.01 * t)),
            ],
        )
        runs[type(law).__name__] = sim.step(1.0)
    hyper, hencky = runs["NeoHookean"], runs["MohrCoulomb"]
    assert hencky.residual_norms[0] == pytest.approx(hyper.residual_norms[0], rel=1e-2)
    assert hencky.residual_norms[1] < 1e-2 * hencky.residual_norms[0]
    assert hencky.newton_iterations == hyper.newton_iterations == 3


@pytest.mark.parametrize("phi, at_pressure", [(20.0, True), (0.5, True), (0.0, False)])
def test_mixed_formulation_returns_a_frictional_law_at_the_fields_pressure(phi, at_pressure):
    """φ > 0 returns at the pressure field's mean stress (``tests/test_frictional_up.py``);
    Tresca keeps the forms' own volumetric law."""
    law = fe_mpm.MohrCoulomb(10.0, 0.3, 0.05, friction_angle=phi)
    _, sim = _simulation(2, "up", material=law)
    forms, *_ = sim.prepare_step(1.0)
    assert forms.at_pressure is at_pressure


def test_the_ufl_stress_needs_the_simulations_linearisation():
    """The law is evaluated in numpy; its UFL stress exists only as the linearisation the
    simulation packs, and asking without one says so."""
    F = ufl.Identity(2)
    for stress in (
        fe_mpm.MohrCoulomb.tresca(1e4, 0.3, 10.0).kirchhoff,
        fe_mpm.MohrCoulomb.tresca(1e4, 0.3, 10.0).kirchhoff_deviatoric,
    ):
        with pytest.raises(
            ValueError,
            match="MohrCoulomb: the state has no linearisation "
            r"slot fields; the law is evaluated at the points \(return_map\)",
        ):
            stress(F, None)


def test_a_collapsed_trial_step_gives_a_non_finite_stress_quietly():
    """det ΔF = 0 has no logarithmic strain: the stress is not finite, which Newton reports
    with the step, and no RuntimeWarning is raised on the way (the suite turns those into
    errors)."""
    law = fe_mpm.MohrCoulomb(1e4, 0.3, 10.0, friction_angle=30.0)
    history = {"be": np.tile(np.eye(3), (2, 1, 1)), "plastic_strain": np.zeros(2)}
    dF = np.array([np.diag([1.01, 0.99]), np.diag([0.0, 1.0])])
    result = law.return_map(dF, history)
    assert np.all(np.isfinite(result.tau[0])) and not np.all(np.isfinite(result.tau[1]))


@pytest.mark.parametrize(
    "bad, match",
    [
        (dict(friction_angle=95.0), "friction_angle must lie in"),
        (dict(friction_angle=90.0), "friction_angle must lie in"),
        (dict(friction_angle=-1.0), "friction_angle must lie in"),
        (dict(friction_angle=20.0, dilatancy_angle=25.0), "dilatancy_angle must lie in"),
        (dict(cohesion=-1.0), "cohesion must lie in"),
        (
            dict(cohesion=0.0),
            r"MohrCoulomb: cohesion must be > 0 when friction_angle = 0 \(the "
            r"material would have no strength\), got 0",
        ),
        (dict(density=0.0), "density must lie in"),
        (dict(density=-5.0), "density must lie in"),
    ],
)
def test_bad_parameters_are_named(bad, match):
    with pytest.raises(ValueError, match=match):
        fe_mpm.MohrCoulomb(**{**dict(E=1e4, nu=0.3, cohesion=10.0), **bad})


def test_tresca_is_mohr_coulomb_without_friction_or_dilatancy():
    assert fe_mpm.MohrCoulomb.tresca(2e4, 0.45, 12.0, density=1800.0) == fe_mpm.MohrCoulomb(
        2e4, 0.45, 12.0, friction_angle=0.0, dilatancy_angle=0.0, density=1800.0
    )
    assert fe_mpm.MohrCoulomb.tresca(2e4, 0.45, 12.0).density is None


def test_history_of_a_plastic_step_is_consistent_with_its_stress():
    """One step from the virgin state, elastic and plastic points: the new bᵉ has the
    elastic logarithmic strains of the returned stress (ε = C⁻¹τ in principal axes), the
    plastic strain grows by √(2/3)‖ε_trial − εᵉ‖ (zero for the elastic point), and the
    returned stresses lie on the surface (f = 0) or inside (f < 0, elastic)."""
    law = fe_mpm.MohrCoulomb(**SOIL, friction_angle=30.0, dilatancy_angle=10.0)
    history = {"be": np.tile(np.eye(3), (3, 1, 1)), "plastic_strain": np.array([0.0, 0.2, 0.1])}
    dF = np.array([np.diag([1.0 + 1e-6, 1.0]), np.diag([0.97, 1.01]), [[1.0, 0.04], [0.0, 0.99]]])
    result = law.return_map(dF, history)
    assert result.region[0] == ELASTIC and np.all(result.region[1:] != ELASTIC)
    f = law.yield_function(result.tau)
    assert f[0] < -0.5 * SOIL["cohesion"]
    assert np.allclose(f[1:], 0.0, atol=1e-9 * SOIL["cohesion"])
    F3 = embed_3d(dF)
    trial = 0.5 * np.log(np.linalg.eigvalsh(F3 @ np.swapaxes(F3, 1, 2)))
    elastic = 0.5 * np.log(np.linalg.eigvalsh(result.history["be"]))
    # εᵉ of the returned stress: the Hencky law, τ_A = λ tr εᵉ + 2μ εᵉ_A, inverted
    tau = np.linalg.eigvalsh(result.tau)
    mu, lam = law.mu, law.bulk_modulus - 2 * law.mu / 3
    from_tau = (tau - lam / (3 * lam + 2 * mu) * tau.sum(axis=1, keepdims=True)) / (2 * mu)
    assert np.allclose(elastic, from_tau, rtol=0, atol=1e-12)
    increment = np.sqrt(2 / 3) * np.linalg.norm(trial - elastic, axis=1)
    assert increment[0] == pytest.approx(0.0, abs=1e-12) and np.all(increment[1:] > 1e-3)
    assert np.allclose(
        result.history["plastic_strain"] - history["plastic_strain"], increment, rtol=1e-9, atol=0
    )
    assert result.history["plastic_strain"][0] == 0.0


def test_parameters_at_the_edge_of_their_range_are_accepted():
    for ok in (
        dict(friction_angle=89.9, dilatancy_angle=89.9),
        dict(cohesion=0.0, friction_angle=0.1),
        dict(density=0.5),
        dict(friction_angle=0.0),
    ):
        law = fe_mpm.MohrCoulomb(**{**dict(E=1e4, nu=0.3, cohesion=10.0), **ok})
        assert all(getattr(law, k) == v for k, v in ok.items())
