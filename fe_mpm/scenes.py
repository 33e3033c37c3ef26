"""Ready-made simulations of the benchmark scenes (geometry from :mod:`fe_mpm.meshes`).

The demos spell these set-ups out step by step; tests and benchmarks call them.
"""

from __future__ import annotations

from fe_mpm import meshes
from fe_mpm.boundary import Dirichlet, PointTraction, Traction
from fe_mpm.materials import NeoHookean
from fe_mpm.particles import seed
from fe_mpm.simulation import Simulation


def cook_membrane(
    n: int = 16,
    nu: float = 0.33,
    formulation: str = "u",
    *,
    E: float = 70.0,
    per_cell: int = 1,
    structured: bool = True,
    h: float | None = None,
    margin: int = 0,
    material=None,
    traction: float = 1.0 / 16.0,
    load: str = "grid",
    **options,
) -> Simulation:
    """Cook's membrane as in Iaconeta (2019) Table 5.1, with marker ``"A"`` at (48, 60).

    Clamped left edge, vertical traction 1/16 on the right edge ramped with the
    pseudo-time ``t`` (full load at ``t = 1``), Neo-Hookean material unless
    another law is given.

    Args:
        n: Elements per side of the structured grid.
        nu: Poisson's ratio.
        formulation: See :mod:`fe_mpm.formulations`.
        E: Young's modulus.
        per_cell: Material points per triangle.
        structured: Structured (lower-left to upper-right cut) or unstructured grid.
        h: Element size of the unstructured grid.
        margin: Rows of empty cells above and below the body (for several steps).
        material: The law; default ``NeoHookean(E, nu)``.
        traction: Vertical traction on the right edge at full load.
        load: ``"grid"``: a :class:`Traction` on the right grid edge (the thesis's
            set-up; it stays there, so it suits one step or small motion);
            ``"points"``: a :class:`PointTraction` on points at the edge's facet
            midpoints, which follow the body (for large motion over many steps;
            in one step it equals the grid load).
        options: Passed on to :class:`~fe_mpm.simulation.Simulation`.
    """
    scene = meshes.cook_membrane(n=n, structured=structured, h=h, margin=margin)
    points = seed(scene.mesh, per_cell=per_cell, cells=meshes.body_cells(scene))
    loads = {}
    if load == "grid":
        loads["tractions"] = [Traction(meshes.COOK_LOADED, (0.0, traction), scale=lambda t: t)]
    elif load == "points":
        x, weight = meshes.facet_points(scene.mesh, scene.facet_tags.find(meshes.COOK_LOADED))
        loads["point_tractions"] = [
            PointTraction("load", x, weight, (0.0, traction), scale=lambda t: t)]
    else:
        raise ValueError(f"cook_membrane: load must be 'grid' or 'points', got {load!r}")
    sim = Simulation(
        scene.mesh, points, material or NeoHookean(E=E, nu=nu), formulation,
        facet_tags=scene.facet_tags, dirichlet=[Dirichlet(meshes.COOK_CLAMPED)],
        **loads, **options,
    )
    sim.add_marker("A", meshes.COOK_POINT_A)
    return sim


def tip_deflection(sim: Simulation) -> float:
    """Vertical displacement of Cook's point A (m)."""
    return float(sim.marker("A")[1] - meshes.COOK_POINT_A[1])
