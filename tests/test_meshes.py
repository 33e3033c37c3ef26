"""gmsh scene builders."""

import math

import numpy as np
import pytest

import fe_mpm
from fe_mpm import meshes
from fe_mpm._dolfinx import dolfinx
from fe_mpm.references import lube_height, lube_runout, lube_time


def _grid_indices(scene, n):
    """Vertices of every cell as (i, j) in the n x n map of the unit square."""
    x = scene.mesh.geometry.x[scene.mesh.geometry.dofmaps[0]]
    xi = x[..., 0] / 48.0
    eta = (x[..., 1] - 44.0 * xi) / (44.0 - 28.0 * xi)
    return np.rint(n * xi).astype(int), np.rint(n * eta).astype(int)


@pytest.mark.parametrize("n", [1, 4, 7])
def test_structured_cook_cuts_lower_left_to_upper_right(n):
    scene = meshes.cook_membrane(n=n)
    assert scene.mesh.topology.index_map(2).size_local == 2 * n * n
    i, j = _grid_indices(scene, n)
    for a, b in ((0, 1), (1, 2), (0, 2)):
        di, dj = i[:, a] - i[:, b], j[:, a] - j[:, b]
        diagonal = (di != 0) & (dj != 0)
        assert np.all(di[diagonal] * dj[diagonal] > 0), "a diagonal runs upper-left to lower-right"
    x = scene.mesh.geometry.x[:, :2]
    assert np.min(np.linalg.norm(x - meshes.COOK_POINT_A, axis=1)) < 1e-12  # A is a node


def test_cook_tags_and_margin():
    n, margin = 8, 2
    plain = meshes.cook_membrane(n=n)
    scene = meshes.cook_membrane(n=n, margin=margin)
    assert meshes.body_cells(scene).size == 2 * n * n
    assert scene.cell_tags.find(meshes.COOK_MARGIN).size == 2 * 2 * n * margin
    for tag in (meshes.COOK_LOADED, meshes.COOK_CLAMPED, meshes.COOK_FREE):
        assert plain.facet_tags.find(tag).size > 0 and scene.facet_tags.find(tag).size > 0
    loaded = scene.facet_tags.find(meshes.COOK_LOADED)
    assert loaded.size == n  # only the body's right edge carries the load

    # The body cells of the grid with margins are the cells of the plain grid.
    def centroids(s, cells):
        c = s.mesh.geometry.x[s.mesh.geometry.dofmaps[0][cells], :2].mean(axis=1)
        return c[np.lexsort(c.T)]

    all_plain = np.arange(plain.mesh.topology.index_map(2).size_local)
    assert np.allclose(centroids(plain, all_plain), centroids(scene, meshes.body_cells(scene)))


def test_cook_extruded_into_tetrahedra_has_its_volume_and_every_face_tagged():
    """Cook in 3D: 6 tetrahedra per quad and layer, the membrane's volume, every
    boundary facet tagged once (the strips' meshes conform), the load on the
    membrane's right face only, the rollers' faces at z = 0 and z = thickness."""
    n, margin, t, layers = 4, 2, 1.5, 2
    scene = meshes.cook_membrane(n=n, margin=margin, thickness=t, layers=layers)
    mesh = scene.mesh
    assert mesh.geometry.dim == 3
    assert meshes.body_cells(scene).size == 6 * n * n * layers
    assert scene.cell_tags.find(meshes.COOK_MARGIN).size == 6 * 2 * n * margin * layers
    x = mesh.geometry.x[mesh.geometry.dofmaps[0][meshes.body_cells(scene)]]
    volume = np.abs(np.linalg.det(x[:, 1:] - x[:, :1])).sum() / 6.0
    assert volume == pytest.approx(0.5 * (44.0 + 16.0) * 48.0 * t, rel=1e-12)
    mesh.topology.create_connectivity(2, 3)
    boundary = np.sort(dolfinx.mesh.exterior_facet_indices(mesh.topology))
    assert np.array_equal(np.sort(scene.facet_tags.indices), boundary)

    def centres(tag):
        facets = scene.facet_tags.find(tag)
        nodes = dolfinx.mesh.entities_to_geometry(mesh, 2, facets)
        return mesh.geometry.x[nodes].mean(axis=1)

    loaded, faces = centres(meshes.COOK_LOADED), centres(meshes.COOK_FACES)
    assert np.allclose(loaded[:, 0], 48.0) and np.all((loaded[:, 1] > 44) & (loaded[:, 1] < 60))
    assert np.all(np.isclose(faces[:, 2], 0.0) | np.isclose(faces[:, 2], t))
    assert np.allclose(centres(meshes.COOK_CLAMPED)[:, 0], 0.0)
    with pytest.raises(ValueError, match="layers is for a 3D grid"):
        meshes.cook_membrane(n=2, layers=2)


def _cell_areas(scene, cells):
    x = scene.mesh.geometry.x[scene.mesh.geometry.dofmaps[0][cells], :2]
    e1, e2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    return 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


def test_unstructured_cook_has_the_trapezoid_area():
    scene = meshes.cook_membrane(structured=False, h=3.0)
    area = _cell_areas(scene, np.arange(scene.mesh.topology.index_map(2).size_local)).sum()
    assert area == pytest.approx(0.5 * (44.0 + 16.0) * 48.0, rel=1e-12)
    assert scene.mesh.topology.index_map(2).size_local > 200


def test_granular_column_tags_the_column_exactly():
    d_i, a = 0.0905, 3.0
    scene = meshes.granular_column(d_i, a, h=0.015)
    column = scene.cell_tags.find(meshes.COLLAPSE_COLUMN)
    assert _cell_areas(scene, column).sum() == pytest.approx(d_i * a * d_i, rel=1e-12)
    x = scene.mesh.geometry.x
    assert x[:, 0].max() == pytest.approx(1.6 * lube_runout(d_i, a) + 5 * 0.015)
    for tag, axis in ((meshes.COLLAPSE_WALL, 0), (meshes.COLLAPSE_BASE, 1)):
        facets = scene.facet_tags.find(tag)
        assert facets.size > 0
        scene.mesh.topology.create_connectivity(1, 0)
        nodes = scene.mesh.topology.connectivity(1, 0).array.reshape(-1, 2)[facets]
        assert np.allclose(x[nodes.ravel(), axis], 0.0)


@pytest.mark.parametrize(
    "a, runout, height, duration",
    [
        (1.2, 0.264, None, 0.35),
        (3, 0.505, 0.14, 0.55),
        (5, 0.673, 0.172, 0.71),
        (7, 0.819, 0.197, 0.838),
    ],
)
def test_lube_laws_reproduce_thesis_table_6_5(a, runout, height, duration):
    """Table 6.5 of the thesis, with d_i = 0.0905 m (which it implies); 3-digit values."""
    d_i = 0.0905
    assert lube_runout(d_i, a) == pytest.approx(runout, rel=4e-3)
    if height is not None:  # a = 1.2: the table lists h_i, not the law's d_i a^{2/5}
        assert lube_height(d_i, a) == pytest.approx(height, rel=4e-3)
    assert lube_time(d_i, a) == pytest.approx(duration, rel=1e-2)


def test_footing_points_fill_the_body_with_equal_weights():
    x, w = meshes.footing_points(1.0, 5, thickness=0.2)
    assert x.shape == (5 * 3, 2) and np.all(w == pytest.approx(0.1))
    assert np.allclose(x[:5, 1], 0.0)  # the base row first
    assert np.allclose(np.unique(x[:, 1]), [0.0, 0.1, 0.2])
    assert np.allclose(np.unique(x[:, 0]), [0.05, 0.15, 0.25, 0.35, 0.45])
    base, _ = meshes.footing_points(1.0, 5)
    assert np.allclose(base, x[:5])
    with pytest.raises(ValueError, match="thickness"):
        meshes.footing_points(1.0, 5, thickness=-0.1)


@pytest.mark.parametrize("degree", [1, 2])
def test_facet_points_integrate_along_each_facet(degree):
    """On every loaded facet of Cook's grid the points integrate polynomials of
    degree 2·degree − 1 along the facet exactly (the midpoint rule: linear; two
    Gauss points: cubic), which a P1 or P2 test function times a constant traction
    needs; the midpoint rule misses a quadratic by L³/12."""
    scene = meshes.cook_membrane(n=4)
    facets = scene.facet_tags.find(meshes.COOK_LOADED)
    x, w = meshes.facet_points(scene.mesh, facets, degree)
    q = 1 if degree == 1 else 2
    assert x.shape == (q * facets.size, 2)
    # The loaded edge is x = 48, y from 44 to 60: s = y − 44 along it.
    s = x[:, 1].reshape(-1, q) - 44.0
    w = w.reshape(-1, q)
    ends = np.sort(np.column_stack([s.min(axis=1), s.max(axis=1)]), axis=1)
    lo, hi = np.floor(ends[:, 0] / 4.0) * 4.0, np.floor(ends[:, 0] / 4.0) * 4.0 + 4.0
    for power in range(2 * degree):
        exact = (hi ** (power + 1) - lo ** (power + 1)) / (power + 1)
        assert np.allclose((w * s**power).sum(axis=1), exact, rtol=1e-13, atol=1e-12)
    quadratic = (hi**3 - lo**3) / 3.0
    missed = np.abs((w * s**2).sum(axis=1) - quadratic)
    assert np.allclose(missed, 0.0 if degree == 2 else 4.0**3 / 12.0, rtol=1e-12, atol=1e-9)
    with pytest.raises(ValueError, match="degree must be 1 or 2"):
        meshes.facet_points(scene.mesh, facets, 3)


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("dim", [2, 3])
def test_facet_points_cut_each_facet_into_equal_pieces(dim, degree):
    """With ``subdivisions=k`` each facet is k segments (2D) or k² triangles (3D), each
    with the degree's rule: the points integrate what that rule integrates on every
    piece exactly, so a quadratic on the unit top face (∫ x y = 1/4) exactly with
    degree 2 and with an error falling as 1/k² with degree 1 (∫ x y misses 1/36, 1/144
    and 1/324 for k = 1, 2, 3 on the two triangles of that face). Facets found with
    ``locate_entities`` need no connectivity built first (until 2026-12-06 DOLFINx
    stopped with "Missing dims")."""
    n = (2, 2) if dim == 2 else (1, 1, 1)
    mesh = meshes.rectangle_mesh(np.zeros(dim), np.ones(dim), n)
    top = dolfinx.mesh.locate_entities(mesh, dim - 1, lambda x: np.isclose(x[dim - 1], 1.0))
    points_per_piece = 1 if degree == 1 else dim  # 2 Gauss points on a segment, 3 on a triangle
    misses = []
    for k in (1, 2, 3):
        x, w = meshes.facet_points(mesh, top, degree, subdivisions=k)
        assert x.shape == (top.size * k ** (dim - 1) * points_per_piece, dim)
        assert np.allclose(w, w[0]) and np.isclose(w.sum(), 1.0, rtol=1e-14)
        assert np.allclose(x[:, dim - 1], 1.0, rtol=0, atol=1e-15)
        quadratic = (w * x[:, 0] * x[:, dim - 2] if dim == 3 else w * x[:, 0] ** 2).sum()
        misses.append(quadratic - (0.25 if dim == 3 else 1.0 / 3.0))
    if degree == 2:
        assert np.allclose(misses, 0.0, atol=1e-15)
    else:
        assert np.allclose(np.array(misses) * np.array([1, 4, 9]), misses[0], rtol=1e-12)
    # Each point's piece: its points share the piece's measure, and the point lies on it.
    for k in (1, 2):
        x, w, corners = meshes.facet_points(mesh, top, degree, subdivisions=k, corners=True)
        assert np.array_equal(x, meshes.facet_points(mesh, top, degree, subdivisions=k)[0])
        measure = np.linalg.norm(fe_mpm.boundary.face_vectors(corners), axis=1)
        np.testing.assert_allclose(w, measure / points_per_piece, rtol=1e-14)
        for point, piece in zip(x, corners, strict=True):
            edges = (piece[1:] - piece[0]).T  # (dim, dim - 1)
            along = np.linalg.lstsq(edges, point - piece[0], rcond=None)[0]
            assert along.min() > 0.0 and along.sum() < 1.0
            np.testing.assert_allclose(edges @ along, point - piece[0], atol=1e-14)
    with pytest.raises(ValueError, match="subdivisions"):
        meshes.facet_points(mesh, top, degree, subdivisions=0)


def test_the_footing_takes_more_base_points_when_asked():
    """``strip_footing(base_points_per_cell=8)`` on h = 0.2: 8 base points per cell
    width (20 on the half-width 0.5), each with its share 0.025 of the base, and the
    same body lattice as the default; 0 or 2.5 points are refused by name."""
    from fe_mpm import scenes

    points = {}
    for per_cell in (2, 8):
        sim = scenes.strip_footing("up", h=0.2, h_far=0.5, base_points_per_cell=per_cell)
        footing = sim._boundary.points
        points[per_cell] = (footing.x.copy(), footing.weight.copy())
    (x2, w2), (x8, w8) = points[2], points[8]
    assert np.allclose(w2[np.isclose(x2[:, 1], 0.0)], 0.1)
    base2, base8 = np.isclose(x2[:, 1], 0.0), np.isclose(x8[:, 1], 0.0)
    assert base2.sum() == 5 and base8.sum() == 20
    assert np.allclose(w8[base8], 0.025) and w8[base8].sum() == pytest.approx(0.5)
    assert np.array_equal(x2[~base2], x8[~base8])
    for bad, error in ((0, ValueError), (2.5, TypeError)):
        with pytest.raises(error, match="base_points_per_cell"):
            scenes.strip_footing("up", h=0.2, base_points_per_cell=bad)


def test_the_footing_grid_is_finer_along_its_edges_path():
    """``edge_size=0.05`` on h = 0.2: the cells around the footing's edge (B/2, 0)
    and down its path (``edge_depth``) are h/4 across, those elsewhere in the
    refined zone are not, the path is a grid line (``edge_line``), and the soil
    still tiles [0, 5] x [−5, 0]. The scene
    spaces the base points by the finer cells (2 per 0.05: 20 on the half-width)
    and scales its penalty by them. Sizes out of range are refused by name."""
    from fe_mpm import scenes

    scene = meshes.strip_footing(
        1.0, h=0.2, h_far=0.5, edge_size=0.05, edge_depth=0.5, edge_line=True
    )
    mesh = scene.mesh
    tdim = mesh.topology.dim
    cells = np.arange(mesh.topology.index_map(tdim).size_local, dtype=np.int32)
    size = mesh.h(tdim, cells)
    centre = dolfinx.mesh.compute_midpoints(mesh, tdim, cells)[:, :2]
    on_path = (np.abs(centre[:, 0] - 0.5) < 0.1) & (centre[:, 1] > -0.6) & (centre[:, 1] < 0.1)
    elsewhere = (centre[:, 0] < 0.5) & (centre[:, 1] < -1.5) & (centre[:, 1] > -2.5)
    assert size[on_path].max() < 0.05 * 1.6, size[on_path].max()
    assert size[elsewhere].min() > 0.2 * 0.8, size[elsewhere].min()
    # The edge's path x = B/2 is a grid line, so the footing ends on a node.
    x = mesh.geometry.x
    column = np.isclose(x[:, 0], 0.5, atol=1e-12) & (x[:, 1] <= 1e-12) & (x[:, 1] >= -2.9)
    assert np.any(np.isclose(x[column, 1], 0.0, atol=1e-12))
    assert np.diff(np.sort(x[column, 1])).max() < 0.2 * 1.2
    soil = np.concatenate(
        [scene.cell_tags.find(meshes.FOOTING_SOIL_NEAR), scene.cell_tags.find(meshes.FOOTING_SOIL)]
    )
    vertices = mesh.geometry.x[dolfinx.mesh.entities_to_geometry(mesh, tdim, soil)][:, :, :2]
    edges = vertices[:, 1:] - vertices[:, :1]
    area = 0.5 * np.abs(np.linalg.det(edges)).sum()
    assert area == pytest.approx(25.0, rel=1e-12)

    sim = scenes.strip_footing("up", h=0.2, h_far=0.5, edge_size=0.05, settlement=0.5)
    footing = sim._boundary.points
    base = np.isclose(footing.x0[:, 1], 0.0)
    assert base.sum() == 20 and footing.weight[base].sum() == pytest.approx(0.5)
    assert footing.stiffness.max() == pytest.approx(1e3 * 1e4 / 0.05)
    for bad, name in (
        (dict(edge_size=0.3), "edge_size"),
        (dict(edge_size=0.05, edge_radius=0.0), "edge_radius"),
        (dict(edge_size=0.05, edge_depth=-1.0), "edge_depth"),
    ):
        with pytest.raises(ValueError, match=name):
            meshes.strip_footing(1.0, h=0.2, **bad)


def test_a_quarter_cylinder_fills_its_sector():
    """The Taylor bar's quarter rod: every node in x, y ≥ 0 within the radius and the
    length; the volume that of the quarter, to the chord error of its curved face
    (measured 0.76 % short with four cells across the radius)."""
    rod = meshes.cylinder(3.2e-3, 32.4e-3, 0.8e-3, sector=math.pi / 2).mesh
    x = rod.geometry.x
    assert x[:, :2].min() >= -1e-15 and np.hypot(x[:, 0], x[:, 1]).max() <= 3.2e-3 * (1 + 1e-12)
    assert np.isclose(x[:, 2].min(), 0.0) and np.isclose(x[:, 2].max(), 32.4e-3)
    cells = rod.geometry.dofmaps[0]
    e = x[cells[:, 1:]] - x[cells[:, :1]]
    volume = np.abs(np.linalg.det(e)).sum() / 6.0
    exact = math.pi * 3.2e-3**2 / 4 * 32.4e-3
    assert 0.98 * exact < volume < exact


@pytest.mark.parametrize(
    "bad, match",
    [
        (dict(radius=0.0), r"cylinder: radius must lie in \(0, inf"),
        (dict(h=1.0), r"cylinder: h must lie in \(0, 0.1\]"),
        (dict(sector=7.0), r"cylinder: sector must lie in \(0, 6.28"),
    ],
)
def test_a_cylinder_with_bad_sizes_is_refused_by_name(bad, match):
    with pytest.raises(ValueError, match=match):
        meshes.cylinder(**{**dict(radius=0.1, length=1.0, h=0.05), **bad})


@pytest.mark.parametrize(
    "inner, outer, h, margin", [(1.0, 2.0, 0.2, None), (0.1, 0.15, 0.01, 0.05)]
)
def test_the_quarter_ring_tags_its_ring_margin_arc_and_axes(inner, outer, h, margin):
    """The ring's and the margin's cells fill their quarter annuli (to the polygon's
    chord error, measured under 0.3 %), the inner arc's facets lie on r = a, and the
    axes' facets on y = 0 and x = 0, each reaching out to the margin's edge."""
    scene = meshes.quarter_ring(inner, outer, h, margin)
    width = 2 * h if margin is None else margin
    mesh = scene.mesh
    x = mesh.geometry.x[:, :2]
    cells = mesh.geometry.dofmaps[0]

    def area(tag):
        p = x[cells[scene.cell_tags.find(tag)]]
        e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
        return 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()

    quarter = lambda r0, r1: math.pi / 4 * (r1**2 - r0**2)  # noqa: E731
    assert area(meshes.RING_BODY) == pytest.approx(quarter(inner, outer), rel=3e-3)
    assert area(meshes.RING_MARGIN) == pytest.approx(quarter(outer, outer + width), rel=3e-3)
    mesh.topology.create_connectivity(1, 0)

    def vertices(tag):
        return x[dolfinx.mesh.entities_to_geometry(mesh, 1, scene.facet_tags.find(tag)).ravel()]

    np.testing.assert_allclose(np.hypot(*vertices(meshes.RING_INNER).T), inner, rtol=1e-12)
    for tag, c in ((meshes.RING_X_AXIS, 1), (meshes.RING_Y_AXIS, 0)):
        on = vertices(tag)
        np.testing.assert_allclose(on[:, c], 0.0, atol=1e-12 * outer)
        assert on[:, 1 - c].min() == pytest.approx(inner) and on[:, 1 - c].max() == pytest.approx(
            outer + width
        )


def test_a_graded_quarter_ring_is_fine_at_its_inner_arc_and_coarse_at_its_outer():
    """With ``h_outer`` the cells grow with r from h at r = a: the inner arc's facets
    are about h long, those on the axes near r = b about h_outer, and the ring still
    fills its quarter annulus (a cavity's grid, ``demos/cavity_expansion.py``)."""
    scene = meshes.quarter_ring(1.0, 20.0, 0.1, 2.0, h_outer=2.0)
    mesh = scene.mesh
    x = mesh.geometry.x[:, :2]
    mesh.topology.create_connectivity(1, 0)

    def lengths(tag):
        ends = x[dolfinx.mesh.entities_to_geometry(mesh, 1, scene.facet_tags.find(tag))]
        return np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1), ends.mean(axis=1)

    inner, _ = lengths(meshes.RING_INNER)
    assert 0.07 < inner.mean() < 0.13
    axis, middle = lengths(meshes.RING_X_AXIS)
    far = np.hypot(*middle.T) > 15.0
    assert 1.2 < axis[far].mean() < 2.6
    cells = mesh.geometry.dofmaps[0][scene.cell_tags.find(meshes.RING_BODY)]
    p = x[cells]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    assert area == pytest.approx(math.pi / 4 * (20.0**2 - 1.0), rel=3e-3)
    assert mesh.topology.index_map(2).size_local < 3000  # uniform h = 0.1: about 70 000


def _gmsh_grid(build, gdim: int):
    """The grid of the model that ``build(model)`` draws and meshes, on COMM_SELF."""
    from mpi4py import MPI

    from fe_mpm.meshes.gmsh_session import gmsh_session, to_dolfinx

    with gmsh_session("test") as model:
        build(model)
        return to_dolfinx(model, gdim, MPI.COMM_SELF).mesh


def _in_xz_plane(model):
    square = model.occ.addRectangle(0.0, 0.0, 0.0, 1.0, 1.0)
    model.occ.rotate([(2, square)], 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, math.pi / 2)
    model.occ.synchronize()
    model.addPhysicalGroup(2, [square], 1)
    import gmsh

    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.25)
    model.mesh.generate(2)


def _half_recombined(model):
    import gmsh

    a = model.occ.addRectangle(0.0, 0.0, 0.0, 1.0, 1.0)
    b = model.occ.addRectangle(1.0, 0.0, 0.0, 1.0, 1.0)
    model.occ.fragment([(2, a)], [(2, b)])
    model.occ.synchronize()
    model.addPhysicalGroup(2, [a, b], 1)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.25)
    model.mesh.setRecombine(2, b)
    model.mesh.generate(2)


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (_in_xz_plane, r"cells are flat .* Draw it in x-y"),
        (
            _half_recombined,
            r"one simplex cell type, got a grid mixing \w+ and \w+ cells",
        ),
    ],
)
def test_a_flat_or_mixed_grid_is_refused_by_seed_and_simulation(build, match):
    """A 2D gmsh model drawn in the x–z plane and read with gdim = 2 is flat: seed gave
    a body of 1e-16 m² and the first step spoke of a free rotation. A surface
    recombined into quadrilaterals beside triangles ended in DOLFINx's "Multiple index
    maps of this dimension". Both are refused by name (a helper's grids, 2026-12-06)."""
    mesh = _gmsh_grid(build, 2)
    with pytest.raises(ValueError, match=match):
        fe_mpm.seed(mesh, 1)
    points = fe_mpm.MaterialPoints(x=np.array([[0.5, 0.0]]), volume=np.ones(1), mass=np.ones(1))
    with pytest.raises(ValueError, match=match):
        fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1e6, 0.3))


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_the_footing_and_the_granular_column_tag_their_sides_at_any_size(scale):
    """A strip footing of B = 0.02 m and a granular column of d = 0.02 had no facet
    tags: OCC pads its bounding boxes by an absolute 1e-7, which a tolerance of 1e-6
    of the model's size missed below about 0.1 (a helper's scenes in mm and km,
    2026-12-08). The sides are now found by their curves' end points. Each side holds
    as many facets at every size (the grids themselves may differ by a few cells:
    gmsh meshes with absolute tolerances)."""
    footing = meshes.strip_footing(B=scale, h=0.1 * scale)
    sides = (meshes.FOOTING_SYMMETRY, meshes.FOOTING_FAR_SIDE, meshes.FOOTING_BASE)
    assert [len(footing.facet_tags.find(t)) for t in sides] == [60, 60, 50]
    column = meshes.granular_column(d_i=0.2 * scale, aspect=2.0, h=0.025 * scale)
    sides = (meshes.COLLAPSE_WALL, meshes.COLLAPSE_BASE)
    assert [len(column.facet_tags.find(t)) for t in sides] == [19, 63]


def test_the_footings_default_cell_size_scales_with_its_width():
    """A strip footing of B = 1000 (a user in millimetres) takes the grid of B = 1 m,
    cells of 0.05 B: the default h was an absolute 0.05, 0.05 mm to that user, and
    gmsh set out to build about 1e9 triangles without a word (a helper, 2026-12-08).
    Measured: 27 928 and 28 012 cells (gmsh's absolute tolerances)."""
    metres = meshes.strip_footing(B=1.0).mesh.topology.index_map(2).size_local
    millimetres = meshes.strip_footing(B=1000.0).mesh.topology.index_map(2).size_local
    assert abs(millimetres / metres - 1) < 0.01
