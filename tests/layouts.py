"""Random material-point layouts and small scenes shared by the verification tests."""

import numpy as np

import fe_mpm
from fe_mpm.meshes import cell_centroids, rectangle_mesh
from fe_mpm.particles import MaterialPoints
from fe_mpm.tracker import Tracker


def random_points(mesh, rng, counts, fill=True, F_spread=0.0):
    """Points at random positions inside cells, ``counts[c]`` in cell c.

    With ``fill`` the volumes of each cell's points are a random partition of
    the cell volume; otherwise they are random. ``F_spread`` perturbs F_n
    randomly around the identity (a deformed history).
    """
    tracker = Tracker(mesh)
    tdim = mesh.topology.dim
    gdim = mesh.geometry.dim
    cells = np.repeat(np.arange(counts.size, dtype=np.int32), counts)
    bary = rng.dirichlet(np.ones(tdim + 1), size=cells.size)
    nodes = mesh.geometry.x[mesh.geometry.dofmaps[0][cells], :gdim]
    x = np.einsum("pv,pvg->pg", bary, nodes)
    share = rng.uniform(0.2, 1.0, size=cells.size)
    if fill:
        total = np.bincount(cells, weights=share, minlength=counts.size)
        volume = tracker.volumes[cells] * share / total[cells]
    else:
        volume = tracker.volumes[cells] * share
    F = np.eye(gdim) + F_spread * rng.uniform(-1, 1, size=(cells.size, gdim, gdim))
    pts = MaterialPoints(x=x, volume=volume, mass=volume * rng.uniform(0.5, 2.0, cells.size), F=F)
    return pts, cells


def embed_3d(F):
    """3x3 deformation gradients of (..., g, g) ones: plane strain puts F_33 = 1."""
    F = np.asarray(F)
    F3 = np.broadcast_to(np.eye(3), (*F.shape[:-2], 3, 3)).copy()
    F3[..., : F.shape[-2], : F.shape[-1]] = F
    return F3


def geostatic_layer(gravity: float = 9.81):
    """A Mohr–Coulomb layer 1 m deep in a 4 m × 2 m grid of 0.2 m cells, at rest.

    Returns the grid, the points (three per triangle below y = 1 m), the law
    (E = 20 MPa, ν = 0.3, c = 1 kPa, φ = 30°, 2000 kg/m³) and the points' stress at
    rest (K₀ = 0.5), for ``Simulation(..., initial_stress=)``.
    """
    import fe_mpm
    from fe_mpm.meshes import cell_centroids, rectangle_mesh

    grid = rectangle_mesh((0.0, 0.0), (4.0, 2.0), (20, 10))
    cells = np.flatnonzero(cell_centroids(grid)[:, 1] < 1.0)
    points = fe_mpm.seed(grid, 3, density=2000.0, cells=cells)
    law = fe_mpm.MohrCoulomb(E=2e7, nu=0.3, cohesion=1e3, friction_angle=30.0, density=2000.0)
    return grid, points, law, fe_mpm.geostatic_stress(points, 1.0, gravity, 0.5)


def base_and_rollers(width: float) -> list:
    """A fixed base (y = 0) and rollers on the sides x = 0 and x = ``width``: a layer's supports."""
    import fe_mpm

    def sides(x):
        return np.isclose(x[0], 0.0) | np.isclose(x[0], width)

    return [
        fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0)),
        fe_mpm.Dirichlet(sides, component=0),
    ]


def translating_block(points_leaving: str, per_cell: int = 1, **options):
    """Points in the right half of a 2 × 1 grid of 8 × 4 cells, every node moved 0.6 t
    to the right (a Neo-Hookean block translated rigidly out through the grid's right
    edge); ``options`` go to ``Simulation``. Returns the simulation and its points."""
    mesh = rectangle_mesh((0.0, 0.0), (2.0, 1.0), (8, 4))
    cells = np.flatnonzero(cell_centroids(mesh)[:, 0] > 1.0)
    points = fe_mpm.seed(mesh, per_cell=per_cell, cells=cells)
    everywhere = lambda x: np.ones(x.shape[1], dtype=bool)  # noqa: E731
    sim = fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.NeoHookean(E=1.0, nu=0.3),
        dirichlet=[fe_mpm.Dirichlet(everywhere, value=lambda t: (0.6 * t, 0.0))],
        points_leaving=points_leaving,
        **options,
    )
    return sim, points
