"""J2 plasticity in whole simulations: the plane-strain tension test and Cook's membrane.

Tension test (Iaconeta 2019 §5.4.2; data assumed as in demos/tension_plate.py):
the limit load per unit thickness is (2/√3) σ_Y W in plane strain.
"""

import numpy as np
import pytest

import fe_mpm
from fe_mpm import meshes
from fe_mpm.scenes import cook_membrane, tip_deflection

W, H, E, SIGMA_Y, U = 0.01, 0.02, 200e9, 250e6, 1e-4
LIMIT = 2 / np.sqrt(3) * SIGMA_Y * W


def tension(formulation, nu, steps=20):
    scene = meshes.tension_specimen(W, H, 0.001)
    points = fe_mpm.seed(scene.mesh, per_cell=3)
    sim = fe_mpm.Simulation(
        scene.mesh,
        points,
        fe_mpm.J2Plasticity(E, nu, SIGMA_Y),
        formulation,
        facet_tags=scene.facet_tags,
        dirichlet=[
            fe_mpm.Dirichlet(meshes.TENSION_BOTTOM),
            fe_mpm.Dirichlet(meshes.TENSION_TOP, value=lambda t: np.array([0.0, U * t])),
        ],
        reactions={"top": meshes.TENSION_TOP},
    )
    reports = sim.run(1.0, steps, progress=False)
    force = np.array([r.reactions["top"][1] for r in reports])
    return sim, reports, force


@pytest.mark.parametrize("nu", [0.3, 0.4999])
def test_tension_test_u_p_reaches_the_plane_strain_limit_load(nu):
    """Measured (40 steps): u-p +0.12 % (ν = 0.3) and +0.13 % (ν = 0.4999); 20 steps here."""
    sim, reports, force = tension("up", nu)
    assert abs(force.max() / LIMIT - 1) < 0.01
    assert force[:3].max() < 0.9 * LIMIT  # the first steps are elastic
    assert sim.points.history["plastic_strain"].max() > 0.005
    assert max(r.newton_iterations for r in reports) <= 10


def test_tension_test_u_form_locks_in_the_incompressible_case():
    """The displacement form overshoots the limit load at ν = 0.4999 (measured +3.7 %)
    and keeps climbing after yield; u-p stays flat at the limit."""
    _, _, force_u = tension("u", 0.4999)
    _, _, force_up = tension("up", 0.4999)
    assert force_u.max() / LIMIT - 1 > 0.02
    assert force_u.max() > force_up.max()
    plateau = slice(len(force_u) // 2, None)
    assert np.ptp(force_up[plateau]) < 1e-3 * LIMIT
    assert np.all(np.diff(force_u[plateau]) > 0)


def test_elastoplastic_cook_membrane_newton_stays_quadratic_over_twenty_steps():
    """Cook's membrane with J2 and linear hardening (E = 70, ν = 0.499, σ_Y = 0.243,
    H = 0.135; the variant of Simo & Rifai used by Code_Aster's SSLP v6.03.178), right
    edge traction 0.1125, u-p, n = 16, 20 load steps. Measured: 3 to 6 iterations per
    step, tip deflection 0.69987 (u locks: 0.160). The grid traction loses its top node
    from t = 0.7 (a warning says so); with the load on boundary points
    (``load="points"``) the tip reaches 0.847 in up to 11 iterations. No published
    value to choose between them was found, so this stays a regression check."""
    material = fe_mpm.J2Plasticity(70.0, 0.499, 0.243, 0.135)
    sim = cook_membrane(16, formulation="up", material=material, traction=0.1125, margin=2)
    reports = sim.run(1.0, 20, progress=False)
    assert len(reports) == 20  # no step was cut
    for r in reports:
        assert r.newton_iterations <= 8
        norms = np.array(r.residual_norms)
        # quadratic at the end: the last ratio well below the one before
        if len(norms) >= 4:
            assert (
                norms[-1] / norms[-2] < 1e-2 * max(norms[-2] / norms[-3], 1e-6)
                or norms[-1] < 1e-8 * norms[0]
            )
    assert sim.points.history["plastic_strain"].max() > 0.01
    # round-off moves the tip by 3e-13 (benchmarks/roundoff_spread.py); a regression value
    assert abs(tip_deflection(sim) / 0.69987 - 1) < 1e-3
