r"""Penalty term of boundary points with a prescribed displacement (non-conforming Dirichlet).

For boundary points :math:`b` with weight :math:`w_b` (the boundary length or
area each represents), penalty stiffness :math:`\beta` and the gap
:math:`g_b = x_b - x_b^{target}(t_{n+1})` at the start of the step,

.. math::  R_{pen} = \sum_b w_b\, \beta\, P_b \big(g_b + \Delta u(x_b)\big) \cdot \delta u(x_b),

where :math:`P_b` keeps the constrained components. It is linear in
:math:`\Delta u`, so its tangent is the constant :math:`\sum_b w_b \beta\, N^T P_b N`.
Boundary points that carry a traction :math:`t_b` (and no penalty) add
:math:`-\sum_b w_b\, t_b \cdot \delta u(x_b)`, and those that carry a pressure
:math:`p` on their piece :math:`a_b` of the body's face (an area vector at the
step's start) add the follower load
:math:`\sum_b p\, \mathrm{cof}(\Delta F_b)\, a_b \cdot \delta u(x_b)`, the face
moved by the step's :math:`\Delta F_b` (Nanson's rule): its tangent has the load's
stiffness, :math:`p\, \partial\,\mathrm{cof}(\Delta F)/\partial \Delta F`.
"""

from __future__ import annotations

import ufl

from fe_mpm.quadrature import MaterialPointQuadrature


def penalty(
    du: ufl.core.expr.Expr,
    w: ufl.core.expr.Expr,
    q: MaterialPointQuadrature,
    gap: ufl.Coefficient,
    stiffness: ufl.Coefficient,
    traction: ufl.Coefficient,
    u_degree: int = 1,
) -> ufl.Form:
    """The residual of the boundary points: penalty minus the tractions they carry.

    Args:
        du: Grid displacement increment, of degree ``u_degree``.
        w: Displacement test function.
        q: Quadrature of the boundary points (its scale carries w_b).
        gap: Slot field g_b (g,), m.
        stiffness: Slot field β P_b as a vector (g,): β on constrained components, 0 else (Pa/m).
        traction: Slot field t_b (g,), Pa; zero on penalty points.
        u_degree: Polynomial degree of the displacement (1, or 2 for Taylor–Hood).
    """
    mismatch = gap + q.at_points(du, u_degree)
    return q.sum(ufl.dot(ufl.elem_mult(stiffness, mismatch) - traction, q.at_points(w, u_degree)))


def follower_pressure(
    dF: ufl.core.expr.Expr,
    w: ufl.core.expr.Expr,
    q: MaterialPointQuadrature,
    pressure_area: ufl.Coefficient,
    u_degree: int = 1,
) -> ufl.Form:
    """The residual of a pressure that follows the body's face: Σ_b p cof(ΔF_b) a_b · δu.

    Args:
        dF: The grid's increment ΔF = I + ∇Δu at the boundary points (g x g).
        w: Displacement test function.
        q: Quadrature of the boundary points (its scale carries w_b).
        pressure_area: Slot field p a_b / w_b (g,), Pa: the pressure times the point's
            face at the step's start, over its weight.
        u_degree: Polynomial degree of the displacement (1, or 2 for Taylor–Hood).
    """
    # cof, not det ΔF ΔF⁻ᵀ: UFL's inverse divides by det ΔF, 0/0 on a flattened iterate.
    return q.sum(ufl.dot(ufl.dot(ufl.cofac(dF), pressure_area), q.at_points(w, u_degree)))
