"""Errors that say where and when a run stopped, and the warnings fe-mpm gives."""

import warnings
from pathlib import Path

#: Warnings point at the first caller outside the package, however deep they arise.
_PACKAGE = (str(Path(__file__).parent),)


class ConvergenceError(RuntimeError):
    """Newton did not converge, or produced non-finite values, in a step."""


class PointsOutsideError(RuntimeError):
    """Material points left the background grid."""


class StepLeavesGridError(PointsOutsideError):
    """A step would carry point domains (or a marker's host) out of the grid.

    Refused before anything moved, so the run still writes the steps it accepted. (A
    step of standard MPM that carries points out is kept and told of, its solution
    being the grid's; the next step's tracking stops the run.)
    """


class MarkerHostLeftError(StepLeavesGridError):
    """A step would carry a marker's host point out of the grid.

    Refused before anything moved, so the run still writes the steps it accepted.
    """


def warn(message: str) -> None:
    """A ``UserWarning`` attributed to the user's line that called into fe_mpm.

    Under MPI only rank 0 warns: fe-mpm reduces what it warns about over the ranks
    first, so every rank would say the same.
    """
    from mpi4py import MPI  # here: importing the errors must stay light

    if MPI.COMM_WORLD.rank == 0:
        warnings.warn(message, skip_file_prefixes=_PACKAGE)
