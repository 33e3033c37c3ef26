"""Hyperelastic laws: the Neo-Hookean solid, and helpers for plane strain."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import ufl

from fe_mpm.checks import check_range
from fe_mpm.errors import warn
from fe_mpm.materials.state import HistoryField, PointState

#: A friction angle (degrees; Mast's a0) in (0, this] is most likely radians given for degrees:
#: π/2 rad is 90°. A new user's φ = 0.5236 ran as a cohesionless soil at half a degree,
#: without a word (2026-12-07).
RADIAN_LIKE_ANGLE = math.pi / 2


class CheckedFields:
    """A frozen dataclass law whose numeric fields are checked and stored as floats."""

    def _check(self, field: str, **bounds: float | bool) -> None:
        """Check ``field`` with :func:`~fe_mpm.checks.check_range` and store the float back.

        A law then never keeps a string, a bool or a numpy scalar.
        """
        value = check_range(type(self).__name__, field, getattr(self, field), **bounds)
        object.__setattr__(self, field, value)  # the laws are frozen dataclasses

    def _check_angle(self, field: str, **bounds: float | bool) -> None:
        """Check an angle in degrees as :meth:`_check` does, and warn if it looks like radians."""
        self._check(field, **bounds)
        value = getattr(self, field)
        if 0.0 < value <= RADIAN_LIKE_ANGLE:
            warn(
                f"{type(self).__name__}: {field} is in degrees, and {value:g}° is under "
                f"{RADIAN_LIKE_ANGLE:.4g}°; if {value:g} is radians, give "
                f"{math.degrees(value):.4g}"
            )

    def _check_density(self) -> None:
        """The density is None (the points give it) or > 0."""
        if self.density is not None:
            self._check("density", lo=0.0, lo_open=True)


def is_builtin(law) -> bool:
    """Whether ``law``'s class is one of fe-mpm's own laws, not one a user wrote.

    fe-mpm's own are tested and described (their histories, their flow); a user's
    law, or a subclass of one of fe-mpm's, is taken as it is.
    """
    return type(law).__module__.startswith("fe_mpm.")


def young_modulus(law) -> float:
    """Young's modulus E = 9Kμ / (3K + μ) (Pa) of a law with ``mu`` and ``bulk_modulus``.

    For several laws in one body (:mod:`fe_mpm.materials.zones`), the stiffest's.
    """
    laws = getattr(law, "laws", None)
    if laws is not None:
        return max(young_modulus(one) for one in laws)
    K, mu = float(law.bulk_modulus), float(law.mu)
    return 9.0 * K * mu / (3.0 * K + mu)


def p_wave_modulus(law) -> float:
    """The P-wave modulus K + 4μ/3 (Pa) of a solid, K of a law that keeps no shape.

    For several laws in one body (:mod:`fe_mpm.materials.zones`), the stiffest's.
    """
    laws = getattr(law, "laws", None)
    if laws is not None:
        return max(p_wave_modulus(one) for one in laws)
    if not getattr(law, "keeps_shape", True):  # a fluid: no shear stiffness at rest
        return float(law.bulk_modulus)
    return float(law.bulk_modulus) + 4.0 * float(law.mu) / 3.0


class IsotropicModuli(CheckedFields):
    """Shear and bulk moduli of a law with fields ``E`` (Pa) and ``nu``."""

    def _check_moduli(self) -> None:
        """Raise naming the law unless E > 0, ν ∈ (−1, 0.5) and the density is None or > 0.

        Every law has these three fields; they are stored back as floats.
        """
        self._check("E", lo=0.0, lo_open=True)
        self._check("nu", lo=-1.0, hi=0.5, lo_open=True, hi_open=True)
        self._check_density()

    @property
    def mu(self) -> float:
        """Shear modulus μ (Pa)."""
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def bulk_modulus(self) -> float:
        """Bulk modulus K (Pa) of the 3D law."""
        return self.E / (3.0 * (1.0 - 2.0 * self.nu))


@dataclass(frozen=True)
class NeoHookean(IsotropicModuli):
    """Compressible Neo-Hookean solid (Iaconeta 2019, Eqs. 3.17 and 3.25).

    Energy ``Ψ = λ/2 (ln J)² − μ ln J + μ/2 (tr C − 3)`` and Kirchhoff stress
    ``τ = λ ln J I + μ (b − I)``. In plane strain ``tr C`` counts ``C_33 = 1``,
    so the in-plane part of ``τ`` keeps the same form with the 2x2 identity.

    Args:
        E: Young's modulus (Pa), > 0.
        nu: Poisson's ratio, in (-1, 0.5).
        density: Reference mass density ρ₀ (kg/m³), > 0, or None to take it from the
            points (``seed(..., density=...)``). Given in both places, they must agree.
    """

    E: float
    nu: float
    density: float | None = None

    def __post_init__(self) -> None:
        self._check_moduli()

    @property
    def history(self) -> dict[str, HistoryField]:
        """A hyperelastic law has no internal variables."""
        return {}

    @property
    def lmbda(self) -> float:
        """First Lamé parameter λ (Pa)."""
        return self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))

    def stored_energy(self, F: np.ndarray) -> np.ndarray:
        """The energy Ψ per unit reference volume (J/m³, i.e. Pa) of deformations ``F``.

        Args:
            F: Deformation gradients (n, g, g); in plane strain (g = 2) ``C_33 = 1``.

        Returns:
            Ψ (n,). A body's elastic energy is ``(V / J) @ Ψ`` with the points'
            current volumes V (reference volume V / J).
        """
        F = np.asarray(F, dtype=float)
        J = np.linalg.det(F)
        tr_C = np.einsum("pij,pij->p", F, F) + (3 - F.shape[-1])  # C_33 = 1 in plane strain
        return 0.5 * self.lmbda * np.log(J) ** 2 - self.mu * np.log(J) + 0.5 * self.mu * (tr_C - 3)

    def kirchhoff(
        self, F: ufl.core.expr.Expr, state: PointState | None = None
    ) -> ufl.core.expr.Expr:
        """Kirchhoff stress τ(F) (Pa), shape of ``F``; the state is not needed."""
        I = ufl.Identity(ufl.shape(F)[0])
        J = ufl.det(F)
        return self.lmbda * ufl.ln(J) * I + self.mu * (F * F.T - I)

    def kirchhoff_deviatoric(
        self, F: ufl.core.expr.Expr, state: PointState | None = None
    ) -> ufl.core.expr.Expr:
        """Isochoric Kirchhoff stress ``μ dev(b̄)`` (Pa) of the split law (thesis Eq. 3.44).

        ``b̄ = J^{-2/3} F Fᵀ`` and ``dev`` are taken in 3D (``F_33 = 1`` in plane
        strain); the result has the shape of ``F`` (the in-plane block in 2D).
        The volumetric part is the mixed form's pressure field.
        """
        g = ufl.shape(F)[0]
        F3 = embed_3d(F)
        b_bar = ufl.det(F3) ** (-2.0 / 3.0) * F3 * F3.T
        return in_plane(self.mu * ufl.dev(b_bar), g)

    def updated_history(self, F: ufl.core.expr.Expr, state: PointState) -> dict:
        """No internal variables."""
        return {}


def in_plane(A: ufl.core.expr.Expr, g: int) -> ufl.core.expr.Expr:
    """The leading ``g x g`` block of a 3x3 tensor (the in-plane part in plane strain)."""
    if g == 3:
        return A
    return ufl.as_matrix([[A[i, j] for j in range(g)] for i in range(g)])


def embed_3d(F: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """The 3x3 deformation gradient of a 2D plane-strain F (F_33 = 1); 3D F unchanged."""
    if ufl.shape(F)[0] == 3:
        return F
    return ufl.as_matrix([[F[0, 0], F[0, 1], 0], [F[1, 0], F[1, 1], 0], [0, 0, 1]])
