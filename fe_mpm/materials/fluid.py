r"""Mast's nearly incompressible Newtonian fluid (Mast 2013, Eq. 6.1).

The Cauchy stress is a bulk term in the volume change and a viscous term in the rate
of deformation :math:`d = \operatorname{sym} \nabla v`:

.. math::  \sigma = -p\, I + 2 \mu_v\, \operatorname{dev} d, \qquad p = -K (J - 1),

with the volumetric law :math:`U(J) = \tfrac12 K (J-1)^2` of the u-p forms (Mast
writes :math:`\rho \bar k \hat\theta`, the same to first order in the dilation
:math:`\hat\theta = J - 1`). The viscous term is deviatoric here, so the fluid has no
bulk viscosity; Mast's :math:`2\mu d` adds :math:`\tfrac23 \mu_v \operatorname{tr} d`
to the pressure, nothing against K for water.

**The rate over one step.** An implicit step knows the increment :math:`\Delta F` over
the step's length :math:`\Delta t`. The velocity gradient in the configuration at
:math:`t_{n+1}` is taken as the backward difference
:math:`L = (I - \Delta F^{-1}) / \Delta t` (:math:`= \nabla_{x_{n+1}} \Delta u / \Delta t`),
so :math:`d = \operatorname{sym} L`. The step's length reaches the law as
``PointState.step_length``.

**The PPP scale.** The u-p form's stabilisation is :math:`\alpha/G` times a pressure
jump term, with G the law's shear modulus. A fluid has none, so ``shear_scale`` G*
(Pa) stands in for it (and sets a rigid wall's default penalty): the smaller G*,
the stronger the projection. Choose a pressure scale of the flow. Measured on
Martin & Moyce's dam break (``demos/dam_break.py --shear-scale``, h₀ = 0.114 m,
cells of 8.2 mm, Δt = 1 ms), whose hydrostatic pressure at the base is
ρ₀ g h₀ = 1.1 kPa: G* = 1, 2.2 and 10 kPa put the surge front within 1.7 % of one
another; 300 Pa holds the flow back (front up to 8 % slower, height 5 % lower);
with 1 MPa the pressure is left almost free and the points pile up in one cell
(more than 256) at T = 1.9. The demo takes the surge's stagnation pressure ρ₀ v²
with v = √(2 g h₀), 2.2 kPa.
"""

from __future__ import annotations

from dataclasses import dataclass

import ufl

from fe_mpm.materials.elastic import CheckedFields, embed_3d, in_plane
from fe_mpm.materials.state import HistoryField, PointState


@dataclass(frozen=True)
class NewtonianFluid(CheckedFields):
    """A nearly incompressible viscous fluid: water, a slurry, a debris flow's liquid.

    Args:
        bulk_modulus: Bulk modulus K (Pa), > 0 (water: 2.0e9).
        viscosity: Dynamic viscosity μ_v (Pa·s), ≥ 0 (water: 1.0e-3).
        shear_scale: G* (Pa), > 0, in place of a shear modulus: it scales the u-p
            form's PPP term (α/G*) and the walls' default penalty (see above).
        density: Reference mass density ρ₀ (kg/m³), > 0, or None to take it from the
            points (``seed(..., density=...)``).
    """

    bulk_modulus: float
    viscosity: float
    shear_scale: float
    density: float | None = None

    def __post_init__(self) -> None:
        self._check("bulk_modulus", lo=0.0, lo_open=True)
        self._check("viscosity", lo=0.0)
        self._check("shear_scale", lo=0.0, lo_open=True)
        self._check_density()

    @property
    def mu(self) -> float:
        """G* (Pa), which stands for a shear modulus (the PPP scale)."""
        return self.shear_scale

    @property
    def history(self) -> dict[str, HistoryField]:
        """A Newtonian fluid has no internal variables: its stress is the step's rate."""
        return {}

    def kirchhoff(self, F: ufl.core.expr.Expr, state: PointState | None) -> ufl.core.expr.Expr:
        """Kirchhoff stress ``τ = K J (J − 1) I + 2 J μ_v dev d`` (Pa), shape of ``F``."""
        g = ufl.shape(F)[0]
        J = ufl.det(embed_3d(F))
        return self.bulk_modulus * J * (J - 1.0) * ufl.Identity(g) + self.kirchhoff_deviatoric(
            F, state
        )

    def kirchhoff_deviatoric(
        self, F: ufl.core.expr.Expr, state: PointState | None
    ) -> ufl.core.expr.Expr:
        """The viscous Kirchhoff stress ``2 J μ_v dev d`` (Pa), shape of ``F``.

        ``dev`` is taken in 3D, with ``d_33 = 0`` in plane strain.
        """
        if state is None or state.step_length is None:
            raise ValueError(
                "NewtonianFluid: the stress needs the step's increment and length "
                "(PointState.dF and step_length); it has no value at rest"
            )
        dF = state.dF
        g = ufl.shape(dF)[0]
        L = (ufl.Identity(g) - ufl.inv(dF)) / state.step_length
        d = 0.5 * (L + L.T)
        if g == 2:  # plane strain: no rate out of the plane
            d = ufl.as_matrix([[d[0, 0], d[0, 1], 0.0], [d[1, 0], d[1, 1], 0.0], [0.0, 0.0, 0.0]])
        J = ufl.det(embed_3d(F))
        tau = 2.0 * J * self.viscosity * ufl.dev(d)
        return in_plane(tau, ufl.shape(F)[0])

    def updated_history(self, F: ufl.core.expr.Expr, state: PointState) -> dict:
        """No internal variables."""
        return {}
