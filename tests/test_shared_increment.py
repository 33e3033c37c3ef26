"""Point domains whose pieces share their point's increment (``shared_increment=True``).

Every piece of a domain takes the share-weighted mean of the grid's increments over
the point's pieces; the Jacobian adds the couplings this makes across the cells of a
domain (:mod:`fe_mpm.shared_increment`).
"""

import numpy as np
import pytest
from law_checks import TAYLOR_EPS

import fe_mpm
from fe_mpm import scenes
from fe_mpm.markers import Markers
from fe_mpm.verification import rates, taylor_remainders

EPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4)


def _cook(formulation, nu, steps, material=None, **options):
    """Cook at 5 N on n = 8 after ``steps`` steps: domains that straddle cells."""
    sim = scenes.cook_membrane(
        8,
        nu,
        formulation,
        traction=5 / 16,
        load="points",
        margin=4,
        point_domains=True,
        shared_increment=True,
        **({"material": material} if material else {}),
        **options,
    )
    sim.run(steps / 10, steps, progress=False)
    return sim


def _remainders(sim, corrected: bool, seed: int = 0, eps=EPS):
    """Taylor remainders of the next step's residual and Jacobian about a random iterate."""
    rng = np.random.default_rng(seed)
    # As Simulation.step does with domains: the pieces take the step in the points' place.
    points, markers = sim.points, sim.markers
    sim.points = sim.domains.sample(points, sim.tracker)
    sim.markers, sim.domains.active = Markers(), True
    try:
        return _taylor(sim, corrected, rng, eps)
    finally:
        sim.points, sim.markers, sim.domains.active = points, markers, False


def _taylor(sim, corrected: bool, rng, eps):
    _, _, R, J, _ = sim.prepare_step(sim.t + 0.1)
    shift = sim._shift
    assert shift.pairs[0].size > 100  # pieces in several cells: it would test nothing
    shift.hold([])
    plain = J.assemble_matrix

    def with_couplings(A=None, bcs=()):
        A = plain(A, bcs)
        shift.correct(A)
        return A

    if corrected:
        J.assemble_matrix = with_couplings
    sim.w.x.array[:] = rng.uniform(-0.02, 0.02, sim.w.x.array.size)
    d = rng.uniform(-1.0, 1.0, sim.w.x.array.size)
    regions = []

    def refresh():  # a pointwise law's regions must not change between the evaluations
        result = sim.refresh_material()
        if result is not None:
            regions.append(result.region.copy())

    r0, r1 = taylor_remainders(R, J, sim.w, d, eps, before_assembly=refresh)
    assert all(np.array_equal(regions[0], r) for r in regions)
    return r0, r1, regions


@pytest.mark.parametrize(
    "formulation, nu, material",
    [
        ("u", 0.3, None),
        ("up", 0.499, None),
        ("up", 0.3, fe_mpm.MohrCoulomb(E=70.0, nu=0.3, cohesion=0.3, friction_angle=20.0)),
    ],
    ids=["u", "up", "up-mohr-coulomb"],
)
def test_the_jacobian_with_the_couplings_across_cells_is_consistent(formulation, nu, material):
    """Cook after three steps at 5 N (domains across cells): the residual with every piece
    at its point's mean increment and the Jacobian with the couplings across cells pass the
    Taylor test (remainder falls as ε²), a Neo-Hookean law in u and u-p and a Mohr-Coulomb
    law whose return runs outside UFL; without the couplings the remainder falls as ε only
    (rate < 1.2), so the test can fail."""
    sim = _cook(formulation, nu, 3, material)
    eps = EPS if material is None else TAYLOR_EPS  # no point may change its return's region
    r0, r1, regions = _remainders(sim, corrected=True, eps=eps)
    assert np.all(rates(eps, r0) > 0.9)
    assert np.all(rates(eps, r1) > 1.9), f"remainders {r1}"
    if material is not None:
        assert len(np.unique(regions[0])) >= 2  # elastic and plastic points
    _, r1, _ = _remainders(sim, corrected=False, eps=eps)
    assert np.all(rates(eps, r1) < 1.2)


def test_cook_converges_with_shared_increments_and_newton_stays_quadratic():
    """Cook at 5 N, u-p, ν = 0.499, 20 steps, against the converged 1.3542 (Taylor–Hood,
    test_domains.py): with shared increments 1.3184 and 1.3700 on n = 8 and 16 (−2.6 %,
    +1.2 %; the pieces' own increments −6.0 % and −0.8 %, standard MPM −1.2 % and +11.3 %,
    and on n = 32 shared +0.6 %, own −0.1 %, standard +22.9 %), and Newton takes at most 3
    iterations a step (the pieces' own tangent alone took 37–48 on n = 16). The points'
    volumes stay det F V₀."""
    converged = 1.3542
    errors = []
    for n in (8, 16):
        sim = scenes.cook_membrane(
            n,
            0.499,
            "up",
            traction=5 / 16,
            load="points",
            margin=n // 2,
            point_domains=True,
            shared_increment=True,
        )
        volume = sim.points.volume.copy()
        sim.run(1.0, 20, progress=False)
        errors.append(scenes.tip_deflection(sim) / converged - 1)
        assert max(r.newton_iterations for r in sim.history) <= 3
        np.testing.assert_allclose(sim.points.volume, np.linalg.det(sim.points.F) * volume, 1e-12)
    assert abs(errors[0]) < 0.04 and abs(errors[1]) < 0.02


def test_bad_input_names_the_option():
    mesh = fe_mpm.meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    points = fe_mpm.seed(mesh)
    law = fe_mpm.NeoHookean(E=1.0, nu=0.3)
    with pytest.raises(ValueError, match="needs point_domains=True"):
        fe_mpm.Simulation(mesh, points, law, shared_increment=True)
    with pytest.raises(TypeError, match="shared_increment must be True or False"):
        fe_mpm.Simulation(mesh, points, law, point_domains=True, shared_increment=1)
    with pytest.raises(NotImplementedError, match="shared_increment with formulation"):
        fe_mpm.Simulation(mesh, points, law, "u-nbva", point_domains=True, shared_increment=True)
