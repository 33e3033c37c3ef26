"""Bad input fails early with a message that names the field and the valid range."""

from mpi4py import MPI

import basix.ufl
import numpy as np
import pytest

import fe_mpm
from fe_mpm._dolfinx import dolfinx
from fe_mpm.meshes import cook_membrane, rectangle_mesh


@pytest.mark.parametrize("nu", [0.5, 0.6, -1.0, float("nan")])
def test_poisson_ratio_out_of_range(nu):
    with pytest.raises(ValueError, match=r"NeoHookean: nu must lie in \(-1, 0.5\)"):
        fe_mpm.NeoHookean(E=1.0, nu=nu)


@pytest.mark.parametrize("E", [0.0, -70.0])
def test_young_modulus_not_positive(E):
    with pytest.raises(ValueError, match=r"NeoHookean: E must lie in \(0, inf\]"):
        fe_mpm.NeoHookean(E=E, nu=0.3)


def _scene():
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    return mesh, fe_mpm.seed(mesh)


def test_unknown_formulation():
    mesh, points = _scene()
    with pytest.raises(ValueError, match=r"unknown formulation 'uu'; choose one of u"):
        fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1.0, 0.3), formulation="uu")


def test_taylor_hood_needs_enough_points_per_cell():
    mesh, points = _scene()  # one point per cell
    sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1.0, 0.3), formulation="up-p2p1")
    with pytest.raises(ValueError, match="'up-p2p1' needs at least 3 material points in every"):
        sim.step(1.0)


def test_empty_mesh():
    element = basix.ufl.element("Lagrange", "triangle", 1, shape=(2,))
    empty = dolfinx.mesh.create_mesh(
        MPI.COMM_WORLD, np.zeros((0, 3), dtype=np.int64), element, np.zeros((0, 2)))
    with pytest.raises(ValueError, match="seed: the mesh has no cells"):
        fe_mpm.seed(empty)
    _, points = _scene()
    with pytest.raises(ValueError, match="Simulation: the mesh is empty"):
        fe_mpm.Simulation(empty, points, fe_mpm.NeoHookean(1.0, 0.3))


def test_other_bad_values():
    mesh, points = _scene()
    with pytest.raises(ValueError, match=r"seed: per_cell must be one of \[1, 3, 6, 7, 12"):
        fe_mpm.seed(mesh, per_cell=2)
    with pytest.raises(ValueError, match=r"seed: density must lie in \(0, inf\]"):
        fe_mpm.seed(mesh, density=-1.0)
    with pytest.raises(ValueError, match=r"cook_membrane: n must lie in \[1, inf\]"):
        cook_membrane(n=0)
    sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1.0, 0.3))
    with pytest.raises(ValueError, match=r"Simulation.run: n_steps must lie in \[1, inf\]"):
        sim.run(n_steps=0)
    with pytest.raises(ValueError, match="boundary tag 7 given but the mesh has no facet tags"):
        fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1.0, 0.3),
                          dirichlet=[fe_mpm.Dirichlet(7)])
    material = fe_mpm.NeoHookean(1.0, 0.3)
    unknown_mass = "Simulation: unknown mass 'diagonal'; choose one of consistent, lumped"
    with pytest.raises(ValueError, match=unknown_mass):
        fe_mpm.Simulation(mesh, points, material, dynamic=True, mass="diagonal")
    with pytest.raises(ValueError, match=r"Simulation: damping must lie in \[0"):
        fe_mpm.Simulation(mesh, points, material, dynamic=True, damping=-1.0)
    with pytest.raises(ValueError, match="mass='lumped' needs dynamic=True"):
        fe_mpm.Simulation(mesh, points, material, mass="lumped")
    with pytest.raises(ValueError, match="unknown fallback_line_search 'newton'"):
        fe_mpm.Simulation(mesh, points, material, fallback_line_search="newton")
    with pytest.raises(fe_mpm.PointsOutsideError, match="left the grid at set-up"):
        outside = fe_mpm.MaterialPoints(x=[[2.0, 2.0]], volume=[1.0], mass=[1.0])
        fe_mpm.Simulation(mesh, outside, fe_mpm.NeoHookean(1.0, 0.3))


def test_divergence_stops_with_step_and_reason():
    """An impossible load: Newton fails, the message says where and when, nothing moves."""
    mesh, points = _scene()
    x_before = points.x.copy()
    sim = fe_mpm.Simulation(
        mesh, points, fe_mpm.NeoHookean(1.0, 0.3),
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0))],
        tractions=[fe_mpm.Traction(lambda x: np.isclose(x[0], 1.0), (1e6, 0.0))],
        petsc_options={"snes_max_it": 8},
    )
    where = r"Newton failed in step 1 \(t = 0 -> 1\)"
    with pytest.raises(fe_mpm.ConvergenceError, match=where) as err:
        sim.step(1.0)
    assert np.array_equal(points.x, x_before) and sim.step_number == 0
    # Full Newton steps fail at once (the first step makes the residual NaN); the
    # retry with the bt line search then runs to the iteration limit.
    assert "after 8 iterations: DIVERGED_MAX_IT" in str(err.value)


def test_singular_tangent_names_the_hinged_cells():
    """Two occupied cells meeting at one node, the first clamped, under gravity: the
    second can only swing about the shared node (no static equilibrium)."""
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (4, 4))
    nodes = mesh.geometry.dofmaps[0]
    x = mesh.geometry.x[:, :2]
    on_left = np.isclose(x[nodes][:, :, 0], 0.0).any(axis=1)
    clamped_cell = np.flatnonzero(on_left)[0]
    shared = np.array([np.intersect1d(nodes[clamped_cell], row).size for row in nodes])
    away = ~(np.isclose(x[nodes][:, :, 0], 0.0).any(axis=1))
    hinged_cell = np.flatnonzero((shared == 1) & away)[0]
    points = fe_mpm.seed(mesh, per_cell=1, cells=[clamped_cell, hinged_cell])
    sim = fe_mpm.Simulation(
        mesh, points, fe_mpm.NeoHookean(1.0, 0.3), body_force=(0.0, -1.0),
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0))],
    )
    hinge = r"\d+ occupied cell.* share at most one node"
    with pytest.raises(fe_mpm.ConvergenceError, match=hinge):
        sim.step(1.0)


def test_taylor_hood_warns_when_points_move_into_too_few_per_cell():
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    points = fe_mpm.seed(mesh, per_cell=3)
    sim = fe_mpm.Simulation(mesh, points, fe_mpm.NeoHookean(1.0, 0.3), formulation="up-p2p1",
                            dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))])
    sim.step(1.0)
    first = np.flatnonzero(points.cell == points.cell[0])[0]
    other = np.flatnonzero(points.cell != points.cell[0])[0]
    points.x[first] = points.x[other]  # one cell now holds 2 points
    with pytest.warns(UserWarning, match="needs at least 3 material points .* may be singular"):
        sim.step(2.0)
