"""Suite-wide set-up.

- One BLAS/OpenMP thread per process: the suite runs in pytest-xdist workers, one
  per core, and threads on top of that only fight over the cores.
- The suite's kernels are compiled at ``-O1`` through DOLFINx's own JIT options
  file (``$XDG_CONFIG_HOME/dolfinx/dolfinx_jit_options.json``, here in a temporary
  folder, inherited by the demos the tests start). A fresh clone compiles about 400
  forms: ``-O1`` halves the compile time of the largest ones (the 3D P2/P1 test:
  39 s → 21 s) while the kernels run about 9 % slower. It changes no result:
  neither level reorders floating-point operations (no ``-ffast-math``).
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
import tempfile
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

if "FE_MPM_TEST_JIT_CONFIG" not in os.environ:
    _config = Path(tempfile.mkdtemp(prefix="fe_mpm_jit_"))
    (_config / "dolfinx").mkdir()
    (_config / "dolfinx" / "dolfinx_jit_options.json").write_text(
        json.dumps({"cffi_extra_compile_args": ["-O1", "-g0"]}))
    os.environ["FE_MPM_TEST_JIT_CONFIG"] = str(_config)
    os.environ["XDG_CONFIG_HOME"] = str(_config)
    atexit.register(shutil.rmtree, _config, ignore_errors=True)

import fe_mpm  # noqa: E402, F401


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
