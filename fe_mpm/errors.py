"""Errors that say where and when a run stopped, and the warnings fe-mpm gives."""

import warnings
from pathlib import Path

#: Warnings point at the first caller outside the package, however deep they arise.
_PACKAGE = (str(Path(__file__).parent),)


class ConvergenceError(RuntimeError):
    """Newton did not converge, or produced non-finite values, in a step."""


class PointsOutsideError(RuntimeError):
    """Material points left the background grid."""


def warn(message: str) -> None:
    """A ``UserWarning`` attributed to the user's line that called into fe_mpm."""
    warnings.warn(message, skip_file_prefixes=_PACKAGE)
