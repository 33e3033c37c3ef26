r"""Finite-strain Mohr-Coulomb and Tresca plasticity on Hencky strains: Iaconeta (2019) §3.3.

Elasticity is linear in the principal logarithmic elastic strains,
:math:`\tau_A = a_{AB}\,\varepsilon^e_B` (Eqs. 3.99–3.103), and the exponential-map
integration of the flow rule (App. A) makes the step a small-strain return in
principal space (Algorithm 4):

1. :math:`b^{tr} = \Delta F\, b^e_n\, \Delta F^T`, eigen-decomposed;
   :math:`\varepsilon^{tr}_A = \tfrac12 \ln x_A`;
2. the principal return of :mod:`~fe_mpm.materials.principal_return` (plane,
   line or apex, non-associative with dilatancy ψ, perfectly plastic);
3. :math:`\tau = \sum_A \tau_A n_A\otimes n_A`,
   :math:`b^e_{n+1} = \sum_A \exp(2\varepsilon^e_A)\, n_A\otimes n_A`.

The tangent :math:`\partial\tau/\partial\Delta F` is exact
(:mod:`~fe_mpm.materials.spectral`), including repeated eigenvalues. The return
runs at the points, compiled (:mod:`~fe_mpm.materials.compiled`; the numpy route of
:mod:`~fe_mpm.materials.route` gives the same numbers), and the forms see its linearisation
(:mod:`~fe_mpm.materials.linearised`). Tension is positive; the cohesion and
friction angle are the usual soil parameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fe_mpm.materials import route
from fe_mpm.materials.elastic import IsotropicModuli
from fe_mpm.materials.linearised import LinearisedStress, ReturnMapResult
from fe_mpm.materials.principal_return import ELASTIC, MohrCoulombSurface, mohr_coulomb_return
from fe_mpm.materials.spectral import (
    derivative_wrt_dF,
    embedded_3d,
    from_principal,
    spectral_decomposition,
)
from fe_mpm.materials.state import HistoryField

_SQRT_2_3 = math.sqrt(2.0 / 3.0)


@dataclass(frozen=True)
class MohrCoulomb(LinearisedStress, IsotropicModuli):
    """Hencky-elastic, perfectly plastic Mohr-Coulomb solid.

    Args:
        E: Young's modulus (Pa), > 0.
        nu: Poisson's ratio, in (-1, 0.5).
        cohesion: c (Pa), ≥ 0; > 0 when the friction angle is 0.
        friction_angle: φ in degrees, in [0, 90). 0 gives Tresca with c = c_u.
        dilatancy_angle: ψ in degrees, in [0, φ]; ψ = φ is associative.
        density: Reference mass density ρ₀ (kg/m³), > 0, or None to take it from the
            points (``seed(..., density=...)``). Given in both places, they must agree.
    """

    E: float
    nu: float
    cohesion: float
    friction_angle: float = 0.0
    dilatancy_angle: float = 0.0
    density: float | None = None

    def __post_init__(self) -> None:
        self._check_moduli()
        self._check("cohesion", lo=0.0)
        self._check_angle("friction_angle", lo=0.0, hi=90.0, hi_open=True)
        self._check("dilatancy_angle", lo=0.0, hi=self.friction_angle)
        if self.friction_angle == 0.0 and self.cohesion == 0.0:
            raise ValueError(
                "MohrCoulomb: cohesion must be > 0 when friction_angle = 0 "
                "(the material would have no strength), got 0"
            )

    @classmethod
    def tresca(
        cls, E: float, nu: float, cohesion: float, density: float | None = None
    ) -> MohrCoulomb:
        """Tresca solid (φ = ψ = 0) with undrained shear strength ``cohesion`` = c_u (Pa)."""
        return cls(E, nu, cohesion, 0.0, 0.0, density)

    @property
    def surface(self) -> MohrCoulombSurface:
        """The principal-space elasticity and yield surface."""
        return MohrCoulombSurface(
            self.bulk_modulus,
            self.mu,
            self.cohesion,
            math.sin(math.radians(self.friction_angle)),
            math.sin(math.radians(self.dilatancy_angle)),
        )

    @property
    def history(self) -> dict[str, HistoryField]:
        """Elastic left Cauchy–Green tensor and equivalent plastic strain."""
        return {
            "be": HistoryField((3, 3), np.eye(3), "elastic left Cauchy-Green bᵉ", "left"),
            "plastic_strain": HistoryField(
                (), 0.0, "equivalent plastic strain Σ √(2/3)‖Δεᵖ‖ (Hencky)"
            ),
        }

    @property
    def pressure_dependent(self) -> bool:
        """Whether u-p returns at the field's pressure: φ > 0 (Tresca keeps the forms' own)."""
        return self.friction_angle > 0.0

    def largest_mean_stress(self, history: dict[str, np.ndarray]) -> float:
        """The apex's mean stress c cot φ (Pa), inf for Tresca: the most tension a point holds."""
        apex = self.surface.apex()
        return math.inf if apex is None else float(apex)

    def return_map(self, dF: np.ndarray, history: dict[str, np.ndarray]) -> ReturnMapResult:
        """Stress, tangent and history at t_{n+1} for step increments ΔF.

        Args:
            dF: Deformation gradient increments (n, g, g).
            history: ``be`` (n, 3, 3) and ``plastic_strain`` (n,) at t_n.
        """
        g = dF.shape[1]
        kernels = route.compiled()
        if kernels is not None:
            return self._compiled_return_map(kernels, dF, history)
        F3 = embedded_3d(dF)
        b_n = history["be"]
        b = F3 @ b_n @ np.swapaxes(F3, 1, 2)
        x, Q = spectral_decomposition(b)
        # b = ΔF bₙ ΔFᵀ stays positive definite for an inverted trial (det ΔF < 0),
        # so its stress is finite (a helper's Newton iterates had det ΔF = −0.54):
        # a step that ends inverted is refused at the update (checked_update). Only
        # det ΔF = 0 gives nan, which Newton reports (DIVERGED_FUNCTION_NANORINF).
        with np.errstate(invalid="ignore", divide="ignore"):
            strain = 0.5 * np.log(x)
            surface = self.surface
            ret = mohr_coulomb_return(surface, strain)
            tau = from_principal(ret.stress, Q)
            strain_e = ret.stress @ surface.compliance

        def tangent() -> np.ndarray:
            dy_dx = ret.tangent / (2.0 * x[:, None, :])  # ∂ε_B/∂x_B = 1/(2 x_B)
            return derivative_wrt_dF(x, Q, ret.stress, dy_dx, F3, b_n, g)

        elastic = ret.region == ELASTIC
        be = from_principal(np.exp(2.0 * strain_e), Q)
        be[elastic] = b[elastic]
        increment = _SQRT_2_3 * np.linalg.norm(strain - strain_e, axis=1)
        increment[elastic] = 0.0
        return ReturnMapResult(
            tau=tau,
            derivative=tangent,
            region=ret.region,
            history={"be": be, "plastic_strain": history["plastic_strain"] + increment},
            principal_tangent=ret.tangent,
        )

    def _compiled_return_map(self, kernels, dF: np.ndarray, history: dict) -> ReturnMapResult:
        """:meth:`return_map` through :mod:`~fe_mpm.materials.compiled` (the same numbers)."""
        b_n = history["be"]
        out = kernels.mohr_coulomb_points(self.surface, dF, b_n)
        return ReturnMapResult(
            tau=out["tau"],
            derivative=kernels.tangent_of(out, b_n, dF.shape[1]),
            region=out["region"],
            history={
                "be": out["be"],
                "plastic_strain": history["plastic_strain"] + out["increment"],
            },
            principal_tangent=out["dy_deps"],
        )

    def yield_function(self, tau: np.ndarray) -> np.ndarray:
        """F = (τ₁ − τ₃) + (τ₁ + τ₃) sin φ − 2c cos φ (Pa) of Kirchhoff stresses (n, 3, 3)."""
        principal = np.linalg.eigvalsh(tau)[:, ::-1]
        return self.surface.yield_function(principal)
