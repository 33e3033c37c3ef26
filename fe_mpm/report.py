"""What a step reports: :class:`StepReport`, one per accepted step (``Simulation.history``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mpi4py import MPI

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.bodies import joined_at_a_node
from fe_mpm.errors import ConvergenceError
from fe_mpm.force_test import NewtonResult
from fe_mpm.io import write_csv_rows
from fe_mpm.quadrature import SlotLayout
from fe_mpm.tracking import hinge_diagnosis, sparse_mass_diagnosis
from fe_mpm.transfer import summed_over_ranks
from fe_mpm.walls import WallForces


@dataclass
class StepReport:
    """What one step did.

    Attributes:
        step: Step number, from 1.
        t: Time at the end of the step (s, or pseudo-time in static runs).
        newton_iterations: Newton iterations of the step.
        residual_norms: ‖R‖ at each Newton iterate.
        markers: Position of every marker at ``t``, name -> array (g,).
        nslot: Slots per entity in the step (a cell with k points is ceil(k/nslot) entities).
        occupied_cells: Number of cells holding points.
        dt: Length of the step (s).
        reactions: Force each requested boundary exerts on the body, name -> (g,)
            (N, per unit thickness in 2D).
        held_points: How many points were integrated in their last step's cell
            instead of the one they are in, over all ranks (nonzero only in a step
            retried without re-binning).
        migrated_points: Points that moved to another MPI rank's cells before the
            step and were sent there (all ranks together; 0 on one rank).
        point_imbalance: The most points a rank held in the step over the mean per
            rank (1 on one rank): how far the ranks' work is from even, since
            each rank packs and integrates its own points (with point domains, its
            pieces).
        repartitioned: Whether the grid was repartitioned by its points after this
            step (``Simulation(rebalance_above=)``), so that the next step starts
            balanced; read in ``run(on_step=)``, which runs on the step's grid
            first, whether it will be.
        converged_reason: Why Newton stopped, e.g. ``"‖R‖ = 2.1e-13 of the force
            scale 1.962e+04"`` (see :class:`fe_mpm.newton.ForceTest`).
        force_scale: The forces in play at the last iterate, S = max(‖f_ext‖,
            ‖f_int‖, ‖f_M‖), f_M the inertia forces of a dynamic step (N; N/m in 2D).
        relative_residual: The last ‖R_u‖ (the displacement rows) over ``force_scale``.
        lost_load: Share of each grid ``Traction``'s or ``Pressure``'s load that acts
            on nodes with no material, so it is lost (``"Traction 0"`` -> share in
            [0, 1], named by its place in ``tractions=``), and of each
            ``PointTraction``'s or ``PointPressure``'s weight whose points lie in no
            occupied cell, so their load is not applied (by its name); only loads
            that lose some.
        failed_iterations: Newton iterations spent since the last accepted step on
            set-ups that failed (a placement of the points whose Newton solves all
            failed, or a step length that was then cut, see :mod:`fe_mpm.retry`);
            ``newton_iterations`` counts those of the accepted placement (both of
            its line searches when the first failed). Set by
            :meth:`Simulation.run <fe_mpm.Simulation.run>`; 0 for a direct ``step``.
        walls: The force of each rigid wall on the body, name ->
            :class:`~fe_mpm.walls.WallForces` (normal, tangential, node by node).
        grid_kinetic_energy: In dynamics, the kinetic energy of the grid's velocity at
            ``t`` over all ranks (J; J/m in 2D; 0 in static runs): the motion the body
            carries. The points' energy (``points.kinetic_energy()`` summed over the
            ranks) also counts velocity the grid never sees, which a body at rest can
            keep for ever (see
            :meth:`fe_mpm.dynamics.NewmarkDynamics.grid_kinetic_energy`): judge rest by
            this one. While the body moves the two differ by a few per cent either
            way (the row-sum masses count a little more energy than the points of a
            smooth motion carry).
    """

    step: int
    t: float
    newton_iterations: int
    residual_norms: list[float]
    markers: dict[str, np.ndarray] = field(default_factory=dict)
    nslot: int = 0
    occupied_cells: int = 0
    dt: float = 0.0
    reactions: dict[str, np.ndarray] = field(default_factory=dict)
    held_points: int = 0
    migrated_points: int = 0
    point_imbalance: float = 1.0
    repartitioned: bool = False
    converged_reason: str = ""
    force_scale: float = 0.0
    relative_residual: float = 0.0
    lost_load: dict[str, float] = field(default_factory=dict)
    failed_iterations: int = 0
    walls: dict[str, WallForces] = field(default_factory=dict)
    grid_kinetic_energy: float = 0.0

    @classmethod
    def of_step(
        cls,
        step: int,
        t: float,
        result: NewtonResult,
        current,
        reactions: dict,
        markers,
        tracking,
        conditions,
    ) -> StepReport:
        """The report of an accepted step from what its phases hold.

        Args:
            step: The step's number.
            t: Its end time.
            result: Newton's result.
            current: The step's :class:`~fe_mpm.step_forms.StepInProgress`.
            reactions: The reaction forces, name -> (g,).
            markers: The :class:`~fe_mpm.markers.Markers`, moved.
            tracking: The :class:`~fe_mpm.tracking.PointTracking` (held points).
            conditions: The :class:`~fe_mpm.grid_conditions.GridConditions`, whose
                ``lost_load`` is keyed by the tractions' tags, i + 1 for ``tractions[i]``,
                and ``traction_labels`` names them (``"Traction i"``, ``"Pressure i"``).
        """
        # Counts are over every rank: the grid's communicator, not the markers' (a
        # domain step's pieces carry markers of their own, on no communicator).
        comm = conditions.mesh.comm
        lost = {
            conditions.traction_labels[i]: share
            for i, share in conditions.lost_load.items()
            if share > 0
        }
        return cls(
            step=step,
            t=t,
            newton_iterations=result.iterations,
            residual_norms=result.residual_norms,
            markers=markers.positions(),
            nslot=current.forms.q.nslot,
            occupied_cells=occupied_cells(conditions.mesh, current.layout.occupied),
            dt=current.dt,
            reactions=reactions,
            held_points=parallel.total(comm, int(tracking.held_points)),
            migrated_points=tracking.migrated,
            point_imbalance=imbalance(comm, current.layout.cell.size),
            converged_reason=result.reason,
            force_scale=result.force_scale,
            relative_residual=result.relative_residual,
            lost_load=lost,
        )


#: The columns of :func:`write_steps` that count (written as integers).
COUNTS = ("step", "newton_iterations", "occupied_cells")


def write_steps(history: list[StepReport], path: str | Path, first: int = 0) -> Path:
    """Write one CSV row per step of ``history``: what a load–displacement curve needs.

    Columns: ``step, t, dt, newton_iterations, relative_residual, force_scale,
    occupied_cells, grid_kinetic_energy``, then each reaction's components
    (``{name}_x``, in N, per unit thickness in 2D) and each marker's position
    (``{name}_x``, m): those the run's
    first step reports (a marker added later is not written). Every rank's reports
    carry the same numbers, so call it on one.

    Args:
        history: The :class:`StepReport` objects of a run (``Simulation.history``).
        path: The CSV file to write.
        first: 0 writes the file anew; k > 0 appends the rows of ``history[k:]`` to
            it, as a run does at each output (each step's row written once).

    Returns:
        The path written, a :class:`pathlib.Path`.
    """
    path = Path(path)
    if not history:
        return path
    header, fixed, vectors, g = _steps_columns(history[0])
    lines = []
    for report in history[first:]:
        values = [
            str(getattr(report, name)) if name in COUNTS else repr(float(getattr(report, name)))
            for name in fixed
        ]
        for kind, name in vectors:
            vector = getattr(report, kind).get(name, np.full(g, np.nan))
            values += [repr(float(v)) for v in np.ravel(vector)]
        lines.append(",".join(values))
    return write_csv_rows(path, header, lines, first)


#: The columns of ``steps.csv`` that every step has.
_FIXED_COLUMNS = (
    "step",
    "t",
    "dt",
    "newton_iterations",
    "relative_residual",
    "force_scale",
    "occupied_cells",
    "grid_kinetic_energy",
)


def _steps_columns(head: StepReport) -> tuple[list[str], list[str], list, int]:
    """The header of ``steps.csv`` whose first row is ``head``'s, with its parts."""
    vectors = [("reactions", name) for name in head.reactions]
    vectors += [("markers", name) for name in head.markers]
    g = next((np.size(getattr(head, kind)[name]) for kind, name in vectors), 0)
    fixed = list(_FIXED_COLUMNS)
    return [*fixed, *(f"{name}_{c}" for _, name in vectors for c in "xyz"[:g])], fixed, vectors, g


def steps_header(head: StepReport) -> str:
    """The header line of a ``steps.csv`` whose first row is ``head``'s."""
    return ",".join(_steps_columns(head)[0])


def occupied_cells(mesh, occupied: np.ndarray) -> int:
    """How many cells of the grid hold points on some rank, each counted once.

    With point domains a rank's pieces also lie in its ghost cells, which another
    rank owns and may fill too (before 2026-12-06 each rank reported its own count).

    Args:
        mesh: The grid.
        occupied: This rank's occupied cells, owned and ghost (local indices).
    """
    cells = mesh.topology.index_map(mesh.topology.dim)
    used = np.zeros(cells.size_local + cells.num_ghosts)
    used[occupied] = 1.0
    owned = summed_over_ranks(cells, used)[: cells.size_local]
    return int(parallel.total(mesh.comm, int(np.count_nonzero(owned))))


def imbalance(comm, count: int) -> float:
    """The largest of the ranks' ``count`` over their mean (1 when all are empty)."""
    if comm.size == 1:
        return 1.0
    most, total = parallel.largest(comm, count), parallel.total(comm, count)
    return float(most * comm.size / total) if total else 1.0


def newton_failure(
    result: NewtonResult,
    step: int,
    t_old: float,
    t_new: float,
    mesh: dolfinx.mesh.Mesh,
    layout: SlotLayout,
    centroids: np.ndarray,
    dynamic: bool = False,
    consistent_mass: bool = False,
    degree: int = 1,
    nonfinite: str = "",
    where: str = "",
) -> ConvergenceError:
    """The error of a step whose Newton solves all failed.

    It gives the residual history, the accepted bound, and what may explain a
    singular tangent: in a static run the hinged cells, if any (in a dynamic run the
    mass holds them); in a dynamic run with the consistent mass the cells with too few
    points to hold their nodes by it (``degree``: the displacement's, 1 or 2).
    ``nonfinite``: where an iterate's residual or Jacobian held NaN or inf, in words
    (:attr:`fe_mpm.newton.NewtonSolver.nonfinite`), or "". ``where``: where the last
    iterate is out of balance and moved most (:meth:`~fe_mpm.newton.NewtonSolver.where_it_failed`).
    """
    norms = _norms_by_attempt(result)
    if nonfinite:  # a sentence of its own
        nonfinite = f"{nonfinite[:1].upper()}{nonfinite[1:]}. "
    if not dynamic:
        diagnosis = hinge_diagnosis(mesh, layout, centroids)
        if not diagnosis:
            joint = joined_at_a_node(mesh, layout.occupied)
            if joint is not None:
                diagnosis = (
                    "Parts of the material touch at a node and nowhere else (first at x = "
                    f"{joint.tolist()}): each can turn about it, so the static tangent is "
                    "singular unless every part is held on its own. "
                )
    elif consistent_mass:
        diagnosis = sparse_mass_diagnosis(mesh, layout, centroids, degree)
    else:
        diagnosis = ""
    ended = "the last solve " if len(result.attempts) > 1 else ""
    return ConvergenceError(
        f"Newton failed in step {step} (t = {t_old:g} -> {t_new:g}) after "
        f"{result.iterations} iteration{'' if result.iterations == 1 else 's'}: {ended}"
        f"{result.reason}; ‖R‖ history: {norms} "
        f"against the force scale {result.force_scale:.3e} (accepted: ‖R‖ <= "
        f"{result.tolerance:.3e}). {nonfinite}{where}{diagnosis}"
        "Points were not updated and nothing was written for this step."
    )


def _norms_by_attempt(result: NewtonResult) -> str:
    """‖R‖ of each iterate, in brackets per solve, each named by its line search.

    Joined in one list, a solve that was still falling read as part of the next one,
    whose stall test names its own smallest ‖R‖ (a helper's slope, 2026-12-06).
    """
    attempts = result.attempts or [("", len(result.residual_norms))]
    parts, start = [], 0
    for search, count in attempts:
        norms = ", ".join(f"{r:.3e}" for r in result.residual_norms[start : start + count])
        parts.append(f"{search} [{norms}]" if len(attempts) > 1 else f"[{norms}]")
        start += count
    return "; ".join(parts)


class ProgressBar:
    """A run's progress in steps (tqdm), or nothing when ``enabled`` is False or off rank 0."""

    def __init__(self, n_steps: int, enabled: bool = True):
        self._bar = None
        enabled = enabled and MPI.COMM_WORLD.rank == 0
        if enabled:
            from tqdm.auto import tqdm

            # Cut steps count as fractions of a nominal one: show the count rounded.
            self._bar = tqdm(
                total=n_steps,
                desc="fe-mpm",
                unit="step",
                leave=True,  # the run's steps and total time stay on the screen
                bar_format="{l_bar}{bar}| {n:.0f}/{total_fmt} [{elapsed}<{remaining}{postfix}]",
            )

    def update(self, report: StepReport, nominal: float, cuts: int = 0) -> None:
        """Count ``report``'s step as its share of the nominal step length ``nominal``.

        ``cuts``: how many step lengths the run has cut so far, shown once there is one
        (until 2026-12-06 only the slower count told).
        """
        if self._bar is not None:
            extra = (
                {} if MPI.COMM_WORLD.size == 1 else {"imbalance": f"{report.point_imbalance:.2f}"}
            )
            if cuts:
                extra["cuts"] = cuts
            # Drawn with the count, not before it (it read "0/300 ... t=0.002" after step 1).
            self._bar.set_postfix(
                t=f"{report.t:.4g}", newton=report.newton_iterations, refresh=False, **extra
            )
            # Summed step shares overshoot the total by round-off (tqdm then warns of
            # clamping at the last step, as the copper Taylor bar's runs did).
            self._bar.update(max(0.0, min(report.dt / nominal, self._bar.total - self._bar.n)))

    def close(self) -> None:
        """Close the bar, leaving its last state."""
        if self._bar is not None:
            self._bar.close()
