"""Patch test: a homogeneous finite deformation is reproduced exactly at every point.

The displacement ``u = (F̄ − I) X`` is prescribed on the whole boundary of a box
filled with points at random positions, 1 to 4 per cell, whose volumes
partition each cell. Then ``Σ_p V_p ∇N_i`` vanishes at every interior node, the
linear field is the exact discrete solution, and every point must carry
``F = F̄`` and the Neo-Hookean stress of ``F̄`` to round-off; with volumetric
averaging (``u-nbva``) too, as the average of a uniform volume change is itself.
"""

import numpy as np
import pytest
from layouts import embed_3d, random_points

import fe_mpm
from fe_mpm.meshes import rectangle_mesh

F_BAR = {
    2: np.array([[1.3, 0.25], [-0.1, 0.85]]),
    3: np.array([[1.2, 0.1, -0.05], [0.15, 0.9, 0.1], [0.0, -0.2, 1.1]]),
}


def neo_hookean_cauchy_3d(mat, F):
    F3 = embed_3d(F)
    J = np.linalg.det(F3)
    return (mat.lmbda * np.log(J) * np.eye(3) + mat.mu * (F3 @ F3.T - np.eye(3))) / J


@pytest.mark.parametrize("formulation", ["u", "u-nbva"])
@pytest.mark.parametrize("dim", [2, 3])
def test_homogeneous_deformation_is_exact_at_every_point(dim, formulation):
    rng = np.random.default_rng(7)
    n = (5, 4) if dim == 2 else (3, 3, 2)
    mesh = rectangle_mesh(np.zeros(dim), np.ones(dim), n)
    counts = rng.integers(1, 5, size=mesh.topology.index_map(dim).size_local)
    points, _ = random_points(mesh, rng, counts, fill=True)
    mat = fe_mpm.NeoHookean(E=50.0, nu=0.35)
    F_bar = F_BAR[dim]
    on_boundary = fe_mpm.Dirichlet(
        lambda x: np.ones(x.shape[1], dtype=bool),
        profile=lambda x, t: t * (F_bar - np.eye(dim)) @ x[:dim],
    )
    x_start = points.x.copy()
    sim = fe_mpm.Simulation(mesh, points, mat, formulation, dirichlet=[on_boundary])
    sim.run(n_steps=1, progress=False)

    assert np.abs(points.F - F_bar).max() < 1e-12
    assert np.abs(points.x - x_start @ F_bar.T).max() < 1e-12
    sigma = neo_hookean_cauchy_3d(mat, F_bar)
    assert np.abs(points.stress - sigma).max() < 1e-11 * np.abs(sigma).max()
    assert np.allclose(points.volume.sum(), np.linalg.det(F_bar), rtol=1e-12)


def test_two_steps_compose_their_increments_in_order():
    """Two non-commuting homogeneous increments, prescribed at every node of a one-square
    grid (so the grid field is the linear map itself, whatever the points' layout after
    step 1). The grid is reset, so each step imposes ΔF_k = I + ΔM_k on the points where
    they are: they must carry F = ΔF₂ ΔF₁, not ΔF₁ ΔF₂ (which differs by 0.02), positions
    F X, volumes det F V₀, and the stress of F. Both maps keep the body on the grid."""
    rng = np.random.default_rng(11)
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (1, 1))
    points, _ = random_points(mesh, rng, np.array([3, 4]), fill=True)
    first, second = np.array([[-0.2, 0.1], [0.0, 0.0]]), np.array([[0.0, 0.0], [0.1, -0.2]])

    def M(t):
        return t * first if t <= 1.0 else first + (t - 1.0) * second

    everywhere = fe_mpm.Dirichlet(
        lambda x: np.ones(x.shape[1], dtype=bool), profile=lambda x, t: M(t) @ x[:2]
    )
    mat = fe_mpm.NeoHookean(E=50.0, nu=0.35)
    x0, V0 = points.x.copy(), points.volume.copy()
    sim = fe_mpm.Simulation(mesh, points, mat, dirichlet=[everywhere])
    sim.run(t_end=2.0, n_steps=2, progress=False)
    F = (np.eye(2) + second) @ (np.eye(2) + first)
    assert np.abs(F - (np.eye(2) + first) @ (np.eye(2) + second)).max() > 0.01
    assert np.abs(points.F - F).max() < 1e-12
    assert np.abs(points.x - x0 @ F.T).max() < 1e-12
    assert np.allclose(points.volume, np.linalg.det(F) * V0, rtol=1e-12, atol=0)
    sigma = neo_hookean_cauchy_3d(mat, F)
    assert np.abs(points.stress - sigma).max() < 1e-11 * np.abs(sigma).max()
