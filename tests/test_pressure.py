"""A normal pressure on grid facets (`fe_mpm.Pressure`): direction, magnitude, references."""

from mpi4py import MPI

import dolfinx
import numpy as np
import pytest

import fe_mpm
from fe_mpm import meshes

A, B, P = 1.0, 2.0, 1e3  # the ring's radii (m) and its inner pressure (Pa)


def _ring(formulation: str, nu: float, h: float) -> tuple[float, np.ndarray]:
    """The elastic quarter ring pressurised in one step: its u(a) (m) and the reaction
    on the line y = 0 (N/m)."""
    scene = meshes.quarter_ring(A, B, h)
    points = fe_mpm.seed(scene.mesh, per_cell=3, cells=scene.cell_tags.find(meshes.RING_BODY))
    sim = fe_mpm.Simulation(
        scene.mesh,
        points,
        fe_mpm.NeoHookean(1e7, nu),
        formulation,
        facet_tags=scene.facet_tags,
        tractions=[fe_mpm.Pressure(meshes.RING_INNER, P)],
        dirichlet=[
            fe_mpm.Dirichlet(meshes.RING_X_AXIS, component=1),
            fe_mpm.Dirichlet(meshes.RING_Y_AXIS, component=0),
        ],
        reactions={"x_axis": meshes.RING_X_AXIS},
    )
    sim.add_marker("inner", (A * np.cos(0.3), A * np.sin(0.3)))
    report = sim.run(1.0, 1, progress=False)[-1]
    return np.linalg.norm(report.markers["inner"]) - A, report.reactions["x_axis"]


def _lame(nu: float) -> float:
    """u(a) (m) of the plane-strain tube under P, E = 1e7 Pa (Lamé)."""
    return (1 + nu) * A**2 * P / (1e7 * (B**2 - A**2)) * ((1 - 2 * nu) * A + B**2 / A)


@pytest.mark.parametrize("formulation, nu", [("u", 0.3), ("up", 0.4999)])
def test_a_pressurised_ring_converges_to_lame_and_its_reaction_balances_the_pressure(
    formulation, nu
):
    """The pressure pushes each facet of the polygonal inner arc along its own normal,
    so its pull on the line y = 0 is exactly P a (the arc's chords project onto a),
    to round-off (measured 1e-12 of it). u(a) against Lamé (measured: u −2.9 % on
    h = a/5, −0.74 % on a/10; up −2.0 %, −0.38 %): within 1 % on a/10, and falling at
    about second order. A pressure of the wrong sign, or a traction in one direction, fails
    both."""
    errors = []
    for h in (0.2, 0.1):
        expansion, reaction = _ring(formulation, nu, h)
        np.testing.assert_allclose(reaction, [0.0, -P * A], atol=1e-9 * P * A)
        errors.append(expansion / _lame(nu) - 1.0)
    assert abs(errors[1]) < 0.01
    assert abs(errors[1]) < abs(errors[0]) / 3.0


def test_one_pressure_on_two_faces_of_a_box_pushes_each_along_its_own_normal():
    """A cube of tetrahedra, held by rollers on x = 0, y = 0 and z = 0, under one
    Pressure on its faces x = 1 and z = 1: the rollers on x = 0 and z = 0 take P times
    their face's area along their normals and the one on y = 0 nothing, to round-off,
    and the elastic cube deforms as a homogeneous stress of −P in x and z gives
    (Hooke, to the law's small nonlinearity at P/E = 1e-4)."""
    mesh = dolfinx.mesh.create_box(MPI.COMM_WORLD, [[0.0] * 3, [1.0] * 3], [3, 3, 3])
    points = fe_mpm.seed(mesh, per_cell=4)
    rollers = {f"x{c}": (lambda x, c=c: np.isclose(x[c], 0.0)) for c in range(3)}
    E, nu = 1e7, 0.25
    sim = fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.NeoHookean(E, nu),
        "up",
        dirichlet=[
            fe_mpm.Dirichlet(where, component=c) for c, where in enumerate(rollers.values())
        ],
        tractions=[fe_mpm.Pressure(lambda x: np.isclose(x[0], 1.0) | np.isclose(x[2], 1.0), P)],
        reactions=rollers,
    )
    sim.add_marker("corner", (1.0, 1.0, 1.0))
    report = sim.run(1.0, 1, progress=False)[-1]
    # Each roller's own component (its edge nodes also carry the other rollers' share).
    pushed_back = [report.reactions[name][c] for c, name in enumerate(rollers)]
    np.testing.assert_allclose(pushed_back, [P, 0.0, P], atol=1e-9 * P)
    strain = np.array([-P + nu * P, 2 * nu * P, -P + nu * P]) / E  # σ = (−P, 0, −P)
    np.testing.assert_allclose(report.markers["corner"] - 1.0, strain, rtol=1e-3)


def test_a_load_on_facets_inside_the_grid_or_not_finite_is_refused():
    """A tag of facets inside the grid has no outward normal to push along; a NaN
    pressure and a load of another kind in ``tractions=`` are refused by name."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 2.0), (2, 4))
    mesh.topology.create_connectivity(1, 2)
    inside = dolfinx.mesh.locate_entities(mesh, 1, lambda x: np.isclose(x[1], 1.0))
    tags = dolfinx.mesh.meshtags(mesh, 1, inside, np.full(inside.size, 7, dtype=np.int32))
    points = fe_mpm.seed(mesh, per_cell=3)
    law = fe_mpm.NeoHookean(1e7, 0.3)
    base = fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))
    with pytest.raises(ValueError, match=r"Pressure 0: 2 of its facets lie inside the grid"):
        fe_mpm.Simulation(
            mesh, points, law, dirichlet=[base], facet_tags=tags, tractions=[fe_mpm.Pressure(7, P)]
        )
    # Nor a Traction: its load stayed on that line as the face moved off it (a helper's
    # plate pulled to 0.2 E ended 15 % short, 2026-12-07).
    pull = fe_mpm.Traction(7, (0.0, P))
    with pytest.raises(ValueError, match=r"Traction 0: 2 of its facets lie inside the grid, wh"):
        fe_mpm.Simulation(mesh, points, law, dirichlet=[base], facet_tags=tags, tractions=[pull])
    with pytest.raises(ValueError, match=r"Pressure: value must .*got nan"):
        fe_mpm.Pressure(7, float("nan"))
    with pytest.raises(TypeError, match=r"tractions\[0\] must be a Traction or a Pressure"):
        fe_mpm.Simulation(mesh, points, law, dirichlet=[base], tractions=[base])
