r"""J2 plasticity with linear isotropic and kinematic hardening on Hencky strains: Mast (2013) §3.5.

With the trial logarithmic strain :math:`\varepsilon^{tr} = \tfrac12\ln b^{tr}`,
:math:`b^{tr} = \Delta F\, b^e_n\, \Delta F^T`, the step is the small-strain radial
return in logarithmic strains (Eqs. 3.69–3.83), on the relative stress
:math:`\eta = s - \beta` (β the back stress, Mast's :math:`-\kappa^{kin}`):

.. math::

    \eta^{tr} = 2G\,\operatorname{dev}\varepsilon^{tr} - \beta_n, \qquad
    f^{tr} = \lVert\eta^{tr}\rVert - \sqrt{2/3}\,(\sigma_Y + k\,\alpha_n), \qquad
    \Delta\gamma = \frac{f^{tr}}{2G + \tfrac23 H + \tfrac23 k},

:math:`N = \eta^{tr}/\lVert\eta^{tr}\rVert`,
:math:`\varepsilon^e = \varepsilon^{tr} - \Delta\gamma N`,
:math:`\beta_{n+1} = \beta_n + \tfrac23 H\Delta\gamma N`,
:math:`\alpha_{n+1} = \alpha_n + \sqrt{2/3}\,\Delta\gamma`,
:math:`\tau = K\operatorname{tr}\varepsilon^{tr}\,\mathbf 1 + 2G\operatorname{dev}\varepsilon^e` and
:math:`b^e_{n+1} = \exp(2\varepsilon^e)`. The back stress is a tensor, so
:math:`\varepsilon^e` need not share :math:`b^{tr}`'s axes: the return works on
tensors, not principal values. The tangent is the small-strain consistent one,

.. math::

    \mathbb C^{ep} = K\,\mathbf 1\otimes\mathbf 1
      + 2G\Bigl(1 - \frac{2G\Delta\gamma}{\lVert\eta^{tr}\rVert}\Bigr)\mathbb I_{dev}
      + 2G\Bigl(\frac{2G\Delta\gamma}{\lVert\eta^{tr}\rVert}
        - \frac{2G}{2G + \tfrac23 (H + k)}\Bigr) N\otimes N,

composed with the exact :math:`\partial\varepsilon^{tr}/\partial\Delta F` of the
logarithm (the spectral derivative of :mod:`~fe_mpm.materials.spectral`). The law is
pressure-independent and isochoric, so it runs in the u and the u-p forms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fe_mpm.materials import route
from fe_mpm.materials.elastic import IsotropicModuli
from fe_mpm.materials.linearised import LinearisedStress, ReturnMapResult
from fe_mpm.materials.principal_return import YIELD_TOLERANCE
from fe_mpm.materials.spectral import (
    derivative_wrt_dF,
    deviator,
    embedded_3d,
    from_principal,
    norm,
    spectral_decomposition,
)
from fe_mpm.materials.state import HistoryField

_SQRT_2_3 = math.sqrt(2.0 / 3.0)


@dataclass(frozen=True)
class HenckyJ2(LinearisedStress, IsotropicModuli):
    """Hencky-elastic von Mises solid with linear isotropic and kinematic hardening.

    Mast (2013) §3.5, the model of his Taylor bar. Compared with
    :class:`~fe_mpm.materials.J2Plasticity` (Simo's b̄ᵉ form, isotropic hardening
    only): the elasticity is Hencky's (linear in logarithmic strains), and the yield
    surface can move (the back stress β), which gives the Bauschinger effect under
    reversed loading.

    Args:
        E: Young's modulus (Pa), > 0.
        nu: Poisson's ratio, in (-1, 0.5).
        yield_stress: σ_Y (Pa), > 0, the uniaxial yield stress.
        hardening: k (Pa), ≥ 0: the radius √(2/3)(σ_Y + k α) grows with α.
        kinematic_hardening: H (Pa), ≥ 0: β grows by ⅔ H Δγ N.
        density: Reference mass density ρ₀ (kg/m³), > 0, or None to take it from the
            points.
    """

    E: float
    nu: float
    yield_stress: float
    hardening: float = 0.0
    kinematic_hardening: float = 0.0
    density: float | None = None

    def __post_init__(self) -> None:
        self._check_moduli()
        self._check("yield_stress", lo=0.0, lo_open=True)
        self._check("hardening", lo=0.0)
        self._check("kinematic_hardening", lo=0.0)

    @property
    def history(self) -> dict[str, HistoryField]:
        """bᵉ, the back stress and the equivalent plastic strain."""
        return {
            "be": HistoryField((3, 3), np.eye(3), "elastic left Cauchy-Green bᵉ", "left"),
            "back_stress": HistoryField((3, 3), np.zeros((3, 3)), "back stress β (Pa)"),
            "plastic_strain": HistoryField(
                (), 0.0, "equivalent plastic strain α = Σ √(2/3)‖Δεᵖ‖ (Hencky)"
            ),
        }

    def return_map(self, dF: np.ndarray, history: dict[str, np.ndarray]) -> ReturnMapResult:
        """Stress, tangent and history at t_{n+1} for step increments ΔF.

        Args:
            dF: Deformation gradient increments (n, g, g).
            history: ``be`` (n, 3, 3), ``back_stress`` (n, 3, 3) and ``plastic_strain``
                (n,) at t_n.
        """
        n, g = dF.shape[0], dF.shape[1]
        K, G = self.bulk_modulus, self.mu
        k, H = self.hardening, self.kinematic_hardening
        F3 = embedded_3d(dF)
        b_n = history["be"]
        b = F3 @ b_n @ np.swapaxes(F3, 1, 2)
        x, Q = spectral_decomposition(b)
        with np.errstate(invalid="ignore", divide="ignore"):  # an inverted iterate: NaN
            strain = from_principal(0.5 * np.log(x), Q)
        volume = np.trace(strain, axis1=1, axis2=2)
        eta = 2.0 * G * deviator(strain) - history["back_stress"]
        size = norm(eta)
        radius = _SQRT_2_3 * (self.yield_stress + k * history["plastic_strain"])
        f = size - radius
        plastic = f > YIELD_TOLERANCE * (size + radius)
        dgamma = np.where(plastic, f / (2.0 * G + 2.0 / 3.0 * (H + k)), 0.0)
        N = np.zeros_like(eta)
        N[plastic] = eta[plastic] / size[plastic, None, None]
        strain_e = strain - dgamma[:, None, None] * N
        tau = K * volume[:, None, None] * np.eye(3) + 2.0 * G * deviator(strain_e)
        be = b.copy()
        if np.any(plastic):
            values, vectors = spectral_decomposition(strain_e[plastic])
            be[plastic] = from_principal(np.exp(2.0 * values), vectors)

        def tangent() -> np.ndarray:
            # ∂ε^tr/∂ΔF of ε = ½ ln b^tr, then C^ep.
            with np.errstate(invalid="ignore", divide="ignore"):
                y = 0.5 * np.log(x)
                dy_dx = np.zeros((n, 3, 3))
                dy_dx[:, [0, 1, 2], [0, 1, 2]] = 0.5 / x
            kernels = route.compiled()
            if kernels is not None:
                dstrain = kernels.spectral_derivative(x, Q, y, dy_dx, F3, b_n, g)
            else:
                dstrain = derivative_wrt_dF(x, Q, y, dy_dx, F3, b_n, g)
            with np.errstate(invalid="ignore", divide="ignore"):
                ratio = np.where(plastic, 2.0 * G * dgamma / size, 0.0)
            c_dev = 2.0 * G * (1.0 - ratio)
            c_N = np.where(
                plastic, 2.0 * G * (ratio - 2.0 * G / (2.0 * G + 2.0 / 3.0 * (H + k))), 0
            )
            # dτ = K tr(dε) 1 + c_dev dev dε + c_N (N : dε) N
            trace = np.einsum("niikl->nkl", dstrain)
            dev = dstrain - trace[:, None, None] / 3.0 * np.eye(3)[None, :, :, None, None]
            N_dot = np.einsum("nij,nijkl->nkl", N, dstrain)
            return (
                K * np.eye(3)[None, :, :, None, None] * trace[:, None, None]
                + c_dev[:, None, None, None, None] * dev
                + c_N[:, None, None, None, None] * N[:, :, :, None, None] * N_dot[:, None, None]
            )

        return ReturnMapResult(
            tau=tau,
            derivative=tangent,
            region=plastic.astype(np.int8),
            history={
                "be": be,
                "back_stress": history["back_stress"] + 2.0 / 3.0 * H * dgamma[:, None, None] * N,
                "plastic_strain": history["plastic_strain"] + _SQRT_2_3 * dgamma,
            },
        )

    def yield_function(self, tau: np.ndarray, history: dict[str, np.ndarray]) -> np.ndarray:
        """The yield function ‖dev τ − β‖ − √(2/3)(σ_Y + k α) (Pa) of stresses (n, 3, 3)."""
        eta = deviator(tau) - history["back_stress"]
        return norm(eta) - _SQRT_2_3 * (
            self.yield_stress + self.hardening * history["plastic_strain"]
        )
