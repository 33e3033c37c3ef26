"""Checkpoints: the whole state of a run, to continue it later on any number of ranks.

A checkpoint is a folder ``step_NNNNNN`` holding

- ``points_rNNNN.npz``, one piece per rank that wrote it: every per-point field of
  :class:`~fe_mpm.particles.MaterialPoints` and the law's history, the markers
  these points host, and with point domains each point's domain (its corners and
  the shape quality it was drawn with, :mod:`fe_mpm.domains`);
- ``shared.npz``: the boundary points' positions (and a PointPressure's faces), the
  markers' positions and the rigid walls' springs (their extension at each node, by
  the node's grid input index);
- ``state.json``: what the run is (fe-mpm version, formulation, law and its
  parameters, the grid's size and extent) and where it stands (time, step, slot
  counts), with the SHA-256 of every file.

The points and their history are the whole state of a run between steps: the grid
is reset after every step, and a dynamic run carries its velocities and
accelerations on the points. The one exception is the rigid walls' springs, which
keep their extension from step to step (:mod:`fe_mpm.walls`). A restart rebuilds the
simulation with the same script and calls
:meth:`Simulation.restore <fe_mpm.simulation.Simulation.restore>`: on N ranks, rank r
reads the pieces r, r + N, ... and every point then moves to the rank
that owns its cell (:mod:`fe_mpm.migration`), so a checkpoint written on 2 ranks
continues on 3. Restored on another number of ranks than wrote it, the points come
back in another order than they had, so sums over them round off differently: the
answers agree to round-off, not bit for bit. On the same number of ranks they repeat
the uninterrupted run bit for bit.

A checkpoint of another fe-mpm version or format, of another scene, or one whose
files do not match their checksums is refused with a :class:`CheckpointError` that
says why, before the simulation is changed.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import shutil
from pathlib import Path

import numpy as np

from fe_mpm import balance, parallel
from fe_mpm.meshes.centroids import cell_centroids
from fe_mpm.particles import PER_POINT_FIELDS, MaterialPoints

#: Version of the checkpoint layout; a reader refuses any other.
FORMAT = 3
#: The per-point fields a checkpoint keeps (the cell is found again on restart).
SAVED_FIELDS = tuple(name for name in PER_POINT_FIELDS if name != "cell")
#: What ``state.json`` must hold, and each entry of its ``pieces``.
STATE_KEYS = frozenset(
    {"scene", "t", "step", "dropped", "slots", "boundary_slots", "pieces", "shared_sha256"}
)
PIECE_KEYS = frozenset({"file", "points", "sha256"})
#: Fields that checkpoints written before them lack, and their value there, by count.
OPTIONAL_FIELDS = {"material": lambda n: np.zeros(n, dtype=np.int32)}
#: How far the grid's extent may differ (relative to its size) and still be the same grid.
EXTENT_TOLERANCE = 1e-9


class CheckpointError(ValueError):
    """A checkpoint that cannot be read into this simulation; the message says why."""


def folder_for(directory: str | Path, step: int) -> Path:
    """The checkpoint folder of ``step`` under ``directory``."""
    return Path(directory) / f"step_{step:06d}"


def latest(directory: str | Path) -> Path:
    """The checkpoint of the latest step under ``directory``.

    Raises:
        CheckpointError: ``directory`` holds no complete checkpoint.
    """
    found = [
        p
        for p in Path(directory).glob("step_*")
        if p.name[5:].isdigit() and (p / "state.json").is_file()
    ]
    if not found:
        raise CheckpointError(f"no checkpoint (step_NNNNNN/state.json) in {directory}")
    return max(found, key=lambda p: int(p.name[5:]))


def set_aside_after(directory: str | Path, step: int) -> list[Path]:
    """Rename the checkpoints of steps after ``step`` under ``directory`` to ``undone_…``.

    A run restored to an earlier step undoes the steps after it; their checkpoints,
    left as they were, were what :func:`latest` found next (a helper restored step 3
    of 7, ran on to t = 1.0, and a new simulation restored from the folder went back
    to the undone step 6, t = 0.857, without a word). Renamed, not deleted, but for
    an ``undone_…`` folder of the same step from an earlier restore, which the newer
    replaces. Call on one rank.

    Returns:
        The folders as renamed.
    """
    moved = []
    for folder in sorted(Path(directory).glob("step_*")):
        if folder.name[5:].isdigit() and int(folder.name[5:]) > step:
            target = folder.with_name("undone_" + folder.name)
            shutil.rmtree(target, ignore_errors=True)
            folder.rename(target)
            moved.append(target)
    return moved


def write(sim, directory: str | Path) -> Path:
    """Write the state of ``sim`` after its current step; collective.

    The pieces go to a ``.partial`` folder first, which is renamed once complete,
    so a run stopped mid-write leaves the previous checkpoints intact.

    Returns:
        The checkpoint folder.
    """
    comm = sim.mesh.comm
    balance.owned_original_cells(sim.mesh)  # a grid without them is refused before a folder
    final = folder_for(directory, sim.step_number)
    partial = final.with_name(final.name + ".partial")
    error = None
    if comm.rank == 0:
        try:
            shutil.rmtree(partial, ignore_errors=True)
            partial.mkdir(parents=True)
        except OSError as err:
            error = CheckpointError(f"cannot write checkpoint {final}: {err}")
    parallel.raise_together(comm, error)
    piece = f"points_r{comm.rank:04d}.npz"
    arrays = {name: getattr(sim.points, name) for name in SAVED_FIELDS}
    arrays.update({f"history.{k}": v for k, v in sim.points.history.items()})
    arrays.update({f"marker.{k}": np.array(h) for k, h in sim.markers.hosts().items()})
    if sim.domains is not None:
        arrays["domain_corners"], arrays["domain_quality"] = sim.domains.saved_state()
    home = sim.tracking._home  # the accepted step's cells, where a retry may hold the points
    if parallel.all_ranks(comm, home is not None):  # by original index: any partition reads it
        arrays["home_cell"] = balance.original_indices(sim.mesh, home)
    error, digest = None, ""
    try:
        digest = _save(partial / piece, arrays)
    except OSError as err:
        error = CheckpointError(f"cannot write checkpoint {final}: {err}")
    parallel.raise_together(comm, error)
    pieces = comm.gather({"file": piece, "points": len(sim.points), "sha256": digest})
    fingerprint, dropped = scene(sim), sim.dropped  # scene is collective: before rank 0 goes alone
    resets = 0 if sim.domains is None else int(parallel.total(comm, sim.domains.resets))
    flips = 0 if sim.domains is None else int(parallel.total(comm, sim.domains.flips))
    springs = sim.walls.springs()
    if comm.rank == 0:
        try:
            shared = {f"marker.{k}": x for k, x in sim.markers.positions().items()}
            for name, (nodes, extension) in springs.items():
                shared[f"wall.{name}.nodes"] = nodes
                shared[f"wall.{name}.extension"] = extension
            if sim._boundary is not None:
                shared["boundary_x"] = sim._boundary.points.x
                shared["boundary_area"] = sim._boundary.points.area
                shared["boundary_corners"] = sim._boundary.points.corners
            state = {
                "format": FORMAT,
                "scene": fingerprint,
                "t": sim.t,
                "step": sim.step_number,
                "dropped": dropped,
                "domain_resets": resets,
                "domain_flips": flips,
                "slots": sim.tracking._nslot,
                "boundary_slots": None if sim._boundary is None else sim._boundary._nslot,
                "ranks": comm.size,
                # What add_points / remove_points left for the next step to do.
                "restart_dynamics": sim._restart_dynamics,
                "check_supports_again": sim._check_supports_again,
                "bodies_at_start": sim._tears.bodies_at_start,
                "tear_warned": sim._tears.warned,
                "meeting_warned": sim._tears.meeting_warned,
                "contact_steps": sim._contacts.steps,
                "contact_since": sim._contacts.since,
                "contact_warned": sim._contacts.warned,
                "hinge_warned": sim._hinge_warned,
                # Warnings said once per run (a restored run would say them again).
                "travel_warned": [bool(v) for v in sim._travel_warned],
                "staged_at": sim._staged_at,
                "lost_share_warned": {str(k): v for k, v in sim._conditions_warned.items()},
                "pieces": pieces,
                "shared_sha256": _save(partial / "shared.npz", shared),
            }
            (partial / "state.json").write_text(json.dumps(state, indent=1))
            old = final.with_name(final.name + ".old")
            if final.exists():  # the same step of an earlier run: replaced whole
                shutil.rmtree(old, ignore_errors=True)
                final.rename(old)
            partial.rename(final)
            shutil.rmtree(old, ignore_errors=True)
        except OSError as err:
            error = CheckpointError(f"cannot write checkpoint {final}: {err}")
    parallel.raise_together(comm, error)
    return final


def _check_corners(sim, shared, path: Path) -> None:
    """Refuse a checkpoint without corners for the PointPressure points that have them.

    Written without ``corners=`` (NaN) or before them (absent), a face read off those
    corners, or off the undeformed facets, would lose its load without a word (a
    review's restore, 2026-12-06, gave every area NaN after a step).
    """
    if sim._boundary is None or not np.any(sim._boundary.points.framed):
        return
    framed = sim._boundary.points.framed
    saved = shared["boundary_corners"] if "boundary_corners" in shared else None
    if saved is None or saved.shape[0] != framed.size or not np.isfinite(saved[framed]).all():
        raise CheckpointError(
            f"checkpoint {path}: it holds no facet corners for the PointPressure points "
            "that have them here; build the PointPressure as the checkpointed run did "
            "(without corners=), or restore a checkpoint written with them"
        )


def read(sim, path: str | Path) -> Path:
    """Put the state of the checkpoint at ``path`` into ``sim``; collective; the folder read.

    Args:
        sim: A simulation built by the script that wrote the checkpoint (same
            grid, law, formulation and conditions), on any number of ranks.
        path: A checkpoint folder, or a directory of them (the latest is read).

    Raises:
        CheckpointError: The checkpoint is of another format, fe-mpm version or
            scene, or a file is missing or does not match its checksum; ``sim``
            is left as it was.
    """
    comm = sim.mesh.comm
    path = Path(path)
    if not path.exists():  # (it said "cannot read state.json", as if one were broken)
        parallel.raise_together(
            comm,
            CheckpointError(
                f"no checkpoint at {path}: there is no such folder (a run stopped before "
                "its first checkpoint wrote none)"
            ),
        )
    if not (path / "state.json").is_file() and path.is_dir():
        path = latest(path)
    state, error = None, None
    if comm.rank == 0:
        try:
            state = json.loads((path / "state.json").read_text())
        except (OSError, ValueError) as err:
            error = CheckpointError(f"checkpoint {path}: cannot read state.json ({err})")
    parallel.raise_together(comm, error)
    state = comm.bcast(state)
    _check_state(sim, path, state)
    mine = state["pieces"][comm.rank :: comm.size]
    error, loaded = None, []
    try:
        loaded = [_load(path / p["file"], p["sha256"], p["points"]) for p in mine]
        shared = _load(path / "shared.npz", state["shared_sha256"], None)
        points = _joined(loaded, sim)
        domains = _joined_domains(loaded, sim, path)
        _check_corners(sim, shared, path)
    except CheckpointError as err:
        error = err
    parallel.raise_together(comm, error)

    # Checked: now change the simulation.
    pts = sim.points
    for name in (*SAVED_FIELDS, "cell"):
        setattr(pts, name, getattr(points, name))
    pts.history = points.history
    markers = sim.markers
    markers._entries.clear()
    offsets = np.cumsum([0] + [len(a["x"]) for a in loaded])
    hosts = {
        key.removeprefix("marker."): int(offsets[i] + arrays[key])
        for i, arrays in enumerate(loaded)
        for key in arrays
        if key.startswith("marker.")
    }
    for key, x in shared.items():
        if key.startswith("marker."):
            name = key.removeprefix("marker.")
            markers.place(name, x, hosts.get(name, -1))
    springs = {
        key[len("wall.") : -len(".nodes")]: (
            shared[key],
            shared[key[: -len("nodes")] + "extension"],
        )
        for key in shared
        if key.startswith("wall.") and key.endswith(".nodes")
    }
    sim.walls.set_springs(springs)
    if sim._boundary is not None:
        sim._boundary.points.x[:] = shared["boundary_x"]
        if "boundary_area" in shared:  # the faces of PointPressure (absent before them)
            sim._boundary.points.area[:] = shared["boundary_area"]
        if "boundary_corners" in shared:  # their corners (absent before 2026-12-06)
            sim._boundary.points.corners[:] = shared["boundary_corners"]
        sim._boundary._nslot = state["boundary_slots"]
    sim.t, sim.step_number = float(state["t"]), int(state["step"])
    # Points added or removed just before the checkpoint: the next step's equilibrium
    # accelerations and support check are still due (absent before 2026-12-06).
    sim._restart_dynamics = bool(state.get("restart_dynamics", False))
    sim._check_supports_again = bool(state.get("check_supports_again", False))
    sim._tears.bodies_at_start = state.get("bodies_at_start")  # (absent before 2026-12-07)
    sim._tears.warned = bool(state.get("tear_warned", False))
    sim._tears.meeting_warned = bool(state.get("meeting_warned", False))
    # Walls in contact and for how long (absent before 2026-12-07, night).
    sim._contacts.steps = {k: int(v) for k, v in state.get("contact_steps", {}).items()}
    sim._contacts.since = {k: float(v) for k, v in state.get("contact_since", {}).items()}
    sim._contacts.warned = bool(state.get("contact_warned", False))
    sim._hinge_warned = bool(state.get("hinge_warned", False))
    sim._staged_at = state.get("staged_at")  # (absent before 2026-12-07, evening)
    travel_warned = state.get("travel_warned")  # (absent before 2026-12-07, evening)
    if travel_warned is not None and len(travel_warned) == len(sim._travel_warned):
        sim._travel_warned[:] = travel_warned
    sim._conditions_warned.update(
        {int(k): float(v) for k, v in state.get("lost_share_warned", {}).items()}
    )
    sim.tracking._nslot = state["slots"]
    sim.tracking.dropped = int(state["dropped"])  # the total, on every rank
    if sim.domains is not None:
        resets = int(state.get("domain_resets", 0)) if comm.rank == 0 else 0
        flips = int(state.get("domain_flips", 0)) if comm.rank == 0 else 0
        sim.domains.restore_state(*domains, resets, sim.domain_tracker, flips)
    # Where a retry of the next step may hold the points: the cells of the last step.
    sim.tracking.forget()
    # Not kept before the first step; a rank that read no piece has no points to hold.
    if parallel.all_ranks(comm, all("home_cell" in arrays for arrays in loaded)):
        original = [a["home_cell"] for a in loaded]
        original = np.concatenate(original) if original else np.zeros(0, dtype=np.int64)
        sim.tracking._home = balance.owners_of_original_cells(sim.mesh, original)
    sim._current = None
    if sim.domains is None:
        sim._track(sim.step_number, sim.t)  # each point to the rank that owns its cell
    else:  # each point, with its domain, to the rank that owns its cell
        sim.tracking.migrated = sim.domains.migrate(pts, markers, sim.tracker)
    return path


def scene(sim) -> dict:
    """What a checkpoint must match to be read into ``sim``: a JSON-able fingerprint."""
    mesh, comm = sim.mesh, sim.mesh.comm
    tdim, g = mesh.topology.dim, sim.gdim
    x = mesh.geometry.x[:, :g]
    low = -parallel.largest(comm, -x.min(axis=0, initial=np.inf))
    high = parallel.largest(comm, x.max(axis=0, initial=-np.inf))
    from fe_mpm import __version__

    fingerprint = {
        "fe_mpm": __version__,
        "formulation": sim.formulation,
        "dynamic": sim.dynamic,
        "law": type(sim.material).__name__,
        "law_parameters": _parameters(sim.material),
        "history": sorted(sim.material.history),
        "cells": int(mesh.topology.index_map(tdim).size_global),
        "extent": [np.asarray(low).tolist(), np.asarray(high).tolist()],
        "cell_moments": _cell_moments(mesh, np.asarray(low)),
        "boundary_points": 0 if sim._boundary is None else len(sim._boundary.points),
        "point_domains": sim.domains is not None,
    }
    if sim.walls:  # (only then: checkpoints of scenes without walls stay readable)
        # A wall of another name started with unloaded springs, silently (a helper,
        # 2026-12-06: 29 % off in stress five steps later).
        fingerprint["walls"] = [
            {
                "name": w.spec.name,
                "friction": w.spec.friction,
                "penalty": w.spec.penalty,
                "slip_scale": w.spec.slip_scale,
            }
            for w in sim.walls.walls
        ]
    return fingerprint


def _cell_moments(mesh, low: np.ndarray) -> list[float]:
    """The means of the grid's cell centroids and of their pairwise products.

    Measured from the grid's lowest corner ``low`` (g,), so that round-off is the
    grid's size's, and the same on any number of ranks (each cell counted by its
    owner); the products tell a square's two diagonals apart. A grid of another
    layout with the cells and extent of the checkpoint's was read into without a
    word (a helper's gmsh grid and a structured one, 462 triangles each on the same
    rectangle, 2026-12-07).
    """
    c = cell_centroids(mesh) - low
    upper = np.triu_indices(mesh.geometry.dim)
    products = (c[:, :, None] * c[:, None, :])[:, upper[0], upper[1]]
    sums = parallel.total(mesh.comm, np.r_[c.sum(axis=0), products.sum(axis=0)])
    count = parallel.total(mesh.comm, len(c))
    return (sums / max(count, 1)).tolist()


def _parameters(material) -> dict:
    """The law's parameters by name (numbers and names), for the fingerprint."""
    kind = f"{type(material).__module__}.{type(material).__qualname__}"
    laws = getattr(material, "laws", None)
    if laws is not None:  # several laws (fe_mpm.materials.zones): each one's
        return {"type": kind, "laws": [_parameters(law) for law in laws]}
    if not dataclasses.is_dataclass(material):
        return {"type": kind}  # a repr may hold a memory address, which never matches
    out = {}
    for f in dataclasses.fields(material):
        value = getattr(material, f.name)
        scalar = isinstance(value, int | float | str | bool | None)
        out[f.name] = value if scalar else type(value).__name__
    return out


def _check_state(sim, path: Path, state: dict) -> None:
    """Refuse a checkpoint of another format, version or scene, or a malformed one.

    Every rank checks the same ``state``, so every rank refuses alike; all of it is
    checked before :func:`read` changes anything.
    """
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        found = state.get("format") if isinstance(state, dict) else None
        raise CheckpointError(
            f"checkpoint {path}: format {found!r}, this fe-mpm reads format {FORMAT}"
        )
    missing = sorted(STATE_KEYS - state.keys())
    pieces = state.get("pieces")
    if missing or not isinstance(pieces, list) or not isinstance(state["scene"], dict):
        raise CheckpointError(
            f"checkpoint {path}: state.json is malformed (missing {missing or 'nothing'}; "
            "pieces must be a list and scene a mapping)"
        )
    if any(not isinstance(p, dict) or PIECE_KEYS - p.keys() for p in pieces):
        raise CheckpointError(f"checkpoint {path}: state.json is malformed (a piece lacks keys)")
    theirs, ours = state["scene"], scene(sim)
    if theirs.get("fe_mpm") != ours["fe_mpm"]:
        raise CheckpointError(
            f"checkpoint {path} was written by fe-mpm {theirs.get('fe_mpm')}, this is "
            f"{ours['fe_mpm']}; restart with the version that wrote it"
        )
    if "cell_moments" not in theirs:  # written before 2026-12-07, night
        ours.pop("cell_moments")
    if sorted(theirs) != sorted(ours):
        raise CheckpointError(
            f"checkpoint {path} is of another scene: it records {sorted(theirs)}, "
            f"this simulation {sorted(ours)}"
        )
    span = max(float(np.max(np.subtract(ours["extent"][1], ours["extent"][0]))), 1e-300)
    for key, value in ours.items():
        if key == "extent":
            same = np.shape(theirs[key]) == np.shape(value) and np.allclose(
                theirs[key], value, rtol=0, atol=EXTENT_TOLERANCE * span
            )
        elif key == "cell_moments":  # means of x, then of x_i x_j, to round-off
            g = sim.gdim
            scale = np.r_[np.full(g, span), np.full(len(value) - g, span * span)]
            if np.shape(theirs[key]) != np.shape(value) or np.any(
                np.abs(np.subtract(theirs[key], value)) > EXTENT_TOLERANCE * scale
            ):
                raise CheckpointError(
                    f"checkpoint {path} is of another grid with as many cells on the same "
                    f"extent: its cells' mean centroid is {np.round(theirs[key][:g], 6).tolist()}, "
                    f"this simulation's {np.round(value[:g], 6).tolist()}, or their spread "
                    "differs; restore into the grid that wrote it"
                )
            continue
        else:
            same = theirs.get(key) == value
        if not same:
            raise CheckpointError(
                f"checkpoint {path} is of another scene: its {key} is {theirs.get(key)!r}, "
                f"this simulation's is {value!r}"
            )


def _save(file: Path, arrays: dict) -> str:
    """Write ``arrays`` as an .npz file; return its SHA-256."""
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    data = buffer.getvalue()
    file.write_bytes(data)
    return hashlib.sha256(data).hexdigest()


def _load(file: Path, sha256: str, count: int | None) -> dict:
    """The arrays of one checkpoint file, checked against its checksum and point count."""
    try:
        data = file.read_bytes()
    except OSError as err:
        raise CheckpointError(f"checkpoint file {file} cannot be read: {err}") from err
    if hashlib.sha256(data).hexdigest() != sha256:
        raise CheckpointError(f"checkpoint file {file} does not match its checksum: corrupted")
    with np.load(io.BytesIO(data)) as npz:
        arrays = {name: npz[name] for name in npz.files}
    if count is not None:
        missing = [n for n in SAVED_FIELDS if n not in arrays and n not in OPTIONAL_FIELDS]
        if missing or len(arrays["x"]) != count:
            raise CheckpointError(f"checkpoint file {file} lacks {missing or 'points'}")
    return arrays


def _joined_domains(pieces: list[dict], sim, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """This rank's pieces' domains: corners (n, d + 1, d) and drawn quality (n,).

    Empty without point domains, or on a rank that read no piece.
    """
    if sim.domains is None or not pieces:
        return np.zeros((0, sim.gdim + 1, sim.gdim)), np.zeros(0)
    if any("domain_corners" not in p or "domain_quality" not in p for p in pieces):
        raise CheckpointError(f"checkpoint {path}: a piece lacks its points' domains")
    shape = (-1, sim.gdim + 1, sim.gdim)
    corners = [np.reshape(p["domain_corners"], shape) for p in pieces]
    if any(
        len(c) != len(p["x"]) or len(p["domain_quality"]) != len(p["x"])
        for c, p in zip(corners, pieces, strict=True)
    ):
        raise CheckpointError(f"checkpoint {path}: a piece has a domain count unlike its points'")
    return np.concatenate(corners), np.concatenate([p["domain_quality"] for p in pieces])


def _joined(pieces: list[dict], sim) -> MaterialPoints:
    """One point set from this rank's pieces, checked as any new points are."""

    def stacked(name: str) -> np.ndarray:
        parts = [p[name] if name in p else OPTIONAL_FIELDS[name](len(p["x"])) for p in pieces]
        # No pieces on this rank: no points, in the shape the simulation's have.
        return np.concatenate(parts) if parts else getattr(sim.points, name)[:0]

    try:
        points = MaterialPoints(**{name: stacked(name) for name in SAVED_FIELDS})
    except (TypeError, ValueError) as err:
        raise CheckpointError(f"checkpoint points are not valid: {err}") from err
    for name, law_history in sim.material.history.items():
        parts = [p[f"history.{name}"] for p in pieces]
        points.history[name] = np.concatenate(parts) if parts else law_history.initial_values(0)
    return points
