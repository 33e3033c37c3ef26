"""Errors that say where and when a run stopped, and the warnings fe-mpm gives."""

import contextlib
import signal
import threading
import warnings
from collections.abc import Iterator
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


@contextlib.contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Hold off a Ctrl-C (SIGINT) until the block ends, then raise KeyboardInterrupt.

    For the acceptance of a step, which changes the points, the time, the step count
    and the history in turn: a Ctrl-C between them left the points moved and the
    clock behind, and a run continued in the same process took that step twice (a
    block in free fall ended 1 cm off, a helper's interrupted runs, 2026-12-07).
    Outside Python's main thread signals go to the main thread anyway, and nothing is
    deferred.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler if previous is None else previous)
    if caught:
        raise KeyboardInterrupt
