"""Frictional laws in the u-p forms: the return at the pressure of the field.

:mod:`fe_mpm.materials.mixed_return` runs a pressure-dependent law at the Kirchhoff
mean stress −J p of the pressure field. Checked here: at the mean stress the law
itself would give, it gives the law's deviator and a zero volumetric equation (every
region the law has); its four tangent blocks against finite differences, beyond
the apex too; the assembled u-p step against Taylor's expansion; and a homogeneous
plastic step in u-p against the same step in u.
"""

from __future__ import annotations

import numpy as np
import pytest
from law_checks import TAYLOR_EPS
from test_taylor import _simulation

import fe_mpm
from fe_mpm.materials.drucker_prager import MAST_TABLE_3_5
from fe_mpm.materials.mixed_return import BEYOND_APEX, return_at_mean_stress, spring_start
from fe_mpm.meshes import rectangle_mesh
from fe_mpm.verification import rates, taylor_remainders

LAWS = {
    "drucker-prager": fe_mpm.DruckerPrager(10.0, 0.3, 0.05, 30.0, 10.0, hardening=2.0),
    "mohr-coulomb": fe_mpm.MohrCoulomb(10.0, 0.3, 0.05, 30.0, 10.0),
    "modified": fe_mpm.ModifiedDruckerPrager(
        10.0, 0.3, **MAST_TABLE_3_5["dense"], apex_stress=0.05
    ),
    "mn-dp": fe_mpm.MatsuokaNakai(10.0, 0.3, **MAST_TABLE_3_5["dense"], apex_stress=0.05),
    "mn": fe_mpm.MatsuokaNakai(
        10.0, 0.3, **MAST_TABLE_3_5["dense"], apex_stress=0.05, potential="matsuoka-nakai"
    ),
}
#: Where the law's own return is at its apex or on its cutoff, the mean stress does
#: not fix the volumetric strain (any extra dilation is plastic): those are checked
#: beyond the apex instead.
AT_APEX = {
    "drucker-prager": (3,),
    "mohr-coulomb": (4,),
    "modified": (3,),
    "mn-dp": (3,),
    "mn": (3,),
}


def _points(law, g, n=300, seed=1):
    rng = np.random.default_rng(seed)
    dF = np.eye(g) + rng.uniform(-0.03, 0.03, (n, g, g))
    history = {name: h.initial_values(n) for name, h in law.history.items()}
    if "plastic_shear" in history:
        history["plastic_shear"][:] = 0.01  # φ_F ≈ 33°: a cone of some width
    return dF, history


@pytest.mark.parametrize("name", LAWS)
@pytest.mark.parametrize("g", [2, 3])
def test_at_the_laws_own_mean_stress_the_return_is_the_laws(name, g):
    law = LAWS[name]
    dF, history = _points(law, g)
    own = law.return_map(dF, history)
    mean = np.trace(own.tau, axis1=1, axis2=2) / 3.0
    mixed = return_at_mean_stress(law, dF, mean, history)
    inside = ~np.isin(own.region, AT_APEX[name])
    assert len(np.unique(own.region[inside])) >= 2  # elastic and plastic at least
    deviator = own.tau - mean[:, None, None] * np.eye(3)
    scale = np.abs(own.tau).max()
    assert np.abs(mixed.deviator - deviator).max() <= 1e-12 * scale
    assert np.abs(mixed.volumetric[inside]).max() <= 1e-13
    for key, value in own.history.items():
        assert np.allclose(mixed.history[key][inside], value[inside], rtol=1e-10, atol=1e-13)


def _finite_difference_errors(law, dF, mean, history, blocks, h=1e-6):
    """max |central difference − tangent| of ∂s/∂ΔF, ∂v/∂ΔF, ∂s/∂τ̄_m, ∂v/∂τ̄_m, each
    over the largest entry of its block, where no difference left the point's region;
    and the regions of the points compared."""
    g = dF.shape[1]
    base = return_at_mean_stress(law, dF, mean, history)
    ds_dF, ds_dm, dv_dF, dv_dm = blocks if blocks is not None else base.tangent
    same = np.ones(len(dF), dtype=bool)
    errors = np.zeros(4)
    pairs = []
    for k, m in np.ndindex(g, g):
        E = np.zeros((g, g))
        E[k, m] = h
        pairs.append(((dF + E, mean), (dF - E, mean), h, (ds_dF[..., k, m], dv_dF[:, k, m]), 0))
    hm = h
    pairs.append(((dF, mean + hm), (dF, mean - hm), hm, (ds_dm, dv_dm), 2))
    for up_args, down_args, step, (ds, dv), slot in pairs:
        up = return_at_mean_stress(law, *up_args, history)
        down = return_at_mean_stress(law, *down_args, history)
        same &= (up.region == base.region) & (down.region == base.region)
        fd_s = (up.deviator - down.deviator) / (2 * step)
        fd_v = (up.volumetric - down.volumetric) / (2 * step)
        errors[slot] = max(errors[slot], np.abs(fd_s - ds).max(axis=(1, 2))[same].max())
        errors[slot + 1] = max(errors[slot + 1], np.abs(fd_v - dv)[same].max())
    scales = [np.abs(b).max() for b in (ds_dF, dv_dF, ds_dm, dv_dm)]
    return errors / np.maximum(scales, 1e-300), base.region[same]


@pytest.mark.parametrize("name", LAWS)
@pytest.mark.parametrize("g", [2, 3])
def test_tangent_blocks_match_finite_differences_in_every_region(name, g):
    """The four blocks against central differences (relative to each block's largest
    entry), with the field's mean stress pushed up to put points beyond the apex.

    1e-5: the differences (step 1e-6) carry the round-off of two nested root solves
    (the law's and the shift's, about 1e-13 in δ beyond the apex) and the curvature
    of the spectral maps; a tangent without one coupling is off by more than 0.1
    (the negative control below)."""
    law = LAWS[name]
    dF, history = _points(law, g)
    own = law.return_map(dF, history)
    mean = np.trace(own.tau, axis1=1, axis2=2) / 3.0 + 0.02
    errors, regions = _finite_difference_errors(law, dF, mean, history, None)
    assert BEYOND_APEX in regions and len(np.unique(regions)) >= 3
    assert np.all(errors <= 1e-5), errors


def test_the_finite_difference_check_can_fail():
    """Negative control: without the coupling ∂s/∂τ̄_m the check fails."""
    law = LAWS["drucker-prager"]
    dF, history = _points(law, 2)
    own = law.return_map(dF, history)
    mean = np.trace(own.tau, axis1=1, axis2=2) / 3.0
    ds_dF, ds_dm, dv_dF, dv_dm = return_at_mean_stress(law, dF, mean, history).tangent
    errors, _ = _finite_difference_errors(
        law, dF, mean, history, (ds_dF, 0.0 * ds_dm, dv_dF, dv_dm)
    )
    assert errors[2] > 0.1


def test_beyond_the_apex_the_pressure_is_held_by_a_soft_spring():
    """Drucker–Prager without hardening: s = 0 beyond the apex, and the volumetric
    equation continues that of the cone (its slope 1/K_apex = 1e3/K)."""
    law = fe_mpm.DruckerPrager(10.0, 0.3, 0.05, 30.0, 10.0)
    apex = law.apex / 3.0
    dF = np.tile(np.array([[1.01, 0.02], [0.0, 1.0]]), (3, 1, 1))
    history = {name: h.initial_values(3) for name, h in law.history.items()}
    start = spring_start(np.array(apex), law.mu)
    mean = np.array([start - 1e-14, apex + 1e-3, apex + 2e-3])
    out = return_at_mean_stress(law, dF, mean, history)
    assert out.region.tolist()[1:] == [BEYOND_APEX, BEYOND_APEX]
    assert np.abs(out.deviator[1:]).max() <= 1e-12
    slope = (out.volumetric[2] - out.volumetric[1]) / 1e-3
    assert slope == pytest.approx(-1e3 / law.bulk_modulus, rel=1e-9)
    # Continuous where the spring starts: v just below it, and v from beyond
    # extrapolated there, agree to round-off.
    v_start = out.volumetric[1] - slope * (mean[1] - start)
    assert abs(v_start - out.volumetric[0]) <= 1e-10 * abs(out.volumetric[0])


@pytest.mark.parametrize(
    "name, formulation",
    [
        ("drucker-prager", "up"),
        ("mohr-coulomb", "up"),
        ("mn-dp", "up"),
        ("mn", "up"),
        ("drucker-prager", "up-p2p1"),
    ],
)
@pytest.mark.parametrize("dim", [2, 3])
def test_assembled_up_step_is_consistent(name, formulation, dim):
    """Taylor test of an assembled u-p (and P2/P1) step with points on the surface and
    beyond the apex (c = 0.01 Pa, so that pressures of ±0.02 Pa put some there); both
    Matsuoka–Nakai flows."""
    law = {
        "drucker-prager": fe_mpm.DruckerPrager(10.0, 0.3, 0.01, 30.0, 10.0, hardening=2.0),
        "mohr-coulomb": fe_mpm.MohrCoulomb(10.0, 0.3, 0.01, 30.0, 10.0),
        "mn-dp": fe_mpm.MatsuokaNakai(10.0, 0.3, **MAST_TABLE_3_5["dense"], apex_stress=0.01),
        "mn": fe_mpm.MatsuokaNakai(
            10.0, 0.3, **MAST_TABLE_3_5["dense"], apex_stress=0.01, potential="matsuoka-nakai"
        ),
    }[name]
    rng, sim = _simulation(dim, formulation, seed=5, material=law)
    if "plastic_shear" in sim.points.history:
        sim.points.history["plastic_shear"][:] = 0.01
    _, _, R, J, _ = sim.prepare_step(1.0)
    sim.w.x.array[:] = rng.uniform(-0.02, 0.02, sim.w.x.array.size)
    regions = []

    def refresh():
        regions.append(sim.refresh_material().region.copy())

    d = rng.uniform(-1.0, 1.0, sim.w.x.array.size)
    eps = tuple(e / 4 for e in TAYLOR_EPS)  # no point changes region (asserted)
    r0, r1 = taylor_remainders(R, J, sim.w, d, eps, before_assembly=refresh)
    assert all(np.array_equal(regions[0], r) for r in regions)
    assert BEYOND_APEX in regions[0] and len(np.unique(regions[0])) >= 2
    assert np.all(rates(eps, r0) > 0.9)
    assert np.all(rates(eps, r1) > 1.9), f"remainders {r1}"


@pytest.mark.parametrize(
    "law",
    [
        fe_mpm.DruckerPrager(1e4, 0.3, 10.0, 30.0, 10.0, hardening=1e3),
        fe_mpm.MohrCoulomb(1e4, 0.3, 10.0, 30.0, 10.0),
    ],
    ids=["drucker-prager", "mohr-coulomb"],
)
def test_homogeneous_plastic_step_in_up_is_the_step_in_u(law):
    """A square under a homogeneous ΔF on its whole boundary (simple shear with 1 %
    compression, plastic): u-p gives the stress and history of u to 1e-12."""
    H = np.array([[-0.01, 0.0], [0.1, 0.0]])

    def run(formulation):
        mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (4, 4))

        def edge(x):
            ends = np.isclose(x[0], 0.0) | np.isclose(x[0], 1.0)
            return ends | np.isclose(x[1], 0.0) | np.isclose(x[1], 1.0)

        sim = fe_mpm.Simulation(
            mesh,
            fe_mpm.seed(mesh, 3, density=1.0),
            law,
            formulation,
            dirichlet=[fe_mpm.Dirichlet(edge, profile=lambda x, t: (H @ x[:2]) * t)],
        )
        sim.run(1.0, 1, progress=False)
        return sim.points

    u, up = run("u"), run("up")
    assert u.history["plastic_strain"].min() > 0.01  # every point plastic
    scale = np.abs(u.stress).max()
    assert np.abs(up.stress - u.stress).max() <= 1e-12 * scale
    assert np.allclose(up.history["plastic_strain"], u.history["plastic_strain"], rtol=1e-12)
