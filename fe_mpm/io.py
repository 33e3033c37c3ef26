"""Results that ParaView opens.

DOLFINx's VTX/XDMF writers cannot write quadrature data, and meshio's XDMF time
series writes the points only once, so the moving material points go out as one
``.vtu`` per output step (VTK vertex cells), indexed by a ``.pvd`` collection
that carries the times. The ``.pvd`` is rewritten after every step, so a run
that stops early still leaves a readable series up to its last good step.
"""

from __future__ import annotations

import re
from pathlib import Path
from xml.sax.saxutils import quoteattr

from mpi4py import MPI

import numpy as np

from fe_mpm import parallel
from fe_mpm.materials.spectral import embedded_3d
from fe_mpm.particles import MaterialPoints


class ParticleWriter:
    """Writes material points as ``<folder>/<name>_NNNNNN.vtu`` plus ``<folder>/<name>.pvd``.

    Under MPI each rank writes its own points as a piece, ``<name>_NNNNNN_rR.vtu``,
    and rank 0 writes the ``.pvd``, which lists the pieces of a time as its parts
    (ParaView shows them together); nothing is gathered on one rank. A rank that
    holds no points at a time writes no piece for it.

    Args:
        folder: Output folder (created).
        name: File stem; None: :attr:`default_name` ("particles", or "domains" for a
            :class:`DomainWriter`).
        comm: The communicator of the points' grid.
        clear: Remove an earlier run's frames of this name now (a
            :class:`~fe_mpm.output.SimulationOutput` clears its folder at its first
            frame instead).
    """

    #: The file stem when none is given.
    default_name = "particles"

    def __init__(
        self,
        folder: str | Path,
        name: str | None = None,
        comm: MPI.Comm = MPI.COMM_SELF,
        clear: bool = True,
    ):
        self.folder = Path(folder)
        self.comm = comm
        self.name = self.default_name if name is None else name
        error = None
        if comm.rank == 0:
            try:
                self.folder.mkdir(parents=True, exist_ok=True)
                if clear:
                    self._clear_stale()
            except OSError as err:  # e.g. a file of that name: say so on every rank
                error = OSError(
                    f"output folder {str(self.folder)!r} cannot be created or cleaned: "
                    f"{err.strerror or err}. Give output_dir a folder that can be written."
                )
        # The folder exists and is clean before any rank writes; or every rank stops
        # (found 2026-12-06 by a helper: rank 0 stopped and rank 1 waited for ever).
        parallel.raise_together(comm, error)
        self._entries: list[tuple[float, list[str]]] = []

    def _clear_stale(self) -> None:
        """Remove the frames an earlier run left in the folder (rank 0)."""
        for pattern in ("", "_r*"):
            for stale in self.folder.glob(
                f"{self.name}_[0-9][0-9][0-9][0-9][0-9][0-9]{pattern}.vtu"
            ):
                stale.unlink()

    @property
    def pvd(self) -> Path:
        """Path of the collection file."""
        return self.folder / f"{self.name}.pvd"

    def write(self, t: float, points: MaterialPoints, **fields: np.ndarray) -> Path:
        """Write one step of point data.

        Positions, displacement, volume, mass, F, stress, pressure, the material's
        history (e.g. ``plastic_strain``) and extras.

        Args:
            t: Time (s), or pseudo-time in static runs.
            points: The material points.
            fields: More per-point arrays of leading dimension n.
        """
        n, g = points.x.shape
        xyz = np.zeros((n, 3))
        xyz[:, :g] = points.x
        cells = [("vertex", np.arange(n, dtype=np.int64).reshape(-1, 1))]
        return self._write(t, xyz, cells, point_data=_point_fields(points, fields))

    def _write(self, t: float, xyz: np.ndarray, cells: list, **data: dict) -> Path:
        """Write one step's piece of ``xyz`` (m, 3) and ``cells`` with ``data``; list it.

        Under MPI a rank that holds no points writes no piece and the ``.pvd`` leaves it
        out: an empty piece is valid VTK, but meshio cannot read one back (5.3), so a
        script reading the pieces would stop on it. Returns the path of this rank's
        piece, written or not.
        """
        stem = f"{self.name}_{len(self._entries):06d}"
        if self.comm.size == 1:
            names, writes = [f"{stem}.vtu"], True
        else:
            held = self.comm.allgather(len(xyz) > 0)
            held[0] = held[0] or not any(held)  # a time with no points keeps one piece
            names = [f"{stem}_r{rank}.vtu" for rank in range(self.comm.size) if held[rank]]
            writes = held[self.comm.rank]
        import meshio  # here: a run that writes nothing need not import it (~60 ms)

        fname = f"{stem}.vtu" if self.comm.size == 1 else f"{stem}_r{self.comm.rank}.vtu"
        if writes:
            meshio.write(self.folder / fname, meshio.Mesh(xyz, cells, **data))
        self._entries.append((t, names))
        if self.comm.rank == 0:
            self._write_pvd()
        return self.folder / fname

    def rewind(self, t: float) -> bool:
        """Forget the frames after time ``t``, which a restored run writes again.

        Restored to an earlier step, a run writes over their files, and the ``.pvd``
        lists each time once. Returns whether a frame of time ``t`` is kept.
        """
        self._entries = [(time, names) for time, names in self._entries if time <= t]
        if self.comm.rank == 0:
            self._write_pvd()
        return bool(self._entries) and self._entries[-1][0] == t

    def listed(self) -> list[tuple[float, list[str]]]:
        """The frames the folder's ``.pvd`` lists: (time, its pieces' files), in order.

        Read as :meth:`_write_pvd` writes them; none if there is no ``.pvd``.
        """
        frames: list[tuple[float, list[str]]] = []
        for time, name in _DATASET.findall(self.pvd.read_text()) if self.pvd.exists() else []:
            if frames and frames[-1][0] == float(time):
                frames[-1][1].append(name)
            else:
                frames.append((float(time), [name]))
        return frames

    def _write_pvd(self) -> None:
        lines = [
            '<?xml version="1.0"?>',
            '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
            "  <Collection>",
        ]
        lines += [
            f'    <DataSet timestep="{_exact(t)}" part="{part}" file={quoteattr(f)}/>'
            for t, names in self._entries
            for part, f in enumerate(names)
        ]
        lines += ["  </Collection>", "</VTKFile>", ""]
        self.pvd.write_text("\n".join(lines))


#: One frame's piece in a ``.pvd``, as :meth:`ParticleWriter._write_pvd` writes it.
_DATASET = re.compile(r'<DataSet timestep="([^"]+)" part="\d+" file="([^"]+)"/>')


def _exact(t: float) -> str:
    """``t`` as the shortest text that reads back to the same double (``0.5``, ``0``).

    The grid's VTX files and ``steps.csv`` hold the exact double; written to ten digits
    the frames' times differed from theirs (0.075 against 0.07500000000000001, a
    helper's check, 2026-12-07).
    """
    text = repr(float(t))
    return text[:-2] if text.endswith(".0") else text


class DomainWriter(ParticleWriter):
    """Writes the point domains as ``<folder>/<name>_NNNNNN.vtu`` plus ``<name>.pvd``.

    Each domain (:mod:`fe_mpm.domains`) is a triangle or tetrahedron of its own
    corners, carrying its point's fields as cell data (those of
    :meth:`ParticleWriter.write`), so ParaView shows how the body is tiled and where
    domains stretch or were redrawn. Under MPI, pieces per rank as for the points.
    """

    default_name = "domains"

    def write(
        self, t: float, points: MaterialPoints, corners: np.ndarray, **fields: np.ndarray
    ) -> Path:
        """Write one step of domains.

        Args:
            t: Time (s), or pseudo-time in static runs.
            points: The material points, one per domain.
            corners: The domains' vertices (n, g + 1, g) in m.
            fields: More per-point arrays of leading dimension n.
        """
        n, v, g = corners.shape
        # VTK wants every cell turned one way; a domain's corners come in either order.
        edges = corners[:, 1:] - corners[:, :1]
        turned = np.linalg.det(edges) < 0.0 if n else np.zeros(0, dtype=bool)
        corners = corners.copy()
        corners[turned, :2] = corners[turned, 1::-1]
        xyz = np.zeros((n * v, 3))
        xyz[:, :g] = corners.reshape(n * v, g)
        cells = [
            ("triangle" if g == 2 else "tetra", np.arange(n * v, dtype=np.int64).reshape(n, v))
        ]
        data = _point_fields(points, fields)
        return self._write(t, xyz, cells, cell_data={k: [a] for k, a in data.items()})


def write_csv_rows(path: str | Path, header: list[str], rows: list[str], first: int) -> Path:
    """Write ``rows`` (comma-joined lines) to the CSV ``path``; returns it as a Path.

    ``first`` 0 writes the file anew, under ``header``; k > 0 appends the rows to it,
    as a run does at each output with the steps since the last one.
    """
    path = Path(path)
    lines = rows if first else [",".join(header), *rows]
    with path.open("a" if first else "w") as csv:
        csv.write("".join(line + "\n" for line in lines))
    return path


def drop_rows_after(path: str | Path, step: int) -> None:
    """Drop the rows of the CSV ``path`` whose first column, the step, exceeds ``step``.

    A restore to an earlier step undoes the steps after it in ``steps.csv`` and
    ``walls.csv`` too. A missing file is left missing.
    """
    path = Path(path)
    if not path.exists():
        return
    header, *rows = path.read_text().splitlines()
    kept = [row for row in rows if int(row.split(",", 1)[0]) <= step]
    path.write_text("".join(line + "\n" for line in [header, *kept]))


def _point_fields(points: MaterialPoints, fields: dict) -> dict[str, np.ndarray]:
    """The per-point arrays fe-mpm writes, one row per point, vectors and tensors in 3D.

    Displacement, velocity, volume, mass, F, stress, pressure, the cell, the material's
    history (e.g. ``plastic_strain``) and ``fields`` (arrays of leading dimension n),
    which replace those of the same name (a simulation's output gives ``cell`` as the
    grid's input index, the same on any number of ranks).
    """
    n, g = points.x.shape
    disp = np.zeros((n, 3))
    disp[:, :g] = points.x - points.x0
    F3 = embedded_3d(points.F)
    data = {
        "displacement": disp,
        "velocity": np.pad(points.velocity, ((0, 0), (0, 3 - g))),
        "volume": points.volume,
        "mass": points.mass,
        "deformation_gradient": F3.reshape(n, 9),
        "stress": points.stress.reshape(n, 9),
        "pressure": -np.trace(points.stress, axis1=1, axis2=2) / 3.0,
        "cell": points.cell.astype(np.float64),
    }
    data.update({k: _rows(v, n) for k, v in points.history.items()})
    data.update({k: _rows(np.asarray(v), n) for k, v in fields.items()})
    return data


def _rows(values: np.ndarray, n: int) -> np.ndarray:
    """``values`` (n, ...) as one row per point; a scalar field stays 1-D.

    The width is explicit, not ``-1``: a rank may hold no points (n = 0).
    """
    if values.ndim == 1:
        return values
    return values.reshape(n, int(np.prod(values.shape[1:])))
