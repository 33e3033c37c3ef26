r"""Ghost penalty on the facets of poorly filled cells (after Coombs 2023).

A cell that the material fills only in part gives its nodes little stiffness, and
a node reached only by such a cell makes the tangent nearly singular. The ghost
penalty ties each such cell to its neighbours by penalising the jump of the
displacement gradient across their shared facets :math:`F`:

.. math::  G(\Delta u, w) = \gamma\, 2\mu \sum_F h_F
           \int_F [\![\nabla \Delta u]\!] : [\![\nabla w]\!] \, \mathrm{d}s,

with :math:`h_F` the mean diameter of the two cells, :math:`\mu` the shear
modulus and :math:`\gamma` dimensionless. For P1 displacements the gradient is
constant in each cell, so the penalty vanishes for any affine increment (it never
resists a homogeneous deformation or a rigid motion), and it scales with
:math:`h` like the stiffness of a cell: a weak tie, not a constraint. It is
linear in :math:`\Delta u`, so its tangent is the form itself.
"""

from __future__ import annotations

import ufl

#: Subdomain id of the ghost facets in ``dS``.
GHOST_FACETS = 1


def ghost_penalty(
    du: ufl.core.expr.Expr, w: ufl.core.expr.Expr, scale: ufl.core.expr.Expr
) -> ufl.Form:
    r"""The ghost form :math:`G(\Delta u, w)` on the facets of subdomain :data:`GHOST_FACETS`.

    Args:
        du: Displacement increment (trial function), P1.
        w: Displacement test function.
        scale: :math:`\gamma\, 2\mu` (Pa).
    """
    mesh = ufl.domain.extract_unique_domain(du)
    h = ufl.avg(ufl.CellDiameter(mesh))
    dS = ufl.Measure("dS", domain=mesh)
    return scale * h * ufl.inner(ufl.jump(ufl.grad(du)), ufl.jump(ufl.grad(w))) * dS(GHOST_FACETS)
