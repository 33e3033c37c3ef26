"""What a run writes for ParaView: the points at every written step, and the grid's.

``particles.pvd`` holds the material points (positions, stress, pressure, F,
volume, history; :class:`~fe_mpm.io.ParticleWriter`), with point domains
``domains.pvd`` their domains, each a cell with its point's fields
(:class:`~fe_mpm.io.DomainWriter`), ``grid.bp`` the grid
displacement increment of the step and, for the mixed forms, ``grid_pressure.bp``
the grid pressure (ADIOS2 files that ParaView opens with its VTX reader). After
the N-th repartition of the grid under MPI the grid's files are ``grid_N.bp`` and
``grid_pressure_N.bp``, and a run restored from a checkpoint in a new process
continues the series of the run it restores (:meth:`SimulationOutput.continue_earlier_run`),
its grid's files numbered on the same way.
"""

from __future__ import annotations

import atexit
import re
import shutil
import weakref
from pathlib import Path

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.balance import original_indices
from fe_mpm.formulations import GridFields, collapse
from fe_mpm.io import DomainWriter, ParticleWriter, drop_rows_after
from fe_mpm.particles import MaterialPoints

#: Every output that may still hold open grid files, in the order they were made.
_OPEN: list[weakref.ref] = []


@atexit.register
def _close_open_outputs() -> None:
    """Close the grid files still open at exit, on every rank in the same order.

    Left to the garbage collector, an output held in a reference cycle (a script that
    caught a run's error, whose traceback keeps the simulation alive) closed its
    ADIOS2 files, a collective act, at a moment of each rank's own: on 2 ranks one
    waited there while the other had gone on to PETSc's finalisation, and the job
    hung at exit (a helper's script, 2026-12-06). Registered after PETSc's and MPI's
    own exit handlers (fe-mpm imports them first), so it runs before them.
    """
    for ref in _OPEN:
        output = ref()
        if output is not None:
            output.close()
    _OPEN.clear()


#: What a run writes in its output folder: cleared at its first frame, or set aside
#: by a restore before it (:func:`_clear_earlier_run`, :func:`_set_aside`).
_RUN_FILES = re.compile(
    r"steps\.csv|walls\.csv|grid(_pressure)?(_\d+)?\.bp|(particles|domains)\.pvd"
    r"|(particles|domains)_\d{6}(_r\d+)?\.vtu"
)


def _clear_earlier_run(folder: Path) -> None:
    """Remove what an earlier run left in ``folder`` (:data:`_RUN_FILES`).

    A run with domains, walls and a pressure, then a plain one in the same folder,
    left the first run's ``domains.pvd`` (ParaView showed domains to t = 1 for a run
    that ended at 0.5), ``grid_pressure.bp`` and ``walls.csv`` (a helper's scene,
    2026-12-06). Only fe-mpm's own names go.
    """
    for path in folder.glob("*") if folder.is_dir() else []:
        if not _RUN_FILES.fullmatch(path.name):
            continue
        if path.is_dir():
            shutil.rmtree(path)
        else:
            path.unlink()


#: The grid's files of a run: ``grid.bp`` is number 0.
_GRID_FILE = re.compile(r"grid(?:_(\d+))?\.bp")


def _has_row(csv: Path, step: int, t: float) -> bool:
    """Whether the CSV of a run's steps has the row of ``step`` at time ``t`` exactly."""
    if not csv.exists():
        return False
    for row in csv.read_text().splitlines()[1:]:
        fields = row.split(",", 2)
        if len(fields) >= 2 and fields[0] == str(step):
            return float(fields[1]) == t
    return False


def _rows_after(csv: Path, step: int) -> bool:
    """Whether the CSV of a run's steps has rows after ``step``."""
    rows = csv.read_text().splitlines()[1:]
    return any(int(row.split(",", 1)[0]) > step for row in rows if row)


def earlier_run_files(folder: str | Path | None) -> list[str]:
    """The names of an earlier run's files in ``folder`` (sorted; none if it is None)."""
    if folder is None or not Path(folder).is_dir():
        return []
    return sorted(path.name for path in Path(folder).glob("*") if _RUN_FILES.fullmatch(path.name))


def _new_folder(folder: Path, name: str) -> Path:
    """Make the subfolder ``name`` of ``folder``, numbered on (``name_2``, ...) if taken."""
    made, k = folder / name, 1
    while made.exists():
        k += 1
        made = folder / f"{name}_{k}"
    made.mkdir()
    return made


def _set_aside(folder: Path, step: int) -> Path | None:
    """Move the run files in ``folder`` into a new subfolder; None if there are none."""
    found = [path for path in folder.glob("*") if _RUN_FILES.fullmatch(path.name)]
    if not found:
        return None
    kept = _new_folder(folder, f"before_restore_at_step_{step}")
    for path in found:
        path.rename(kept / path.name)
    return kept


class SimulationOutput:
    """The files of one run, written every ``every`` steps and at the ends.

    Args:
        folder: Where to write (created if missing).
        fields: The grid unknowns: Δu, or (Δu, p).
        every: Write every this many steps, ≥ 1.
        domains: Whether the points carry domains, written as ``domains.pvd``.
    """

    def __init__(
        self, folder: str | Path, fields: GridFields, every: int = 1, domains: bool = False
    ):
        # Absolute: the grid's writers close at the end of the run or of the process,
        # and a relative path read then against another working directory (a script or
        # a test that changed it) aborted the process in ADIOS2 ("iostream error").
        self.folder, self.fields, self.every = Path(folder).resolve(), fields, int(every)
        self._written_step = -1
        comm = fields.W.mesh.comm
        # The folder is made now; what an earlier run left there is cleared at the
        # first frame, so that a run restored in a new process can set it aside first
        # (until 2026-12-07 a helper's job, killed and restored, lost its first frames).
        self._points = ParticleWriter(self.folder, comm=comm, clear=False)
        self._domains = DomainWriter(self.folder, comm=comm, clear=False) if domains else None
        self.started = False  # whether a frame was written (the files are this run's)
        #: Whether this run continues the series already in the folder (a restore).
        self.continues = False
        self._grids = 0  # grids written so far: a repartition starts another
        self._writers: list = []
        _OPEN[:] = [ref for ref in _OPEN if ref() is not None]
        _OPEN.append(weakref.ref(self))

    def _start(self) -> None:
        """Clear what an earlier run left in the folder and open the grid's files (collective)."""
        comm, error = self.fields.W.mesh.comm, None
        if comm.rank == 0 and not self.continues:
            try:
                _clear_earlier_run(self.folder)
            except OSError as err:
                error = OSError(f"Simulation: cannot clear {self.folder} of an earlier run: {err}")
        parallel.raise_together(comm, error)
        self._open_grid()
        self.started = True

    def set_aside_earlier_run(self, step: int) -> Path | None:
        """Move an earlier run's files into a subfolder before this run writes any; collective.

        A run restored from a checkpoint in a new process would otherwise clear the
        frames and rows of the run it continues. Returns the subfolder
        (``before_restore_at_step_N``, numbered on if taken), or None if there was
        nothing to keep.
        """
        comm, error, kept = self.fields.W.mesh.comm, None, None
        if comm.rank == 0:
            try:
                kept = _set_aside(self.folder, step)
            except OSError as err:
                error = OSError(f"Simulation.restore: cannot keep the earlier output: {err}")
        parallel.raise_together(comm, error)
        return comm.bcast(kept, root=0) if comm.size > 1 else kept

    def continue_earlier_run(self, t: float, step: int) -> tuple[bool, Path | None]:
        """Take up the series of the run a checkpoint came from (collective).

        Where the folder holds that run's files (``steps.csv`` has the row of ``step``
        at ``t``: a checkpoint writes the rows of its steps), its frames up to ``t``
        stay listed and this run's follow them in the same ``.pvd``, and the grid's
        files go on as ``grid_N.bp`` after the last one there (a VTX file cannot be
        appended to). What that run wrote after ``step`` (frames, rows) goes into
        ``undone_after_step_N/``, with copies of its ``.pvd`` and CSV files whole:
        this run takes those steps again, and a branch from an earlier checkpoint
        loses nothing. Returns whether it continues, and that folder (None if nothing
        came after). Otherwise nothing changes: ``(False, None)``.
        """
        comm, error, found = self.fields.W.mesh.comm, None, None
        writers = [w for w in (self._points, self._domains) if w is not None]
        if comm.rank == 0:
            try:
                found = self._earlier_series(writers, t, step)
            except (OSError, ValueError) as err:
                error = OSError(f"Simulation.restore: cannot read the earlier output: {err}")
        parallel.raise_together(comm, error)
        found = comm.bcast(found, root=0) if comm.size > 1 else found
        if found is None:
            return False, None
        series, self._grids, undone = found
        for writer, frames in zip(writers, series, strict=True):
            writer._entries = frames
            if comm.rank == 0:
                writer._write_pvd()  # the frames kept, now: a run that stops lists no others
        frames = series[0]
        self._written_step = step if frames and frames[-1][0] == t else -1
        self.continues = True
        self._start()  # the grid's next files; nothing is cleared
        return True, None if undone is None else Path(undone)

    def _earlier_series(self, writers: list, t: float, step: int) -> tuple | None:
        """The frames to keep, the next grid file's number and the undone folder (rank 0).

        None where the folder is not the checkpoint's run.
        """
        if not _has_row(self.folder / "steps.csv", step, t):
            return None
        series = [writer.listed() for writer in writers]
        kept = [[frame for frame in frames if frame[0] <= t] for frames in series]
        for frames in kept:
            if not all((self.folder / name).exists() for _, names in frames for name in names):
                return None  # a frame's file is gone: not a series to continue
        later = [name for frames, keep in zip(series, kept, strict=True)
                 for _, names in frames[len(keep):] for name in names]  # fmt: skip
        rows = [
            name
            for name in ("steps.csv", "walls.csv")
            if (self.folder / name).exists() and _rows_after(self.folder / name, step)
        ]
        undone = None
        if later or rows:
            undone = _new_folder(self.folder, f"undone_after_step_{step}")
            for writer in writers:
                if writer.pvd.exists():
                    shutil.copy2(writer.pvd, undone / writer.pvd.name)
            for name in rows:
                shutil.copy2(self.folder / name, undone / name)
            for name in later:
                if (self.folder / name).exists():
                    (self.folder / name).rename(undone / name)
        for name in ("steps.csv", "walls.csv"):
            drop_rows_after(self.folder / name, step)
        numbers = [
            int(match.group(1) or 0)
            for match in map(_GRID_FILE.fullmatch, (p.name for p in self.folder.glob("grid*")))
            if match
        ]
        return kept, max(numbers, default=-1) + 1, None if undone is None else str(undone)

    def _open_grid(self) -> None:
        """The grid files of the current grid: grid.bp, or grid_N.bp for the N-th repartition."""
        comm, tail = self.fields.W.mesh.comm, f"_{self._grids}" if self._grids else ""
        self._grid, self._maps = self._grid_functions()
        self._writers = [
            dolfinx.io.VTXWriter(comm, self.folder / f"grid{tail}.bp", self._grid[:1], engine="BP4")
        ]
        if len(self._grid) > 1:
            self._writers.append(
                dolfinx.io.VTXWriter(
                    comm, self.folder / f"grid_pressure{tail}.bp", self._grid[1:], engine="BP4"
                )
            )

    def regrid(self, fields: GridFields) -> None:
        """Write the grid's fields on ``fields``'s grid from now on (after a repartition).

        A VTX file holds one grid, so the next goes to ``grid_1.bp`` (then
        ``grid_2.bp``, ...); the points' series continues.
        """
        self.close()
        if not self.started:  # nothing written on the old grid: grid.bp is this one's
            self.fields = fields
            return
        self.fields, self._grids = fields, self._grids + 1
        self._open_grid()

    def _grid_functions(self) -> tuple[list[dolfinx.fem.Function], list]:
        """Collapsed copies of Δu (and p or θ) for VTX output, with their dofs in ``w``."""
        W = self.fields.W
        if not self.fields.spec.mixed:
            return [dolfinx.fem.Function(W, name="du")], [slice(None)]
        U, u_map = collapse(W.sub(0))
        Q, p_map = self.fields.second  # p, or θ (one per zone where NB-VA keeps several)
        name = "p" if self.fields.spec.pressure else "volume_change"
        return [dolfinx.fem.Function(U, name="du"), dolfinx.fem.Function(Q, name=name)], [
            u_map,
            p_map,
        ]

    def write(
        self,
        step: int,
        t: float,
        points: MaterialPoints,
        force: bool = False,
        corners: np.ndarray | None = None,
        grid: bool = True,
        cells_known: bool = True,
    ) -> bool:
        """Write the state after ``step`` at time ``t`` if it is due; True if written.

        A step is written once, when it is a multiple of ``every`` or ``force`` is set
        (the first and the last frame of a run). ``corners``: the points' domains
        (n, g + 1, g) in m, written when the output was opened with ``domains``.
        ``grid=False`` writes the points alone: after a step that failed, the grid's
        fields hold its last attempt, not the step the points are at.
        ``cells_known=False`` writes each point's cell as −1: after a repartition the
        points' cells are the old grid's until the next tracking.
        """
        if step == self._written_step or (not force and step % self.every):
            return False
        if not self.started:
            self._start()
        # The grid's input numbering, the same on any number of ranks (a rank's own
        # index differs between partitions and after a repartition).
        comm, mesh = self.fields.W.mesh.comm, self.fields.W.mesh
        cell = np.full(len(points), -1.0)
        if cells_known:  # collective
            where = np.column_stack([np.full(len(points), comm.rank), np.maximum(points.cell, 0)])
            known = original_indices(mesh, where, fallback=True)  # submesh: global indices
            cell = np.where(points.cell >= 0, known, -1).astype(float)
        self._points.write(t, points, cell=cell)
        if self._domains is not None:
            self._domains.write(t, points, corners, cell=cell)
        # Written: marked only now, so a write that a Ctrl-C cut short is taken again
        # when the run goes on in the same process (it lost that frame, a helper's
        # interrupted run, 2026-12-07).
        self._written_step = step
        if not grid:
            return True
        for out, dofs in zip(self._grid, self._maps, strict=True):
            out.x.array[:] = self.fields.w.x.array[dofs]
        for writer in self._writers:
            writer.write(t)
        return True

    def rewind(self, t: float, step: int) -> None:
        """Forget the frames after time ``t``, that of ``step`` (a restore to it).

        The grid's VTX files cannot drop steps: they keep the frames written after
        ``t``, and the restored run's frames follow them.
        """
        kept = self._points.rewind(t)
        if self._domains is not None:
            self._domains.rewind(t)
        self._written_step = step if kept else -1  # a frame of t is written once

    def close(self) -> None:
        """Close the grid files (the points' series is complete after every write)."""
        for writer in self._writers:
            writer.close()
        self._writers = []
