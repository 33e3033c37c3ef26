"""A disk of triangles, to seed a round body's points (it is not the grid)."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np

from fe_mpm.checks import check_finite, check_range
from fe_mpm.meshes.gmsh_session import gmsh_session, to_dolfinx


def disk(
    centre: tuple[float, float],
    radius: float,
    h: float,
    comm: MPI.Comm = MPI.COMM_SELF,
):
    """Unstructured triangles filling a disk, for ``fe_mpm.seed`` of a round body.

    The points seeded in it are then placed on a background grid of their own
    (``Simulation(grid, points, ...)``): the body need not follow the grid's lines.

    Args:
        centre: The disk's centre (m), (x, y).
        radius: Its radius (m), > 0.
        h: Cell size (m), in (0, radius].
        comm: MPI communicator (every rank its own copy by default). Points
            seeded on every rank's copy are that many copies of the body: under
            ``mpiexec`` keep them on one rank (``points.keep(...)`` elsewhere) or pass
            the grid's communicator; ``Simulation`` refuses points at one place.

    Returns:
        ``dolfinx.io.gmsh.MeshData`` with ``.mesh``.
    """
    if np.ndim(centre) != 1 or len(centre) != 2:  # (a third coordinate was dropped)
        raise ValueError(f"disk: centre must be (x, y), a disk is 2D; got {centre!r}")
    centre = check_finite("disk", "centre", centre)
    check_range("disk", "radius", radius, lo=0.0, lo_open=True)
    check_range("disk", "h", h, lo=0.0, hi=radius, lo_open=True)
    with gmsh_session("disk") as model:
        if comm.rank == 0:
            surface = model.occ.addDisk(centre[0], centre[1], 0.0, radius, radius)
            model.occ.synchronize()
            model.addPhysicalGroup(2, [surface], 1, name="disk")
            model.mesh.setSize(model.getEntities(0), h)
            model.mesh.generate(2)
        return to_dolfinx(model, gdim=2, comm=comm)
