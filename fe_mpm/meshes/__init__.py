"""gmsh scene builders: one function per geometry, returning DOLFINx mesh data.

Each builder returns :class:`dolfinx.io.gmsh.MeshData` with ``.mesh``,
``.cell_tags`` and ``.facet_tags`` (the gmsh physical groups).
"""

from fe_mpm.meshes.centroids import cell_centroids
from fe_mpm.meshes.collapse import (
    COLLAPSE_BASE,
    COLLAPSE_CHANNEL,
    COLLAPSE_COLUMN,
    COLLAPSE_WALL,
    granular_column,
)
from fe_mpm.meshes.column import (
    COLUMN_BASE,
    COLUMN_BODY,
    COLUMN_MARGIN,
    COLUMN_SIDES,
    COLUMN_TOP,
    column,
    column_cells,
)
from fe_mpm.meshes.cook import (
    COOK_BODY,
    COOK_CLAMPED,
    COOK_FACES,
    COOK_FREE,
    COOK_LOADED,
    COOK_MARGIN,
    COOK_POINT_A,
    body_cells,
    cook_membrane,
)
from fe_mpm.meshes.cylinder import cylinder
from fe_mpm.meshes.disk import disk
from fe_mpm.meshes.facet_points import facet_points
from fe_mpm.meshes.footing import (
    FOOTING_BASE,
    FOOTING_FAR_SIDE,
    FOOTING_MARGIN,
    FOOTING_SOIL,
    FOOTING_SOIL_NEAR,
    FOOTING_SYMMETRY,
    footing_points,
    strip_footing,
)
from fe_mpm.meshes.gmsh_session import gmsh_session
from fe_mpm.meshes.rectangle import rectangle_mesh
from fe_mpm.meshes.ring import (
    RING_BODY,
    RING_INNER,
    RING_MARGIN,
    RING_X_AXIS,
    RING_Y_AXIS,
    quarter_ring,
)
from fe_mpm.meshes.tension import (
    TENSION_BOTTOM,
    TENSION_SIDES,
    TENSION_TOP,
    tension_specimen,
)

__all__ = [
    "COLLAPSE_BASE",
    "COLLAPSE_CHANNEL",
    "COLLAPSE_COLUMN",
    "COLLAPSE_WALL",
    "granular_column",
    "cell_centroids",
    "cylinder",
    "disk",
    "facet_points",
    "COLUMN_BASE",
    "COLUMN_BODY",
    "COLUMN_MARGIN",
    "COLUMN_SIDES",
    "COLUMN_TOP",
    "column",
    "column_cells",
    "COOK_BODY",
    "COOK_MARGIN",
    "body_cells",
    "COOK_CLAMPED",
    "COOK_FACES",
    "COOK_FREE",
    "COOK_LOADED",
    "COOK_POINT_A",
    "cook_membrane",
    "FOOTING_BASE",
    "FOOTING_FAR_SIDE",
    "FOOTING_MARGIN",
    "FOOTING_SOIL",
    "FOOTING_SOIL_NEAR",
    "FOOTING_SYMMETRY",
    "footing_points",
    "strip_footing",
    "gmsh_session",
    "rectangle_mesh",
    "RING_BODY",
    "RING_INNER",
    "RING_MARGIN",
    "RING_X_AXIS",
    "RING_Y_AXIS",
    "quarter_ring",
    "TENSION_BOTTOM",
    "TENSION_SIDES",
    "TENSION_TOP",
    "tension_specimen",
]
