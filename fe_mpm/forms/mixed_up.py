r"""Mixed displacement–pressure (u-p) form with Polynomial Pressure Projection (PPP).

Iaconeta (2019) Ch. 5. The unknowns of a step are the grid displacement
increment :math:`\Delta u` and the grid pressure :math:`p` at :math:`t_{n+1}`
(positive in compression). The stress splits as (thesis Eq. 3.44)

.. math::  \tau = -J p\, I + \mu\, \mathrm{dev}(\bar b), \qquad \bar b = J^{-2/3} F F^T,

with the volumetric law :math:`U(J) = \tfrac12 (J-1)^2`, i.e. :math:`p = -K (J-1)`.
The step is written against the grid at :math:`t_n` as in
:mod:`fe_mpm.forms.displacement`:

.. math::

    R_u &= \sum_p V_p^n \frac{\tau \Delta F^{-T}}{J_n} : \nabla w - (\text{loads}), \\
    R_p &= -\sum_p V_p^{n+1}\, q \Big[(J - 1) + \frac{p}{K}\Big]
           - \frac{\alpha}{\mu} \sum_K \phi_K \int_K (q - \Pi_0 q)(p - \Pi_0 p)\, dx .

**Units.** The volumetric equation is written in strain units, i.e. divided by
the bulk modulus K, as Kratos does. Thesis Eq. 5.16 instead adds
:math:`(\alpha/G)(q p - \tilde q \tilde p)` to the stress-unit term
:math:`q(\sigma_m - p)`; as printed the two do not match, and PPP then comes out
about K/G times too weak. Here both terms are dimensionless.

**PPP.** Dohrmann–Bochev project the pressure onto cell-wise constants. For P1 on
an affine cell, :math:`(q - \Pi_0 q)(x) = \nabla q \cdot (x - x_c)` with
:math:`x_c` the centroid, so the term is the single exact integral
:math:`\int_K (\nabla q \cdot (x-x_c))(\nabla p \cdot (x-x_c))\,dx` (degree-2 rule). It is
deliberately *not* written as ``c*q*p*dx(degree=2) - c*q*p*dx(degree=1)``. With
``p`` from a split mixed function, that difference assembled to zero in the
residual while the Jacobian kept it (the form compiler merges identical
integrands), and Newton converged linearly to the unstabilised answer. The
Taylor tests guard against this. :math:`\phi_K` is the fraction of the cell
filled by material points (their volume at :math:`t_n` over :math:`|K|`), so
partly filled cells are stabilised in proportion.

**α.** The thesis states α = 1. Kratos MPM, the thesis group's code, multiplies
it by a default factor of 8 in 2D and 10 in 3D. With that effective value and
the strain-unit scaling, a P1/P1 prototype reproduced the Kratos UP+PPP column
of Cook's membrane to four digits. So :func:`effective_alpha` returns
``alpha * (8 in 2D, 10 in 3D)``, and ``alpha = 1`` is what reproduces the thesis.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import ufl

from fe_mpm._dolfinx import dolfinx
from fe_mpm.forms.loads import external_work, start_pressure_by_parts
from fe_mpm.materials import embed_3d
from fe_mpm.materials.protocol import checked_stress
from fe_mpm.quadrature import OCCUPIED, MaterialPointQuadrature
from fe_mpm.transfer import summed_over_ranks

#: Kratos MPM's factor on the PPP α, by geometric dimension.
KRATOS_PPP_FACTOR = {2: 8.0, 3: 10.0}


def effective_alpha(alpha: float, gdim: int) -> float:
    """The PPP coefficient used in the form: thesis α times Kratos's factor."""
    return alpha * KRATOS_PPP_FACTOR[gdim]


@dataclass
class PPPData:
    """Per-cell data of the PPP term.

    Attributes:
        alpha_eff: Effective α (dimensionless, a constant of the forms so that a new α
            compiles nothing), see :func:`effective_alpha`.
        centroid: DG0 vector field of cell centroids x_c (m).
        fill: DG0 field φ_K, volume of the cell's points over the cell volume.
        dx: Cell measure with a degree-2 rule over the occupied cells.
    """

    alpha_eff: dolfinx.fem.Constant
    centroid: ufl.Coefficient
    fill: ufl.Coefficient
    dx: ufl.Measure

    @classmethod
    def on_grid(cls, mesh, centroids: np.ndarray, alpha: float) -> PPPData:
        """The PPP data of a grid with cell centroids (cells, g) in m, thesis α ≥ 0."""
        g = mesh.geometry.dim
        centroid, dx2 = _cell_centroids_and_measure(mesh, centroids)
        fill = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("DG", 0)), name="fill")
        alpha_eff = dolfinx.fem.Constant(mesh, np.float64(effective_alpha(alpha, g)))
        return cls(alpha_eff, centroid, fill, dx2)


#: The pressure floor's share of the points' own volumetric term V_p/K. It only has
#: to make the pressure's unseen combinations definite. Measured on a dam break
#: against a downstream ``RigidWall`` (lumped mass, Δt = 1 ms) with the floor in
#: every occupied cell: a share of 7e-7 left the wall forces unchanged to 1e-6 until
#: the surge reached the wall, 7e-4 moved the wall's peak force by 3 %, and 1 in the
#: blind cells alone by half.
PRESSURE_FLOOR = 1e-6

#: A cell's points fix a linear pressure in it when the smallest eigenvalue of their
#: volume-weighted barycentric moments Σ V_p λ_p λ_pᵀ / Σ V_p is at least this: 1/12
#: for the three points of a seeded triangle, 0 for one or two points, or for
#: points on one line.
BLIND_CELL_MOMENT = 1e-2


@dataclass
class PressureFloor:
    r"""Per-cell data of the pressure floor of a u-p form without PPP.

    At the points the P1 pressure is seen only through its values there
    (:math:`V_p\, q\, p/K` and :math:`p\,\nabla\cdot w`). A cell that holds fewer
    than g + 1 points, or points on one line, leaves combinations of its nodal
    pressures that vanish at all of them. Where no other cell fixes those nodes (the
    tip of a jet, a drop, a film climbing a wall) the Jacobian is singular, the
    direct solver puts pressures of 1e10–1e20 Pa on them, and their round-off keeps
    Newton's residual from falling (a dam break against a ``RigidWall`` stopped so
    at t = 0.231 s). In those cells only (:func:`floor_weights`) the floor adds

    .. math:: -\epsilon\,\frac{\sum_{p\in K} V_p/K_p}{\sum_{p\in K} V_p}
              \int_K (\nabla q\cdot(x - x_c))(\nabla p\cdot(x - x_c))\,dx,

    PPP's term with the bulk modulus in place of the shear modulus, as for a full
    cell, and ε = :data:`PRESSURE_FLOOR`: a millionth of a full cell's own term,
    enough to make the unseen combinations definite, too little to move a pressure
    the neighbouring cells fix. It is weighted as for a full cell because a sliver
    of a point domain in a cell still sees the opposite node, a little: weighted by
    the sliver's volume, a drop with domains kept nodal pressures of 2e8 Pa. Cells
    whose points fix a linear pressure get nothing, so a hydrostatic or geostatic
    pressure, which PPP would resist, stays exact where every cell holds g + 1
    spread points; where every cell is blind (one point per cell, point domains) it
    is kept to about ε of its variation across a cell (a geostatic layer with one
    point per cell: σ_yy to 8e-9 of ρ g H).

    Attributes:
        centroid: DG0 vector field of cell centroids x_c (m).
        weight: DG0 field ε Σ_p (V_p / K_p) / Σ_p V_p in blind cells, else 0 (1/Pa),
            packed each step.
        dx: Cell measure with a degree-2 rule over the occupied cells.
    """

    centroid: ufl.Coefficient
    weight: ufl.Coefficient
    dx: ufl.Measure

    @classmethod
    def on_grid(cls, mesh, centroids: np.ndarray) -> PressureFloor:
        """The floor's data on a grid with cell centroids (cells, g) in m."""
        centroid, dx = _cell_centroids_and_measure(mesh, centroids)
        weight = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("DG", 0)), name="floor")
        return cls(centroid, weight, dx)


def floor_weights(
    cell: np.ndarray,
    bary: np.ndarray,
    volume: np.ndarray,
    compliance: np.ndarray,
    cell_map,
    num_cells: int,
) -> np.ndarray:
    """This rank's share of each cell's :class:`PressureFloor` weight, (num_cells,) in 1/Pa.

    A cell is blind where its points' moments Σ V_p λ_p λ_pᵀ / Σ V_p fall below
    :data:`BLIND_CELL_MOMENT` (empty cells are not); there its weight is
    ε Σ_p (V_p/K_p) / Σ_p V_p, as for a full cell, elsewhere 0. Under MPI with point
    domains a cell may hold pieces of two ranks: the moments and volumes are summed
    over the ranks before a cell is judged, and each rank packs its own points'
    compliance over the cell's whole volume, so that the ranks' shares add up to the
    serial weight (judged on each rank's share, a cell holding a sliver on one rank
    got the floor twice: nodal pressures 0.2 % off the serial run's, a helper's
    drop on two ranks, 2026-12-06).

    Args:
        cell: Each point's cell (n,), local (owned or ghost).
        bary: Its barycentric coordinates there (n, g + 1).
        volume: Its volume (n,), m³ (m² in 2D).
        compliance: Its V_p / K_p (n,), m³/Pa (m²/Pa in 2D).
        cell_map: The grid's cell index map.
        num_cells: Cells the weights are wanted for (owned, and ghosts where packed).
    """
    k = bary.shape[1]
    n_all = cell_map.size_local + cell_map.num_ghosts
    moments = (volume[:, None, None] * bary[:, :, None] * bary[:, None, :]).reshape(-1, k * k)
    # One bincount per column: 2.4 times faster than np.add.at on 200k points.
    columns = [np.bincount(cell, weights=moments[:, j], minlength=n_all) for j in range(k * k)]
    sums = np.stack([*columns, np.bincount(cell, weights=volume, minlength=n_all)], axis=1)
    sums = summed_over_ranks(cell_map, sums)[:num_cells]
    total = sums[:, -1]
    held = np.flatnonzero(total > 0.0)
    smallest = np.linalg.eigvalsh(sums[held, :-1].reshape(-1, k, k) / total[held, None, None])
    blind = held[smallest[:, 0] < BLIND_CELL_MOMENT]
    weight = np.zeros(num_cells)
    own = np.bincount(cell, weights=compliance, minlength=n_all)[:num_cells]
    weight[blind] = PRESSURE_FLOOR * own[blind] / total[blind]
    return weight


def _cell_centroids_and_measure(mesh, centroids: np.ndarray) -> tuple:
    """A DG0 field of the cell centroids (cells, g) and the occupied cells' degree-2 dx."""
    g = mesh.geometry.dim
    dg0_vec = dolfinx.fem.functionspace(mesh, ("DG", 0, (g,)))
    centroid = dolfinx.fem.Function(dg0_vec, name="centroid")
    cells = np.arange(centroids.shape[0])
    centroid.x.array.reshape(-1, g)[dg0_vec.dofmap.list[cells, 0]] = centroids
    centroid.x.scatter_forward()  # given for owned cells; the ghosts' too are integrated
    # In the material-point subdomain, so one kernel does both; the per-cell
    # weights are packed per entity (zero on a cell's copies), so each cell counts
    # once; under MPI each rank packs its own points' share of a cell's weight.
    dx2 = ufl.Measure("dx", domain=mesh, subdomain_id=OCCUPIED, metadata={"quadrature_degree": 2})
    return centroid, dx2


def _within_cell_product(q_test, p, centroid) -> ufl.core.expr.Expr:
    """(q − Π₀q)(p − Π₀p) of P1 fields on an affine cell: (∇q·(x − x_c))(∇p·(x − x_c))."""
    r = ufl.SpatialCoordinate(ufl.domain.extract_unique_domain(centroid)) - centroid
    return ufl.dot(ufl.grad(q_test), r) * ufl.dot(ufl.grad(p), r)


def stress_parts(material, F: ufl.core.expr.Expr, p: ufl.core.expr.Expr, state=None):
    """Kirchhoff stress τ = −J p I + dev τ (the material's) of shape g x g, and J = det F."""
    J = ufl.det(embed_3d(F))
    g = ufl.shape(F)[0]
    deviator = material.kirchhoff_deviatoric(F, state)
    return -J * p * ufl.Identity(g) + checked_stress(
        material, "kirchhoff_deviatoric", deviator, F
    ), J


def point_terms(material, dF, F_n, p_p, state=None, p_stress=None):
    """What a point puts against ∇w and against q in :func:`residual`.

    ``(τ ΔF⁻ᵀ / det F_n, det ΔF · e)`` at the point's increment ``dF`` (g x g), with e
    the volumetric equation in strain units, (J − 1) + p/K or a pressure-dependent
    law's own (with its plastic volume change, :mod:`fe_mpm.materials.mixed_return`).
    ``p_stress``: the pressure in τ, if not ``p_p`` (the part of it not integrated by
    parts, :mod:`fe_mpm.pressure_by_parts`); the volumetric equation keeps ``p_p``.
    """
    zones = getattr(material, "zones", None)
    if zones is not None:  # several laws (fe_mpm.materials.zones): each at its own points
        terms = [
            (chi, point_terms(law, dF, F_n, p_p, own, p_stress)) for chi, law, own in zones(state)
        ]
        return sum(chi * t[0] for chi, t in terms), sum(chi * t[1] for chi, t in terms)
    F = dF * F_n
    tau, J = stress_parts(material, F, p_p if p_stress is None else p_stress, state)
    volumetric = getattr(material, "volumetric_equation", lambda state: None)(state)
    if volumetric is None:
        volumetric = (J - 1.0) + p_p / material.bulk_modulus
    return tau * ufl.inv(dF).T / ufl.det(F_n), ufl.det(dF) * volumetric


def residual(
    du: ufl.core.expr.Expr,
    p: ufl.core.expr.Expr,
    w: ufl.core.expr.Expr,
    q_test: ufl.core.expr.Expr,
    mpq: MaterialPointQuadrature,
    F_n: ufl.Coefficient,
    density: ufl.Coefficient,
    material,
    ppp: PPPData | None,
    body_force: ufl.core.expr.Expr | None = None,
    tractions: Sequence[tuple[ufl.core.expr.Expr, ufl.Measure]] = (),
    u_degree: int = 1,
    state=None,
    increment: ufl.core.expr.Expr | None = None,
    by_parts: tuple[ufl.Coefficient, ufl.Coefficient] | None = None,
    floor: PressureFloor | None = None,
) -> ufl.Form:
    """Residual of one static u-p step.

    Args:
        du: Grid displacement increment Δu (m), degree ``u_degree``.
        p: Grid pressure at t_{n+1} (Pa, compression positive), P1.
        w: Displacement test function.
        q_test: Pressure test function.
        mpq: Material-point quadrature of this step.
        F_n: Deformation gradient of the points at t_n (slot field).
        density: Mass density of the points (kg/m³, slot field).
        material: A law with ``kirchhoff_deviatoric(F)`` and ``bulk_modulus`` (Pa).
        ppp: PPP data, or None for the unstabilised form.
        body_force: Body force per unit mass (m/s²), or None.
        tractions: Pairs (t̄, ds) of traction (Pa) and facet measure.
        u_degree: Polynomial degree of the displacement (1, or 2 for Taylor–Hood).
        state: The points' :class:`~fe_mpm.materials.PointState` (ΔF and history),
            for laws with internal variables.
        increment: The point's ΔF, if not the grid's at the point (the shared
            increment of a point domain's pieces, :mod:`fe_mpm.domains`).
        by_parts: ``(p̄, χ)``: the step's starting pressure (P1) and each point's
            cell's χ (slot field, 1 or 0); where χ = 1, p̄'s work on the grid of the
            step's start is integrated by parts and its geometric part kept at the
            points (:mod:`fe_mpm.pressure_by_parts`, whose facet terms complete it).
        floor: Without PPP, the :class:`PressureFloor` that keeps the pressure of
            cells with too few points definite, or None.
    """
    g = ufl.shape(du)[0]
    dF = ufl.Identity(g) + mpq.grad_at_points(du, u_degree) if increment is None else increment
    p_p = mpq.at_points(p)
    p_stress = None
    if by_parts is not None:
        p_start, chi = by_parts
        p_stress = p_p - chi * mpq.at_points(p_start)
    stress, volume = point_terms(material, dF, F_n, p_p, state, p_stress)
    R = mpq.sum(ufl.inner(stress, mpq.grad_at_points(w, u_degree)))
    if by_parts is not None:
        R += start_pressure_by_parts(w, mpq, chi, p_start, dF, u_degree)
    R -= mpq.sum(volume * mpq.at_points(q_test))
    if ppp is not None:
        within = _within_cell_product(q_test, p, ppp.centroid)
        R -= (ppp.alpha_eff / material.mu) * ppp.fill * within * ppp.dx
    if floor is not None:
        R -= floor.weight * _within_cell_product(q_test, p, floor.centroid) * floor.dx
    loads = external_work(w, mpq, density, body_force, tractions, u_degree)
    return R if loads is None else R - loads


def cauchy_stress_3d(material, F: ufl.core.expr.Expr, p: ufl.core.expr.Expr, state=None):
    """Full 3x3 Cauchy stress σ = −p I + dev τ/J (Pa), σ_33 included in plane strain."""
    F3 = embed_3d(F)
    J = ufl.det(F3)
    return -p * ufl.Identity(3) + material.kirchhoff_deviatoric(F3, state) / J
