r"""Laws whose return map runs in numpy: the UFL side is their linearisation.

A pointwise law (one with ``return_map``) computes, at every Newton iterate
:math:`\Delta F_k`, the Kirchhoff stress :math:`\tau_k` and its exact derivative
:math:`D_k = \partial\tau/\partial\Delta F` at the points. The form sees

.. math::  \tau(\Delta F) = \tau_k + D_k : (\Delta F - \Delta F_k),

with :math:`\tau_k, D_k, \Delta F_k` in slot fields. At :math:`\Delta F = \Delta F_k`
the residual is the law's own, and ``ufl.derivative`` of it is :math:`D_k`, the
consistent tangent; so Newton stays quadratic. The simulation refreshes the
slot fields before every residual assembly (see ``NewtonSolver.solve``).

:math:`D_k` costs more than the return itself, and a residual needs only
:math:`\tau_k` (the last residual of a solve, the convergence check, has no
Jacobian after it). So a result computes its tangent on first access.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import ufl

from fe_mpm.materials.elastic import in_plane


@dataclass(frozen=True)
class ReturnMapResult:
    """What a pointwise law returns for ``n`` points.

    Attributes:
        tau: Kirchhoff stress (n, 3, 3), Pa (τ₃₃ included in plane strain).
        derivative: Computes ∂τ_ij/∂ΔF_kl (n, 3, 3, g, g) in Pa; read it
            through :attr:`tangent`, which calls it once.
        history: Internal variables at t_{n+1} by name, each ``(n, *shape)``.
        region: Optional per-point label of the return taken (n,).
    """

    tau: np.ndarray
    derivative: Callable[[], np.ndarray]
    history: dict[str, np.ndarray]
    region: np.ndarray | None = None

    @cached_property
    def tangent(self) -> np.ndarray:
        """∂τ_ij/∂ΔF_kl (n, 3, 3, g, g), Pa, computed on first access."""
        return self.derivative()


@dataclass
class Linearisation:
    """Slot fields holding τ_k (3x3), D_k (flattened 3·3·g·g) and ΔF_k (g x g)."""

    tau: ufl.Coefficient
    tangent: ufl.Coefficient
    dF: ufl.Coefficient
    gdim: int

    def kirchhoff(self, dF: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """τ_k + D_k : (ΔF − ΔF_k), 3x3 (Pa)."""
        g = self.gdim
        step = dF - self.dF
        D = self.tangent

        def entry(i, j):
            base = (3 * i + j) * g * g
            return self.tau[i, j] + sum(
                D[base + g * k + m] * step[k, m] for k in range(g) for m in range(g)
            )

        return ufl.as_matrix([[entry(i, j) for j in range(3)] for i in range(3)])

    @staticmethod
    def flat_tangent(tangent: np.ndarray) -> np.ndarray:
        """(n, 3, 3, g, g) → (n, 9·g·g) in the order :meth:`kirchhoff` reads."""
        return tangent.reshape(tangent.shape[0], int(np.prod(tangent.shape[1:])))


class LinearisedStress:
    """The UFL side of a law whose return map runs at the points (a mixin).

    The forms see the linearisation τ_k + D_k : (ΔF − ΔF_k) of the state's slot
    fields; the history comes from ``return_map``, not from UFL. The mixed forms
    take its deviator, so a law that uses this must refuse them where it depends on
    the pressure (``check_formulation``).
    """

    def kirchhoff(self, F: ufl.core.expr.Expr, state) -> ufl.core.expr.Expr:
        """The linearised return-map stress τ (Pa), shape of ``F``."""
        return in_plane(self._linearised(state), ufl.shape(F)[0])

    def kirchhoff_deviatoric(self, F: ufl.core.expr.Expr, state) -> ufl.core.expr.Expr:
        """Dev τ (Pa), shape of ``F``: the u-p part."""
        return in_plane(ufl.dev(self._linearised(state)), ufl.shape(F)[0])

    def _linearised(self, state) -> ufl.core.expr.Expr:
        if state is None or state.linearisation is None:
            raise ValueError(
                f"{type(self).__name__}: the state has no linearisation slot fields; the "
                "law is evaluated at the points (return_map) by the simulation"
            )
        return state.linearisation.kirchhoff(state.dF)

    def updated_history(self, F: ufl.core.expr.Expr, state) -> dict:
        """Nothing in UFL: ``return_map`` gives the history."""
        return {}
