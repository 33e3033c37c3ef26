"""fe-mpm: an implicit Material Point Method on FEniCSx.

The material points are the quadrature points of UFL weak forms on a background
simplex grid that is reset after every step (Iaconeta 2019).

Typical use::

    import fe_mpm
    from fe_mpm import meshes
    from fe_mpm.materials import NeoHookean

    scene = meshes.cook_membrane(n=16, margin=1)  # an empty row for the body to move into
    points = fe_mpm.seed(scene.mesh, per_cell=1, cells=meshes.body_cells(scene))
    sim = fe_mpm.Simulation(scene.mesh, points, NeoHookean(E=70.0, nu=0.33),
                            facet_tags=scene.facet_tags, ...)
"""

# dolfinx must be imported through fe_mpm._dolfinx first: the PyPI wheel needs
# `import dolfinx_solver` before dolfinx, petsc4py and mpi4py.
from fe_mpm import _dolfinx  # noqa: F401, I001
from fe_mpm.boundary import (
    STICKING,
    Dirichlet,
    PointDirichlet,
    PointPressure,
    PointTraction,
    Pressure,
    RigidWall,
    Traction,
)
from fe_mpm.checkpoint import CheckpointError
from fe_mpm.errors import ConvergenceError, PointsOutsideError
from fe_mpm.initial_stress import geostatic_stress
from fe_mpm.materials import (
    DruckerPrager,
    HenckyJ2,
    J2Plasticity,
    MatsuokaNakai,
    ModifiedDruckerPrager,
    MohrCoulomb,
    NeoHookean,
    NewtonianFluid,
    SmoothCapDruckerPrager,
)
from fe_mpm.particles import MaterialPoints, merge, seed
from fe_mpm.report import StepReport
from fe_mpm.simulation import Simulation
from fe_mpm.walls import WallForces

# The scene builders and ready-made scenes are public too: ``fe_mpm.meshes.…`` works
# after ``import fe_mpm``, as ``dolfinx.mesh`` does after ``import dolfinx``.
from fe_mpm import meshes, scenes  # noqa: E402

__version__ = "0.1.0"

__all__ = [
    "CheckpointError",
    "ConvergenceError",
    "Dirichlet",
    "DruckerPrager",
    "HenckyJ2",
    "J2Plasticity",
    "MaterialPoints",
    "MatsuokaNakai",
    "ModifiedDruckerPrager",
    "MohrCoulomb",
    "NeoHookean",
    "NewtonianFluid",
    "PointDirichlet",
    "PointPressure",
    "PointTraction",
    "PointsOutsideError",
    "Pressure",
    "RigidWall",
    "STICKING",
    "Simulation",
    "SmoothCapDruckerPrager",
    "StepReport",
    "Traction",
    "WallForces",
    "geostatic_stress",
    "merge",
    "meshes",
    "scenes",
    "seed",
]
