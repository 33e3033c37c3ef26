"""Import DOLFINx the way every install route needs, and check its version.

The PyPI wheel ``dolfinx-solver-real`` must be imported (``import
dolfinx_solver``) before dolfinx, petsc4py or mpi4py so that its bundled PETSc
and MPI libraries are the ones loaded. A conda or Spack install has no such
module, which is fine. Every fe_mpm module imports dolfinx through here.
"""

from __future__ import annotations

try:  # the wheel route; absent on conda/Spack installs
    import dolfinx_solver  # noqa: F401
except ImportError:
    pass

try:
    import dolfinx
except ImportError as err:  # pragma: no cover - depends on the machine
    raise ImportError(
        "fe-mpm needs DOLFINx 0.11. Install it with `pip install fe-mpm[wheel]` "
        "(PyPI wheel dolfinx-solver-real), or from conda-forge "
        "(`conda install -c conda-forge fenics-dolfinx=0.11`) or Spack."
    ) from err

REQUIRED = (0, 11)


def _major_minor(version: str) -> tuple[int, int]:
    parts = version.split(".")
    return int(parts[0]), int(parts[1])


if _major_minor(dolfinx.__version__) != REQUIRED:  # pragma: no cover
    raise ImportError(
        f"fe-mpm needs DOLFINx 0.11.x but found dolfinx {dolfinx.__version__} at "
        f"{dolfinx.__file__}. Install `fe-mpm[wheel]` or a 0.11 conda/Spack build."
    )
