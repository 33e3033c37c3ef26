"""The geometry under point domains: clipping a triangle by cells, and tiling a cell."""

import numpy as np
import pytest

import fe_mpm
from fe_mpm import meshes
from fe_mpm.clipping import _pieces_in_reference_cell, clip_to_reference_cell, piece_rule
from fe_mpm.domains import _may_overlap
from fe_mpm.materials import route
from fe_mpm.tilings import equal_tiling, initial_domains
from fe_mpm.tracker import Tracker

REFERENCE = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
#: The unit square as the reference cell and its mirror image, in the reference
#: cell's coordinates: a triangle inside the square is cut into exactly two pieces.
MIRROR = np.array([[1.0, 1.0], [0.0, 1.0], [1.0, 0.0]])


def _area_and_centroid(t):
    e = t[:, 1:] - t[:, :1]
    return 0.5 * np.abs(np.linalg.det(e)), t.mean(axis=1)


@pytest.mark.parametrize(
    ("triangle", "area", "centroid"),
    [
        (REFERENCE, 0.5, (1 / 3, 1 / 3)),  # the cell itself
        (REFERENCE[::-1], 0.5, (1 / 3, 1 / 3)),  # clockwise
        ([[-1, -1], [3, -1], [-1, 3]], 0.5, (1 / 3, 1 / 3)),  # covers the cell
        ([[-0.5, 0], [0.5, 0], [0, 0.5]], 0.125, (1 / 6, 1 / 6)),  # half inside
        ([[0.1, 0.1], [0.3, 0.1], [0.1, 0.3]], 0.02, (1 / 6, 1 / 6)),  # wholly inside
        ([[2, 2], [3, 2], [2, 3]], 0.0, (0, 0)),  # disjoint
        ([[1, 0], [2, 0], [1, 1]], 0.0, (0, 0)),  # touches a corner only
        ([[0.5, 0.5], [1, 1], [0, 1]], 0.0, (0, 0)),  # shares an edge only
    ],
)
def test_clipping_known_overlaps(triangle, area, centroid):
    a, c = clip_to_reference_cell(np.array([triangle], dtype=float))
    assert a[0] == pytest.approx(area, rel=1e-14, abs=1e-15)
    assert np.allclose(c[0], centroid, rtol=0, atol=1e-14)


def test_the_pieces_of_a_triangle_add_up_to_it():
    """500 random triangles in the unit square, cut by its two halves: the pieces'
    areas add up to the triangle's, and their area-weighted centroids give its
    centroid (both to round-off), whatever the orientation."""
    rng = np.random.default_rng(20261202)
    t = rng.uniform(0.0, 1.0, (500, 3, 2))
    a1, c1 = clip_to_reference_cell(t)
    # The mirror half in its own reference coordinates: ξ' = (1, 1) − ξ.
    a2, c2 = clip_to_reference_cell(1.0 - t)
    c2 = 1.0 - c2
    area, centroid = _area_and_centroid(t)
    assert np.allclose(a1 + a2, area, rtol=1e-12, atol=1e-15)
    both = (a1 > 0) & (a2 > 0)
    assert both.sum() > 100  # most triangles cross the diagonal
    weighted = (a1[:, None] * c1 + a2[:, None] * np.where(a2[:, None] > 0, c2, 0)) / area[:, None]
    assert np.allclose(weighted, centroid, rtol=0, atol=1e-12)


def _random_triangles_on_the_cell(rng, n: int) -> np.ndarray:
    """Triangles (n, 3, 2) about the reference cell, a tenth with vertices on its edges."""
    t = rng.uniform(-0.6, 1.2, (n, 3, 2))
    t[: n // 30, 0, 0] = 0.0  # on ξ₁ = 0
    t[n // 30 : n // 15, :, 1] = 0.0  # an edge along ξ₂ = 0
    t[n // 15 : n // 10, 0] = 1.0 - t[n // 15 : n // 10, 0, ::-1]  # near ξ₁ + ξ₂ = 1
    t[n // 15 : n // 10, 0, 1] = 1.0 - t[n // 15 : n // 10, 0, 0]  # on it
    return t


def _compiled_route(monkeypatch) -> None:
    """Take the compiled route, whatever the environment says, and check that it is taken."""
    monkeypatch.delenv(route.ENVIRONMENT_VARIABLE, raising=False)
    assert route.compiled_module("fe_mpm.clip_kernels", "the cuts") is not None


def test_the_compiled_clipping_gives_the_numpy_route_to_the_bit(monkeypatch):
    """20 000 triangles clipped by the compiled loops and by the numpy route's three
    vectorised Sutherland–Hodgman passes (``FE_MPM_COMPILED=0``): the same polygons,
    vertex by vertex and bit for bit, including triangles with vertices and edges on
    the cell's edges. A loop that emitted a crossing before its vertex would reorder
    the vertices; one that computed a crossing otherwise would move them by round-off."""
    _compiled_route(monkeypatch)
    rng = np.random.default_rng(20261206)
    t = _random_triangles_on_the_cell(rng, 20_000)
    polygons, counts = _pieces_in_reference_cell(t)
    monkeypatch.setenv(route.ENVIRONMENT_VARIABLE, "0")
    want, want_counts = _pieces_in_reference_cell(t)
    np.testing.assert_array_equal(counts, want_counts)
    np.testing.assert_array_equal(polygons, want)
    assert np.count_nonzero((counts > 3) & (counts < 7)) > 5_000  # most were clipped


@pytest.mark.parametrize("g", [2, 3])
def test_the_compiled_overlap_test_gives_the_numpy_route(monkeypatch, g):
    """Which (domain, cell) pairs may meet (their bounding boxes do, and the cell does
    not lie beyond a face of the domain), in compiled loops and by the numpy route,
    on 100 000 random pairs: the same answer for every pair, with pairs of each kind."""
    _compiled_route(monkeypatch)
    rng = np.random.default_rng(g)
    corners = rng.uniform(0.0, 1.0, (5_000, g + 1, g))
    cells = rng.uniform(0.0, 1.0, (3_000, g + 1, g))
    owner, cell = rng.integers(0, 5_000, 100_000), rng.integers(0, 3_000, 100_000)
    bounds = corners.min(axis=1), corners.max(axis=1)
    boxes = cells.min(axis=1), cells.max(axis=1)
    got = _may_overlap(corners, bounds, cells, boxes, owner, cell)
    monkeypatch.setenv(route.ENVIRONMENT_VARIABLE, "0")
    want = _may_overlap(corners, bounds, cells, boxes, owner, cell)
    np.testing.assert_array_equal(got, want)
    apart = ~np.all((boxes[0][cell] <= bounds[1][owner]) & (boxes[1][cell] >= bounds[0][owner]), 1)
    assert 0.2 < want.mean() < 0.9 and np.any(apart) and np.any(~apart & ~want)


def _quadratic(x):
    return x[..., 0] ** 2 + 0.3 * x[..., 0] * x[..., 1] - x[..., 1] ** 2 + x[..., 0] - 0.7


def test_the_three_point_rule_integrates_quadratics_over_the_pieces_from_inside():
    """5 000 random triangles cut by the unit square's two halves: the degree-2 rule
    on the two pieces integrates a full quadratic over the triangle to round-off (its
    exact integral from the triangle's own three-point rule); every point lies
    strictly inside its piece's cell, and on a triangle the rule is the usual one."""
    rng = np.random.default_rng(20261202)
    t = rng.uniform(0.0, 1.0, (5000, 3, 2))
    a1, p1 = piece_rule(t, 2)
    a2, p2 = piece_rule(1.0 - t, 2)
    p2 = 1.0 - p2
    integral = a1 * _quadratic(p1).mean(axis=1) + a2 * _quadratic(p2).mean(axis=1)
    area, centroid = _area_and_centroid(t)
    exact = area * _quadratic(centroid[:, None] + 0.5 * (t - centroid[:, None])).mean(axis=1)
    assert np.allclose(integral, exact, rtol=0, atol=1e-15)
    cut = (a1 > 0) & (a2 > 0)
    assert cut.sum() > 2000  # most triangles cross the diagonal
    for a, p in ((a1, p1), (a2, 1.0 - p2)):
        lam = np.concatenate([1.0 - p.sum(axis=2, keepdims=True), p], axis=2)
        assert lam[a > 0].min() > 0.0
    assert np.allclose(piece_rule(t, 1)[0], a1, rtol=1e-12, atol=1e-15)
    inside = np.array([[[0.1, 0.1], [0.5, 0.2], [0.2, 0.6]]])
    c = inside.mean(axis=1)
    usual = c + 0.5 * (inside[0] - c)
    rule = piece_rule(inside, 2)[1][0]
    assert np.allclose(rule[np.lexsort(rule.T)], usual[np.lexsort(usual.T)])
    # A triangle given with a fourth vertex a hair off one edge's midpoint (clipped
    # from a larger one): the rule still aims at a true corner, away from the edges.
    kinked = np.array([[[0.1, -1e-12], [0.5, 1e-12], [0.3, 0.4]]])
    p = piece_rule(kinked, 2)[1][0]
    assert np.concatenate([1.0 - p.sum(axis=1, keepdims=True), p], axis=1).min() > 0.06
    with pytest.raises(ValueError, match="degree must be 1 or 2"):
        piece_rule(t, 3)


@pytest.mark.parametrize("k", [1, 3, 4, 6, 9, 12, 16, 24])
def test_a_cell_is_tiled_by_k_equal_triangles(k):
    tiles = equal_tiling(k)
    xi = tiles[..., 1:]
    area, _ = _area_and_centroid(xi)
    assert tiles.shape == (k, 3, 3)
    assert np.allclose(area, 0.5 / k, rtol=1e-13, atol=0)
    # Every tile lies in the cell, so equal areas adding up to the cell's leave no
    # room for overlap: the tiles cover it once.
    inside, _ = clip_to_reference_cell(xi)
    assert np.allclose(inside, area, rtol=1e-13, atol=0)


@pytest.mark.parametrize("k", [2, 5, 7, 15])
def test_other_counts_have_no_equal_tiling(k):
    assert equal_tiling(k) is None


@pytest.mark.parametrize("per_cell", [1, 3, 6, 7, 12])
def test_the_first_domains_tile_the_body(per_cell):
    """The points of a cell get the cell's equal tiles, one each, inside the cell,
    and share its volume and mass equally (seed's Gauss weights differ for 6 and 12
    points); they move to their tiles' centroids. The 7-point rule has no equal
    tiling: its points keep their volumes and get the cell shrunk to them."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (2.0, 1.0), (4, 3))
    points = fe_mpm.seed(mesh, per_cell=per_cell, density=3.0)
    volume, mass, x = points.volume.copy(), points.mass.copy(), points.x.copy()
    tracker = Tracker(mesh)
    corners = initial_domains(points, tracker.cell_vertices)
    area, centroid = _area_and_centroid(corners)
    assert np.allclose(area, points.volume, rtol=1e-12, atol=0)
    assert np.allclose(centroid, points.x, rtol=0, atol=1e-14)
    assert np.array_equal(points.x0, points.x)
    assert points.mass.sum() == pytest.approx(mass.sum(), rel=1e-14)
    assert np.allclose(points.mass, 3.0 * points.volume, rtol=1e-14, atol=0)
    xi = tracker.barycentric(corners.reshape(-1, 2), np.repeat(points.cell, 3))[:, 1:]
    inside, _ = clip_to_reference_cell(xi.reshape(-1, 3, 2))
    inside *= 2 * tracker.volumes[points.cell]
    if per_cell == 7:
        assert np.array_equal(points.volume, volume)
        assert np.allclose(points.x, x, rtol=0, atol=1e-14)
        assert not np.allclose(inside, area, rtol=1e-12, atol=0)
    else:
        assert np.allclose(area, tracker.volumes[points.cell] / per_cell, rtol=1e-12, atol=0)
        assert np.allclose(inside, area, rtol=1e-12, atol=0)
        # One tile each: no two points of a cell share a centroid.
        for c in np.unique(points.cell):
            mine = centroid[points.cell == c]
            assert len(np.unique(np.round(mine, 12), axis=0)) == per_cell


def test_fields_set_from_the_points_places_move_with_them_to_their_tiles():
    """A stress affine in x and a rigid spin's velocity, set before the domains move the
    points, are read at their new places exactly; a uniform F stays bit for bit."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (2.0, 1.0), (4, 3))
    points = fe_mpm.seed(mesh, per_cell=6, density=3.0)

    def stress(x):
        return np.einsum("n,ij->nij", 5.0 + 2.0 * x[:, 0] - 7.0 * x[:, 1], np.eye(3))

    def spin(x):
        return np.column_stack([-(x[:, 1] - 0.5), x[:, 0] - 1.0]) * 3.0

    points.stress, points.velocity = stress(points.x), spin(points.x)
    points.F[:] = np.diag([1.01, 0.99])
    before, x = points.F.copy(), points.x.copy()
    initial_domains(points, Tracker(mesh).cell_vertices)
    assert np.abs(points.x - x).max() > 0.02  # the test can fail: the points moved
    assert np.allclose(points.stress, stress(points.x), rtol=0, atol=1e-12)
    assert np.allclose(points.velocity, spin(points.x), rtol=0, atol=1e-12)
    assert np.array_equal(points.F, before)
    assert np.array_equal(points.x0, points.x)


def test_cells_without_a_tiling_keep_shrunk_cells():
    """Cells of 2 points (no equal tiling) take their cell shrunk to each point's
    volume around it; the other cells are still tiled."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    points = fe_mpm.seed(mesh, per_cell=3)
    drop = np.zeros(len(points), dtype=bool)
    drop[0] = True  # the first cell keeps 2 of its 3 points
    points.keep(~drop)
    x = points.x.copy()
    tracker = Tracker(mesh)
    corners = initial_domains(points, tracker.cell_vertices)
    area, centroid = _area_and_centroid(corners)
    pair = np.flatnonzero(points.cell == points.cell[0])
    assert pair.size == 2
    assert np.allclose(area[pair], points.volume[pair], rtol=1e-12, atol=0)
    assert np.allclose(centroid[pair], x[pair], rtol=0, atol=1e-14)
    others = np.setdiff1d(np.arange(len(points)), pair)
    assert not np.allclose(centroid[others], x[others], rtol=0, atol=1e-3)


def test_cells_a_trimmed_body_fills_in_part_keep_shrunk_cells():
    """A disc trimmed from a grid seeded with 3 points per cell: its edge cells keep
    1 or 2 of their points, whose volumes do not fill the cell; those points stay
    where they are, with their cell shrunk to their volume; full cells are tiled."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (8, 8))
    points = fe_mpm.seed(mesh, per_cell=3)
    points.keep(np.linalg.norm(points.x - 0.5, axis=1) < 0.4)
    x, volume = points.x.copy(), points.volume.copy()
    tracker = Tracker(mesh)
    corners = initial_domains(points, tracker.cell_vertices)
    area, centroid = _area_and_centroid(corners)
    count = np.bincount(points.cell)[points.cell]
    part = count < 3
    assert part.sum() > 8 and (~part).sum() > 100
    assert np.allclose(points.x[part], x[part], rtol=0, atol=1e-14)
    assert np.allclose(area, volume, rtol=1e-12, atol=0)
    assert np.allclose(centroid[part], x[part], rtol=0, atol=1e-14)
    assert not np.allclose(points.x[~part], x[~part], rtol=0, atol=1e-3)
