"""Rectangles and boxes of simplices, for tests and simple scenes."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np

from fe_mpm._dolfinx import dolfinx


def rectangle_mesh(
    lower: tuple[float, ...],
    upper: tuple[float, ...],
    n: tuple[int, ...],
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> dolfinx.mesh.Mesh:
    """Structured triangle (2D) or tetrahedron (3D) grid of the box ``[lower, upper]``.

    Args:
        lower: Lower corner (m), length 2 or 3.
        upper: Upper corner (m), length 2 or 3.
        n: Cells per direction, length 2 or 3.
        comm: MPI communicator.
    """
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    if lower.size == 2:
        return dolfinx.mesh.create_rectangle(
            comm, [lower, upper], list(n), dolfinx.mesh.CellType.triangle
        )
    return dolfinx.mesh.create_box(comm, [lower, upper], list(n), dolfinx.mesh.CellType.tetrahedron)
