"""Point domains (``Simulation(point_domains=m)``): a point's volume spread over the cells
its convected domain covers, sampled by m² sub-points per step."""

from mpi4py import MPI

import meshio
import numpy as np
import pytest
from dolfinx.mesh import create_unit_cube

import fe_mpm
from fe_mpm import meshes, scenes
from fe_mpm.domains import subdivision_centroids

COOK_LOAD = 5.0 / 16.0  # 5 N on the right edge: large rotations, points cross cells


def _cook(n, steps, m, formulation="up", nu=0.499, **options):
    sim = scenes.cook_membrane(
        n,
        nu,
        formulation,
        traction=COOK_LOAD,
        load="points",
        margin=n // 2,
        point_domains=m,
        **options,
    )
    sim.run(1.0, steps, progress=False)
    return sim


@pytest.mark.parametrize("m", [1, 2, 3, 5])
def test_the_sub_points_are_the_centroids_of_equal_sub_triangles(m):
    lam = subdivision_centroids(m)
    assert lam.shape == (m * m, 3) and np.all(lam > 0)
    assert np.allclose(lam.sum(axis=1), 1.0, rtol=0, atol=1e-15)
    # Equal weights integrate the linear functions exactly: the mean is the centroid.
    assert np.allclose(lam.mean(axis=0), 1 / 3, rtol=0, atol=1e-15)
    # All distinct, and on the lattice of the sub-triangles' centroids (multiples of 1/3m).
    assert len(np.unique(np.round(lam * 3 * m, 9), axis=0)) == m * m
    assert np.allclose(lam * 3 * m, np.round(lam * 3 * m), rtol=0, atol=1e-12)


def test_one_step_of_the_u_form_is_standard_mpm():
    """Before any point has moved, a domain is its own cell and a P1 strain is constant
    there: the sub-points see the point's own ΔF, so one step is standard MPM (the
    finite element solve with the points as Gauss points) to round-off."""
    tips = [scenes.tip_deflection(_cook(8, 1, m, "u", nu=0.33)) for m in (1, 3)]
    assert tips[1] == pytest.approx(tips[0], rel=1e-10)


def test_domains_cut_the_drift_of_cook_over_twenty_steps(tmp_path):
    """Cook's membrane at 5 N, u-p, ν = 0.499, n = 16, one point per cell: 20 load
    steps drift 16.5 % above the one-step answer with standard MPM (points crossing
    cells leave some cells empty inside the body) and 5.6 % with 3 x 3 sub-points per
    domain (measured; the drift halves with each refinement, benchmarks/cell_crossing.py).
    The points keep their mass, their volumes are det F V₀ and their domains' areas;
    the output holds the points, not the sub-points."""
    one_step = scenes.tip_deflection(_cook(16, 1, 1))
    standard = scenes.tip_deflection(_cook(16, 20, 1))
    sim = _cook(16, 20, 3, output_dir=tmp_path / "out")
    with_domains = scenes.tip_deflection(sim)
    assert standard / one_step - 1 > 0.15
    assert 0.0 < with_domains / one_step - 1 < 0.07
    pts = sim.points
    initial = fe_mpm.seed(
        sim.mesh, per_cell=1, cells=meshes.body_cells(meshes.cook_membrane(16, margin=8))
    )
    assert len(pts) == len(initial)
    assert pts.mass.sum() == pytest.approx(initial.mass.sum(), rel=1e-14)
    assert np.allclose(pts.volume, np.linalg.det(pts.F) * initial.volume, rtol=1e-12)
    edges = sim.domains.corners[:, 1:] - sim.domains.corners[:, :1]
    assert np.allclose(0.5 * np.abs(np.linalg.det(edges)), pts.volume, rtol=1e-12)
    pvd = (tmp_path / "out" / "particles.pvd").read_text()
    last = pvd.split('file="')[-1].split('"')[0]
    assert meshio.read(tmp_path / "out" / last).points.shape[0] == len(pts)


def test_free_fall_with_domains_is_exact():
    """A body in free fall across several cells is an exact discrete solution of
    Newmark's rule for every point (x − x₀ = ½ g t², v = g t), so it stays one with
    sub-points: velocity, acceleration and the update pass through them and back."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (4.0, 4.0), (8, 8))
    points = fe_mpm.seed(mesh, per_cell=1, density=1000.0)
    points.keep((points.x[:, 0] < 1.0) & (points.x[:, 1] > 3.0))
    g = np.array([3.0, -9.0])
    sim = fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.NeoHookean(1e6, 0.3, density=1000.0),
        dynamic=True,
        body_force=g,
        point_domains=2,
    )
    x0 = points.x.copy()
    sim.run(0.6, 6, progress=False)
    assert np.allclose(points.x - x0, 0.5 * g * 0.6**2, rtol=1e-10, atol=0)
    assert np.allclose(points.velocity, g * 0.6, rtol=1e-10, atol=0)
    assert np.allclose(points.acceleration, g, rtol=1e-10, atol=0)
    assert np.allclose(points.F, np.eye(2), rtol=0, atol=1e-12)


def test_a_plastic_law_gathers_its_history_from_the_sub_points():
    """J2 squeezed between two grid edges by 5 %: no point leaves its cell, whose P1
    strain is constant, so every sub-point returns exactly as its point would, and the
    gathered plastic strain (their mean) equals standard MPM's (measured: 2e-11
    relative, for plastic strains of 0.017 to 0.126)."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (4, 4))
    law = fe_mpm.J2Plasticity(E=1e4, nu=0.3, yield_stress=20.0)
    base = fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))
    top = fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 1.0), lambda t: (0.0, -0.05 * t))
    sims = [
        fe_mpm.Simulation(mesh, fe_mpm.seed(mesh), law, "u", dirichlet=[base, top], point_domains=m)
        for m in (1, 2)
    ]
    for sim in sims:
        sim.run(1.0, 4, progress=False)
    standard, domains = (s.points.history["plastic_strain"] for s in sims)
    assert standard.min() > 0.01
    assert np.allclose(domains, standard, rtol=1e-9, atol=0)
    assert np.allclose(sims[1].points.x, sims[0].points.x, rtol=0, atol=1e-11)


@pytest.mark.parametrize(("m", "error"), [(0, ValueError), (2.0, TypeError)])
def test_point_domains_must_be_a_positive_int(m, error):
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    with pytest.raises(error, match="point_domains"):
        fe_mpm.Simulation(mesh, fe_mpm.seed(mesh), fe_mpm.NeoHookean(1.0, 0.3), point_domains=m)


def test_point_domains_refuse_3d_and_dropping_points():
    cube = create_unit_cube(MPI.COMM_SELF, 1, 1, 1)
    with pytest.raises(NotImplementedError, match="point_domains > 1 works on triangles"):
        fe_mpm.Simulation(cube, fe_mpm.seed(cube), fe_mpm.NeoHookean(1.0, 0.3), point_domains=2)
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    with pytest.raises(ValueError, match="points_leaving='raise'"):
        fe_mpm.Simulation(
            mesh,
            fe_mpm.seed(mesh),
            fe_mpm.NeoHookean(1.0, 0.3),
            point_domains=2,
            points_leaving="drop",
        )
