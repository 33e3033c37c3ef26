"""Which route compiled work takes: compiled (numba) or numpy.

The compiled kernels (:mod:`fe_mpm.materials.compiled` for the principal-space
laws, :mod:`fe_mpm.clip_kernels` for cutting point domains) are the default. The
numpy functions they mirror stay as the reference the suite checks them against,
and as the route where numba is missing (a warning says so, once) or where
``FE_MPM_COMPILED=0`` is set in the environment (e.g. to compare the two).
"""

from __future__ import annotations

import importlib
import os
from types import ModuleType

from fe_mpm.errors import warn

#: Set to ``0`` to take the numpy route.
ENVIRONMENT_VARIABLE = "FE_MPM_COMPILED"

_missing: dict[str, str] = {}  # module -> why it could not be imported


def compiled_module(name: str, purpose: str) -> ModuleType | None:
    """The compiled module ``name``, or None for the numpy route.

    None where ``FE_MPM_COMPILED=0`` is set, or where the module cannot be imported
    (numba missing): a warning naming ``purpose`` says so, once per module.
    """
    if os.environ.get(ENVIRONMENT_VARIABLE, "1").strip() == "0" or name in _missing:
        return None
    try:
        return importlib.import_module(name)
    # numba is a dependency, but an environment may lack it, or a place to cache
    # compiled code (a RuntimeError when the kernels are decorated).
    except (ImportError, RuntimeError) as error:
        _missing[name] = str(error)
        warn(
            f"fe_mpm: {purpose} need numba ({error}); taking the numpy route, several "
            "times slower. pip install numba"
        )
        return None


def compiled() -> ModuleType | None:
    """:mod:`fe_mpm.materials.compiled`, or None for the numpy route."""
    return compiled_module("fe_mpm.materials.compiled", "the compiled return maps")
