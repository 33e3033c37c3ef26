r"""Irreducible (displacement) form, updated Lagrangian at finite strain.

One step of the implicit MPM (Iaconeta 2019, Algorithm 1) solves for the grid
displacement increment :math:`\Delta u` against the grid at :math:`t_n`, which
is reset after the step. Written in total-Lagrangian form against that grid:

.. math::

    \Delta F = I + \nabla_{X_n} \Delta u, \qquad F = \Delta F \, F_n,

and the virtual work of the material points,

.. math::

    R(\Delta u; w) = \sum_p V_p^n \, \frac{\tau(F)\,\Delta F^{-T}}{J_n} : \nabla_{X_n} w
                   - \sum_p m_p\, b \cdot w(x_p)
                   - \int_{\Gamma_N} \bar t \cdot w \, ds = 0 ,

since :math:`V_p^{n+1}\sigma = V_p^n \tau / J_n` and
:math:`\nabla_x w = \nabla_{X_n} w\, \Delta F^{-1}`. At convergence this equals
the updated-Lagrangian statement on the moved grid, with no mesh motion.
Tractions :math:`\bar t` act on the facets of the grid (Kratos's grid line
loads), per unit area of the grid at :math:`t_n`; body forces :math:`b` (per
unit mass) act through the points. The tangent is ``ufl.derivative`` of
:math:`R`, so it is consistent by construction.
"""

from __future__ import annotations

from collections.abc import Sequence

import ufl

from fe_mpm.forms.loads import external_work
from fe_mpm.materials import embed_3d
from fe_mpm.quadrature import MaterialPointQuadrature


def deformation_increment(q: MaterialPointQuadrature, du: ufl.Coefficient) -> ufl.core.expr.Expr:
    """ΔF = I + ∇Δu at the material points, shape (g, g)."""
    g = ufl.shape(du)[0]
    return ufl.Identity(g) + q.grad_at_points(du)


def grid_stress(kirchhoff, dF, F_n, material_increment=None) -> ufl.core.expr.Expr:
    """τ ΔF⁻ᵀ / det F_n (Pa): what a point puts against ∇w in :func:`residual`.

    τ is the law's at ``material_increment`` (if given, else ``dF``) times F_n.
    """
    F = (dF if material_increment is None else material_increment) * F_n
    return kirchhoff(F) * ufl.inv(dF).T / ufl.det(F_n)


def residual(
    du: ufl.Coefficient,
    w: ufl.Argument,
    q: MaterialPointQuadrature,
    F_n: ufl.Coefficient,
    density: ufl.Coefficient,
    kirchhoff,
    body_force: ufl.core.expr.Expr | None = None,
    tractions: Sequence[tuple[ufl.core.expr.Expr, ufl.Measure]] = (),
    material_increment: ufl.core.expr.Expr | None = None,
    increment: ufl.core.expr.Expr | None = None,
) -> ufl.Form:
    """Residual R(Δu; w) of one static step.

    Args:
        du: Grid displacement increment Δu (m), P1 vector field.
        w: Test function on the same space.
        q: Material-point quadrature of this step.
        F_n: Deformation gradient of the points at t_n (slot field, g x g).
        density: Mass density of the points m_p/V_p (kg/m³, slot field).
        kirchhoff: Callable F -> Kirchhoff stress τ (Pa), the material law.
        body_force: Body force per unit mass b (m/s²), or None.
        tractions: Pairs (t̄, ds) of traction vector (Pa) and facet measure.
        material_increment: The increment the law sees, if not ΔF (the averaged
            ΔF̄ of :mod:`fe_mpm.forms.volume_average`); ΔF still maps ∇w.
        increment: The point's ΔF, if not the grid's at the point (the shared
            increment of a point domain's pieces, :mod:`fe_mpm.domains`).
    """
    dF = deformation_increment(q, du) if increment is None else increment
    R = q.sum(ufl.inner(grid_stress(kirchhoff, dF, F_n, material_increment), q.grad_at_points(w)))
    loads = external_work(w, q, density, body_force, tractions)
    return R if loads is None else R - loads


def cauchy_stress_3d(kirchhoff, F: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """Full 3x3 Cauchy stress σ = τ/J (Pa), including σ_33 in plane strain."""
    F3 = embed_3d(F)
    return kirchhoff(F3) / ufl.det(F3)
