"""A cylinder of tetrahedra, or a sector of it, to seed a round bar's points (not the grid)."""

from __future__ import annotations

import math

from mpi4py import MPI

from fe_mpm.checks import check_range
from fe_mpm.meshes.gmsh_session import gmsh_session, to_dolfinx


def cylinder(
    radius: float,
    length: float,
    h: float,
    sector: float = 2.0 * math.pi,
    comm: MPI.Comm = MPI.COMM_SELF,
):
    """Unstructured tetrahedra filling a cylinder on the z axis, from z = 0 to ``length``.

    For ``fe_mpm.seed`` of a bar whose points are then set on a background grid of
    their own, as :func:`~fe_mpm.meshes.disk` does in 2D. A ``sector`` of π/2 gives
    the quarter x ≥ 0, y ≥ 0 that a model with two symmetry planes needs.

    Args:
        radius: The radius (m), > 0.
        length: The length (m), > 0.
        h: Cell size (m), in (0, radius].
        sector: The angle of the sector about the axis (rad), in (0, 2π], from the
            x axis towards the y axis.
        comm: MPI communicator (every rank its own copy by default). Points
            seeded on every rank's copy are that many copies of the body: under
            ``mpiexec`` keep them on one rank (``points.keep(...)`` elsewhere) or pass
            the grid's communicator; ``Simulation`` refuses points at one place.

    Returns:
        ``dolfinx.io.gmsh.MeshData`` with ``.mesh``.
    """
    check_range("cylinder", "radius", radius, lo=0.0, lo_open=True)
    check_range("cylinder", "length", length, lo=0.0, lo_open=True)
    check_range("cylinder", "h", h, lo=0.0, hi=radius, lo_open=True)
    check_range("cylinder", "sector", sector, lo=0.0, hi=2.0 * math.pi, lo_open=True)
    with gmsh_session("cylinder") as model:
        if comm.rank == 0:
            volume = model.occ.addCylinder(0.0, 0.0, 0.0, 0.0, 0.0, length, radius, angle=sector)
            model.occ.synchronize()
            model.addPhysicalGroup(3, [volume], 1, name="cylinder")
            model.mesh.setSize(model.getEntities(0), h)
            model.mesh.generate(3)
        return to_dolfinx(model, gdim=3, comm=comm)
