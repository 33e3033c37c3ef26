"""Cook's membrane (Iaconeta 2019 §5.4.1; Kratos MPM cooks_membrane tests).

Trapezoid (0,0), (48,44), (48,60), (0,44) in plane strain. The left edge is
clamped and the right edge carries a vertical shear load; point A is the
top-right corner (48, 60).

With several load steps the body moves out of a grid that fits it exactly
(the top-right corner rises by about 0.3), so the grid can carry ``margin``
extra rows of empty cells above the top edge and below the bottom edge. They
extend the same bilinear map, so the cells of the body are unchanged.

With a ``thickness`` the grid is the same trapezoid extruded in z into tetrahedra
(``layers`` of them, three per prism), a 3D grid whose front and back faces
(:data:`COOK_FACES`) take rollers for plane strain: its answer converges to the 2D
one.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np

from fe_mpm.checks import check_int, check_range
from fe_mpm.meshes.gmsh_session import gmsh_session, to_dolfinx

#: Facet tag of the clamped left edge x = 0 (the grid's whole left side).
COOK_CLAMPED = 1
#: Facet tag of the loaded right edge x = 48, 44 <= y <= 60.
COOK_LOADED = 2
#: Facet tag of the other boundary facets.
COOK_FREE = 3
#: Facet tag of the front and back faces z = 0 and z = thickness (3D grid only).
COOK_FACES = 4
#: Cell tag of the membrane (where material points are seeded).
COOK_BODY = 1
#: Cell tag of the empty margin cells.
COOK_MARGIN = 2
#: Point A, the top-right corner, where the deflection is measured.
COOK_POINT_A = (48.0, 60.0)


def _bilinear(xi: float, eta: float) -> tuple[float, float]:
    """Map of the unit square onto the trapezoid (extends beyond eta in [0, 1])."""
    return 48.0 * xi, 44.0 * eta + xi * (44.0 - 28.0 * eta)


def cook_membrane(
    n: int = 16,
    *,
    structured: bool = True,
    h: float | None = None,
    margin: int = 0,
    thickness: float | None = None,
    layers: int = 1,
    comm: MPI.Comm = MPI.COMM_WORLD,
):
    """Background grid of Cook's membrane.

    Args:
        n: Structured mesh: ``n x n`` quadrilaterals, each cut along the diagonal
            from its lower-left to its upper-right corner, mapped bilinearly onto
            the trapezoid (the meshes of the thesis's Table 5.1 and Kratos's tests).
        structured: If False, an unstructured Delaunay mesh of size ``h``.
        h: Element size of the unstructured mesh (default ``44 / n``).
        margin: Rows of empty cells (of height 1/n in the map) above and below the body.
        thickness: None: a 2D grid of triangles. A length > 0: the grid extruded by
            it in z, into tetrahedra.
        layers: Layers of prisms across the thickness (3D only), each cut into three
            tetrahedra.
        comm: MPI communicator.

    Returns:
        ``dolfinx.io.gmsh.MeshData`` with ``mesh``, ``cell_tags`` (:data:`COOK_BODY`,
        :data:`COOK_MARGIN`) and ``facet_tags`` (:data:`COOK_CLAMPED`,
        :data:`COOK_LOADED`, :data:`COOK_FREE`, and in 3D :data:`COOK_FACES`).
    """
    n = check_int("cook_membrane", "n", n, lo=1)  # (2.5 was taken as 2)
    margin = check_int("cook_membrane", "margin", margin, lo=0)
    if h is None:
        h = 44.0 / n
    elif structured:  # (it was ignored)
        raise ValueError(
            "cook_membrane: h sizes the unstructured grid; give structured=False with it, "
            "or n alone for the structured grid"
        )
    check_range("cook_membrane", "h", h, lo=0.0, lo_open=True)
    layers = check_int("cook_membrane", "layers", layers, lo=1)
    if thickness is not None:
        check_range("cook_membrane", "thickness", thickness, lo=0.0, lo_open=True)
    elif layers != 1:
        raise ValueError("cook_membrane: layers is for a 3D grid; give a thickness too")
    m = margin / n
    with gmsh_session("cook_membrane") as model:
        if comm.rank == 0:
            geo = model.geo
            # Strips in eta: [-m, 0] (margin), [0, 1] (body), [1, 1 + m] (margin).
            etas = [0.0, 1.0] if margin == 0 else [-m, 0.0, 1.0, 1.0 + m]
            left = [geo.addPoint(*_bilinear(0.0, e), 0.0, h) for e in etas]
            right = [geo.addPoint(*_bilinear(1.0, e), 0.0, h) for e in etas]
            across = [geo.addLine(a, b) for a, b in zip(left, right)]
            up_left = [geo.addLine(left[i], left[i + 1]) for i in range(len(etas) - 1)]
            up_right = [geo.addLine(right[i], right[i + 1]) for i in range(len(etas) - 1)]
            surfaces = []
            for i in range(len(etas) - 1):
                loop = geo.addCurveLoop([across[i], up_right[i], -across[i + 1], -up_left[i]])
                surfaces.append(geo.addPlaneSurface([loop]))
                if structured:
                    rows = n if etas[i + 1] - etas[i] == 1.0 else margin
                    for line in (up_left[i], up_right[i]):
                        geo.mesh.setTransfiniteCurve(line, rows + 1)
                    # gmsh's "Right" splits each quad from its lower-left to its
                    # upper-right corner when the corners run counter-clockwise
                    # from the lower-left one (checked in tests/test_meshes.py).
                    corners = [left[i], right[i], right[i + 1], left[i + 1]]
                    geo.mesh.setTransfiniteSurface(surfaces[-1], "Right", corners)
            if structured:
                for line in across:
                    geo.mesh.setTransfiniteCurve(line, n + 1)
            body = etas.index(0.0)
            if thickness is None:
                geo.synchronize()
                _tag(model, 1, body, surfaces, across, up_left, up_right)
                model.mesh.generate(2)
            else:
                # Each strip's extrusion gives its back face, its volume, then the
                # faces swept by its loop's curves in order: across[i], up_right[i],
                # across[i + 1], up_left[i] (a shared curve's face appears twice).
                swept = geo.extrude(
                    [(2, s) for s in surfaces], 0, 0, thickness, [layers], recombine=False
                )
                strips = [swept[6 * i : 6 * i + 6] for i in range(len(surfaces))]
                geo.synchronize()
                volumes = [strip[1][1] for strip in strips]
                faces = [strip[2 + k][1] for strip in strips for k in (0, 1, 2, 3)]
                right = [strip[3][1] for strip in strips]
                left = [strip[5][1] for strip in strips]
                lower, upper = strips[0][2][1], strips[-1][4][1]
                _tag(model, 2, body, volumes, [lower, upper], left, right)
                back = [strip[0][1] for strip in strips]
                model.addPhysicalGroup(2, surfaces + back, COOK_FACES, name="faces")
                assert len(set(faces)) == 3 * len(surfaces) + 1  # the strips share faces
                model.mesh.generate(3)
        return to_dolfinx(model, gdim=2 if thickness is None else 3, comm=comm)


def _tag(model, fdim: int, body: int, cells: list, edges: list, left: list, right: list):
    """Physical groups of the strips' cells and of the boundary's left, right and other edges.

    ``edges`` holds the lowest strip's lower edge first and the highest's upper edge
    last (what lies between them is inside the grid).
    """
    model.addPhysicalGroup(fdim, left, COOK_CLAMPED, name="clamped")
    model.addPhysicalGroup(fdim, [right[body]], COOK_LOADED, name="loaded")
    free = [edges[0], edges[-1]] + [c for i, c in enumerate(right) if i != body]
    model.addPhysicalGroup(fdim, free, COOK_FREE, name="free")
    model.addPhysicalGroup(fdim + 1, [cells[body]], COOK_BODY, name="membrane")
    if len(cells) > 1:
        margins = [c for i, c in enumerate(cells) if i != body]
        model.addPhysicalGroup(fdim + 1, margins, COOK_MARGIN, name="margin")


def body_cells(scene) -> np.ndarray:
    """Cells of the membrane itself (local indices), for seeding material points."""
    return scene.cell_tags.find(COOK_BODY)
