"""Half model of a plane-strain rigid strip footing on a soil layer (Iaconeta 2019 §6.2).

The grid covers the soil ``[0, width] x [−depth, 0]`` and an empty strip
``[0, width] x [0, margin]`` above it, into which the soil beside the footing
heaves. The footing (half-width ``B/2``) sits on the surface y = 0 at x ∈ [0, B/2];
x = 0 is the symmetry line. A zone ``[0, near_width] x [−near_depth, 0]`` below
the footing is tagged separately so that it can be seeded with more material
points, as the thesis does (12 per cell there, fewer elsewhere). The grid lines
y = 0 and the zone's edges are meshed conformingly, so seeding by cell tag fills
the soil exactly.
"""

from __future__ import annotations

from mpi4py import MPI

import gmsh
import numpy as np

from fe_mpm.checks import check_int, check_range
from fe_mpm.meshes.gmsh_session import curve_ends, gmsh_session, to_dolfinx

#: Facet tag of the symmetry line x = 0.
FOOTING_SYMMETRY = 1
#: Facet tag of the far side x = width.
FOOTING_FAR_SIDE = 2
#: Facet tag of the fixed base y = −depth.
FOOTING_BASE = 3
#: Cell tag of the soil near the footing (the refined seeding zone).
FOOTING_SOIL_NEAR = 1
#: Cell tag of the rest of the soil.
FOOTING_SOIL = 2
#: Cell tag of the empty strip above the soil.
FOOTING_MARGIN = 3


#: How far the refinement box reaches past the grid's left and top edges, as a
#: fraction of the refined zone's size.
BOX_REACH = 0.5


def strip_footing(
    B: float = 1.0,
    *,
    width: float | None = None,
    depth: float | None = None,
    margin: float | None = None,
    near_width: float | None = None,
    near_depth: float | None = None,
    h: float | None = None,
    h_far: float | None = None,
    edge_size: float | None = None,
    edge_radius: float | None = None,
    edge_depth: float = 0.0,
    edge_line: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
):
    """Unstructured triangle grid of the footing scene.

    Args:
        B: Footing width (m); the model holds its half, B/2.
        width: Grid width from the symmetry line (m); 5B by default.
        depth: Soil depth (m); 5B by default.
        margin: Height of the empty strip above the soil (m); B by default.
        near_width: Width of the refined seeding zone (m); 1.5B by default.
        near_depth: Depth of the refined seeding zone (m); 3B by default (the
            footing ends 2B down).
        h: Cell size in the refined zone and the margin above it (m); 0.05 B by default
            (each default size scales with B: the grid does not hang on the length unit, up
            to gmsh's own absolute tolerances).
        h_far: Cell size far from it (m); ``h`` by default (a uniform grid).
        edge_size: Cell size at the footing's edge (m), ≤ h; None: h. The stresses
            are singular at the edge, and on uniform P1 cells of h = 0.1 B the
            collapse load comes out 12.5 % above 2 + π; cells of h/4 there bring it
            to 0.3–3.8 % (``benchmarks/footing_prandtl.py``), as finite element
            analyses of Prandtl's footing refine at its edge.
        edge_radius: Half-width of the zone of ``edge_size`` cells around the edge
            (m); 0.4 B by default. The size grows back to h over as far again.
        edge_depth: How far down the edge will travel (m), from 0 to ``depth``: the
            zone reaches this much deeper, so the edge stays in it.
        edge_line: Make the edge's path, x = B/2 through the margin and the refined
            zone, a grid line. The footing then ends on grid nodes at every
            settlement, whatever the number of its base points; otherwise the cell
            it ends in is held over as much of its width as base points fall in it
            (on h = 0.2, 2 or 8 base points per cell gave q/c_u 7.1 or 8.9 at
            s/B = 0.5; with the line 7.5 either way).
        comm: MPI communicator.

    Returns:
        ``dolfinx.io.gmsh.MeshData`` with ``cell_tags`` (:data:`FOOTING_SOIL_NEAR`,
        :data:`FOOTING_SOIL`, :data:`FOOTING_MARGIN`) and ``facet_tags``
        (:data:`FOOTING_SYMMETRY`, :data:`FOOTING_FAR_SIDE`, :data:`FOOTING_BASE`).
    """
    check_range("strip_footing", "B", B, lo=0.0, lo_open=True)
    width = check_range(
        "strip_footing", "width", 5 * B if width is None else width, lo=B / 2, lo_open=True
    )
    depth = check_range(
        "strip_footing", "depth", 5 * B if depth is None else depth, lo=0.0, lo_open=True
    )
    margin = check_range(
        "strip_footing", "margin", B if margin is None else margin, lo=0.0, lo_open=True
    )
    near_width = check_range(
        "strip_footing",
        "near_width",
        1.5 * B if near_width is None else near_width,
        lo=0.0,
        hi=width,
        lo_open=True,
        hi_open=True,
    )
    near_depth = check_range(
        "strip_footing",
        "near_depth",
        3 * B if near_depth is None else near_depth,
        lo=0.0,
        hi=depth,
        lo_open=True,
        hi_open=True,
    )
    h = 0.05 * B if h is None else h  # an absolute 0.05 was 0.05 mm to a user in mm: 1e9 cells
    check_range("strip_footing", "h", h, lo=0.0, hi=min(near_width, margin), lo_open=True)
    h_far = check_range("strip_footing", "h_far", h if h_far is None else h_far, lo=h)
    edge = None
    if edge_size is not None:
        edge = (
            check_range("strip_footing", "edge_size", edge_size, lo=0.0, hi=h, lo_open=True),
            check_range(
                "strip_footing",
                "edge_radius",
                0.4 * B if edge_radius is None else edge_radius,
                lo=0.0,
                hi=B / 2,
                lo_open=True,
            ),
            check_range("strip_footing", "edge_depth", edge_depth, lo=0.0, hi=depth),
        )
    with gmsh_session("strip_footing") as model:
        if comm.rank == 0:
            occ = model.occ
            near = occ.addRectangle(0.0, -near_depth, 0.0, near_width, near_depth)
            soil = occ.addRectangle(0.0, -depth, 0.0, width, depth)
            above = occ.addRectangle(0.0, 0.0, 0.0, width, margin)
            tools = [(2, near), (2, above)]
            if edge_line:  # the footing's edge, x = B/2, on grid nodes at every settlement
                top, bottom = (
                    occ.addPoint(B / 2, margin, 0.0),
                    occ.addPoint(B / 2, -near_depth, 0.0),
                )
                tools.append((1, occ.addLine(top, bottom)))
            out, _ = occ.fragment([(2, soil)], tools)
            out = [entity for entity in out if entity[0] == 2]
            occ.synchronize()
            _tag_regions(model, [s for _, s in out], near_width, near_depth)
            _tag_sides(model, width, depth)
            _refine_near_footing(model, near_width, near_depth, margin, h, h_far, B, edge)
            model.mesh.generate(2)
        return to_dolfinx(model, gdim=2, comm=comm)


def _tag_regions(model, surfaces: list[int], near_width: float, near_depth: float) -> None:
    """Cell tags: the margin above the soil, the refined zone, the rest of the soil."""
    tags = {FOOTING_SOIL_NEAR: [], FOOTING_SOIL: [], FOOTING_MARGIN: []}
    for s in surfaces:
        x, y, _ = model.occ.getCenterOfMass(2, s)
        if y > 0:
            tags[FOOTING_MARGIN].append(s)
        elif x < near_width and y > -near_depth:
            tags[FOOTING_SOIL_NEAR].append(s)
        else:
            tags[FOOTING_SOIL].append(s)
    names = {FOOTING_SOIL_NEAR: "soil_near", FOOTING_SOIL: "soil", FOOTING_MARGIN: "margin"}
    for tag, tagged in tags.items():
        model.addPhysicalGroup(2, tagged, tag, name=names[tag])


def _tag_sides(model, width: float, depth: float) -> None:
    """Facet tags: the symmetry line x = 0, the far side x = width, the base y = −depth."""
    sides = {FOOTING_SYMMETRY: [], FOOTING_FAR_SIDE: [], FOOTING_BASE: []}
    tol = 1e-9 * max(width, depth)
    for _, c in model.getEntities(1):
        x, y = curve_ends(model, c)[:, :2].T
        if np.all(np.abs(x) < tol):
            sides[FOOTING_SYMMETRY].append(c)
        elif np.all(np.abs(x - width) < tol):
            sides[FOOTING_FAR_SIDE].append(c)
        elif np.all(np.abs(y + depth) < tol):
            sides[FOOTING_BASE].append(c)
    names = {FOOTING_SYMMETRY: "symmetry", FOOTING_FAR_SIDE: "far_side", FOOTING_BASE: "base"}
    for tag, curves in sides.items():
        model.addPhysicalGroup(1, curves, tag, name=names[tag])


def _refine_near_footing(
    model,
    near_width: float,
    near_depth: float,
    margin: float,
    h: float,
    h_far: float,
    B: float,
    edge: tuple[float, float, float] | None,
) -> None:
    """Cell size h in the refined zone and the strip above it, growing to h_far away.

    ``edge``: (size, radius, depth) of the finer zone around the footing's edge, or None.
    """
    field = model.mesh.field
    box = field.add("Box")
    # The box reaches past the grid's left and top edges, so the whole strip above
    # the zone and the symmetry line lie inside it (any reach > 0 gives the same grid).
    reach = BOX_REACH * max(near_width, margin)
    field.setNumber(box, "VIn", h)
    field.setNumber(box, "VOut", h_far)
    field.setNumber(box, "XMin", -reach)
    field.setNumber(box, "XMax", near_width)
    field.setNumber(box, "YMin", -near_depth)
    field.setNumber(box, "YMax", margin + reach)
    field.setNumber(box, "Thickness", max(near_width, near_depth))
    if edge is not None:
        size, radius, travel = edge
        fine = field.add("Box")
        field.setNumber(fine, "VIn", size)
        field.setNumber(fine, "VOut", h_far)
        field.setNumber(fine, "XMin", B / 2 - radius)
        field.setNumber(fine, "XMax", B / 2 + radius)
        field.setNumber(fine, "YMin", -travel - radius)
        field.setNumber(fine, "YMax", radius)
        field.setNumber(fine, "Thickness", radius)
        smallest = field.add("Min")
        field.setNumbers(smallest, "FieldsList", [box, fine])
        box = smallest
    field.setAsBackgroundMesh(box)
    model.mesh.setSize(model.getEntities(0), h_far)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)


def footing_points(B: float, n: int, thickness: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Penalty points of a rigid footing: its base, y = 0, x ∈ [0, B/2], and optionally its body.

    The base points alone leave the cells that the base crosses nearly empty
    above it: their upper grid nodes are held only by the few soil points just
    under the base, with an almost singular tangent once the soil there is
    plastic. Those cells then collapse in a converged step (at s/B ≈ 0.3 on a
    grid of h = 0.2 B). Body points on a square lattice of the same spacing
    filling the footing up to ``thickness`` above its base tie those nodes to the
    footing, as a real footing does; about two cell sizes is enough.

    Args:
        B: Footing width (m); the points cover the half-width B/2.
        n: Number of base points, spaced B/(2n) (m).
        thickness: Height of the body above the base (m), ≥ 0; 0 gives the base only.

    Returns:
        Positions (k, 2), base points first (at the segment midpoints), and weights
        (k,), all B/(2n) (m): every point carries the same penalty stiffness β·B/(2n).
    """
    check_range("footing_points", "B", B, lo=0.0, lo_open=True)
    n = check_int("footing_points", "n", n, lo=1)
    check_range("footing_points", "thickness", thickness, lo=0.0)
    spacing = B / (2 * int(n))
    s = (np.arange(int(n)) + 0.5) * spacing
    rows = np.arange(int(np.floor(thickness / spacing + 1e-9)) + 1) * spacing
    X, Y = np.meshgrid(s, rows)
    x = np.column_stack([X.ravel(), Y.ravel()])
    return x, np.full(x.shape[0], spacing)
