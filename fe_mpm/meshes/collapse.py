"""A granular column against a wall, free to collapse along a channel (Lube et al. 2005).

Iaconeta (2019) §6.1. The column ``[0, d_i] x [0, a·d_i]`` stands against a
wall at x = 0 on a rough base y = 0; the gate that held its other side is gone
at t = 0. The grid covers the channel ``[0, length] x [0, height]`` into which
it spreads. The column's edges are grid lines, so seeding its cells fills it
exactly.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np

from fe_mpm.checks import check_range
from fe_mpm.meshes.gmsh_session import curve_ends, gmsh_session, to_dolfinx
from fe_mpm.references import lube_runout

#: Facet tag of the wall x = 0.
COLLAPSE_WALL = 1
#: Facet tag of the base y = 0.
COLLAPSE_BASE = 2
#: Cell tag of the column at t = 0.
COLLAPSE_COLUMN = 1
#: Cell tag of the empty channel.
COLLAPSE_CHANNEL = 2


def granular_column(
    d_i: float = 0.0905,
    aspect: float = 3.0,
    *,
    h: float = 0.0065,
    length: float | None = None,
    height: float | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
):
    """Unstructured triangle grid of the collapse channel.

    Args:
        d_i: Initial column width (m), > 0.
        aspect: Aspect ratio a = h_i / d_i, > 0.
        h: Cell size (m); the thesis uses 0.0065, 0.005 and 0.0025.
        length: Channel length (m); 1.6 times the empirical run-out plus 5 cells
            by default (an undamped a = 5 run threw a point past 1.3 times).
        height: Grid height (m); h_i plus 3 cells by default.
        comm: MPI communicator.

    Returns:
        ``dolfinx.io.gmsh.MeshData`` with ``cell_tags`` (:data:`COLLAPSE_COLUMN`,
        :data:`COLLAPSE_CHANNEL`) and ``facet_tags`` (:data:`COLLAPSE_WALL`,
        :data:`COLLAPSE_BASE`).
    """
    check_range("granular_column", "d_i", d_i, lo=0.0, lo_open=True)
    check_range("granular_column", "aspect", aspect, lo=0.0, lo_open=True)
    h_i = aspect * d_i
    check_range("granular_column", "h", h, lo=0.0, hi=min(d_i, h_i), lo_open=True)
    length = check_range(
        "granular_column",
        "length",
        1.6 * lube_runout(d_i, aspect) + 5 * h if length is None else length,
        lo=d_i,
        lo_open=True,
    )
    height = check_range(
        "granular_column", "height", h_i + 3 * h if height is None else height, lo=h_i, lo_open=True
    )
    with gmsh_session("granular_column") as model:
        if comm.rank == 0:
            occ = model.occ
            channel = occ.addRectangle(0.0, 0.0, 0.0, length, height)
            body = occ.addRectangle(0.0, 0.0, 0.0, d_i, h_i)
            out, _ = occ.fragment([(2, channel)], [(2, body)])
            occ.synchronize()
            cells = {COLLAPSE_COLUMN: [], COLLAPSE_CHANNEL: []}
            for _, s in out:
                x, y, _ = occ.getCenterOfMass(2, s)
                inside = x < d_i and y < h_i
                cells[COLLAPSE_COLUMN if inside else COLLAPSE_CHANNEL].append(s)
            sides = {COLLAPSE_WALL: [], COLLAPSE_BASE: []}
            tol = 1e-9 * length
            for _, c in model.getEntities(1):
                x, y = curve_ends(model, c)[:, :2].T
                if np.all(np.abs(x) < tol):
                    sides[COLLAPSE_WALL].append(c)
                elif np.all(np.abs(y) < tol):
                    sides[COLLAPSE_BASE].append(c)
            model.addPhysicalGroup(1, sides[COLLAPSE_WALL], COLLAPSE_WALL, name="wall")
            model.addPhysicalGroup(1, sides[COLLAPSE_BASE], COLLAPSE_BASE, name="base")
            model.addPhysicalGroup(2, cells[COLLAPSE_COLUMN], COLLAPSE_COLUMN, name="column")
            model.addPhysicalGroup(2, cells[COLLAPSE_CHANNEL], COLLAPSE_CHANNEL, name="channel")
            model.mesh.setSize(model.getEntities(0), h)
            model.mesh.generate(2)
        return to_dolfinx(model, gdim=2, comm=comm)
