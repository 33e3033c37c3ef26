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
    """The inertia and damping terms ``w·M (a + α_R v)`` of the residual.

    ``lumping`` is the per-point second moment C_p (m², a g×g slot field) for the
    lumped mass; None gives the consistent mass.
    """
    a = acceleration(du, nm) + nm.damping * velocity(du, nm)
    return mass_product(a, w, mpq, density, lumping)
