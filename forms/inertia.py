r"""Inertia of the material points with Newmark's trapezoidal rule (β = 1/4, γ = 1/2).

Iaconeta (2019) Eqs. 2.10–2.12. The grid starts every step from rest in its own
frame: its nodal velocity :math:`\tilde v` and acceleration :math:`\tilde a` at
:math:`t_n` come from the mass-weighted projection of the particles' (Eqs.
2.6–2.9). With the step's displacement increment :math:`\Delta u`,

.. math::

    a_{n+1} = \frac{4}{\Delta t^2}\Delta u - \frac{4}{\Delta t}\tilde v - \tilde a, \qquad
    v_{n+1} = \frac{2}{\Delta t}\Delta u - \tilde v,

and the inertia (plus optional mass-proportional Rayleigh damping α_R) enters
the residual as the particle sum

.. math::  \sum_p m_p \,\big(a_{n+1} + \alpha_R v_{n+1}\big)(x_p) \cdot w(x_p),

i.e. with the consistent mass matrix :math:`M_{IJ} = \sum_p m_p N_I(x_p) N_J(x_p)`,
which is what the thesis uses (Eqs. 4.31, 4.36). Its tangent,
:math:`(4/\Delta t^2 + 2\alpha_R/\Delta t) M`, comes from ``ufl.derivative``.
"""

from __future__ import annotations

from dataclasses import dataclass

import ufl

from fe_mpm.quadrature import MaterialPointQuadrature


@dataclass
class NewmarkData:
    """Grid state and coefficients of one dynamic step.

    Attributes:
        v_n: Projected nodal velocity ṽ at t_n (P1 vector function, m/s).
        a_n: Projected nodal acceleration ã at t_n (P1 vector function, m/s²).
        c_a: Constant 4/Δt² (1/s²).
        c_v: Constant 2/Δt (1/s).
        damping: Mass-proportional Rayleigh coefficient α_R (1/s), a Constant.
    """

    v_n: ufl.Coefficient
    a_n: ufl.Coefficient
    c_a: ufl.Constant
    c_v: ufl.Constant
    damping: ufl.Constant


def acceleration(du: ufl.core.expr.Expr, nm: NewmarkData) -> ufl.core.expr.Expr:
    """Grid acceleration a_{n+1} (m/s²) of the increment Δu (Eq. 2.12)."""
    return nm.c_a * du - 2.0 * nm.c_v * nm.v_n - nm.a_n


def velocity(du: ufl.core.expr.Expr, nm: NewmarkData) -> ufl.core.expr.Expr:
    """Grid velocity v_{n+1} (m/s) of the increment Δu (Eq. 2.11)."""
    return nm.c_v * du - nm.v_n


def inertia(
    du: ufl.core.expr.Expr,
    w: ufl.core.expr.Expr,
    mpq: MaterialPointQuadrature,
    density: ufl.Coefficient,
    nm: NewmarkData,
) -> ufl.Form:
    """The inertia and damping terms ``Σ_p m_p (a + α_R v)(x_p)·w(x_p)`` of the residual."""
    a = acceleration(du, nm) + nm.damping * velocity(du, nm)
    return mpq.sum(density * ufl.dot(mpq.at_points(a), mpq.at_points(w)))
