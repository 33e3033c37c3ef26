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

from fe_mpm.materials.elastic import in_plane, is_builtin


@dataclass(frozen=True)
class ReturnMapResult:
    """What a pointwise law returns for ``n`` points.

    Attributes:
        tau: Kirchhoff stress (n, 3, 3), Pa (τ₃₃ included in plane strain).
        derivative: Computes ∂τ_ij/∂ΔF_kl (n, 3, 3, g, g) in Pa; read it
            through :attr:`tangent`, which calls it once.
        history: Internal variables at t_{n+1} by name, each ``(n, *shape)``.
        region: Optional per-point label of the return taken (n,).
        principal_tangent: Optional ∂τ_A/∂ε^tr_B (n, 3, 3), Pa, of a principal-space
            return: cheap, and what the return at the field's pressure steps with
            (:mod:`~fe_mpm.materials.mixed_return`).
    """

    tau: np.ndarray
    derivative: Callable[[], np.ndarray]
    history: dict[str, np.ndarray]
    region: np.ndarray | None = None
    principal_tangent: np.ndarray | None = None

    @cached_property
    def tangent(self) -> np.ndarray:
        """∂τ_ij/∂ΔF_kl (n, 3, 3, g, g), Pa, computed on first access."""
        return self.derivative()


def check_returned(material, result: ReturnMapResult, n: int) -> None:
    """Refuse a pointwise law's return whose stress or history has the wrong shape.

    Found 2026-12-07 by a helper writing a law of their own: a τ of shape (n, 2, 2)
    ended inside PETSc ("cannot reshape array"), and a history variable missing from
    the return, or misspelt, was never updated (a damage law's κ stayed 0) or was
    stored beside the declared one, without a word. The history is checked for laws
    outside fe_mpm (its own are tested).
    """
    owner = f"{type(material).__name__}.return_map"
    if np.shape(result.tau) != (n, 3, 3):
        raise ValueError(
            f"{owner}: tau must have shape ({n}, 3, 3) (Kirchhoff stress, τ₃₃ included in "
            f"plane strain), got {np.shape(result.tau)}"
        )
    if is_builtin(material):
        return
    declared = getattr(material, "history", {})
    missing = sorted(set(declared) - set(result.history))
    extra = sorted(set(result.history) - set(declared))
    if missing or extra:
        raise ValueError(
            f"{owner}: its history must hold the law's declared variables "
            f"{sorted(declared)}; missing {missing}, not declared {extra}"
        )
    for name, field in declared.items():
        want = (n, *field.shape)
        if np.shape(result.history[name]) != want:
            raise ValueError(
                f"{owner}: history[{name!r}] must have shape {want}, "
                f"got {np.shape(result.history[name])}"
            )


@dataclass
class Linearisation:
    """Slot fields holding τ_k (3x3), D_k (flattened 3·3·g·g) and ΔF_k (g x g)."""

    tau: ufl.Coefficient
    tangent: ufl.Coefficient
    dF: ufl.Coefficient
    gdim: int

    @classmethod
    def on(cls, q, g: int) -> Linearisation:
        """The slot fields on the material-point quadrature ``q``, g dimensions."""
        return cls(
            q.function((3, 3), "tau_k"),
            q.function((9 * g * g,), "tangent_k"),
            q.function((g, g), "dF_k", empty=np.eye(g)),
            g,
        )

    @property
    def slot_fields(self) -> tuple[ufl.Coefficient, ...]:
        """The fields that change at every iterate; the tangent ones last."""
        return (self.tau, self.dF, self.tangent)

    def point_values(self, dF: ufl.core.expr.Expr, mean_stress=None) -> ufl.core.expr.Expr:
        """What the return needs at the points, as one UFL vector: ΔF's g² entries."""
        return ufl.as_vector(_entries(dF, self.gdim))

    def returned(self, material, values: np.ndarray, history: dict):
        """The law's return at the iterate, and the slot values it sets.

        ``values`` (n, g²) are :meth:`point_values` at the points; the slot values
        are field -> (n, ...).
        """
        dF = values.reshape(-1, self.gdim, self.gdim)
        result = material.return_map(dF, history)
        check_returned(material, result, dF.shape[0])
        return result, {self.tau: result.tau, self.dF: dF}

    def tangent_values(self, result: ReturnMapResult) -> dict:
        """The tangent's slot values, field -> (n, ...): computed only for a Jacobian."""
        tangent = result.tangent
        n, g = result.tau.shape[0], self.gdim
        if tangent.shape != (n, 3, 3, g, g):
            raise ValueError(
                f"return_map's tangent must have shape ({n}, 3, 3, {g}, {g}) "
                f"(∂τ_ij/∂ΔF_kl, τ 3 x 3), got {tangent.shape}"
            )
        return {self.tangent: self.flat_tangent(tangent)}

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


@dataclass
class MixedLinearisation:
    r"""Slot fields of a pressure-dependent law's return at the field's pressure (u-p).

    The law gives the deviator :math:`s` and the volumetric equation :math:`v` (strain)
    as functions of :math:`\Delta F` and the Kirchhoff mean stress
    :math:`\bar\tau_m = -J p` (:mod:`~fe_mpm.materials.mixed_return`); the forms see
    both linearised at the iterate :math:`(\Delta F_k, \bar\tau_{m,k})`. Since
    :math:`\bar\tau_m` is a UFL expression of ``du`` and ``p``, ``ufl.derivative``
    adds the pressure coupling to the tangent.

    Attributes:
        deviator: s_k (3x3, Pa).
        deviator_tangent: ∂s/∂ΔF at the iterate, flattened (9·g·g, Pa).
        deviator_pressure: ∂s/∂τ̄_m (3x3, dimensionless).
        volumetric: v_k (strain).
        volumetric_tangent: ∂v/∂ΔF (g x g).
        volumetric_pressure: ∂v/∂τ̄_m (1/Pa).
        dF: ΔF_k (g x g).
        mean_stress: τ̄_m,k (Pa).
        gdim: Geometric dimension g.
    """

    deviator: ufl.Coefficient
    deviator_tangent: ufl.Coefficient
    deviator_pressure: ufl.Coefficient
    volumetric: ufl.Coefficient
    volumetric_tangent: ufl.Coefficient
    volumetric_pressure: ufl.Coefficient
    dF: ufl.Coefficient
    mean_stress: ufl.Coefficient
    gdim: int

    @classmethod
    def on(cls, q, g: int) -> MixedLinearisation:
        """The slot fields on the material-point quadrature ``q``, g dimensions."""
        return cls(
            q.function((3, 3), "s_k"),
            q.function((9 * g * g,), "ds_dF_k"),
            q.function((3, 3), "ds_dm_k"),
            q.function((), "v_k"),
            q.function((g, g), "dv_dF_k"),
            q.function((), "dv_dm_k"),
            q.function((g, g), "dF_k", empty=np.eye(g)),
            q.function((), "tau_m_k"),
            g,
        )

    @property
    def slot_fields(self) -> tuple[ufl.Coefficient, ...]:
        """The fields that change at every iterate."""
        return (
            self.deviator,
            self.volumetric,
            self.dF,
            self.mean_stress,
            self.deviator_tangent,
            self.deviator_pressure,
            self.volumetric_tangent,
            self.volumetric_pressure,
        )

    def point_values(self, dF: ufl.core.expr.Expr, mean_stress: ufl.core.expr.Expr):
        """What the return needs at the points, as one UFL vector: ΔF's g², then τ̄_m."""
        return ufl.as_vector([*_entries(dF, self.gdim), mean_stress])

    def returned(self, material, values: np.ndarray, history: dict):
        """The law's return at the field's pressure at the iterate, and the slot values.

        ``values`` (n, g² + 1) are :meth:`point_values` at the points; the slot values
        are field -> (n, ...).
        """
        g = self.gdim
        dF, mean_stress = values[:, : g * g].reshape(-1, g, g), values[:, g * g]
        result = material.return_at_pressure(dF, mean_stress, history)
        return result, {
            self.deviator: result.deviator,
            self.volumetric: result.volumetric,
            self.dF: dF,
            self.mean_stress: mean_stress,
        }

    def tangent_values(self, result) -> dict:
        """The four tangent blocks' slot values, field -> (n, ...): only for a Jacobian."""
        ds_dF, ds_dm, dv_dF, dv_dm = result.tangent
        return {
            self.deviator_tangent: Linearisation.flat_tangent(ds_dF),
            self.deviator_pressure: ds_dm,
            self.volumetric_tangent: dv_dF,
            self.volumetric_pressure: dv_dm,
        }

    def deviatoric(self, dF: ufl.core.expr.Expr, mean_stress: ufl.core.expr.Expr):
        """s_k + ∂s/∂ΔF : (ΔF − ΔF_k) + ∂s/∂τ̄_m (τ̄_m − τ̄_m,k), 3x3 (Pa)."""
        g = self.gdim
        step, dm = dF - self.dF, mean_stress - self.mean_stress
        D = self.deviator_tangent

        def entry(i, j):
            base = (3 * i + j) * g * g
            return (
                self.deviator[i, j]
                + sum(D[base + g * k + m] * step[k, m] for k in range(g) for m in range(g))
                + self.deviator_pressure[i, j] * dm
            )

        return ufl.as_matrix([[entry(i, j) for j in range(3)] for i in range(3)])

    def volumetric_equation(self, dF: ufl.core.expr.Expr, mean_stress: ufl.core.expr.Expr):
        """v_k + ∂v/∂ΔF : (ΔF − ΔF_k) + ∂v/∂τ̄_m (τ̄_m − τ̄_m,k), strain."""
        step = dF - self.dF
        return (
            self.volumetric
            + ufl.inner(self.volumetric_tangent, step)
            + self.volumetric_pressure * (mean_stress - self.mean_stress)
        )


def _entries(A: ufl.core.expr.Expr, g: int) -> list:
    """The g² entries of a g x g UFL tensor, row by row."""
    return [A[i, j] for i in range(g) for j in range(g)]


class LinearisedStress:
    """The UFL side of a law whose return map runs at the points (a mixin).

    The forms see the linearisation τ_k + D_k : (ΔF − ΔF_k) of the state's slot
    fields; the history comes from ``return_map``, not from UFL. The mixed forms
    take its deviator; where the law depends on the pressure
    (:attr:`pressure_dependent`) they take the deviator and the volumetric equation of
    its return at the field's pressure instead (:class:`MixedLinearisation`).
    """

    def kirchhoff(self, F: ufl.core.expr.Expr, state) -> ufl.core.expr.Expr:
        """The linearised return-map stress τ (Pa), shape of ``F``."""
        return in_plane(self._linearised(state), ufl.shape(F)[0])

    def kirchhoff_deviatoric(self, F: ufl.core.expr.Expr, state) -> ufl.core.expr.Expr:
        """Dev τ (Pa), shape of ``F``: the u-p part (at the field's pressure, if needed)."""
        lin = None if state is None else state.linearisation
        if isinstance(lin, MixedLinearisation):
            return in_plane(lin.deviatoric(state.dF, state.mean_stress), ufl.shape(F)[0])
        return in_plane(ufl.dev(self._linearised(state)), ufl.shape(F)[0])

    def volumetric_equation(self, state) -> ufl.core.expr.Expr | None:
        """The u-p volumetric equation v (strain), or None for the forms' (J − 1) + p/K."""
        lin = None if state is None else state.linearisation
        if isinstance(lin, MixedLinearisation):
            return lin.volumetric_equation(state.dF, state.mean_stress)
        return None

    @property
    def pressure_dependent(self) -> bool:
        """Whether the return depends on the mean stress: no, unless the law says so.

        A law that does (the cones, Mohr-Coulomb with φ > 0) runs in u-p at the
        field's pressure (:mod:`~fe_mpm.materials.mixed_return`), which needs a Hencky
        principal-space return with ``be`` in its history.
        """
        return False

    def return_at_pressure(self, dF: np.ndarray, mean_stress: np.ndarray, history: dict):
        """The return at the field's Kirchhoff mean stress (n,), Pa.

        See :func:`~fe_mpm.materials.mixed_return.return_at_mean_stress`.
        """
        from fe_mpm.materials.mixed_return import return_at_mean_stress

        return return_at_mean_stress(self, dF, mean_stress, history)

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
