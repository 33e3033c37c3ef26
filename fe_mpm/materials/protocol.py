"""What a constitutive law provides: the contract between a law and the simulation.

:class:`Law` is what every law has; the simulation checks it when it is built and
names whatever is missing. Two optional parts extend it:

- :class:`MixedLaw`, for the u-p formulations, where the pressure is a grid field
  and the law gives only the deviatoric stress;
- :class:`PointwiseLaw`, for laws whose return map runs at the points, compiled or
  in numpy (:class:`~fe_mpm.materials.MohrCoulomb`, Mast's laws): the forms then see
  the law's linearisation at the current Newton iterate
  (:mod:`fe_mpm.materials.linearised`; :class:`~fe_mpm.materials.linearised.LinearisedStress`
  gives such a law its UFL side).

A new law implements :class:`Law`, and :class:`PointwiseLaw` if its return map is
not written in UFL. The protocols are
``runtime_checkable``: ``isinstance(law, PointwiseLaw)`` asks whether the members
exist, not whether their signatures match.
"""

from __future__ import annotations

import inspect
from typing import Protocol, runtime_checkable

import numpy as np
import ufl

from fe_mpm.materials.linearised import ReturnMapResult
from fe_mpm.materials.state import HistoryField, PointState


@runtime_checkable
class Law(Protocol):
    """A constitutive law of the material points.

    Attributes:
        mu: Shear modulus μ (Pa): the scale of the PPP stabilisation.
        bulk_modulus: Bulk modulus K (Pa): the volumetric law of the u-p forms.
        density: Mass density ρ₀ (kg/m³), or None to take it from the points.
    """

    mu: float
    bulk_modulus: float
    density: float | None

    @property
    def history(self) -> dict[str, HistoryField]:
        """The internal variables, name -> shape, initial value and meaning."""

    def kirchhoff(self, F: ufl.core.expr.Expr, state: PointState | None) -> ufl.core.expr.Expr:
        """Kirchhoff stress τ = J σ (Pa), shape of ``F`` (g x g), in UFL."""

    def updated_history(self, F: ufl.core.expr.Expr, state: PointState) -> dict:
        """The internal variables at t_{n+1} as UFL expressions, name -> value."""


@runtime_checkable
class MixedLaw(Law, Protocol):
    """A law the mixed u-p formulations can use: the pressure is their field."""

    def kirchhoff_deviatoric(
        self, F: ufl.core.expr.Expr, state: PointState | None
    ) -> ufl.core.expr.Expr:
        """Isochoric Kirchhoff stress dev τ (Pa), shape of ``F``, in UFL."""


@runtime_checkable
class PointwiseLaw(Law, Protocol):
    """A law whose return map runs in numpy, point by point."""

    def return_map(self, dF: np.ndarray, history: dict[str, np.ndarray]) -> ReturnMapResult:
        """Stress, tangent and history at t_{n+1} for the step increments ``dF`` (n, g, g)."""


def checked_stress(law: object, member: str, tau, F):
    """``tau``, the UFL stress ``law.member(F, ...)`` gave, refused unless of F's shape.

    A user's law that returned a 3 x 3 stress for a plane-strain F, or a vector,
    stopped inside UFL ("Shapes do not match: <ComponentTensor id=...>"; a helper's
    laws, 2026-12-07).
    """
    if ufl.shape(tau) != ufl.shape(F):
        law = getattr(law, "_law", law)  # the law itself, not its view in the forms
        raise ValueError(
            f"{type(law).__name__}.{member} must return a stress of F's shape "
            f"{ufl.shape(F)} (g x g), got shape {ufl.shape(tau)}"
        )
    return tau


def missing_members(law: object, protocol: type) -> list[str]:
    """The members of ``protocol`` that ``law`` lacks, in the protocol's order.

    Looked up without calling them: a property may refuse to give a value the scene
    does not need (``NewtonianFluid.mu`` without a shear scale).
    """
    return [name for name in _members(protocol) if not _has(law, name)]


def _has(law: object, name: str) -> bool:
    try:
        inspect.getattr_static(law, name)
    except AttributeError:
        return False
    return True


def _members(protocol: type) -> list[str]:
    names: list[str] = []
    for cls in reversed(protocol.__mro__):
        if cls is object or cls is Protocol or not getattr(cls, "_is_protocol", False):
            continue
        for name in (*getattr(cls, "__annotations__", {}), *vars(cls)):
            if not name.startswith("_") and name not in names:
                names.append(name)
    return names
