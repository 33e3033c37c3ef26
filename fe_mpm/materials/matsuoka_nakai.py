r"""Matsuoka–Nakai yield with evolving angles on Hencky strains: Mast (2013) §3.7.

The yield function of the shifted Kirchhoff stress :math:`\bar\tau = \tau - c_F\mathbf 1`
(Eq. 3.120, compression negative)

.. math::  F = 6\kappa_F \bar I_3 + 3\bar I_1\lVert s\rVert^2 - 2\bar I_1^3, \qquad
           \kappa_F = \frac{\sin^2\varphi_F - 9}{\sin^2\varphi_F - 1},

bounds a smooth convex cone that passes through Mohr-Coulomb's compression and
extension corners (the Rankine prism at φ_F = 90°); its apex and the tension cutoff
are at :math:`\tau = c_F\mathbf 1`. The flow is Drucker–Prager's,
:math:`n + \varrho_G\mathbf 1` with :math:`\varrho_G(\psi_G)` (Eq. 3.108): Mast's "MN
with DP G", which he recommends because the pure Matsuoka–Nakai potential
(Eq. 3.123) changes volume at any stress (Eq. 3.129) and never reaches a critical
state. The angles evolve as in :class:`~fe_mpm.materials.ModifiedDruckerPrager`
(Eqs. 3.112–3.116), taken at t_n and frozen over a step.

The return (:func:`~fe_mpm.materials.cone_return._matsuoka_nakai_return`) and its
tangent are compiled; the tangent is exact for the frozen angles.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fe_mpm.materials.drucker_prager import ModifiedDruckerPrager

#: The flow rules: Drucker–Prager's n + ϱ_G 1 (Eq. 3.108) or Matsuoka–Nakai's (Eq. 3.123).
POTENTIALS = ("drucker-prager", "matsuoka-nakai")


def kappa_of(angle: np.ndarray | float) -> np.ndarray | float:
    """κ = (sin²θ − 9)/(sin²θ − 1) of an angle θ in degrees (Eq. 3.121)."""
    s2 = np.sin(np.radians(angle)) ** 2
    return (s2 - 9.0) / (s2 - 1.0)


@dataclass(frozen=True)
class MatsuokaNakai(ModifiedDruckerPrager):
    """Matsuoka–Nakai yield, Drucker–Prager flow, evolving angles (Mast 2013, §3.7).

    The parameters are those of :class:`~fe_mpm.materials.ModifiedDruckerPrager`
    (Mast's ``MatsuokaNakaiSolid`` takes the same vector), with which it shares the
    flow rule and the evolution of φ_F, φ_cs and ψ_G; only the yield surface differs.
    In triaxial compression (two equal principal stresses, the lesser compressive)
    the two surfaces coincide, so both laws give the same response there.

    Args:
        E: Young's modulus (Pa), > 0.
        nu: Poisson's ratio, in (-1, 0.5).
        a0, a1, a2, a3, a4, a5: Mast's constants of the angles (Eqs. 3.113–3.114),
            as for :class:`~fe_mpm.materials.ModifiedDruckerPrager`.
        apex_stress: c_F (Pa), ≥ 0: the apex of the cone, τ = c_F 1.
        density: Reference mass density ρ₀ (kg/m³), > 0, or None to take it from the
            points.
        potential: ``"drucker-prager"`` (Mast's recommendation) or
            ``"matsuoka-nakai"``: Eq. 3.123 with κ_G(ψ_G), for comparison. Mast
            attaches that potential to the current point by its own shift c_G, which
            has no solution at ψ_G = 0 (the critical state, κ_G = 9); here it keeps
            the yield surface's apex, c_G = c_F, and its flow is the gradient of its
            level set through the point. κ_G depends on sin²ψ_G, so this flow
            dilates where ψ_G < 0 asks for contraction.
    """

    potential: str = "drucker-prager"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.potential not in POTENTIALS:
            raise ValueError(
                f"MatsuokaNakai: potential must be one of {', '.join(map(repr, POTENTIALS))}, "
                f"got {self.potential!r}"
            )

    def _matsuoka_nakai_kappa(self, history):
        phi_F, _ = self.state_angles(history)
        return kappa_of(phi_F)

    def _potential_kappa(self, history):
        if self.potential == "drucker-prager":
            return None
        _, psi = self.state_angles(history)
        return kappa_of(psi)

    def yield_functions(
        self, tau: np.ndarray, history: dict[str, np.ndarray]
    ) -> tuple[np.ndarray, np.ndarray]:
        """F (Pa³, Eq. 3.120) and the cutoff I₁ − 3c_F (Pa) of stresses (n, 3, 3).

        The angles are those of ``history``.
        """
        shifted = np.linalg.eigvalsh(tau) - self.apex_stress
        I1 = shifted.sum(axis=1)
        kappa = self._matsuoka_nakai_kappa(history)
        value = (
            6.0 * kappa * shifted.prod(axis=1) + 3.0 * I1 * (shifted**2).sum(axis=1) - 3.0 * I1**3
        )
        return value, I1
