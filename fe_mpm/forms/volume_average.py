r"""Node-based volumetric averaging (NB-VA) of the displacement form, after Mast (2013) Ch. 4.

On linear simplices the displacement form locks when the material keeps its
volume (ν → ½, or isochoric plastic flow): every cell carries a volume
constraint of its own, about twice as many in 2D as the grid has nodes, and the
grid cannot move. Mast's anti-locking replaces each point's volume change by an
average over a control volume. With cell-based control volumes (his CB-VA) this
changes nothing on P1 simplices: :math:`\nabla \Delta u` is constant in a cell,
so every point of a cell already has the same :math:`\Delta J`. The node-based
average (NB-VA) leaves one volume constraint per node.

**The average.** A second P1 field :math:`\theta` holds the step's volume change
averaged at the nodes, :math:`\bar J = 1 + \theta`: the points' volume changes
:math:`\Delta J_p = \det \Delta F_p` projected with a lumped, volume-weighted mass,

.. math::

    \sum_p V_p^n N_I(x_p)\, \theta_I = \sum_p V_p^n N_I(x_p)\, (\Delta J_p - 1)
    \quad \text{for every node } I .

For P1, :math:`\sum_I N_I(x)\,\theta_I \vartheta_I = \theta\vartheta + \nabla\theta
\cdot C_p \nabla\vartheta` with the point's second moment
:math:`C_p = \sum_I N_I(x_p)(x_I - x_p) \otimes (x_I - x_p)` (the lumped mass
uses the same identity, :mod:`fe_mpm.forms.inertia`), so the projection is the
particle sum

.. math::

    R_\theta(\Delta u, \theta; \vartheta) = \sum_p V_p^n \big[\theta \vartheta
    + \nabla\theta \cdot C_p \nabla\vartheta - (\Delta J_p - 1)\vartheta\big] = 0,

in volume × strain, like the volumetric rows of the u-p form. Its matrix is
diagonal in θ and positive at every node that a point reaches, however few
points a cell holds.

**The averaged increment.** Each point takes the averaged volume change at its
place and keeps its own isochoric part,

.. math::

    \Delta\bar F_p = \Big(\frac{\bar J(x_p)}{\Delta J_p}\Big)^{1/g} \Delta F_p,
    \qquad \det \Delta\bar F_p = \bar J(x_p),

(g = 2 in plane strain, where the out-of-plane stretch is 1). The law sees
:math:`\bar F = \Delta\bar F F_n`, and the points keep :math:`\bar F` and the
volume :math:`V_p^{n+1} = \bar J(x_p) V_p^n`. With that volume the virtual work is
the displacement form's with :math:`\tau(\bar F)`:
:math:`V_p^{n+1}\bar\sigma : \nabla_x w = V_p^n\, \tau(\bar F)\, \Delta F^{-T} /
J_n : \nabla_{X_n} w`, where :math:`\Delta F` (not :math:`\Delta\bar F`) maps the
test function's gradient to the moved grid (the F-bar method of de Souza Neto
et al. 1996, with Mast's node-based control volumes). The total volume is kept:
:math:`\sum_p V_p^n \theta(x_p) = \sum_I \theta_I \sum_p V_p^n N_I(x_p) =
\sum_p V_p^n (\Delta J_p - 1)`. The tangent is ``ufl.derivative`` of the pair
:math:`(R_u, R_\theta)`, consistent by construction.

**Several laws.** A body of zones (:mod:`fe_mpm.materials.zones`) keeps one
:math:`\theta_z` per zone, each projected from its own points only
(:math:`\chi_z = 1` at the points of zone z),

.. math::

    \sum_p \chi_z V_p^n \big[\theta_z \vartheta_z + \nabla\theta_z \cdot C_p
    \nabla\vartheta_z - (\Delta J_p - 1)\vartheta_z\big] = 0,
    \qquad \bar J(x_p) = 1 + \sum_z \chi_z(p)\, \theta_z(x_p),

so a point takes the volume change of its own zone around it. One average over
both sides of an interface gives a stiff zone the soft zone's volume change: two
elastic layers 10:1 in stiffness under gravity (a helper's scene, 2026-12-06) had
their stresses beside the interface off by most of their value (tension in a
layer under compression) and pushed 38 % too hard on the side walls. A zone's
:math:`\theta_z` has no equation at the nodes none of its points reaches; they
are pinned (:meth:`fe_mpm.formulations.GridFields.pin_unsupported`).
"""

from __future__ import annotations

import ufl

from fe_mpm.quadrature import MaterialPointQuadrature


def averaged_increment(
    dF: ufl.core.expr.Expr, volume_change_at_point: ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """ΔF̄ = (J̄/ΔJ)^{1/g} ΔF at the points, g x g, with J̄ = 1 + θ(x_p).

    Args:
        dF: The points' deformation gradient increment ΔF (g x g).
        volume_change_at_point: θ at the points (dimensionless).
    """
    g = ufl.shape(dF)[0]
    ratio = (1.0 + volume_change_at_point) / ufl.det(dF)
    return ratio ** (1.0 / g) * dF


def volume_change_at_points(
    q: MaterialPointQuadrature, volume_change: ufl.core.expr.Expr, zones: list | None = None
) -> ufl.core.expr.Expr:
    """θ at the points: the field's, or with zones Σ_z χ_z θ_z (dimensionless).

    Args:
        q: Material-point quadrature of the step.
        volume_change: θ (P1), or one θ_z per zone (a P1 vector).
        zones: The indicators χ_z of the zones (:func:`fe_mpm.materials.zones.indicator`),
            or None for one θ.
    """
    if zones is None:
        return q.at_points(volume_change)
    return sum(chi * q.at_points(volume_change[z]) for z, chi in enumerate(zones))


def projection_residual(
    q: MaterialPointQuadrature,
    dF: ufl.core.expr.Expr,
    volume_change: ufl.core.expr.Expr,
    test: ufl.core.expr.Expr,
    second_moment: ufl.Coefficient,
    zones: list | None = None,
) -> ufl.Form:
    """R_θ: the lumped, volume-weighted projection of ΔJ − 1 onto the P1 field θ.

    Args:
        q: Material-point quadrature of the step.
        dF: The points' deformation gradient increment ΔF (g x g).
        volume_change: θ, the P1 field of the averaged volume change (with zones a
            P1 vector, one θ_z per zone).
        test: Its test function ϑ (of the same shape).
        second_moment: C_p (m², g x g slot field), see :func:`fe_mpm.transfer.second_moments`.
        zones: The indicators χ_z of the zones, each θ_z projected from its own
            points; None for one θ.
    """

    def projection(theta, vartheta):
        lumped_product = q.at_points(theta) * q.at_points(vartheta) + ufl.inner(
            second_moment * ufl.grad(theta), ufl.grad(vartheta)
        )
        return lumped_product - (ufl.det(dF) - 1.0) * q.at_points(vartheta)

    if zones is None:
        return q.sum(projection(volume_change, test))
    return q.sum(sum(chi * projection(volume_change[z], test[z]) for z, chi in enumerate(zones)))


def without_start_pressure(kirchhoff, chi: ufl.Coefficient, p_start: ufl.core.expr.Expr):
    """τ(F) + χ det F p̄ I: the law's Kirchhoff stress less the step's starting pressure p̄.

    Where χ = 1, p̄ is integrated by parts instead (:mod:`fe_mpm.pressure_by_parts`);
    NB-VA has no pressure field to split, so the points' stress gives it up.

    Args:
        kirchhoff: Callable F (g x g) -> τ (Pa, g x g), the law at the points.
        chi: χ of each point's cell (slot field, 1 or 0).
        p_start: p̄ at the points (Pa, compression positive).

    Returns:
        The callable F -> τ + χ det F p̄ I.
    """

    def reduced(F):
        g = ufl.shape(F)[0]
        return kirchhoff(F) + chi * ufl.det(F) * p_start * ufl.Identity(g)

    return reduced
