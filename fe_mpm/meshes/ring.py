"""A quarter of a thick ring with a margin around it: a pressurised cylinder's grid."""

from __future__ import annotations

import math

from mpi4py import MPI

import gmsh

from fe_mpm._dolfinx import dolfinx
from fe_mpm.checks import check_range
from fe_mpm.meshes.gmsh_session import gmsh_session, to_dolfinx

#: Cell tag of the ring a ≤ r ≤ b, which holds the material.
RING_BODY = 1
#: Cell tag of the empty margin b ≤ r ≤ b + margin it may grow into.
RING_MARGIN = 2
#: Facet tag of the inner face r = a, where the pressure acts.
RING_INNER = 3
#: Facet tag of the symmetry line y = 0 (it holds u_y).
RING_X_AXIS = 4
#: Facet tag of the symmetry line x = 0 (it holds u_x).
RING_Y_AXIS = 5


def quarter_ring(
    inner: float,
    outer: float,
    h: float,
    margin: float | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    *,
    h_outer: float | None = None,
) -> dolfinx.io.gmsh.MeshData:
    """Triangles on the quarter x, y ≥ 0 of the annulus ``inner`` ≤ r ≤ ``outer`` + margin.

    The circle r = ``outer`` is a line of the grid, so the ring's cells
    (:data:`RING_BODY`) hold its material exactly, and the margin's
    (:data:`RING_MARGIN`) give its outer face room to move out.

    Args:
        inner: Inner radius a (m), > 0.
        outer: Outer radius b (m), > a.
        h: Cell size (m), in (0, b − a]: at r = a where ``h_outer`` is given.
        margin: Width of the empty margin (m), > 0; None: 2 h.
        comm: MPI communicator of the grid.
        h_outer: Cell size at r = b (m), > 0, the size growing linearly with r from
            ``h`` (a cavity in a wide body: fine at its face, coarse far off); None:
            ``h`` throughout.

    Returns:
        ``dolfinx.io.gmsh.MeshData`` with the tags of this module.
    """
    inner = check_range("quarter_ring", "inner", inner, lo=0.0, lo_open=True)
    outer = check_range("quarter_ring", "outer", outer, lo=inner, lo_open=True)
    h = check_range("quarter_ring", "h", h, lo=0.0, hi=outer - inner, lo_open=True)
    margin = 2.0 * h if margin is None else margin
    margin = check_range("quarter_ring", "margin", margin, lo=0.0, lo_open=True)
    if h_outer is not None:
        h_outer = check_range("quarter_ring", "h_outer", h_outer, lo=0.0, lo_open=True)
    with gmsh_session("quarter_ring") as model:
        if comm.rank == 0:
            occ = model.occ
            radii = (inner, outer, outer + margin)
            big = occ.addDisk(0.0, 0.0, 0.0, radii[2], radii[2])
            hole = occ.addDisk(0.0, 0.0, 0.0, inner, inner)
            quarter = occ.addRectangle(0.0, 0.0, 0.0, 2 * radii[2], 2 * radii[2])
            annulus, _ = occ.cut([(2, big)], [(2, hole)])
            region, _ = occ.intersect(annulus, [(2, quarter)])
            # The arc r = b splits the quarter annulus into the ring and its margin.
            face = occ.addCircle(0.0, 0.0, 0.0, outer, angle1=0.0, angle2=math.pi / 2)
            occ.fragment(region, [(1, face)])
            occ.synchronize()
            kinds = {}
            for dim, tag in model.getEntities(2):
                reach = model.getBoundingBox(dim, tag)[3]  # the largest x: its outer radius
                kinds[tag] = RING_BODY if reach < outer + 0.5 * margin else RING_MARGIN
            for kind in (RING_BODY, RING_MARGIN):
                model.addPhysicalGroup(2, [t for t, k in kinds.items() if k == kind], kind)
            faces = {RING_INNER: [], RING_X_AXIS: [], RING_Y_AXIS: []}
            for _, tag in model.getEntities(1):
                x, y, _ = occ.getCenterOfMass(1, tag)
                if abs(y) < 1e-9 * radii[-1]:
                    faces[RING_X_AXIS].append(tag)
                elif abs(x) < 1e-9 * radii[-1]:
                    faces[RING_Y_AXIS].append(tag)
                # A quarter arc of radius r has its centre of mass at 2√2 r / π.
                elif abs(math.hypot(x, y) * math.pi / math.sqrt(8) - inner) < 1e-9 * radii[-1]:
                    faces[RING_INNER].append(tag)
            for kind, tags in faces.items():
                model.addPhysicalGroup(1, tags, kind)
            model.mesh.setSize(model.getEntities(0), h)
            if h_outer is not None:
                slope = (h_outer - h) / (outer - inner)

                def size(dim, tag, x, y, z, lc):
                    return h + slope * max(0.0, min(math.hypot(x, y), outer) - inner)

                model.mesh.setSizeCallback(size)
                from_points = gmsh.option.getNumber("Mesh.MeshSizeFromPoints")
                gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
            try:
                model.mesh.generate(2)
            finally:  # a session the caller opened keeps its own settings
                if h_outer is not None:
                    model.mesh.removeSizeCallback()
                    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", from_points)
        return to_dolfinx(model, gdim=2, comm=comm)
