"""One MPM load step equals a standard DOLFINx FEM solve with the same quadrature rule.

With the points at the Gauss points of a rule (1 at the centroid, or the
degree-2 rule: 3 per triangle, 4 per tetrahedron) and the volumes equal to the
Gauss weights, the particle sums are that rule's quadrature, so one static step
from the undeformed state must give the FEM answer to solver precision.
"""

import dolfinx.fem.petsc
import numpy as np
import pytest
import ufl

import fe_mpm
from fe_mpm import meshes
from fe_mpm._dolfinx import dolfinx as dfx

TIGHT = {"snes_rtol": 1e-12, "snes_atol": 1e-15, "snes_stol": 1e-14}
RTOL = 1e-10


def _fem_solve(mesh, facet_tags, loaded, clamped, material, density, b, t, degree):
    """Standard finite-strain FEM (Neo-Hookean, P1) with a degree-``degree`` rule."""
    g = mesh.geometry.dim
    V = dfx.fem.functionspace(mesh, ("Lagrange", 1, (g,)))
    u, w = dfx.fem.Function(V), ufl.TestFunction(V)
    F = ufl.Identity(g) + ufl.grad(u)
    P = material.kirchhoff(F) * ufl.inv(F).T
    dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": degree})
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)
    R = (ufl.inner(P, ufl.grad(w)) - density * ufl.dot(ufl.as_vector(b), w)) * dx
    R -= ufl.dot(ufl.as_vector(t), w) * ds(loaded)
    fdim = g - 1
    dofs = dfx.fem.locate_dofs_topological(V, fdim, facet_tags.find(clamped))
    bc = dfx.fem.dirichletbc(np.zeros(g), dofs, V)
    options = {
        "snes_type": "newtonls",
        "snes_linesearch_type": "basic",
        "ksp_type": "preonly",
        "pc_type": "lu",
        "pc_factor_mat_solver_type": "mumps",
        **TIGHT,
    }
    problem = dolfinx.fem.petsc.NonlinearProblem(
        R, u, bcs=[bc], petsc_options_prefix="fem_ref_", petsc_options=options
    )
    problem.solve()
    assert problem.solver.getConvergedReason() > 0
    return u.x.array.copy()


def _mpm_solve(mesh, facet_tags, loaded, clamped, material, density, b, t, per_cell):
    points = fe_mpm.seed(mesh, per_cell=per_cell, density=density)
    sim = fe_mpm.Simulation(
        mesh,
        points,
        material,
        facet_tags=facet_tags,
        dirichlet=[fe_mpm.Dirichlet(clamped)],
        tractions=[fe_mpm.Traction(loaded, t)],
        body_force=b,
        petsc_options=TIGHT,
    )
    sim.run(n_steps=1, progress=False)
    return sim.w.x.array.copy(), points


def _box_3d():
    mesh = meshes.rectangle_mesh((0.0, 0.0, 0.0), (4.0, 1.0, 1.0), (6, 2, 2))
    fdim = 2
    mesh.topology.create_connectivity(fdim, 3)
    left = dfx.mesh.locate_entities_boundary(mesh, fdim, lambda x: np.isclose(x[0], 0.0))
    right = dfx.mesh.locate_entities_boundary(mesh, fdim, lambda x: np.isclose(x[0], 4.0))
    facets = np.concatenate([left, right])
    values = np.concatenate([np.full(left.size, 1), np.full(right.size, 2)]).astype(np.int32)
    order = np.argsort(facets)
    tags = dfx.mesh.meshtags(mesh, fdim, facets[order], values[order])
    return mesh, tags, 2, 1


@pytest.mark.parametrize("per_cell,degree", [(1, 1), (3, 2)])
def test_cook_one_step_equals_fem(per_cell, degree):
    scene = meshes.cook_membrane(n=8)
    args = (
        scene.mesh,
        scene.facet_tags,
        meshes.COOK_LOADED,
        meshes.COOK_CLAMPED,
        fe_mpm.NeoHookean(E=70.0, nu=0.4),
        2.0,
        (0.0, -0.005),
        (0.0, 1 / 16),
    )
    u_mpm, points = _mpm_solve(*args, per_cell)
    u_fem = _fem_solve(*args, degree)
    assert len(points) == per_cell * scene.mesh.topology.index_map(2).size_local
    assert np.linalg.norm(u_mpm - u_fem) <= RTOL * np.linalg.norm(u_fem)


@pytest.mark.parametrize("per_cell,degree", [(1, 1), (4, 2)])
def test_3d_beam_one_step_equals_fem(per_cell, degree):
    mesh, tags, loaded, clamped = _box_3d()
    args = (
        mesh,
        tags,
        loaded,
        clamped,
        fe_mpm.NeoHookean(E=100.0, nu=0.3),
        1.0,
        (0.0, 0.0, -0.5),
        (0.0, 0.3, 1.0),
    )
    u_mpm, _ = _mpm_solve(*args, per_cell)
    u_fem = _fem_solve(*args, degree)
    assert np.abs(u_fem).max() > 0.05, "want a finite-strain case"
    assert np.linalg.norm(u_mpm - u_fem) <= RTOL * np.linalg.norm(u_fem)
