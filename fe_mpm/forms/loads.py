r"""External loads of a step: body forces through the points, tractions on grid facets.

.. math::

    f_{ext}(w) = \sum_p m_p\, b \cdot w(x_p) + \int_{\Gamma_N} \bar t \cdot w \, ds ,

with :math:`b` per unit mass (m/s²) and :math:`\bar t` per unit area of the grid
at :math:`t_n` (Pa). Every residual subtracts this form; the Newton test
(:mod:`fe_mpm.newton`) also assembles it alone, as one of the forces against
which a residual counts as small.
"""

from __future__ import annotations

from collections.abc import Sequence

import ufl

from fe_mpm.quadrature import MaterialPointQuadrature


def external_work(
    w: ufl.core.expr.Expr,
    q: MaterialPointQuadrature,
    density: ufl.Coefficient,
    body_force: ufl.core.expr.Expr | None = None,
    tractions: Sequence[tuple[ufl.core.expr.Expr, ufl.Measure]] = (),
    u_degree: int = 1,
) -> ufl.Form | None:
    """The virtual work of the loads, or None when there are none.

    Args:
        w: Displacement test function (of degree ``u_degree``).
        q: Material-point quadrature of the step.
        density: Mass density of the points m_p/V_p (kg/m³, slot field).
        body_force: Body force per unit mass b (m/s²), or None.
        tractions: Pairs (t̄, ds) of traction vector (Pa) and facet measure.
        u_degree: Polynomial degree of the displacement.
    """
    terms = []
    if body_force is not None:
        terms.append(q.sum(density * ufl.dot(body_force, q.at_points(w, u_degree))))
    terms += [ufl.dot(t, w) * ds for t, ds in tractions]
    return sum(terms[1:], terms[0]) if terms else None


def start_pressure_by_parts(
    w: ufl.core.expr.Expr,
    q: MaterialPointQuadrature,
    chi: ufl.Coefficient,
    p_start: ufl.Coefficient,
    dF: ufl.core.expr.Expr,
    u_degree: int = 1,
) -> ufl.Form:
    """Σ_p V_p χ (w·∇p̄ − p̄ (det ΔF ΔF⁻ᵀ − I) : ∇w): the starting pressure by parts.

    Added to the residual where the formulation's stress gives up χ p̄
    (:mod:`fe_mpm.pressure_by_parts`). Of p̄'s work −χ p̄ det ΔF ΔF⁻ᵀ : ∇w on the grid
    of the step's start, the part that does not depend on Δu, −χ p̄ ∇·w, is taken by
    parts: ``w·∇p̄`` here and the facet terms of :mod:`fe_mpm.pressure_by_parts`. The
    rest, p̄'s geometric part, is linear in Δu and barely jumps as points cross
    facets; it stays at the points. Without it (until 2026-12-08) p̄ acted on the
    geometry of the step's start, a step late, and a dam break gained energy at
    first order in the step (``tests/test_fluid.py``).

    Args:
        w: Displacement test function (of degree ``u_degree``).
        q: Material-point quadrature of the step.
        chi: χ of each point's cell (slot field, 1 or 0).
        p_start: The step's starting pressure p̄ (Pa, P1 on the grid).
        dF: The increment ΔF that maps ∇w in the formulation's stress (g x g).
        u_degree: Polynomial degree of the displacement.
    """
    g = ufl.shape(dF)[0]
    geometric = ufl.det(dF) * ufl.inv(dF).T - ufl.Identity(g)
    work = ufl.dot(q.at_points(w, u_degree), ufl.grad(p_start))
    work -= q.at_points(p_start) * ufl.inner(geometric, q.grad_at_points(w, u_degree))
    return q.sum(chi * work)
