"""What the ranks of a distributed run must agree on, in one place.

A simulation on a mesh shared by several MPI ranks runs the same Python on every
rank, and every collective call (a form's compilation, a PETSc solve, a norm) must
be reached by all of them. So a decision taken from local data (a point that left
the grid, a rank with no loaded facets, the slot count) is reduced first, and an
error found on one rank is raised on every rank, with the message of the lowest
rank that found one. On one rank every function here is the serial identity.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Callable

from mpi4py import MPI

import numpy as np


def any_rank(comm: MPI.Comm, flag: bool) -> bool:
    """Whether ``flag`` is true on some rank."""
    return bool(flag) if comm.size == 1 else bool(comm.allreduce(bool(flag), op=MPI.LOR))


def all_ranks(comm: MPI.Comm, flag: bool) -> bool:
    """Whether ``flag`` is true on every rank."""
    return bool(flag) if comm.size == 1 else bool(comm.allreduce(bool(flag), op=MPI.LAND))


def total(comm: MPI.Comm, value):
    """The sum of ``value`` (a number or an array) over the ranks."""
    return _reduced(comm, value, MPI.SUM)


def smallest(comm: MPI.Comm, value):
    """The minimum of ``value`` (a number, or an array elementwise) over the ranks."""
    return _reduced(comm, value, MPI.MIN)


def largest(comm: MPI.Comm, value):
    """The maximum of ``value`` (a number, or an array elementwise) over the ranks."""
    return _reduced(comm, value, MPI.MAX)


def lowest_rank(comm: MPI.Comm, flag: np.ndarray) -> np.ndarray:
    """Elementwise, the lowest rank where ``flag`` is set; ``comm.size`` where none."""
    return smallest(comm, np.where(flag, comm.rank, comm.size).astype(np.int64))


def _reduced(comm: MPI.Comm, value, op: MPI.Op):
    """``value`` (a number, or an array elementwise) reduced with ``op`` over the ranks."""
    if comm.size == 1:
        return value
    if np.ndim(value) == 0:
        return comm.allreduce(value, op=op)
    local = np.ascontiguousarray(value)
    out = np.empty_like(local)
    comm.Allreduce(local, out, op=op)
    return out


def gathered(comm: MPI.Comm, values: np.ndarray) -> np.ndarray:
    """Every rank's rows of ``values`` (n_rank, ...), in rank order, on every rank.

    For what every rank needs whole: diagnostics over all points (a plot, a stress
    profile) and the boundary points, which every rank holds; not for the step's points.
    """
    if comm.size == 1:
        return values
    return np.concatenate(comm.allgather(np.asarray(values)))


def first_given(comm: MPI.Comm, value):
    """The lowest rank's ``value`` that is not None, on every rank (None if none is)."""
    if comm.size == 1:
        return value
    return next((v for v in comm.allgather(value) if v is not None), None)


def raise_together(comm: MPI.Comm, error: Exception | None) -> None:
    """Raise on every rank if ``error`` is set on some rank; return otherwise.

    The lowest rank with an error gives the type and message; the other ranks raise
    an exception of that type (its class must take a message) naming that rank.
    """
    if comm.size == 1:
        if error is not None:
            raise error
        return
    found = comm.allgather(None if error is None else (type(error), str(error)))
    first = next(((rank, e) for rank, e in enumerate(found) if e is not None), None)
    if first is None:
        return
    rank, (kind, message) = first
    if rank == comm.rank:
        raise error
    raise kind(f"(on rank {rank}) {message}")


def abort_on_lone_exception(wait: float = 30.0) -> None:
    """Abort every rank when one stops on an exception the others do not raise. Collective.

    Call it at the top of an MPI script, on every rank. An exception that one rank
    alone raises (a bug in a script's own code, say) would leave the other ranks
    waiting in a collective call for ever; ``python -m mpi4py`` is meant to abort
    them, but only at the rank's exit, and petsc4py's finalisation, which runs first,
    waits for the other ranks (a helper's 3-rank run hung until killed, 2026-12-06).
    With this, a rank that stops on an uncaught exception prints it, waits up to
    ``wait`` seconds for the others to stop too (an error fe-mpm raises on every
    rank: they then end normally, writing what they write at exit) and otherwise
    aborts them all with ``MPI_Abort``. Nothing changes on one rank.

    Args:
        wait: Seconds (> 0) a stopped rank waits for the others before aborting.
    """
    comm = MPI.COMM_WORLD
    if comm.size == 1:
        return
    if not (math.isfinite(wait) and wait > 0.0):
        raise ValueError(f"abort_on_lone_exception: wait must be > 0 (s), got {wait!r}")
    # A communicator of its own: the stopped ranks' barrier matches nothing else.
    stopped = comm.Dup()
    previous = sys.excepthook

    def hook(kind, value, traceback) -> None:
        previous(kind, value, traceback)
        request, deadline = stopped.Ibarrier(), time.monotonic() + wait
        while not request.Test():
            if time.monotonic() > deadline:
                sys.stderr.write(
                    f"fe_mpm: rank {comm.rank} stopped on an exception that the other ranks "
                    f"did not raise within {wait:g} s: aborting every rank\n"
                )
                sys.stderr.flush()
                # mpiexec may stop forwarding a rank's output once it aborts: a loaded
                # machine lost this line (a fresh clone's suite, 2026-12-06).
                time.sleep(0.5)
                comm.Abort(1)
            time.sleep(0.01)

    sys.excepthook = hook


def check_together(
    comm: MPI.Comm,
    check: Callable[..., object],
    *args,
    kinds: tuple[type[Exception], ...] = (ValueError,),
):
    """Run ``check(*args)`` and raise what it raised on some rank on every rank.

    Errors of ``kinds`` only (:func:`raise_together`): no rank then waits in a
    collective for one that has stopped. Returns what ``check`` returned. Collective.
    """
    error, result = None, None
    try:
        result = check(*args)
    except kinds as err:
        error = err
    raise_together(comm, error)
    return result


def one_thread_per_rank(comm: MPI.Comm) -> None:
    """Limit numpy's BLAS to one thread, and under MPI every thread pool when ranks share a machine.

    numpy's OpenBLAS starts a thread per core and its idle threads spin for a while
    after each call, taking the core of the rank next to it: a granular column on 2
    ranks and 2 cores took 8 times as long as with one thread per rank (DOLFINx's
    advice is ``OMP_NUM_THREADS=1`` under MPI). A serial run is slowed the same way
    by any other busy process: with a second process running on a 2-core machine,
    a dot product of 50 000 entries took 7.7 ms with numpy's two threads against
    8.6 µs with one, and Cook with point domains (u-p, n = 64, 20 steps) 15.0–16.5 s
    against 8.2–8.4 s (standard MPM 10.8–13.6 s against 5.1–5.5 s; 2026-12-07). The
    BLAS of PETSc and MUMPS is another library, single-threaded already; numpy's
    serves fe-mpm's vector sums, where a second thread gains nothing measurable.
    Done with ``threadpoolctl`` at run time, as numpy is loaded before fe-mpm can set
    the environment, for the whole process. A thread count the user chose
    (``OMP_NUM_THREADS``, ``OPENBLAS_NUM_THREADS``, ``MKL_NUM_THREADS``) is kept.
    """
    chosen = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
    if any(v in os.environ for v in chosen):
        return
    from threadpoolctl import threadpool_limits

    if _ranks_share_this_machine(comm):
        threadpool_limits(limits=1)
    else:
        threadpool_limits(limits=1, user_api="blas")


def _ranks_share_this_machine(comm: MPI.Comm) -> bool:
    """Whether other ranks of this run are on this machine, from the launcher's word.

    MPICH's and Open MPI's launchers say how many ranks run here; without it, any
    run of more than one rank counts. Not collective (a simulation may be on one rank).
    """
    for name in ("MPI_LOCALNRANKS", "OMPI_COMM_WORLD_LOCAL_SIZE"):
        if os.environ.get(name, "").isdigit():
            return int(os.environ[name]) > 1
    return comm.size > 1 or MPI.COMM_WORLD.size > 1


def print_on_rank_zero(comm: MPI.Comm = MPI.COMM_WORLD) -> bool:
    """Send the standard output of every rank but 0 to ``os.devnull``.

    Every rank runs a script under ``mpiexec``; its prints then appear once. Returns
    whether this is rank 0 (which also writes the script's own files).
    """
    if comm.rank != 0:
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - open for the process's life
    return comm.rank == 0


def on_rank_zero(comm: MPI.Comm) -> bool:
    """Whether this rank prints and writes the run's shared files (rank 0)."""
    return comm.rank == 0
