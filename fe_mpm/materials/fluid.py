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

**Its points keep no shape.** In the u-p forms the pressure field p holds the
volume, and a point's own det F, left to itself, drifts from the J = 1 − p/K the
field says: the points' volumes then no longer add up to the water's (Mast's tank
drain, measured: 0.62 of m/ρ after 1 s, single points compressed to J ≈ 0), and
water at rest churns. So after every step a fluid point keeps the isotropic
F = J^{1/g} I of its pressure, and its volume V₀ J (``keeps_shape = False``,
:func:`fe_mpm.point_update.keep_volume_of_pressure`); its stress needs no more (the
viscous term reads the step's ΔF). With point domains the same holds, each point
taking its pieces' mean J (until 2026-12-07 it kept its corners' map: a slosh's
points' det F left their pressure's by 0.4 % in 0.3 s and its surface blew up).
NB-VA (``"u-nbva"``) has no pressure field: there a fluid point keeps the
isotropic F of the points' volume changes averaged at its place, their det F
projected onto the nodes mass weighted and read back
(:func:`fe_mpm.point_update.volume_of_average`), so that its pressure, the law's at
that volume, is as smooth as a field. Measured 2026-12-05: with each point's own
volume a vortex under gravity in a closed tank gained 193 times its energy in 0.5 s
(``benchmarks/fluid_energy.py --formulation u-nbva``, 40 cells across, the pressure's
usual form; 230 000 times on 20 cells with the starting pressure by parts,
``tests/test_fluid.py``) and the dam break threw a point out of its tank; with the
average and the starting pressure by parts (:mod:`fe_mpm.pressure_by_parts`) the
vortex keeps its energy (1.000 after 0.5 s; 0.996 on 20 cells) and the dam break
passes its check. With point domains in NB-VA the pieces take the averaged volume
and their points keep it (no pressure by parts then; until 2026-12-07 with their
corners' shape):
water at rest 0.79 % of ρ g h₀ off hydrostatic at 4e-6 m/s after 100 steps, the
20-cell closed vortex 0.79 of its energy after 0.5 s (u-p with domains 1.07; `/tmp`
scripts around ``tests/test_fluid.py``'s scenes, 2026-12-05).

**It runs without PPP**, the default of ``Simulation`` for a law that keeps no shape
(``ppp_alpha=1`` turns it on). The u-p form's
stabilisation penalises the pressure's variation inside each cell, the hydrostatic
gradient too, at the scale α/G*; a fluid has no shear modulus, so ``shear_scale`` G*
(Pa) stands in for it, and the smaller G* the harder PPP resists hydrostatics.
Measured 2026-12-05 on a column of water filling a tank as wide as itself
(h₀ = 0.114 m, 7 × 14 cells, 12 points per triangle, Δt = 1 ms, Bossak −0.3, started
unstressed): with PPP (G* = 2ρ₀gh₀) the water moves at 0.14–0.20 m/s after 40 steps,
with the rule above or without (without it 0.64 m/s after 200 steps, its points' det F
spread to 0.07–2.7); without PPP and without the rule the motion grows from 1e-5 to
0.3 m/s in 160 steps and the run stops; with
the rule and without PPP it stays at rest (1.5e-5 m/s after 200 steps, point pressures
within 0.4 % of ρ₀ g h₀ of hydrostatic). In 3D the same (water 0.1 m deep in a
0.1 m square box of tetrahedra, 5 × 5 × 7 cubes, 4 points per tetrahedron, 100 steps):
1.7e-5 m/s, against 0.35 m/s and det F spread to 0.54–1.53 with PPP and the points'
own volumes. Martin & Moyce's dam break
(``demos/dam_break.py``) then keeps its front and comes nearer the film's height on
every grid checked (see the demo), and Mast's tank drain keeps its volume and runs on
every grid (``benchmarks/tank_drain.py``; its discharge does not converge yet, see
``docs/limitations.md``). With PPP and the rule together the dam break's front runs
25 % ahead. ``shear_scale`` still sets a
rigid wall's default penalty, and PPP's scale if ``ppp_alpha`` > 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import ufl

from fe_mpm.materials.elastic import CheckedFields, embed_3d, in_plane
from fe_mpm.materials.state import HistoryField, PointState


@dataclass(frozen=True)
class NewtonianFluid(CheckedFields):
    """A nearly incompressible viscous fluid: water, a slurry, a debris flow's liquid.

    Args:
        bulk_modulus: Bulk modulus K (Pa), > 0 (water: 2.0e9).
        viscosity: Dynamic viscosity μ_v (Pa·s), ≥ 0 (water: 1.0e-3).
        shear_scale: G* (Pa), > 0, in place of a shear modulus, or None (the
            default) where nothing needs it. It sets a rigid wall's default penalty,
            the u-p form's PPP term (α/G*) if PPP is turned on (off by default for a
            fluid, see above) and the ghost penalty's scale; a scene that needs it
            without it stops at set-up, naming it. The demos take 2 ρ₀ g h₀.
        density: Reference mass density ρ₀ (kg/m³), > 0, or None to take it from the
            points (``seed(..., density=...)``).
    """

    bulk_modulus: float
    viscosity: float
    shear_scale: float | None = None
    density: float | None = None
    #: In the u-p forms the points keep the isotropic F of their pressure (above).
    keeps_shape: ClassVar[bool] = False

    def __post_init__(self) -> None:
        self._check("bulk_modulus", lo=0.0, lo_open=True)
        self._check("viscosity", lo=0.0)
        if self.shear_scale is not None:
            self._check("shear_scale", lo=0.0, lo_open=True)
        self._check_density()

    @property
    def mu(self) -> float:
        """G* (Pa), which stands for a shear modulus (the PPP scale).

        Raises:
            ValueError: No ``shear_scale`` was given.
        """
        if self.shear_scale is None:
            raise ValueError(
                "NewtonianFluid: this scene needs shear_scale (G*, Pa, > 0), which stands "
                "for the shear modulus a fluid lacks: a RigidWall without a penalty of its "
                "own, ppp_alpha > 0 or a ghost penalty scale by it (point_domains=True "
                "takes a weak ghost penalty by default, ghost_penalty=0 none). Give it, e.g. "
                "NewtonianFluid(..., shear_scale=2 * rho * g * depth) as the demos do."
            )
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
