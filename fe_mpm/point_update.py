"""The last phase of a step: the points take their new state from the converged grid.

:func:`checked_update` decodes the update vector (:class:`~fe_mpm.step_forms.UpdateLayout`)
and refuses a state that is not physical before anything moves; :func:`apply_update`
then moves the points and markers and sets ``F``, ``V``, the stress, the velocity
and acceleration (dynamics) and the history (thesis Algorithm 1, the update of the
material points; the grid is reset simply by never moving it).
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.dynamics import NewmarkDynamics
from fe_mpm.errors import ConvergenceError
from fe_mpm.markers import Markers
from fe_mpm.particles import MaterialPoints
from fe_mpm.step_forms import PointUpdate, UpdateLayout
from fe_mpm.transfer import mass_weighted_projection


def checked_update(
    values: np.ndarray,
    layout: UpdateLayout,
    points: MaterialPoints,
    cell_sizes: np.ndarray,
    max_step_cells: float | None,
    step: int,
    t: float,
    comm: MPI.Comm = MPI.COMM_SELF,
) -> PointUpdate:
    """The points' new state from the evaluated update vector, once it passes the checks.

    Args:
        values: The update vector at every point (n, ``layout.width``).
        layout: Its columns.
        points: The points at the start of the step (not changed here).
        cell_sizes: The size of each point's cell (n,) in m.
        max_step_cells: The farthest a point may move, in sizes of its cell; None:
            no limit (dynamics).
        step: The step's number, for messages.
        t: Its end time, for messages.
        comm: The grid's communicator: a check that fails on one rank stops them all.

    Raises:
        ConvergenceError: A value is not finite, a point moves farther than
            ``max_step_cells``, or ``det ΔF <= 0``; the message names the first point.
    """
    error = None
    if not np.all(np.isfinite(values)):
        bad = np.flatnonzero(~np.all(np.isfinite(values), axis=1))
        error = ConvergenceError(
            f"non-finite state at {bad.size} material point(s) in step {step} (t = {t:g}); "
            f"first: point {bad[0]} at x = {points.x[bad[0]]}. Nothing was updated."
        )
    parallel.raise_together(comm, error)
    new = layout.decode(values)
    parallel.raise_together(comm, _moved_too_far(new, points, cell_sizes, max_step_cells, step, t))
    det_dF = np.linalg.det(new.dF)
    error = None
    if np.any(det_dF <= 0):
        bad = np.flatnonzero(det_dF <= 0)[0]
        error = ConvergenceError(
            f"det(ΔF) <= 0 at point {bad} (x = {points.x[bad]}) in step {step} "
            f"(t = {t:g}): the step inverts material; take smaller steps."
        )
    parallel.raise_together(comm, error)
    return new


def _moved_too_far(
    new: PointUpdate,
    points: MaterialPoints,
    cell_sizes: np.ndarray,
    max_step_cells: float | None,
    step: int,
    t: float,
) -> ConvergenceError | None:
    """The error for a point that moves more than ``max_step_cells`` of its cell, or None."""
    if max_step_cells is None or len(points) == 0:
        return None
    cells_moved = np.linalg.norm(new.du, axis=1) / cell_sizes
    far = int(np.argmax(cells_moved))
    if cells_moved[far] <= max_step_cells:
        return None
    return ConvergenceError(
        f"point {far} (x = {points.x[far]}) would move "
        f"{cells_moved[far]:.3g} cell sizes ({np.linalg.norm(new.du[far]):.3g} m) in "
        f"static step {step} (t = {t:g}), more than max_step_cells = "
        f"{max_step_cells:g}. Nothing was updated. Either a grid value blew up (e.g. at "
        "a node with almost no material), or the step is that large: take more steps "
        "(run() cuts this one and goes on) or raise max_step_cells, which a large "
        "deformation in few steps may need (a cantilever bent to 0.55 of its length in "
        "one step moved its tip 16.6 cells, the answer a finite element solve gives)."
    )


def apply_update(
    points: MaterialPoints,
    new: PointUpdate,
    markers: Markers,
    dynamics: NewmarkDynamics | None,
    dt: float,
    return_map_history: dict | None = None,
) -> None:
    """Move the points and markers and give the points their state at t_{n+1}.

    ``x += Δu``, ``F = ΔF F_n``, ``V = det(ΔF) V_n``, σ from the update, and in
    dynamics Newmark's velocity from the two accelerations.

    Args:
        points: The material points, updated in place.
        new: Their new state (:func:`checked_update`).
        markers: Moved with their hosts.
        dynamics: Newmark's rule, or None (static).
        dt: The step length (s).
        return_map_history: A pointwise law's history at the converged iterate; it
            replaces the update's (the law, not UFL, computed it).
    """
    markers.move(points.x, new.du, new.dF)
    points.x += new.du
    points.F = new.dF @ points.F
    points.volume *= np.linalg.det(new.dF)
    points.stress = new.stress
    if dynamics is not None:
        points.velocity = dynamics.updated_velocity(
            points.velocity, points.acceleration, new.acceleration, dt
        )
        points.acceleration = new.acceleration
    for name, value in new.history.items():
        points.history[name] = value.reshape(points.history[name].shape)
    if return_map_history is not None:
        points.history.update(return_map_history)


def volume_of_pressure(
    new: PointUpdate, bulk_modulus: float, step: int, t: float, comm: MPI.Comm = MPI.COMM_SELF
) -> np.ndarray:
    """The volume change J = 1 − p/K (n,) that a fluid point's pressure p = −tr σ/3 says.

    Args:
        new: The points' checked update; its stress is the converged Cauchy stress.
        bulk_modulus: The fluid's K (Pa).
        step: The step's number, for messages.
        t: Its end time, for messages.
        comm: The grid's communicator: a check that fails on one rank stops them all.

    Raises:
        ConvergenceError: A pressure of K or more (J ≤ 0); nothing was updated.
    """
    J = 1.0 + np.trace(new.stress, axis1=1, axis2=2) / (3.0 * bulk_modulus)
    _refuse_vanishing_volumes(
        J,
        lambda bad: (
            f"the pressure at fluid point {bad} reaches its bulk modulus K = "
            f"{bulk_modulus:g} Pa in step {step} (t = {t:g}), so its volume would vanish; "
            "take smaller steps or a larger K. Nothing was updated."
        ),
        comm,
    )
    return J


def volume_of_average(
    space: dolfinx.fem.FunctionSpace,
    cells: np.ndarray,
    bary: np.ndarray,
    mass: np.ndarray,
    J: np.ndarray,
    step: int,
    t: float,
) -> np.ndarray:
    """The volume change (n,) a fluid point takes in NB-VA: the points' own, averaged.

    The points' volume changes J, projected onto the nodes of ``space`` mass weighted and
    read back at the points, ``Σ_I N_I(x_p) Σ_q N_I(x_q) m_q J_q / Σ_q N_I(x_q) m_q``.
    The mass-weighted sum Σ m_p J_p is kept, so water of one density keeps its volume.

    Args:
        space: A scalar P1 space on the grid of the step's start.
        cells: The points' cells there (n,).
        bary: Their barycentric coordinates in them (n, g + 1).
        mass: Their masses (n,) in kg.
        J: Their own volume changes det F after the step (n,).
        step: The step's number, for messages.
        t: Its end time, for messages.

    Raises:
        ConvergenceError: An averaged J ≤ 0 (a point held outside its cell reads the
            nodes with weights of both signs); nothing was updated.
    """
    nodal, _ = mass_weighted_projection(space, cells, bary, mass, J[:, None])
    averaged = np.einsum("nv,nv->n", bary, nodal[space.dofmap.list[cells], 0])
    _refuse_vanishing_volumes(
        averaged,
        lambda bad: (
            f"the averaged volume change at fluid point {bad} is "
            f"{averaged[bad]:.3g} ≤ 0 in step {step} (t = {t:g}); take smaller steps. "
            "Nothing was updated."
        ),
        space.mesh.comm,
    )
    return averaged


def _refuse_vanishing_volumes(J: np.ndarray, message, comm: MPI.Comm) -> None:
    """Raise ConvergenceError on every rank if some J (n,) is ≤ 0 on any.

    ``message(p)`` says what happened to the first such point p of this rank.
    """
    error = None
    if np.any(J <= 0.0):
        error = ConvergenceError(message(int(np.flatnonzero(J <= 0.0)[0])))
    parallel.raise_together(comm, error)


def keep_volume_of_pressure(points: MaterialPoints, J: np.ndarray) -> None:
    """A fluid point keeps no shape: ``F = J^{1/g} I`` and ``V = V_0 J`` (after the update).

    ``V_0 = V / det F`` is the point's reference volume, which the update kept. ``J``
    comes from the point's pressure (:func:`volume_of_pressure`, u-p) or from the
    averaged volume changes (:func:`volume_of_average`, NB-VA); the stress stays the
    step's converged one, and the next step's law starts from this J.
    """
    g = points.F.shape[1]
    points.volume *= J / np.linalg.det(points.F)
    points.F = (J ** (1.0 / g))[:, None, None] * np.eye(g)
