"""Cook's membrane (Iaconeta 2019 §5.4.1; Kratos MPM cooks_membrane tests).

Trapezoid (0,0), (48,44), (48,60), (0,44) in plane strain. The left edge is
clamped and the right edge carries a vertical shear load; point A is the
top-right corner (48, 60).
"""

from __future__ import annotations

from mpi4py import MPI

from fe_mpm.checks import check_range
from fe_mpm.meshes.gmsh_session import gmsh_session, to_dolfinx

#: Facet tag of the clamped left edge x = 0.
COOK_CLAMPED = 1
#: Facet tag of the loaded right edge x = 48.
COOK_LOADED = 2
#: Facet tag of the free top and bottom edges.
COOK_FREE = 3
#: Point A, the top-right corner, where the deflection is measured.
COOK_POINT_A = (48.0, 60.0)

_CORNERS = [(0.0, 0.0), (48.0, 44.0), (48.0, 60.0), (0.0, 44.0)]


def cook_membrane(
    n: int = 16,
    *,
    structured: bool = True,
    h: float | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
):
    """Background grid of Cook's membrane.

    Args:
        n: Structured mesh: ``n x n`` quadrilaterals, each cut along the diagonal
            from its lower-left to its upper-right corner, mapped bilinearly onto
            the trapezoid (the meshes of the thesis's Table 5.1 and Kratos's tests).
        structured: If False, an unstructured Delaunay mesh of size ``h``.
        h: Element size of the unstructured mesh (default ``44 / n``).
        comm: MPI communicator.

    Returns:
        ``dolfinx.io.gmsh.MeshData`` with ``mesh`` and ``facet_tags``
        (:data:`COOK_CLAMPED`, :data:`COOK_LOADED`, :data:`COOK_FREE`).
    """
    n = int(check_range("cook_membrane", "n", n, lo=1))
    if h is None:
        h = 44.0 / n
    check_range("cook_membrane", "h", h, lo=0.0, lo_open=True)
    with gmsh_session("cook_membrane") as model:
        if comm.rank == 0:
            geo = model.geo
            p = [geo.addPoint(x, y, 0.0, h) for x, y in _CORNERS]
            bottom = geo.addLine(p[0], p[1])
            right = geo.addLine(p[1], p[2])
            top = geo.addLine(p[2], p[3])
            left = geo.addLine(p[3], p[0])
            loop = geo.addCurveLoop([bottom, right, top, left])
            surface = geo.addPlaneSurface([loop])
            if structured:
                for line in (bottom, right, top, left):
                    geo.mesh.setTransfiniteCurve(line, n + 1)
                # gmsh's "Right" splits each quad from its lower-left to its
                # upper-right corner when the corners start at (0, 0) and run
                # counter-clockwise (checked in tests/test_meshes.py).
                geo.mesh.setTransfiniteSurface(surface, "Right", p)
            geo.synchronize()
            model.addPhysicalGroup(1, [left], COOK_CLAMPED, name="clamped")
            model.addPhysicalGroup(1, [right], COOK_LOADED, name="loaded")
            model.addPhysicalGroup(1, [top, bottom], COOK_FREE, name="free")
            model.addPhysicalGroup(2, [surface], 1, name="membrane")
            model.mesh.generate(2)
        return to_dolfinx(model, gdim=2, comm=comm)
