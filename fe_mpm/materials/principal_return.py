r"""Mohr-Coulomb return map in principal stress space (Clausen, Damkilde & Andersen 2006).

Iaconeta (2019) §3.3, Eqs. 3.104–3.144. Everything here acts on principal values
ordered :math:`\tau_1 \ge \tau_2 \ge \tau_3`, tension positive, with the isotropic
Hencky elasticity :math:`\tau = a\,\varepsilon`,
:math:`a = K\,\mathbf 1\mathbf 1^T + 2G(I - \tfrac13 \mathbf 1\mathbf 1^T)`. In that
sextant only the primary yield plane and plastic potential are active:

.. math::

    f = k\tau_1 - \tau_3 - 2c\sqrt k, \quad g = m\tau_1 - \tau_3, \quad
    k = \frac{1+\sin\varphi}{1-\sin\varphi}, \quad m = \frac{1+\sin\psi}{1-\sin\psi}.

The return goes to the plane, to one of the two edge lines (``l1``: τ₁ = τ₂,
triaxial compression; ``l2``: τ₂ = τ₃, triaxial extension) or to the apex
:math:`\tau = c\cot\varphi\,\mathbf 1`. The region is found the way Clausen
et al. do it geometrically: the plane return is kept if it preserves the order
of the principal stresses; otherwise the line whose order it broke is used, and
the apex if that line's return lands beyond the apex. On a line the plastic
strain lies in the span of the two active potential gradients, so the return is
:math:`\tau = P + t\,r`, with :math:`t = r_g^T a^{-1}(\tau^{tr} - P)/(r_g^T a^{-1} r)`
and :math:`r_g` the direction of the potential's edge line (Eq. 3.133).

The lines are anchored at a point on the yield surface with zero mean stress,
not at the apex, so the same formulas hold for Tresca (φ = 0), whose apex is at
infinity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Region codes returned by :func:`mohr_coulomb_return`.
ELASTIC, PLANE, LINE_1, LINE_2, APEX = 0, 1, 2, 3, 4

#: A trial stress is plastic when f > YIELD_TOLERANCE · (abs(k τ₁) + abs(τ₃) + 2c√k). A point
#: that ended the last step on the surface starts the next with f = 0 up to
#: round-off; without a tolerance its elastic or plastic tangent would hang on the
#: last bit of a logarithm (and differ between the numpy and compiled routes).
YIELD_TOLERANCE = 1e-12


@dataclass(frozen=True)
class PrincipalReturn:
    """Result of the principal-space return for ``n`` points.

    Attributes:
        stress: Returned principal Kirchhoff stresses (n, 3), Pa, still ordered.
        tangent: Algorithmic tangent ∂τ_A/∂ε^tr_B (n, 3, 3), Pa.
        region: Return region per point (n,), one of the module's region codes.
    """

    stress: np.ndarray
    tangent: np.ndarray
    region: np.ndarray


@dataclass(frozen=True)
class MohrCoulombSurface:
    """Elastic constants and yield surface of the principal-space return.

    Args:
        bulk_modulus: K (Pa).
        shear_modulus: G (Pa).
        cohesion: c (Pa).
        sin_phi: sin of the friction angle.
        sin_psi: sin of the dilatancy angle.
    """

    bulk_modulus: float
    shear_modulus: float
    cohesion: float
    sin_phi: float
    sin_psi: float

    @property
    def elastic(self) -> np.ndarray:
        """Principal Hencky elasticity a (3, 3), Pa."""
        K, G = self.bulk_modulus, self.shear_modulus
        one = np.ones((3, 3))
        return K * one + 2.0 * G * (np.eye(3) - one / 3.0)

    @property
    def compliance(self) -> np.ndarray:
        """a⁻¹ (3, 3), 1/Pa."""
        K, G = self.bulk_modulus, self.shear_modulus
        one = np.ones((3, 3))
        return one / (9.0 * K) + (np.eye(3) - one / 3.0) / (2.0 * G)

    @property
    def k(self) -> float:
        """Friction factor k = (1 + sin φ)/(1 − sin φ) of the yield plane (Eq. 3.109)."""
        return (1.0 + self.sin_phi) / (1.0 - self.sin_phi)

    @property
    def m(self) -> float:
        """Dilatancy factor m = (1 + sin ψ)/(1 − sin ψ) of the potential (Eq. 3.110)."""
        return (1.0 + self.sin_psi) / (1.0 - self.sin_psi)

    def yield_function(self, stress: np.ndarray) -> np.ndarray:
        """F = (τ₁ − τ₃) + (τ₁ + τ₃) sin φ − 2c cos φ (Pa, Eq. 3.105) of ordered stresses (n, 3)."""
        s1, s3 = stress[:, 0], stress[:, 2]
        cos_phi = np.sqrt(1.0 - self.sin_phi**2)
        return (s1 - s3) + (s1 + s3) * self.sin_phi - 2.0 * self.cohesion * cos_phi

    def apex(self) -> float | None:
        """Apex stress c cot φ (Pa, on every axis), or None for Tresca (no apex)."""
        if self.sin_phi == 0.0:
            return None
        k = self.k
        return 2.0 * self.cohesion * np.sqrt(k) / (k - 1.0)

    def line_points(self) -> tuple[np.ndarray, np.ndarray]:
        """A point with zero mean stress on each edge line, l1 (x, x, −2x) and l2 (2y, −y, −y)."""
        k, c = self.k, self.cohesion
        x1 = 2.0 * c * np.sqrt(k) / (k + 2.0)
        x2 = 2.0 * c * np.sqrt(k) / (k + 0.5)
        return np.array([x1, x1, -2.0 * x1]), np.array([x2, -0.5 * x2, -0.5 * x2])


def _line_return(surface, trial, point, direction, potential_direction):
    """Return to the line ``point + t·direction`` (Eq. 3.133) and its tangent (Eq. 3.139)."""
    C = surface.compliance
    Cg = C @ potential_direction
    denom = direction @ Cg
    t = ((trial - point) @ Cg) / denom
    stress = point + t[:, None] * direction
    tangent = np.outer(direction, potential_direction) / denom
    return stress, tangent


def mohr_coulomb_return(surface: MohrCoulombSurface, strain: np.ndarray) -> PrincipalReturn:
    """Return trial principal elastic strains to the Mohr-Coulomb surface.

    Args:
        surface: Elastic constants and yield surface.
        strain: Trial principal Hencky strains ε^tr (n, 3), ordered ε₁ ≥ ε₂ ≥ ε₃.

    Returns:
        The returned stresses, the algorithmic tangent ∂τ/∂ε^tr and the regions.
    """
    a = surface.elastic
    n = strain.shape[0]
    trial = strain @ a
    stress = trial.copy()
    tangent = np.broadcast_to(a, (n, 3, 3)).copy()
    region = np.full(n, ELASTIC, dtype=np.int8)

    k, m, c = surface.k, surface.m, surface.cohesion
    f_trial = k * trial[:, 0] - trial[:, 2] - 2.0 * c * np.sqrt(k)
    scale = np.abs(k * trial[:, 0]) + np.abs(trial[:, 2]) + 2.0 * c * np.sqrt(k)
    plastic = f_trial > YIELD_TOLERANCE * scale
    if not np.any(plastic):
        return PrincipalReturn(stress, tangent, region)

    df = np.array([k, 0.0, -1.0])  # ∂f/∂τ
    dg = np.array([m, 0.0, -1.0])  # ∂g/∂τ
    a_dg, df_a = a @ dg, df @ a
    denom = df @ a_dg
    plane = trial - (f_trial / denom)[:, None] * a_dg  # Eqs. 3.121–3.127
    plane_tangent = a - np.outer(a_dg, df_a) / denom  # Eq. 3.125
    breaks_12 = plane[:, 1] > plane[:, 0]
    breaks_23 = plane[:, 2] > plane[:, 1]

    p1, p2 = surface.line_points()
    line1, line1_tangent = _line_return(
        surface, trial, p1, np.array([1.0, 1.0, k]), np.array([1.0, 1.0, m])
    )
    line2, line2_tangent = _line_return(
        surface, trial, p2, np.array([1.0, k, k]), np.array([1.0, m, m])
    )
    # A line point is valid while its double value stays on the right side of the single one.
    beyond_1 = line1[:, 0] < line1[:, 2]
    beyond_2 = line2[:, 0] < line2[:, 1]
    on_apex = (breaks_12 & breaks_23) | (breaks_12 & beyond_1) | (breaks_23 & beyond_2)
    if surface.apex() is None:
        on_apex[:] = False  # Tresca: lines are parallel to the hydrostatic axis

    choose = {
        PLANE: plastic & ~breaks_12 & ~breaks_23,
        LINE_1: plastic & breaks_12 & ~on_apex,
        LINE_2: plastic & breaks_23 & ~breaks_12 & ~on_apex,
        APEX: plastic & on_apex,
    }
    for code, (values, tan) in {
        PLANE: (plane, plane_tangent),
        LINE_1: (line1, line1_tangent),
        LINE_2: (line2, line2_tangent),
    }.items():
        mask = choose[code]
        stress[mask] = values[mask]
        tangent[mask] = tan
        region[mask] = code
    mask = choose[APEX]
    if np.any(mask):
        stress[mask] = surface.apex()
        tangent[mask] = 0.0
        region[mask] = APEX
    return PrincipalReturn(stress, tangent, region)
