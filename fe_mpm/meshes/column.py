"""A rectangular column on a rigid base: self-weight, vibration, collapse scenes.

The grid is ``width x (height + margin)``: the body fills ``[0, width] x [0,
height]`` and the empty strip above lets it rise or spread upwards.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np

from fe_mpm.checks import check_range
from fe_mpm.meshes.gmsh_session import gmsh_session, to_dolfinx

#: Facet tag of the base y = 0.
COLUMN_BASE = 1
#: Facet tag of the two sides x = 0 and x = width.
COLUMN_SIDES = 2
#: Facet tag of the top of the grid.
COLUMN_TOP = 3
#: Cell tag of the column itself.
COLUMN_BODY = 1
#: Cell tag of the empty strip above it.
COLUMN_MARGIN = 2


def column(
    width: float,
    height: float,
    nx: int,
    ny: int,
    *,
    margin: int = 0,
    comm: MPI.Comm = MPI.COMM_WORLD,
):
    """Structured triangle grid of a column (cells ``width/nx`` by ``height/ny``).

    Args:
        width: Column width (m).
        height: Column height (m).
        nx: Cells across.
        ny: Cells over the height of the column.
        margin: Extra rows of empty cells above the column.
        comm: MPI communicator.

    Returns:
        ``dolfinx.io.gmsh.MeshData`` with ``cell_tags`` (:data:`COLUMN_BODY`,
        :data:`COLUMN_MARGIN`) and ``facet_tags`` (:data:`COLUMN_BASE`,
        :data:`COLUMN_SIDES`, :data:`COLUMN_TOP`).
    """
    check_range("column", "width", width, lo=0.0, lo_open=True)
    check_range("column", "height", height, lo=0.0, lo_open=True)
    nx = int(check_range("column", "nx", nx, lo=1))
    ny = int(check_range("column", "ny", ny, lo=1))
    margin = int(check_range("column", "margin", margin, lo=0))
    levels = [0.0, height] + ([height * (1 + margin / ny)] if margin else [])
    with gmsh_session("column") as model:
        if comm.rank == 0:
            geo = model.geo
            left = [geo.addPoint(0.0, y, 0.0) for y in levels]
            right = [geo.addPoint(width, y, 0.0) for y in levels]
            across = [geo.addLine(a, b) for a, b in zip(left, right)]
            up_left = [geo.addLine(left[i], left[i + 1]) for i in range(len(levels) - 1)]
            up_right = [geo.addLine(right[i], right[i + 1]) for i in range(len(levels) - 1)]
            surfaces = []
            for i, rows in enumerate([ny, margin][: len(levels) - 1]):
                loop = geo.addCurveLoop([across[i], up_right[i], -across[i + 1], -up_left[i]])
                surfaces.append(geo.addPlaneSurface([loop]))
                for line in (up_left[i], up_right[i]):
                    geo.mesh.setTransfiniteCurve(line, rows + 1)
                corners = [left[i], right[i], right[i + 1], left[i + 1]]
                geo.mesh.setTransfiniteSurface(surfaces[-1], "Right", corners)
            for line in across:
                geo.mesh.setTransfiniteCurve(line, nx + 1)
            geo.synchronize()
            model.addPhysicalGroup(1, [across[0]], COLUMN_BASE, name="base")
            model.addPhysicalGroup(1, up_left + up_right, COLUMN_SIDES, name="sides")
            model.addPhysicalGroup(1, [across[-1]], COLUMN_TOP, name="top")
            model.addPhysicalGroup(2, surfaces[:1], COLUMN_BODY, name="column")
            if margin:
                model.addPhysicalGroup(2, surfaces[1:], COLUMN_MARGIN, name="margin")
            model.mesh.generate(2)
        return to_dolfinx(model, gdim=2, comm=comm)


def column_cells(scene) -> np.ndarray:
    """Cells of the column itself (local indices), for seeding material points."""
    return scene.cell_tags.find(COLUMN_BODY)
