"""gmsh scene builders."""

import numpy as np
import pytest

from fe_mpm import meshes


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


def test_unstructured_cook_has_the_trapezoid_area():
    scene = meshes.cook_membrane(structured=False, h=3.0)
    x = scene.mesh.geometry.x[scene.mesh.geometry.dofmaps[0], :2]
    e1, e2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    assert area == pytest.approx(0.5 * (44.0 + 16.0) * 48.0, rel=1e-12)
    assert scene.mesh.topology.index_map(2).size_local > 200
