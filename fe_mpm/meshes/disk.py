"""A disk, meshed on its own to seed material points (the grid is a separate mesh)."""

from __future__ import annotations

from mpi4py import MPI

from fe_mpm.checks import check_range
from fe_mpm.meshes.gmsh_session import gmsh_session, to_dolfinx


def disk(
    center: tuple[float, float],
    radius: float,
    h: float,
    comm: MPI.Comm = MPI.COMM_WORLD,
):
    """Unstructured triangles of size ``h`` filling a disk (m).

    Returns:
        ``dolfinx.io.gmsh.MeshData``; seed its ``mesh`` to get the disk's points.
    """
    check_range("disk", "radius", radius, lo=0.0, lo_open=True)
    check_range("disk", "h", h, lo=0.0, lo_open=True)
    with gmsh_session("disk") as model:
        if comm.rank == 0:
            surface = model.occ.addDisk(center[0], center[1], 0.0, radius, radius)
            model.occ.synchronize()
            model.addPhysicalGroup(2, [surface], 1, name="disk")
            model.mesh.setSize(model.getEntities(0), h)
            model.mesh.generate(2)
        return to_dolfinx(model, gdim=2, comm=comm)
