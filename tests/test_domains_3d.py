"""Point domains on tetrahedra: clipping a tetrahedron by cells, tiling a cell, and
the 3D runs that show what the domains are for."""

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx.mesh import CellType, create_box

import fe_mpm
from fe_mpm import scenes
from fe_mpm.domains import RESET_QUALITY, PointDomains, shape_quality
from fe_mpm.materials import route
from fe_mpm.tet_clipping import clip_to_reference_tet, tet_volumes
from fe_mpm.tilings import equal_tiling
from fe_mpm.tracker import Tracker

REFERENCE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize(
    ("tet", "volume", "centroid"),
    [
        (REFERENCE, 1 / 6, (0.25, 0.25, 0.25)),  # the cell itself
        (REFERENCE[[1, 0, 2, 3]], 1 / 6, (0.25, 0.25, 0.25)),  # the other orientation
        (4 * REFERENCE - 1, 1 / 6, (0.25, 0.25, 0.25)),  # covers the cell
        # Shifted by half a cell along ξ₁: the corner tetrahedron at (1/2, 0, 0) is left.
        (REFERENCE - (0.5, 0, 0), 1 / 48, (0.125, 0.125, 0.125)),
        (0.2 * REFERENCE + 0.1, 0.2**3 / 6, (0.15, 0.15, 0.15)),  # wholly inside
        (REFERENCE + 2.0, 0.0, (0, 0, 0)),  # disjoint
        (REFERENCE + (1.0, 0, 0), 0.0, (0, 0, 0)),  # touches a corner only
        (REFERENCE * (-1, 1, 1), 0.0, (0, 0, 0)),  # shares a face only
    ],
)
def test_clipping_known_overlaps(tet, volume, centroid):
    v, c = clip_to_reference_tet(np.array([tet], dtype=float))
    assert v[0] == pytest.approx(volume, rel=1e-14, abs=1e-16)
    assert np.allclose(c[0], centroid, rtol=0, atol=1e-14)


def test_the_pieces_of_a_tetrahedron_add_up_to_it():
    """300 random tetrahedra in a cube of 2 × 2 × 2 × 6 cells, each cut by every
    cell: the pieces' volumes add up to the tetrahedron's, and their volume-weighted
    centroids give its centroid, to round-off. Cutting a cell by a tetrahedron's
    faces must leave no piece out and count none twice."""
    mesh = create_box(MPI.COMM_SELF, [[0, 0, 0], [1, 1, 1]], [2, 2, 2], CellType.tetrahedron)
    tracker = Tracker(mesh)
    nc = len(tracker.volumes)
    rng = np.random.default_rng(20261202)
    tets = rng.uniform(0.0, 1.0, (300, 4, 3))
    xi = tracker.barycentric(np.tile(tets.reshape(-1, 3), (nc, 1)), np.repeat(np.arange(nc), 1200))
    volume, centroid = clip_to_reference_tet(xi[:, 1:].reshape(nc * 300, 4, 3))
    volume = volume.reshape(nc, 300) * 6.0 * tracker.volumes[:, None]
    bary = np.concatenate([1.0 - centroid.sum(axis=1, keepdims=True), centroid], axis=1)
    x = np.einsum("kv,kvg->kg", bary, np.repeat(tracker.cell_vertices, 300, axis=0))
    moment = np.einsum("ct,ctg->tg", volume, x.reshape(nc, 300, 3))
    # Absolute round-off on the cube's scale: a random sliver's own volume carries a
    # larger relative one (seed 16 has one of 1.65e-6, off by 4e-18).
    assert np.allclose(volume.sum(axis=0), tet_volumes(tets), rtol=1e-12, atol=1e-15)
    assert np.allclose(moment / volume.sum(axis=0)[:, None], tets.mean(axis=1), atol=1e-12)
    assert np.mean(np.count_nonzero(volume, axis=0) > 1) > 0.9  # most cross facets


def _compiled_route(monkeypatch) -> None:
    """Take the compiled route, whatever the environment says, and check that it is taken."""
    monkeypatch.delenv(route.ENVIRONMENT_VARIABLE, raising=False)
    assert route.compiled_module("fe_mpm.clip_kernels", "the cuts") is not None


def test_the_compiled_cut_gives_the_numpy_route_to_the_bit(monkeypatch):
    """20 000 tetrahedra about the reference cell, a tenth with corners or faces on
    its faces, clipped by the compiled loops and by the numpy route's four
    vectorised cuts (``FE_MPM_COMPILED=0``): the same volumes and centroids, bit for
    bit. The pieces must be summed in the numpy route's order: another order moves
    half of the volumes by round-off (reversed: up to 7e-17), which this sees."""
    _compiled_route(monkeypatch)
    rng = np.random.default_rng(20261206)
    tets = rng.uniform(-0.5, 1.1, (20_000, 4, 3))
    tets[:1_000, 0, 0] = 0.0  # a corner on ξ₁ = 0
    tets[1_000:2_000, :3, 2] = 0.0  # a face on ξ₃ = 0
    volume, centroid = clip_to_reference_tet(tets)
    monkeypatch.setenv(route.ENVIRONMENT_VARIABLE, "0")
    want, want_centroid = clip_to_reference_tet(tets)
    np.testing.assert_array_equal(volume, want)
    np.testing.assert_array_equal(centroid, want_centroid)
    assert 0.3 < np.mean((want > 0) & (want < 1 / 6)) < 0.95  # most were cut


@pytest.mark.parametrize("k", [1, 4, 8, 24, 32, 64])
def test_a_cell_is_tiled_by_k_equal_tetrahedra(k):
    """Equal volumes adding up to the cell's, and every one of 2 000 random points of
    the cell in exactly one tile: the tiles cover the cell once."""
    tiles = equal_tiling(k, 3)
    assert tiles.shape == (k, 4, 4)
    xi = tiles[..., 1:]
    assert np.allclose(tet_volumes(xi), 1 / (6 * k), rtol=1e-12, atol=0)
    rng = np.random.default_rng(k)
    samples = rng.dirichlet(np.ones(4), 2000)  # uniform in the cell, barycentric
    # Each sample's barycentric coordinates in each tile (tiles are barycentric too).
    lam = np.linalg.solve(np.swapaxes(tiles, 1, 2)[None], samples[:, None, :, None])[..., 0]
    assert np.array_equal(np.sum(np.all(lam > -1e-12, axis=2), axis=1), np.ones(2000))


@pytest.mark.parametrize("k", [2, 3, 5, 16, 57])
def test_other_counts_have_no_equal_tiling_of_a_tetrahedron(k):
    assert equal_tiling(k, 3) is None


def test_shape_quality_of_tetrahedra():
    regular = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    flat = regular.copy()
    flat[:, 2] *= 1e-9
    assert shape_quality(np.array([regular, 3.0 * regular, regular[[1, 0, 2, 3]]])) == (
        pytest.approx([1.0, 1.0, 1.0], rel=1e-14)
    )
    assert shape_quality(flat[None])[0] < 1e-5


def test_a_distorted_tetrahedral_domain_is_redrawn_with_its_volume_around_its_point():
    mesh = create_box(MPI.COMM_SELF, [[0, 0, 0], [1, 1, 1]], [2, 2, 2], CellType.tetrahedron)
    points = fe_mpm.seed(mesh)
    tracker = Tracker(mesh)
    domains = PointDomains(points, tracker)
    k = int(np.argmin(np.linalg.norm(points.x - 0.5, axis=1)))
    x = points.x[k].copy()
    sheared = domains.corners[k] - x
    sheared[:, 0] += 8.0 * sheared[:, 2]  # x += 8 z: volume kept
    domains.corners[k] = x + sheared
    assert shape_quality(domains.corners[k : k + 1])[0] < RESET_QUALITY
    volume = tet_volumes(domains.corners[k : k + 1])[0]
    domains.sample(points, tracker)
    assert domains.resets == 1
    assert tet_volumes(domains.corners[k : k + 1])[0] == pytest.approx(volume, rel=1e-12)
    assert np.allclose(domains.corners[k].mean(axis=0), x, rtol=0, atol=1e-14)
    own = tracker.cell_vertices[points.cell[k]][None]
    assert shape_quality(domains.corners[k : k + 1])[0] == pytest.approx(shape_quality(own)[0])


def _cook(n, steps, domains, formulation="up", per_cell=1):
    sim = scenes.cook_membrane(
        n,
        0.499,
        formulation,
        per_cell=per_cell,
        traction=5.0 / 16.0,
        load="points",
        margin=n // 2,
        thickness=44.0 / n,
        point_domains=domains,
    )
    sim.run(1.0, steps, progress=False)
    return scenes.tip_deflection(sim)


@pytest.mark.parametrize("per_cell", [1, 4])
def test_one_step_on_tetrahedra_is_standard_mpm(per_cell):
    """Before any point has moved, the domains tile the cells (the cell itself, or
    its four tetrahedra from the centroid) and a P1 strain is constant in a cell, so
    one step with domains is standard MPM to round-off."""
    tips = [_cook(4, 1, domains, "u", per_cell) for domains in (False, True)]
    assert tips[1] == pytest.approx(tips[0], rel=1e-10)


def test_the_3d_column_converges_with_domains_and_stalls_without():
    """AMPLE's column as a prism of tetrahedra, 20 load steps, 8, 16 and 32 cells
    high: standard MPM's stress error stalls at 5–6 % (measured 5.30, 5.55, 5.60 %),
    with point domains it halves with every refinement (measured 2.12e-2, 1.00e-2,
    5.01e-3), as in 2D."""

    def error(ny, domains):
        sim = scenes.elastic_column(ny, dim=3, point_domains=domains)
        sim.run(1.0, 20, progress=False)
        return scenes.column_stress_error(sim)

    standard = [error(ny, False) for ny in (8, 16, 32)]
    domains = [error(ny, True) for ny in (8, 16, 32)]
    assert min(standard) > 0.05
    assert domains[0] < 0.025
    assert all(coarse / fine > 1.9 for coarse, fine in zip(domains, domains[1:]))


@pytest.mark.slow
def test_cook_on_tetrahedra_loses_its_drift_with_domains():
    """Cook's membrane extruded into tetrahedra with plane-strain rollers, u-p,
    ν = 0.499, 5 N over 20 steps, n = 16, against the converged 2D answer 1.3542:
    standard MPM ends 4 % above it (measured 1.4103; the one-step answer on this
    grid is 1.2886, −4.8 %), point domains 1.8 % below (measured 1.3303; 2D at the
    same n: −0.8 %)."""
    converged = 1.3542
    assert _cook(16, 20, False) / converged - 1 > 0.03
    assert abs(_cook(16, 20, True) / converged - 1) < 0.025


def test_point_domains_on_tetrahedra_refuse_p2():
    cube = create_box(MPI.COMM_SELF, [[0, 0, 0], [1, 1, 1]], [1, 1, 1], CellType.tetrahedron)
    with pytest.raises(NotImplementedError, match="tetrahedra works with P1"):
        fe_mpm.Simulation(
            cube,
            fe_mpm.seed(cube, per_cell=4),
            fe_mpm.NeoHookean(1.0, 0.3),
            "up-p2p1",
            point_domains=True,
        )
