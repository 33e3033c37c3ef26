r"""Finite-strain Drucker–Prager plasticity on Hencky strains: Mast (2013) §3.6.

Three laws share the returns of :mod:`~fe_mpm.materials.cone_return` (the steps and
their algorithms in that module's docstring), integrated like
:class:`~fe_mpm.materials.MohrCoulomb`: :math:`b^{tr} = \Delta F\, b^e_n\, \Delta F^T`,
principal Hencky strains, the return, :math:`b^e_{n+1} = \exp(2\varepsilon^e)`, and the
exact tangent :math:`\partial\tau/\partial\Delta F` for Newton.

- :class:`DruckerPrager`, the traditional two-surface model (§3.6.1): the cone
  matched to Mohr-Coulomb's compression meridian (Eq. 3.107),
  :math:`\varrho_F = \sqrt{2/3}\,2\sin\varphi/(3-\sin\varphi)` and
  :math:`\kappa = \sqrt{2/3}\,6c\cos\varphi/(3-\sin\varphi)`, the tension cutoff at its
  apex :math:`I_1 = 3c\cot\varphi`, and linear isotropic hardening of the cone.
- :class:`SmoothCapDruckerPrager`, the cone ending in a circular tension cap
  (§3.6.2).
- :class:`ModifiedDruckerPrager`, the cone with evolving friction and dilatancy
  angles (§3.6.3–3.6.4, Eqs. 3.112–3.116), semi-implicit (§3.3.3): the angles are
  taken at the state of t_n and frozen over the step, so the step is the
  traditional return with those angles, and its tangent is exact for it.

Kirchhoff stresses, tension positive (compression negative, as in Mast);
:math:`I_1 = \operatorname{tr}\tau`, :math:`s = \operatorname{dev}\tau`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Self

import numpy as np

from fe_mpm.checks import check_range
from fe_mpm.materials.elastic import IsotropicModuli
from fe_mpm.materials.linearised import LinearisedStress, ReturnMapResult
from fe_mpm.materials.principal_return import YIELD_TOLERANCE
from fe_mpm.materials.spectral import deviator, norm
from fe_mpm.materials.state import HistoryField

_SQRT_2_3 = math.sqrt(2.0 / 3.0)


#: Where the cone meets Mohr-Coulomb: its compression corners (outer cone, Mast
#: Eq. 3.107), its extension corners (inner cone, 3 + sin φ), or the plane-strain
#: limit of associated flow (√J₂ + α I₁ = k, α = tan φ/√(9 + 12 tan²φ), k = 3c/√(…)).
MATCHES = ("compression", "extension", "plane strain")


def cone_slope(angle: np.ndarray | float, match: str = "compression") -> np.ndarray | float:
    """ϱ of F = ‖s‖ + ϱ I₁ − κ for an angle θ in degrees (Eqs. 3.107, 3.109).

    ``compression``: ϱ = √(2/3) 2 sin θ/(3 − sin θ); ``extension``: 3 + sin θ;
    ``plane strain``: ϱ = √2 tan θ/√(9 + 12 tan²θ).
    """
    if match == "plane strain":
        t = np.tan(np.radians(angle))
        return math.sqrt(2.0) * t / np.sqrt(9.0 + 12.0 * t**2)
    s = np.sin(np.radians(angle))
    return _SQRT_2_3 * 2.0 * s / (3.0 - s if match == "compression" else 3.0 + s)


def cone_radius(cohesion: float, friction_angle: float, match: str = "compression") -> float:
    """κ (Pa), the cone's ‖s‖ at I₁ = 0 for a cohesion c (Pa) and φ (degrees).

    ``compression``: κ = √(2/3) 6c cos φ/(3 − sin φ); ``extension``: 3 + sin φ;
    ``plane strain``: κ = √2 · 3c/√(9 + 12 tan²φ). In each the apex is at
    I₁ = κ/ϱ = 3c cot φ.
    """
    phi = math.radians(friction_angle)
    if match == "plane strain":
        return math.sqrt(2.0) * 3.0 * cohesion / math.sqrt(9.0 + 12.0 * math.tan(phi) ** 2)
    s = math.sin(phi)
    return (
        _SQRT_2_3
        * 6.0
        * cohesion
        * math.cos(phi)
        / (3.0 - s if match == "compression" else 3.0 + s)
    )


class _ConeLaw(LinearisedStress, IsotropicModuli):
    """What the cone laws share: the compiled return, the linearised UFL stress."""

    #: Whether the cone ends in Mast's smooth cap instead of the cutoff.
    _smooth_cap = False

    def _cone_parameters(self, history: dict[str, np.ndarray]):
        """(ϱ_F, ϱ_G, κ, T) per point at t_n, κ with the hardening of α_n; k."""
        raise NotImplementedError

    @property
    def history(self) -> dict[str, HistoryField]:
        """Elastic left Cauchy–Green tensor and equivalent plastic strain."""
        return {
            "be": HistoryField((3, 3), np.eye(3), "elastic left Cauchy-Green bᵉ", "left"),
            "plastic_strain": HistoryField(
                (), 0.0, "equivalent plastic strain α = Σ √(2/3)‖dev Δεᵖ‖ (Hencky)"
            ),
        }

    def _updated(self, history: dict[str, np.ndarray], dgamma: np.ndarray) -> dict:
        """The scalar internal variables at t_{n+1} from ‖dev Δεᵖ‖ (n,)."""
        return {"plastic_strain": history["plastic_strain"] + _SQRT_2_3 * dgamma}

    @property
    def pressure_dependent(self) -> bool:
        """Yes: in u-p the return runs at the field's pressure."""
        return True

    def _matsuoka_nakai_kappa(self, history: dict[str, np.ndarray]) -> np.ndarray | None:
        """Matsuoka–Nakai's κ_F per point, or None for the Drucker–Prager cone."""
        return None

    def _potential_kappa(self, history: dict[str, np.ndarray]) -> np.ndarray | None:
        """The Matsuoka–Nakai potential's κ_G per point, or None for Drucker–Prager's flow."""
        return None

    def return_map(self, dF: np.ndarray, history: dict[str, np.ndarray]) -> ReturnMapResult:
        """Stress, tangent and history at t_{n+1} for step increments ΔF.

        Args:
            dF: Deformation gradient increments (n, g, g).
            history: The law's internal variables at t_n (``be`` (n, 3, 3) and its scalars).
        """
        # Imported here: numba only when a law first runs (as for Mohr-Coulomb).
        try:
            from fe_mpm.materials import compiled
            from fe_mpm.materials.cone_return import cone_points
        except ImportError as error:
            raise ImportError(
                f"{type(self).__name__}: the return map is compiled by numba, which "
                f"could not be imported ({error}); pip install numba"
            ) from error

        b_n = history["be"]
        rho_F, rho_G, kappa, T, k = self._cone_parameters(history)
        out = cone_points(
            dF,
            b_n,
            self.bulk_modulus,
            self.mu,
            rho_F,
            rho_G,
            kappa,
            T,
            k,
            YIELD_TOLERANCE,
            self._matsuoka_nakai_kappa(history),
            self._potential_kappa(history),
            cap=self._smooth_cap,
        )
        return ReturnMapResult(
            tau=out["tau"],
            derivative=compiled.tangent_of(out, b_n, dF.shape[1]),
            region=out["region"],
            history={"be": out["be"], **self._updated(history, out["dgamma"])},
            principal_tangent=out["dy_deps"],
        )

    def yield_functions(
        self, tau: np.ndarray, history: dict[str, np.ndarray]
    ) -> tuple[np.ndarray, np.ndarray]:
        """F₁ (cone) and F₂ (cutoff), Pa, of stresses (n, 3, 3) with the parameters of ``history``.

        ``history`` is the state the parameters are taken from: t_n's for the
        returned stress of a step (the angles are frozen over it), with the
        plastic strain of t_{n+1} for the hardening.
        """
        I1, s = np.trace(tau, axis1=1, axis2=2), norm(deviator(tau))
        rho_F, _, kappa, T, _ = self._cone_parameters(history)
        return s + rho_F * I1 - kappa, I1 - T


@dataclass(frozen=True)
class DruckerPrager(_ConeLaw):
    """Hencky-elastic Drucker–Prager solid with a tension cutoff (Mast 2013, §3.6.1).

    The cone passes through Mohr-Coulomb's compression corners (Eq. 3.107; the
    default), its extension corners, or gives its plane-strain collapse stress for
    associated flow (``match``, :data:`MATCHES`); ``φ = 0`` gives von Mises, with
    ‖s‖ ≤ 2√(2/3) c (compression, extension) or √2 c (plane strain: Tresca's c_u).
    Plane-strain scenes that should fail where Mohr-Coulomb does take
    ``match="plane strain"``: the outer cone is stronger there (in plane-strain
    compression under a confining stress p, after 3 % axial strain in
    :class:`~fe_mpm.material_driver.MaterialDriver`, the deviator σ₁ − σ₃ is 3.04
    times Mohr-Coulomb's at φ = ψ = 30° and p = 10 c, 2.62 times at p = 0.1 c, and
    2/√3 = 1.155 times at φ = 0 for either; the axial stress σ₁ itself 2.43, 2.57,
    1.03 and 1.15 times; measured 2026-12-07). The cone hardens linearly with the
    equivalent plastic strain α (``hardening`` k: ‖s‖ at I₁ = 0 grows by √(2/3) k α);
    the cutoff stays at the initial apex I₁ = 3c cot φ.

    Args:
        E: Young's modulus (Pa), > 0.
        nu: Poisson's ratio, in (-1, 0.5).
        cohesion: c (Pa), ≥ 0; > 0 when the friction angle is 0.
        friction_angle: φ in degrees, in [0, 90).
        dilatancy_angle: ψ in degrees, in [0, φ]; ψ = φ is associative.
        hardening: k (Pa), ≥ 0.
        density: Reference mass density ρ₀ (kg/m³), > 0, or None to take it from the
            points.
        match: Where the cone meets Mohr-Coulomb, one of :data:`MATCHES`; the
            dilatancy cone follows the same rule with ψ.
    """

    E: float
    nu: float
    cohesion: float
    friction_angle: float = 0.0
    dilatancy_angle: float = 0.0
    hardening: float = 0.0
    density: float | None = None
    match: str = "compression"

    def __post_init__(self) -> None:
        self._check_moduli()
        self._check("cohesion", lo=0.0)
        self._check_angle("friction_angle", lo=0.0, hi=90.0, hi_open=True)
        self._check("dilatancy_angle", lo=0.0, hi=self.friction_angle)
        self._check("hardening", lo=0.0)
        if self.match not in MATCHES:
            raise ValueError(
                f"DruckerPrager: match must be one of {', '.join(map(repr, MATCHES))}, "
                f"got {self.match!r}"
            )
        if self.friction_angle == 0.0 and self.cohesion == 0.0:
            raise ValueError(
                "DruckerPrager: cohesion must be > 0 when friction_angle = 0 "
                "(the material would have no strength), got 0"
            )

    @property
    def apex(self) -> float:
        """I₁ at the cone's initial apex and the cutoff, 3c cot φ (Pa); inf for φ = 0."""
        if self.friction_angle == 0.0:
            return math.inf
        return 3.0 * self.cohesion / math.tan(math.radians(self.friction_angle))

    @property
    def pressure_dependent(self) -> bool:
        """Whether u-p returns at the field's pressure: φ > 0 (von Mises keeps the forms' own)."""
        return self.friction_angle > 0.0

    def largest_mean_stress(self, history: dict[str, np.ndarray]) -> float:
        """The cutoff's mean stress c cot φ (Pa; inf for φ = 0): the most tension held.

        Hardening widens the cone; the cutoff stays.
        """
        return self.apex / 3.0

    def _cone_parameters(self, history):
        kappa0 = cone_radius(self.cohesion, self.friction_angle, self.match)
        kappa = kappa0 + _SQRT_2_3 * self.hardening * history["plastic_strain"]
        rho_F = cone_slope(self.friction_angle, self.match)
        rho_G = cone_slope(self.dilatancy_angle, self.match)
        return rho_F, rho_G, kappa, self.apex, self.hardening


@dataclass(frozen=True)
class SmoothCapDruckerPrager(_ConeLaw):
    r"""Drucker–Prager cone with Mast's smooth tension cap (Mast 2013, §3.6.2).

    The cone F = ‖s‖ + ϱ_F I₁ − μ (ϱ_F by Eq. 3.107 from φ, μ the
    ``deviatoric_strength``) ends on the tension side
    in the largest circle about the origin of the (I₁, ‖s‖) plane that fits in it,
    radius R_t = μ/√(1 + ϱ_F²), tangent to the cone at I_t = μϱ_F/(1 + ϱ_F²): no apex,
    no corner. One surface is active at a time. The cone's flow is n + ϱ_G 1 with
    ϱ_G = ``associativity`` ϱ_F; the cap's is associated. The cap's radius follows
    from μ and φ (the largest circle that fits), so it cannot be given wrong. No
    hardening. Mast used it
    with a very small μ for sand, for the cap's smoothness near zero stress
    (after Swan & Seo; their compression cap is left out, as in Mast).

    Args:
        E: Young's modulus (Pa), > 0.
        nu: Poisson's ratio, in (-1, 0.5).
        friction_angle: φ in degrees, in (0, 90).
        deviatoric_strength: Mast's μ (Pa), > 0: the cone's ‖s‖ at I₁ = 0.
        associativity: ϱ_G/ϱ_F, in [0, 1]; 1 is associated flow.
        density: Reference mass density ρ₀ (kg/m³), > 0, or None to take it from the
            points.
    """

    _smooth_cap = True

    E: float
    nu: float
    friction_angle: float
    deviatoric_strength: float
    associativity: float = 1.0
    density: float | None = None

    def __post_init__(self) -> None:
        self._check_moduli()
        self._check_angle("friction_angle", lo=0.0, hi=90.0, lo_open=True, hi_open=True)
        self._check("deviatoric_strength", lo=0.0, lo_open=True)
        self._check("associativity", lo=0.0, hi=1.0)

    @property
    def cap(self) -> tuple[float, float, float]:
        """R_t, I_t and ‖s‖_t (Pa): the cap's radius and where it meets the cone."""
        rho = cone_slope(self.friction_angle)
        return (
            self.deviatoric_strength / math.sqrt(1.0 + rho * rho),
            self.deviatoric_strength * rho / (1.0 + rho * rho),
            self.deviatoric_strength / (1.0 + rho * rho),
        )

    def check_formulation(self, pressure: bool) -> None:
        """Refuse u-p: the cap has no return at the field's pressure at its top.

        The cap's mean stress levels off smoothly there, and the return at the
        field's pressure (:mod:`~fe_mpm.materials.mixed_return`) would divide by a
        slope that goes to zero.
        """
        if pressure:
            raise ValueError(
                "SmoothCapDruckerPrager: the u-p formulations take the mean stress from "
                "the pressure field, and the cap has no inverse at its top; use "
                "formulation='u', or DruckerPrager (cone and cutoff) in u-p."
            )

    def _cone_parameters(self, history):
        rho_F = cone_slope(self.friction_angle)
        return rho_F, self.associativity * rho_F, self.deviatoric_strength, math.inf, 0.0

    def yield_functions(
        self, tau: np.ndarray, history: dict[str, np.ndarray]
    ) -> tuple[np.ndarray, np.ndarray]:
        """The cone's F (Pa) where I₁ ≤ I_t, the cap's √(I₁² + ‖s‖²) − R_t beyond; and I₁."""
        cone, _ = super().yield_functions(tau, history)  # the cutoff is the cap here
        I1, s = np.trace(tau, axis1=1, axis2=2), norm(deviator(tau))
        R, I_t, _ = self.cap
        return np.where(I1 <= I_t, cone, np.sqrt(I1**2 + s**2) - R), I1


#: Mast (2013) Table 3.5, the constants of the evolving angles (degrees), with a₂
#: converted from 1/kPa to 1/Pa: dense, moderately dense and loose sand.
MAST_TABLE_3_5 = {
    "dense": dict(a0=20.0, a1=7750.0, a2=3.33e-7, a3=150.0, a4=20.0, a5=300.0),
    "moderately dense": dict(a0=20.0, a1=2000.0, a2=1.67e-8, a3=100.0, a4=20.0, a5=100.0),
    "loose": dict(a0=20.0, a1=0.0, a2=0.0, a3=70.0, a4=20.0, a5=50.0),
}


@dataclass(frozen=True)
class ModifiedDruckerPrager(_ConeLaw):
    r"""Drucker–Prager with evolving friction and dilatancy angles (Mast 2013, §3.6.3–3.6.4).

    The mobilised friction angle and the critical-state angle (degrees, Eqs. 3.113–3.114)

    .. math::

        \varphi_F = a_0 + (a_1\lambda - a_4)\, e^{a_2 I_1 - a_3\lambda}, \qquad
        \varphi_{cs} = a_0 - a_4 e^{-a_5\lambda}, \qquad
        \tan\psi_G = \tan\varphi_F - \tan\varphi_{cs}

    set the cone's slopes ϱ_F and ϱ_G (Eqs. 3.107, 3.109, 3.112; ψ_G < 0 contracts).
    The cone's apex stays at τ = c_F 1 (I₁ = 3c_F), where the tension cutoff is. The
    plastic measure λ grows by Δλ = ‖Δγ dev g‖ (the third option of Eq. 3.116): the
    plastic shear strain, which is what softens and hardens a sand; it does not feed
    the volume change (which ψ_G sets) back into the angles that set it, and at the
    critical state (ψ_G = 0) it equals the first option. The angles are taken at
    t_n (I₁ of τ_n, λ_n) and frozen over a step: the semi-implicit return of §3.3.3.

    With a₀ = a₄ (Table 3.5) the cone starts with no width at I₁ = 0: a stress-free
    point has no shear strength in its first step, and a scene started from rest
    under gravity has a singular tangent (Newton stops in the first step, measured).
    Mast drives that sand from a hydrostatic state (§3.8); a scene needs a₀ > a₄
    (his Table 7.2 has 25° to 35° at the start) or an initial stress.

    Args:
        E: Young's modulus (Pa), > 0.
        nu: Poisson's ratio, in (-1, 0.5).
        a0: The final value of both φ_F and φ_cs (degrees), in [a4, 90).
        a1: Peak height and rate, ≥ 0.
        a2: Pressure sensitivity of φ_F (1/Pa), ≥ 0 (Mast's Table 3.5 gives 1/kPa).
        a3: Width of φ_F's curve, ≥ 0; > 0 when a1 > 0.
        a4: a0 − a4 is the initial friction angle (degrees), in [0, a0].
        a5: Rate of φ_cs, ≥ 0.
        apex_stress: c_F (Pa), ≥ 0: the apex of the cone, τ = c_F 1.
        density: Reference mass density ρ₀ (kg/m³), > 0, or None to take it from the
            points.
    """

    E: float
    nu: float
    a0: float
    a1: float
    a2: float
    a3: float
    a4: float
    a5: float
    apex_stress: float = 0.0
    density: float | None = None

    def __post_init__(self) -> None:
        self._check_moduli()
        self._check("a4", lo=0.0, hi=90.0, hi_open=True)
        self._check_angle("a0", lo=self.a4, hi=90.0, hi_open=True)
        for name in ("a1", "a2", "a3", "a5", "apex_stress"):
            self._check(name, lo=0.0)
        if self.a1 > 0.0 and self.a3 == 0.0:
            raise ValueError(
                "ModifiedDruckerPrager: a3 must be > 0 when a1 > 0 (φ_F would grow "
                "without bound), got 0"
            )
        # a2 I1 at the apex: past ~700 exp overflows (Mast's a2 is in 1/kPa, ours 1/Pa)
        exponent = self.a2 * 3.0 * self.apex_stress
        if exponent > 700.0:
            raise ValueError(
                f"ModifiedDruckerPrager: a2 (1/Pa) times 3 apex_stress (Pa) is {exponent:.4g}, "
                "so exp(a2 I1) overflows at the apex; a2 is in 1/Pa (Mast gives it in 1/kPa: "
                "divide his by 1000)"
            )
        peak = self.a0 + self._largest_rise() * math.exp(exponent)
        if peak >= 90.0:
            raise ValueError(
                "ModifiedDruckerPrager: a0 + max over λ of (a1 λ − a4) exp(a2 I1 − a3 λ) must "
                f"stay below 90°; the constants give φ_F up to {peak:.4g}°"
            )

    @classmethod
    def constant(
        cls,
        E: float,
        nu: float,
        friction_angle: float,
        cohesion: float = 0.0,
        density: float | None = None,
        **options,
    ) -> Self:
        """The law with a fixed friction angle and no dilatancy.

        With a₁ = a₂ = a₃ = a₄ = a₅ = 0 and a₀ = φ, Mast's angles stay φ_F = φ_cs = φ,
        so ψ_G = 0 at every state: a frictional law without Mast's evolving angles,
        for a first scene. The cone's apex is where its Mohr-Coulomb envelope of
        cohesion c meets the hydrostatic axis, c_F = c cot φ.

        Args:
            E: Young's modulus (Pa), > 0.
            nu: Poisson's ratio, in (-1, 0.5).
            friction_angle: φ (degrees), in (0, 90).
            cohesion: c (Pa), ≥ 0.
            density: Reference mass density ρ₀ (kg/m³), > 0, or None.
            options: Further fields of the law (``potential`` of
                :class:`~fe_mpm.materials.MatsuokaNakai`).
        """
        name = cls.__name__
        friction_angle = check_range(f"{name}.constant", "friction_angle", friction_angle)
        cohesion = check_range(f"{name}.constant", "cohesion", cohesion)
        if not 0.0 < friction_angle < 90.0:
            raise ValueError(
                f"{name}.constant: friction_angle must be in (0, 90) degrees, got {friction_angle}"
            )
        if not cohesion >= 0.0:
            raise ValueError(f"{name}.constant: cohesion must be >= 0 Pa, got {cohesion}")
        apex = cohesion / math.tan(math.radians(friction_angle))
        return cls(E, nu, friction_angle, 0.0, 0.0, 0.0, 0.0, 0.0, apex, density, **options)

    def _largest_rise(self) -> float:
        """The largest (a1 λ − a4) e^{−a3 λ} over λ ≥ 0 (degrees)."""
        if self.a1 == 0.0:
            return 0.0
        top = 1.0 / self.a3 + self.a4 / self.a1
        return max(self.a1 / self.a3 * math.exp(-self.a3 * top), 0.0)

    @property
    def history(self) -> dict[str, HistoryField]:
        """Elastic left Cauchy–Green tensor and Mast's plastic measure λ."""
        return {
            "be": HistoryField((3, 3), np.eye(3), "elastic left Cauchy-Green bᵉ", "left"),
            "plastic_shear": HistoryField(
                (), 0.0, "plastic measure λ = Σ ‖dev Δεᵖ‖ (Hencky; Mast Eq. 3.116)"
            ),
        }

    def angles(
        self, I1: np.ndarray, plastic_shear: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """φ_F, φ_cs and ψ_G (degrees) at I₁ (Pa) and λ, each (n,)."""
        lam = plastic_shear
        phi_F = self.a0 + (self.a1 * lam - self.a4) * np.exp(self.a2 * I1 - self.a3 * lam)
        phi_cs = self.a0 - self.a4 * np.exp(-self.a5 * lam)
        psi = np.degrees(np.arctan(np.tan(np.radians(phi_F)) - np.tan(np.radians(phi_cs))))
        return phi_F, phi_cs, psi

    def state_angles(self, history: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """φ_F and ψ_G (degrees) of the state ``history`` (frozen over the next step)."""
        # I₁ of τ_n = 3K ε_v of bᵉ_n (Hencky): ε_v = ½ ln det bᵉ_n. In u-p a point that
        # stepped elastically keeps the displacement's volume (mixed_return), so this
        # I₁ differs from the field's by 3K v, the step's volumetric mismatch: with
        # Mast's a2 = 3.3e-7 /Pa, 0.3 % of e^{a2 I₁} for a mismatch of 1e4 Pa.
        I1 = 1.5 * self.bulk_modulus * np.log(np.linalg.det(history["be"]))
        # The state is admissible (I₁ ≤ 3c_F) except by round-off; clip so that the
        # angles stay within the bounds checked at construction.
        I1 = np.minimum(I1, 3.0 * self.apex_stress)
        phi_F, _, psi = self.angles(I1, history["plastic_shear"])
        return phi_F, psi

    def _cone_parameters(self, history):
        phi_F, psi = self.state_angles(history)
        rho_F, rho_G = cone_slope(phi_F), cone_slope(psi)
        T = 3.0 * self.apex_stress
        return rho_F, rho_G, rho_F * T, np.full_like(rho_F, T), 0.0

    def largest_mean_stress(self, history: dict[str, np.ndarray]) -> float:
        """The apex's mean stress c_F (Pa), where the cutoff is: the most tension held."""
        return self.apex_stress

    def _updated(self, history, dgamma):
        return {"plastic_shear": history["plastic_shear"] + dgamma}
