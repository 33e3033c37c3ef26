"""Suite-wide set-up.

- One BLAS/OpenMP thread per process: the suite runs in pytest-xdist workers, one
  per core, and threads on top of that only fight over the cores.
- MPICH's progress engine sleeps after polling in vain (``MPIR_CVAR_CH4_PROGRESS_THROTTLE``)
  in the ``mpiexec`` runs of ``tests/test_mpi.py``: they start three ranks, on two
  cores beside another worker, and a rank that spins while it waits for a
  descheduled one holds a core it needs. Measured on 2 cores, the three slowest MPI
  tests alone: 44, 15 and 14 s spinning, 27, 8 and 7 s throttled (a 3-rank run of the
  ghost case 10.4 s against 4.4 s; on 2 ranks 2.1 s both ways). No result changes.
- The suite compiles its kernels through DOLFINx's own JIT options file
  (``$XDG_CONFIG_HOME/dolfinx/dolfinx_jit_options.json``, in a temporary folder): at
  ``-O0`` for the tests in this process, at ``-O1`` for the demos they start. A fresh
  clone compiles about 400 forms for small grids, where compiling costs more than
  running: ``-O0`` compiles the largest (3D P2/P1) in 2.5 s instead of 13 s at ``-O1``
  and 39 s at DOLFINx's default ``-O2``. The demos run long on few forms, so they keep
  ``-O1``. No level changes a result: none reorders floating-point operations (no
  ``-ffast-math``). Users keep DOLFINx's default. A worker that finds another
  compiling the same form waits for it up to the options' ``timeout``: DOLFINx's 10 s
  ran out on a machine loaded nine-fold (a 3D form of Mast's laws, 2026-12-07), so
  the suite waits up to :data:`JIT_TIMEOUT` seconds.
- fe_mpm is imported first: the dolfinx-solver-real wheel must be imported before
  dolfinx, petsc4py and mpi4py, and fe_mpm takes care of that.
- Test order (:func:`pytest_collection_modifyitems`): under xdist the ``slow``
  tests first, so that the workers start on them and the short ones fill in around
  them; in one process last; under mutmut shortest first.
"""

import atexit
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
os.environ.setdefault("MPIR_CVAR_CH4_PROGRESS_THROTTLE", "1")
os.environ.setdefault("MPIR_CVAR_CH4_PROGRESS_THROTTLE_NO_PROGRESS_COUNT", "100")


#: Seconds a process waits for another's compile of the same form (DOLFINx: 10).
JIT_TIMEOUT = 300


def _jit_config(*flags: str) -> str:
    """A temporary XDG_CONFIG_HOME whose DOLFINx JIT options add ``flags`` to the C compiler."""
    config = Path(tempfile.mkdtemp(prefix="fe_mpm_jit_"))
    (config / "dolfinx").mkdir()
    (config / "dolfinx" / "dolfinx_jit_options.json").write_text(
        json.dumps({"cffi_extra_compile_args": [*flags, "-g0"], "timeout": JIT_TIMEOUT})
    )
    atexit.register(shutil.rmtree, config, ignore_errors=True)
    return str(config)


# Set once by the controller; pytest-xdist workers inherit both.
if "FE_MPM_TEST_JIT_CONFIG" not in os.environ:
    os.environ["FE_MPM_TEST_JIT_CONFIG"] = os.environ["XDG_CONFIG_HOME"] = _jit_config("-O0")
    os.environ["FE_MPM_DEMO_JIT_CONFIG"] = _jit_config("-O1")

import fe_mpm  # noqa: E402, F401


def _warnings_skip_mutmut_frames() -> None:
    """Under mutmut a mutated function is called through its trampoline, a frame in
    mutmut's own package between the user's line and fe_mpm's: fe_mpm's warnings skip
    it too, so the tests that check a warning's line see the user's line, as a user
    does. Outside mutmut (not imported) nothing changes. (The folder, not the file:
    CPython matches a prefix against the file name less its last character.)"""
    if "mutmut" not in sys.modules:
        return
    from mutmut.mutation import trampoline

    import fe_mpm.errors

    fe_mpm.errors._PACKAGE = (*fe_mpm.errors._PACKAGE, str(Path(trampoline.__file__).parent))


_warnings_skip_mutmut_frames()


def pytest_collection_modifyitems(items):
    """Slow tests first under xdist, so the workers start on the long runs; last in
    one process, so that ``-x`` stops at the first failing short test. A stable sort
    keeps the order within each group. Under mutmut, shortest first by the durations
    it recorded: a mutant is killed by its quickest failing test."""
    durations = _mutmut_durations()
    if durations is not None:
        items.sort(key=lambda item: durations.get(item.nodeid, 0.0))
        return
    slow_first = "PYTEST_XDIST_WORKER" in os.environ
    items.sort(key=lambda item: (item.get_closest_marker("slow") is None) == slow_first)


def _mutmut_durations() -> dict[str, float] | None:
    """Seconds per test id from mutmut's stats, while it runs a mutant; else None."""
    stats = Path("mutmut-stats.json")  # mutmut runs the tests from its mutants/ folder
    if "__mutmut_" not in os.environ.get("MUTANT_UNDER_TEST", "") or not stats.exists():
        return None
    return json.loads(stats.read_text())["duration_by_test"]
