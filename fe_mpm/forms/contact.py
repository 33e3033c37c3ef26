r"""Contact with a fixed rigid wall: a penalty spring per grid node, with Coulomb friction.

At a node of the wall, with the grid's outward normal :math:`\mathbf n` (pointing into
the wall), the spring's extension at the iterate is

.. math::  \mathbf d = \mathbf e_n + \Delta\mathbf u,

where :math:`\mathbf e_n` is its extension at the end of the last step: how far the
body has entered the wall and how far it has slipped elastically. Keeping it is what
stops both from growing step after step on a grid that is reset. With the penalty
stiffness :math:`\beta` (Pa/m), Coulomb's coefficient :math:`\mu` and a slip scale
:math:`s` (m), the normal pressure and the friction are

.. math::

   p_N = \beta\,\langle d_N\rangle, \quad d_N = \mathbf d\cdot\mathbf n - g_0, \qquad
   \mathbf t_T = -\mu\, p_N \tanh\!\Big(\frac{|\mathbf d_T|}{s}\Big)
   \frac{\mathbf d_T}{|\mathbf d_T|}, \quad
   \mathbf d_T = \mathbf d - (\mathbf d\cdot\mathbf n)\,\mathbf n,

where :math:`g_0 \ge 0` is the node's gap to the body at the start of the step
(:meth:`fe_mpm.walls.RigidWalls.start_step`). The wall's traction on the body is
:math:`\mathbf t = -p_N\mathbf n + \mathbf t_T` (Pa),
and the residual gains :math:`-\int_\Gamma \mathbf t\cdot\delta\mathbf u\,d\Gamma`,
integrated with the vertex rule so that each node carries its own spring (a lumped,
node-to-wall contact, as Mast's grid-node boundaries). The contact is closed at zero
extension, so the first Jacobian of a step already holds the body along the normal.
The consistent tangent is ``ufl.derivative`` of this residual.

The friction is Coulomb's, smoothed over slips of the order of s: below s the wall
holds like a spring of stiffness μ p_N / s; beyond 3 s the force is μ p_N to
0.5 % (tanh 3 = 0.995), beyond 10 s to round-off. With the exact law (a kink where
the spring's force reaches μ p_N, a nanometre of slip on a steel block), Newton
cycled between sliding both ways at the nodes of a block on an incline that were
about to slip. A smooth wall has μ = 0; a sticking one is the spring alone,
:math:`\mathbf t_T = -\beta\,\mathbf d_T`.

Between steps the springs keep :math:`\mathbf e_{n+1} = \langle d_N\rangle\mathbf n +
\mathbf d_T \min(1, X s/|\mathbf d_T|)` with X = :data:`KEPT_SLIP`: a block at rest
on an incline does not creep, and one that slid on keeps at most X s of its slip.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import ufl

#: The vertex rule of UFL's facet measures: one quadrature point per facet vertex.
VERTEX_RULE = {"quadrature_rule": "vertex", "quadrature_degree": 1}

#: A slip of this length (m) stands in for zero in ``|d_T|``, so that its derivative
#: stays finite.
ZERO_SLIP = 1e-30

#: The springs keep at most this many slip scales s along the wall.
KEPT_SLIP = 3.0

#: Below this x = ``|d_T| / s``, tanh(x)/x is its series 1 − x²/3 (to round-off).
SMALL_X = 1e-4

#: Above this x, tanh(x) is 1 in double precision and tanh(x)/x is 1/x. Beyond
#: x ≈ 710 UFL's derivative of tanh, 2 cosh x / (cosh 2x + 1), is inf/inf: a NaN in
#: the Jacobian at every node that slid more than 710 slip scales in the iterate.
LARGE_X = 20.0

#: :func:`unloaded_tangent` holds an unloaded node along the wall with this share of
#: μβ: μE/(10 h) at the default penalty (1000 E/h). Measured on a block resting on
#: a wall (μ = 0.6, gravity ramped over 3 steps): level, the first step takes 3
#: Newton iterations with 1e-4 as without the term, 4 with 1e-3 or 1e-2; on a 20°
#: slope, which fails without it, 7 (u) and 5 (u-p) with 1e-4, 12 with 1e-5, and
#: steps cut with 1e-6.
UNLOADED_SHARE = 1e-4


@dataclass(frozen=True)
class WallLaw:
    """One wall's springs.

    Attributes:
        normal: The wall's unit normal n (g,), pointing into the wall (UFL).
        stiffness: β (Pa/m), UFL.
        friction: μ > 0 (UFL), 0.0 for a smooth wall, or ``math.inf`` for a sticking one.
        slip_scale: s (m), > 0, UFL.
        gap: How far the body is from the wall at the node at the start of the
            step (m, ≥ 0, UFL): the spring engages once the node has moved that far.
    """

    normal: ufl.core.expr.Expr
    stiffness: ufl.core.expr.Expr
    friction: ufl.core.expr.Expr | float
    slip_scale: ufl.core.expr.Expr
    gap: ufl.core.expr.Expr | float = 0.0


def _parts(d, law: WallLaw):
    """(d_N, touching, p_N, d_T, |d_T| / s or None) of the law at extension ``d``."""
    n = law.normal
    entry = ufl.dot(d, n) - law.gap
    touching = ufl.ge(entry, 0.0)
    pressure = ufl.conditional(touching, law.stiffness * entry, 0.0)
    tangential = d - ufl.dot(d, n) * n
    x = None
    if not _smooth(law.friction) and not _sticking(law.friction):
        x = ufl.sqrt(ufl.dot(tangential, tangential) + ZERO_SLIP**2) / law.slip_scale
    return entry, touching, pressure, tangential, x


def _smooth(friction) -> bool:
    return isinstance(friction, float | int) and friction == 0.0


def _sticking(friction) -> bool:
    return isinstance(friction, float | int) and friction == math.inf


def wall_traction(extension: ufl.core.expr.Expr, law: WallLaw) -> ufl.core.expr.Expr:
    r"""The wall's traction :math:`\mathbf t` on the body (Pa), shape (g,).

    Args:
        extension: The spring's extension :math:`\mathbf d` (g,), m.
        law: The wall's springs.
    """
    _, touching, pressure, tangential, x = _parts(extension, law)
    push = -pressure * law.normal
    if _smooth(law.friction):
        return push
    if _sticking(law.friction):
        return push - ufl.conditional(touching, law.stiffness, 0.0) * tangential
    # −μ p_N tanh(x) d_T/|d_T| = −(μ p_N / s) (tanh(x)/x) d_T, tanh(x)/x → 1 at x → 0.
    ratio = ufl.conditional(
        ufl.lt(x, SMALL_X),
        1.0 - x**2 / 3.0,
        ufl.conditional(ufl.gt(x, LARGE_X), 1.0 / x, ufl.tanh(x) / x),
    )
    return push - law.friction * pressure / law.slip_scale * ratio * tangential


def kept_extension(extension: ufl.core.expr.Expr, law: WallLaw) -> ufl.core.expr.Expr:
    """The extension the springs keep into the next step (m), shape (g,).

    The entry into the wall, and along it the slip, at most :data:`KEPT_SLIP` s;
    nothing where the body has left the wall.
    """
    entry, touching, _, tangential, x = _parts(extension, law)
    kept = ufl.conditional(touching, entry, 0.0) * law.normal
    if _smooth(law.friction):
        return kept
    if _sticking(law.friction):
        return kept + ufl.conditional(touching, 1.0, 0.0) * tangential
    share = ufl.conditional(ufl.le(x, KEPT_SLIP), 1.0, KEPT_SLIP / x)
    return kept + ufl.conditional(touching, share, 0.0) * tangential


def residual(
    du: ufl.core.expr.Expr,
    w: ufl.core.expr.Expr,
    extension: ufl.Coefficient,
    law: WallLaw,
    ds: ufl.Measure,
) -> ufl.Form:
    """The wall's share of the residual, ``−∫ t·δu dΓ`` over its facets by the vertex rule.

    Args:
        du: Grid displacement increment Δu (P1).
        w: Displacement test function.
        extension: The springs' extension at the end of the last step (P1 vector).
        law: The wall's springs.
        ds: The wall's facets, with :data:`VERTEX_RULE` as metadata.
    """
    return -ufl.dot(wall_traction(extension + du, law), w) * ds


def unloaded_tangent(
    du: ufl.core.expr.Expr,
    trial: ufl.core.expr.Expr,
    w: ufl.core.expr.Expr,
    extension: ufl.Coefficient,
    law: WallLaw,
    ds: ufl.Measure,
) -> ufl.Form | None:
    r"""A Jacobian term for the nodes that touch a frictional wall with no pressure yet.

    The friction's tangent :math:`\mu\,p_N/s` vanishes with :math:`p_N`: at the first
    iterate of a static step on springs that carry nothing yet (the first step of a
    body seeded on its wall), nothing holds the body along a wall that only friction
    holds, the Jacobian is singular there, and the linear solve fails (a block at
    rest on a frictional slope stopped in its first step). Where the entry
    :math:`d_N` is exactly 0, this adds a spring along the wall, of stiffness
    :data:`UNLOADED_SHARE` × μβ: a predictor for the first iterate, after which the
    springs of the nodes under the body carry it and the term is 0 there. It is in
    the Jacobian only, so the answer is the residual's; None for a smooth or a
    sticking wall. Static steps only: in dynamics the mass holds the first iterate,
    and a body sliding onto new nodes met the predictor there at every step (Newton
    stalled on a sliding block). Nodes that stay at entry 0 keep it at every
    iterate: wall nodes of empty cells, whose rows are pinned anyway, and a node a
    Dirichlet condition holds along the normal, where the Jacobian is then inexact
    along the wall (Newton converges, less than quadratically).

    Args:
        du: Grid displacement increment Δu (P1), the iterate.
        trial: The displacement part of the Jacobian's trial function.
        w: Displacement test function.
        extension: The springs' extension at the end of the last step (P1 vector).
        law: The wall's springs.
        ds: The wall's facets, with :data:`VERTEX_RULE` as metadata.
    """
    if _smooth(law.friction) or _sticking(law.friction):
        return None
    entry, _, _, _, _ = _parts(extension + du, law)
    n = law.normal
    along = trial - ufl.dot(trial, n) * n
    stiffness = ufl.conditional(
        ufl.eq(entry, 0.0), UNLOADED_SHARE * law.friction * law.stiffness, 0.0
    )
    return stiffness * ufl.dot(along, w) * ds
