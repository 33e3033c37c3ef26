"""Suite-wide set-up.

fe_mpm is imported first: the dolfinx-solver-real wheel must be imported
before dolfinx, petsc4py and mpi4py, and fe_mpm takes care of that.
"""

import fe_mpm  # noqa: F401
