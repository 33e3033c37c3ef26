"""Checks that a residual and its Jacobian belong together (Taylor tests).

A residual term can silently vanish while the Jacobian keeps it (identical
integrands under different quadrature metadata get merged by the form
compiler). Only a Taylor test catches that: for a consistent pair the remainder
``‖R(u + εd) − R(u) − ε J(u) d‖`` falls as ε², and as ε¹ otherwise.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import dolfinx.fem.petsc as fem_petsc
import numpy as np

from fe_mpm._dolfinx import dolfinx
from fe_mpm.packing import BoundForm


def _residual(R: BoundForm | dolfinx.fem.Form, size: int) -> np.ndarray:
    if isinstance(R, BoundForm):
        return R.assemble_vector()[:size].copy()
    b = dolfinx.fem.assemble_vector(R)
    b.scatter_reverse(dolfinx.la.InsertMode.add)
    return b.array[:size].copy()


def _matrix(J: BoundForm | dolfinx.fem.Form):
    if isinstance(J, BoundForm):
        return J.assemble_matrix()
    A = fem_petsc.assemble_matrix(J)
    A.assemble()
    return A


def taylor_remainders(
    R: BoundForm | dolfinx.fem.Form,
    J: BoundForm | dolfinx.fem.Form,
    u: dolfinx.fem.Function,
    direction: np.ndarray,
    eps: Sequence[float] = (1e-3, 5e-4, 2.5e-4, 1.25e-4),
    before_assembly: Callable[[], object] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Zeroth- and first-order Taylor remainders of ``R`` about the current ``u``.

    Args:
        R: Residual form, depending on ``u`` (a step's, or a plain DOLFINx form).
        J: Its Jacobian form.
        u: The unknown; restored on return.
        direction: Perturbation direction, same length as ``u.x.array``.
        eps: Perturbation sizes.
        before_assembly: Called after every change of ``u`` and before assembling,
            e.g. ``Simulation.refresh_material`` for a law whose return map runs
            outside UFL.

    Returns:
        ``(r0, r1)`` with ``r0[i] = ‖R(u+ε_i d) − R(u)‖`` (falls as ε) and
        ``r1[i] = ‖R(u+ε_i d) − R(u) − ε_i J d‖`` (falls as ε² if J is consistent).
    """
    refresh = before_assembly or (lambda: None)
    u0 = u.x.array.copy()
    size = u.function_space.dofmap.index_map.size_local * u.function_space.dofmap.index_map_bs
    refresh()
    R0 = _residual(R, size)
    A = _matrix(J)
    d = dolfinx.fem.Function(u.function_space)
    d.x.array[:] = direction
    Jd_vec = A.createVecLeft()
    A.mult(d.x.petsc_vec, Jd_vec)
    Jd = Jd_vec.getArray().copy()
    A.destroy()
    Jd_vec.destroy()
    r0, r1 = [], []
    try:
        for e in eps:
            u.x.array[:] = u0 + e * direction
            refresh()
            Re = _residual(R, size)
            r0.append(np.linalg.norm(Re - R0))
            r1.append(np.linalg.norm(Re - R0 - e * Jd))
    finally:
        u.x.array[:] = u0
        refresh()
    return np.array(r0), np.array(r1)


def rates(eps: Sequence[float], remainders: np.ndarray) -> np.ndarray:
    """Observed convergence orders between successive ε of a remainder sequence."""
    eps = np.asarray(eps, dtype=float)
    return np.log(remainders[1:] / remainders[:-1]) / np.log(eps[1:] / eps[:-1])
