"""The plane-strain tension specimen (Iaconeta 2019 §5.4.2, after Chiumenti et al. 2004).

A ``width x height`` plate, clamped at the bottom and pulled at the top. The
grid is the plate itself, and the grid lines y = 0 and y = height carry the
clamps. The imposed displacement (0.1 mm) is a tenth of a cell, and points
seeded at least that far inside the cells (3 per triangle sit at 1/6 of the
height from each edge) never cross the top line.
"""

from __future__ import annotations

from mpi4py import MPI

from fe_mpm.checks import check_range
from fe_mpm.meshes.gmsh_session import gmsh_session, to_dolfinx

#: Facet tag of the clamped bottom y = 0.
TENSION_BOTTOM = 1
#: Facet tag of the pulled top y = height.
TENSION_TOP = 2
#: Facet tag of the free sides x = 0 and x = width.
TENSION_SIDES = 3


def tension_specimen(
    width: float = 0.01,
    height: float = 0.02,
    h: float = 0.001,
    *,
    comm: MPI.Comm = MPI.COMM_WORLD,
):
    """Unstructured (Frontal-Delaunay) triangle grid of the specimen, cell size ``h``.

    Args:
        width: Plate width W (m).
        height: Plate height H (m).
        h: Target cell size (m), the thesis's 0.001 by default.
        comm: MPI communicator.

    Returns:
        ``dolfinx.io.gmsh.MeshData`` with ``facet_tags`` (:data:`TENSION_BOTTOM`,
        :data:`TENSION_TOP`, :data:`TENSION_SIDES`).
    """
    check_range("tension_specimen", "width", width, lo=0.0, lo_open=True)
    check_range("tension_specimen", "height", height, lo=0.0, lo_open=True)
    check_range("tension_specimen", "h", h, lo=0.0, hi=min(width, height), lo_open=True)
    with gmsh_session("tension") as model:
        if comm.rank == 0:
            occ = model.occ
            plate = occ.addRectangle(0.0, 0.0, 0.0, width, height)
            occ.synchronize()
            bottom, top, sides = [], [], []
            for _, curve in model.getBoundary([(2, plate)], oriented=False):
                _, y, _ = occ.getCenterOfMass(1, curve)
                if abs(y) < 1e-9 * height:
                    bottom.append(curve)
                elif abs(y - height) < 1e-9 * height:
                    top.append(curve)
                else:
                    sides.append(curve)
            model.addPhysicalGroup(1, bottom, TENSION_BOTTOM, name="bottom")
            model.addPhysicalGroup(1, top, TENSION_TOP, name="top")
            model.addPhysicalGroup(1, sides, TENSION_SIDES, name="sides")
            model.addPhysicalGroup(2, [plate], 1, name="plate")
            model.mesh.setSize(model.getEntities(0), h)
            model.mesh.setAlgorithm(2, plate, 6)  # Frontal-Delaunay
            model.mesh.generate(2)
        return to_dolfinx(model, gdim=2, comm=comm)
