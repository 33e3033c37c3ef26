"""Which route the principal-space laws take: compiled (numba) or numpy.

The compiled kernels (:mod:`fe_mpm.materials.compiled`) are the default. The numpy
functions they mirror stay as the reference the suite checks them against, and as
the route where numba is missing (a warning says so, once) or where
``FE_MPM_COMPILED=0`` is set in the environment (e.g. to compare the two).
"""

from __future__ import annotations

import os
from types import ModuleType

from fe_mpm.errors import warn

#: Set to ``0`` to take the numpy route.
ENVIRONMENT_VARIABLE = "FE_MPM_COMPILED"

_missing: list[str] = []


def compiled() -> ModuleType | None:
    """:mod:`fe_mpm.materials.compiled`, or None for the numpy route."""
    if os.environ.get(ENVIRONMENT_VARIABLE, "1").strip() == "0" or _missing:
        return None
    try:
        from fe_mpm.materials import compiled as module
    except ImportError as error:  # numba is a dependency, but an environment may lack it
        _missing.append(str(error))
        warn(
            f"fe_mpm: the compiled return maps need numba ({error}); taking the numpy "
            "route, several times slower on plastic scenes. pip install numba"
        )
        return None
    return module
