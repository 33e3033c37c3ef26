"""A gmsh session that builds one model and turns it into a DOLFINx mesh."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from mpi4py import MPI

import gmsh

from fe_mpm._dolfinx import dolfinx


@contextmanager
def gmsh_session(name: str) -> Iterator[gmsh.model]:
    """Open gmsh quietly with a fresh model; finalize it afterwards if we started it."""
    started = not gmsh.isInitialized()
    if started:
        gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(name)
    try:
        yield gmsh.model
    finally:
        gmsh.model.remove()
        if started:
            gmsh.finalize()


def to_dolfinx(model: gmsh.model, gdim: int, comm: MPI.Comm = MPI.COMM_WORLD):
    """Convert the meshed gmsh model (on rank 0) into DOLFINx mesh data.

    Under MPI each rank also holds the cells across its facets on other ranks
    (``GhostMode.shared_facet``, as ``create_rectangle`` gives by default), which the
    ghost penalty's facet integrals need.
    """
    partitioner = dolfinx.mesh.create_cell_partitioner(dolfinx.mesh.GhostMode.shared_facet, 2)
    return dolfinx.io.gmsh.model_to_mesh(model, comm, rank=0, gdim=gdim, partitioner=partitioner)
