"""The centroids of a grid's cells, to pick the cells a body fills."""

from __future__ import annotations

import numpy as np

from fe_mpm._dolfinx import dolfinx


def cell_centroids(mesh: dolfinx.mesh.Mesh) -> np.ndarray:
    """Centroid of each cell this rank owns (m), shape ``(num_owned_cells, gdim)``.

    Row ``i`` is local cell ``i``, so ``np.flatnonzero(test(cell_centroids(mesh)))``
    gives the ``cells=`` of :func:`fe_mpm.seed`: each rank seeds the cells it owns.
    Affine cells only (the mean of the vertices).
    """
    if not isinstance(mesh, dolfinx.mesh.Mesh):
        hint = "; a scene's grid is scene.mesh" if hasattr(mesh, "mesh") else ""
        raise TypeError(
            f"cell_centroids: mesh must be a dolfinx Mesh, got {type(mesh).__name__}{hint}"
        )
    owned = mesh.topology.index_map(mesh.topology.dim).size_local
    vertices = mesh.geometry.x[mesh.geometry.dofmaps[0][:owned]]  # (cells, t + 1, 3)
    return vertices[:, :, : mesh.geometry.dim].mean(axis=1)
