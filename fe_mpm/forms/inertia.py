r"""Inertia of the material points with Newmark's rule and Bossak's α.

Iaconeta (2019) Eqs. 2.10–2.12, with the Bossak–Newmark variant (Wood, Bossak and
Zienkiewicz 1980) that Kratos MPM offers beside it. The grid starts every step from
rest in its own frame: its nodal velocity :math:`\tilde v` and acceleration
:math:`\tilde a` at :math:`t_n` come from the mass-weighted projection of the
particles' (Eqs. 2.6–2.9). With the step's displacement increment :math:`\Delta u`,

.. math::

    a_{n+1} = \frac{\Delta u - \Delta t\,\tilde v}{\beta\Delta t^2}
              - \Big(\frac{1}{2\beta} - 1\Big)\tilde a, \qquad
    v_{n+1} = \tilde v + \Delta t\big((1-\gamma)\,\tilde a + \gamma\, a_{n+1}\big),

and the inertia (plus optional mass-proportional Rayleigh damping α_R; the
stiffness-proportional β_R K is :func:`stiffness_damping`) enters the residual as the
particle sum

.. math::  \sum_p m_p \,\big((1-\alpha_B)\, a_{n+1} + \alpha_B\,\tilde a
           + \alpha_R v_{n+1}\big)(x_p) \cdot w(x_p),

i.e. with the consistent mass matrix :math:`M_{IJ} = \sum_p m_p N_I(x_p) N_J(x_p)`,
which is what the thesis uses (Eqs. 4.31, 4.36). Bossak's α_B ∈ [−1/3, 0] sets
β = (1 − α_B)²/4 and γ = 1/2 − α_B: α_B = 0 is the thesis's trapezoidal rule
(β = 1/4, γ = 1/2, no numerical dissipation); α_B < 0 damps the modes that the
step cannot resolve (spectral radius (1 + α_B)/(1 − α_B) as Δt ω → ∞) and keeps
second-order accuracy. Its tangent, :math:`((1-\alpha_B)/(\beta\Delta t^2) +
\alpha_R\gamma/(\beta\Delta t)) M`, comes from ``ufl.derivative``.

**Lumped mass.** The row-sum mass :math:`M^L_{II} = \sum_p m_p N_I(x_p)` gives the
term :math:`\sum_p m_p \sum_I N_I(x_p)\, a_I \cdot w_I`. For a P1 field the nodal
values are :math:`a_I = a(x_p) + \nabla a\, r_I` with :math:`r_I = x_I - x_p`, and
:math:`\sum_I N_I(x_p) r_I = 0`, so the lumped term is the consistent one plus a
gradient correction, exactly:

.. math::

    \sum_p m_p \Big( a(x_p)\cdot w(x_p) + \nabla a : \nabla w\, C_p \Big), \qquad
    C_p = \sum_I N_I(x_p)\, r_I \otimes r_I \quad (\text{m}^2),

with the per-point second moment :math:`C_p` packed like any other particle datum.
The form stays a particle sum and its tangent is the diagonal lumped matrix.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import ufl

from fe_mpm.quadrature import MaterialPointQuadrature

#: The names of Newmark's coefficients in :class:`NewmarkData`, as :meth:`NewmarkData.set_step`
#: fills them.
COEFFICIENTS = ("c_a", "c_av", "c_aa", "c_v", "c_vv", "c_va")


def newmark_parameters(bossak_alpha: float) -> tuple[float, float]:
    """Newmark's (β, γ) for Bossak's α_B: ((1 − α_B)²/4, 1/2 − α_B)."""
    return (1.0 - bossak_alpha) ** 2 / 4.0, 0.5 - bossak_alpha


@dataclass
class NewmarkData:
    """Grid state and coefficients of one dynamic step.

    The coefficients are Constants so that a new Δt or α_B needs no new kernels;
    :meth:`set_step` fills them.

    Attributes:
        v_n: Projected nodal velocity ṽ at t_n (P1 vector function, m/s).
        a_n: Projected nodal acceleration ã at t_n (P1 vector function, m/s²).
        c_a: 1/(βΔt²) (1/s²), the weight of Δu in a_{n+1}.
        c_av: 1/(βΔt) (1/s), the weight of ṽ in a_{n+1}.
        c_aa: 1/(2β) − 1, the weight of ã in a_{n+1}.
        c_v: γ/(βΔt) (1/s), the weight of Δu in v_{n+1}.
        c_vv: 1 − γ/β, the weight of ṽ in v_{n+1}.
        c_va: Δt (1 − γ/(2β)) (s), the weight of ã in v_{n+1}.
        bossak: Bossak's α_B (the weight of ã in the inertia), a Constant.
        damping: Mass-proportional Rayleigh coefficient α_R (1/s), a Constant.
        stiffness_damping: Stiffness-proportional Rayleigh coefficient β_R (s), a
            Constant, or None where β_R = 0 (the forms then have no such term).
    """

    v_n: ufl.Coefficient
    a_n: ufl.Coefficient
    c_a: ufl.Constant
    c_av: ufl.Constant
    c_aa: ufl.Constant
    c_v: ufl.Constant
    c_vv: ufl.Constant
    c_va: ufl.Constant
    bossak: ufl.Constant
    damping: ufl.Constant
    stiffness_damping: ufl.Constant | None = None

    @property
    def gamma(self) -> float:
        """Newmark's γ = 1/2 − α_B at the current α_B."""
        return newmark_parameters(float(self.bossak.value))[1]

    def set_step(self, dt: float) -> None:
        """Newmark's coefficients for a step of ``dt`` seconds (> 0) at the current α_B.

        Raises:
            ValueError: A step so short that 1/(β Δt²) is not a finite number (a bare
                ZeroDivisionError until 2026-12-07), or so long that β Δt² is not (an
                OverflowError).
        """
        beta, gamma = newmark_parameters(float(self.bossak.value))
        scale = beta * dt * dt  # (dt**2 raised OverflowError past 1e154 s)
        if not scale < math.inf:
            raise ValueError(
                f"Simulation: a dynamic step of {dt:.3g} s is too long for Newmark's rule "
                "(β Δt² is not a finite number)"
            )
        if not 0.0 < scale or not math.isfinite(1.0 / scale):
            raise ValueError(
                f"Simulation: a dynamic step of {dt:.3g} s is too short for Newmark's rule "
                f"(1/(β Δt²) is not a finite number); take steps of at least "
                f"{math.sqrt(1.0 / (beta * 1e300)):.0e} s"
            )
        self.c_a.value = 1.0 / (beta * dt**2)
        self.c_av.value = 1.0 / (beta * dt)
        self.c_aa.value = 0.5 / beta - 1.0
        self.c_v.value = gamma / (beta * dt)
        self.c_vv.value = 1.0 - gamma / beta
        self.c_va.value = dt * (1.0 - 0.5 * gamma / beta)


def acceleration(du: ufl.core.expr.Expr, nm: NewmarkData) -> ufl.core.expr.Expr:
    """Grid acceleration a_{n+1} (m/s²) of the increment Δu (Eq. 2.12)."""
    return nm.c_a * du - nm.c_av * nm.v_n - nm.c_aa * nm.a_n


def velocity(du: ufl.core.expr.Expr, nm: NewmarkData) -> ufl.core.expr.Expr:
    """Grid velocity v_{n+1} (m/s) of the increment Δu (Eq. 2.11)."""
    return nm.c_v * du + nm.c_vv * nm.v_n + nm.c_va * nm.a_n


def mass_product(
    a: ufl.core.expr.Expr,
    w: ufl.core.expr.Expr,
    mpq: MaterialPointQuadrature,
    density: ufl.Coefficient,
    lumping: ufl.Coefficient | None,
) -> ufl.Form:
    """``w·M a`` as a particle sum: consistent, or lumped if ``lumping`` (C_p) is given."""
    integrand = ufl.dot(mpq.at_points(a), mpq.at_points(w))
    if lumping is not None:
        integrand += ufl.inner(ufl.grad(a) * lumping, ufl.grad(w))
    return mpq.sum(density * integrand)


def inertia(
    du: ufl.core.expr.Expr,
    w: ufl.core.expr.Expr,
    mpq: MaterialPointQuadrature,
    density: ufl.Coefficient,
    nm: NewmarkData,
    lumping: ufl.Coefficient | None = None,
) -> ufl.Form:
    """The inertia and damping terms ``w·M ((1 − α_B) a + α_B ã + α_R v)`` of the residual.

    ``lumping`` is the per-point second moment C_p (m², a g×g slot field) for the
    lumped mass; None gives the consistent mass.
    """
    a = (1.0 - nm.bossak) * acceleration(du, nm) + nm.bossak * nm.a_n
    a += nm.damping * velocity(du, nm)
    return mass_product(a, w, mpq, density, lumping)


def stiffness_damping(
    du: ufl.core.expr.Expr,
    w: ufl.core.expr.Expr,
    mpq: MaterialPointQuadrature,
    moduli: ufl.Coefficient,
    nm: NewmarkData,
) -> ufl.Form:
    r"""The stiffness-proportional Rayleigh term ``w·β_R K v_{n+1}`` as a particle sum.

    .. math:: \beta_R \sum_p V_p \big(\lambda_p \operatorname{tr}\varepsilon(v)
              \operatorname{tr}\varepsilon(w) + 2\mu_p\, \varepsilon(v):\varepsilon(w)\big)(x_p)

    K is the points' linear elastic stiffness on the grid of the step's start
    (Lamé's λ_p = K_p − ⅔μ_p and μ_p of each point's law), not the current tangent:
    a plastic or softened point is damped as if it were elastic, and the term stays
    linear in v, so Newton's tangent gains ``β_R γ/(βΔt) K`` and nothing else. A mode
    of circular frequency ω of a linear elastic body is damped at the ratio
    ζ = β_R ω / 2, which grows with ω: the term damps the fast modes that mass
    damping leaves alone.

    Args:
        du: The step's displacement increment Δu (P1, m).
        w: Its test function.
        mpq: Material-point quadrature of the step.
        moduli: (λ_p, μ_p) at each point (slot field of shape (2,), Pa).
        nm: Newmark's data, whose ``stiffness_damping`` is set.
    """
    strain_rate = ufl.sym(mpq.grad_at_points(velocity(du, nm)))
    virtual = ufl.sym(mpq.grad_at_points(w))
    work = moduli[0] * ufl.tr(strain_rate) * ufl.tr(virtual)
    work += 2.0 * moduli[1] * ufl.inner(strain_rate, virtual)
    return mpq.sum(nm.stiffness_damping * work)
