"""The grid unknowns of each formulation, and what the time loop needs from them.

=============  ===============  ==============================================
name           unknowns         against locking
=============  ===============  ==============================================
``u``          Δu (P1)          nothing (locks when nearly incompressible)
``u-nbva``     Δu (P1), θ (P1)  node-based volumetric averaging (Mast, NB-VA)
``up``         Δu (P1), p (P1)  pressure field, PPP (Dohrmann–Bochev)
``up-nostab``  Δu (P1), p (P1)  pressure field, no stabilisation
``up-p2p1``    Δu (P2), p (P1)  pressure field (Taylor–Hood)
=============  ===============  ==============================================

θ is the step's volume change averaged over each node's patch
(:mod:`fe_mpm.forms.volume_average`); a body of several laws averages each zone on
its own, with one θ per zone.

The weak forms themselves live in :mod:`fe_mpm.forms`.
"""

from __future__ import annotations

from dataclasses import dataclass

import basix.ufl
import numpy as np
import ufl

from fe_mpm._dolfinx import dolfinx
from fe_mpm.transfer import (
    mass_weighted_projection,
    nodal_sum_norm,
    touched_nodes,
)


@dataclass(frozen=True)
class FormulationSpec:
    """What distinguishes the formulations."""

    name: str
    u_degree: int
    pressure: bool
    ppp: bool
    #: Whether the second field is the averaged volume change θ (NB-VA) instead of p.
    volume_average: bool = False

    def min_points_per_cell(self, gdim: int) -> int:
        """Fewest material points an occupied cell may hold: the rank of the strain.

        P1: one. P2 on a triangle has 12 − 3 = 9 strain modes, three seen per point,
        so three; on a tetrahedron 30 − 6 = 24, six per point, so four (a tetrahedron
        of three points accepted as a triangle's was, until 2026-12-06, left a 3D
        column 8 % off in stress and 24 % in displacement; a helper's scene).
        """
        if self.u_degree == 1:
            return 1
        return 3 if gdim == 2 else 4

    @property
    def mixed(self) -> bool:
        """Whether a P1 scalar field (p or θ) joins Δu in the unknown."""
        return self.pressure or self.volume_average

    def multi_step_warning(self) -> str:
        """Why a P2 displacement is not yet trustworthy beyond its first step."""
        return (
            f"Simulation: {self.name!r} beyond its first step is not yet "
            "trustworthy: points away from their Gauss positions do not integrate "
            "the gradients of the P2 shape functions exactly, and a homogeneous "
            "stress then leaves spurious nodal forces (the patch test fails; see "
            "docs/formulations.md, 'P2/P1 once the points have moved'). Use "
            "point_domains=True, or 'up', for runs of many steps."
        )


FORMULATIONS = {
    "u": FormulationSpec("u", 1, pressure=False, ppp=False),
    "u-nbva": FormulationSpec("u-nbva", 1, pressure=False, ppp=False, volume_average=True),
    "up": FormulationSpec("up", 1, pressure=True, ppp=True),
    "up-nostab": FormulationSpec("up-nostab", 1, pressure=True, ppp=False),
    "up-p2p1": FormulationSpec("up-p2p1", 2, pressure=True, ppp=False),
}


class GridFields:
    """The unknown function of a step and its subspaces.

    Attributes:
        W: Space of the unknown (P1/P2 vector, or mixed displacement–pressure).
        w: The unknown: Δu, or (Δu, p), or (Δu, θ).
        du: UFL displacement increment (a view of ``w``).
        p: UFL pressure (a view of ``w``), or None.
        volume_change: UFL averaged volume change θ of the step (a view of
            ``w``, NB-VA): a scalar, or a vector of one θ per zone; or None.
        U: The displacement (sub)space, where Dirichlet conditions act.
        Q: The collapsed space of the scalar field (p, or the first zone's θ) and
            its dofs in ``W``, or None.
        second: The collapsed space of the whole second field (p, or every θ) and
            its dofs in ``W``, or None: what the output writes.
        p_start: The step's starting pressure p̄ (a P1 function on ``Q``), the
            projection of :meth:`start_from_rest`: in u-p, and in NB-VA (whose
            pressure is the law's at the points) where ``start_pressure`` asks for
            it; else None.

    Args:
        mesh: The background grid.
        spec: The formulation.
        start_pressure: Whether NB-VA needs p̄ (its starting pressure taken by
            parts, :mod:`fe_mpm.pressure_by_parts`); u-p always projects it.
        zones: The number of laws of the body. NB-VA averages the volume change of
            each zone over its own points: one average across an interface would
            give a stiff zone the soft one's volume change (a layered ground's
            stresses off by most of their value beside the interface).
    """

    def __init__(
        self,
        mesh: dolfinx.mesh.Mesh,
        spec: FormulationSpec,
        start_pressure: bool = False,
        zones: int = 1,
    ):
        self.spec = spec
        self.zones = zones if spec.volume_average else 1
        g = mesh.geometry.dim
        cell = mesh.topology.cell_name()
        u_el = basix.ufl.element("Lagrange", cell, spec.u_degree, shape=(g,))
        self.Q = self.second = None
        if spec.mixed:
            shape = (self.zones,) if self.zones > 1 else ()
            p_el = basix.ufl.element("Lagrange", cell, 1, shape=shape)
            self.W = dolfinx.fem.functionspace(mesh, basix.ufl.mixed_element([u_el, p_el]))
            self.U = self.W.sub(0)
            self.second = collapse(self.W.sub(1))
            self.Q = collapse(self.W.sub(1).sub(0)) if self.zones > 1 else self.second
        else:
            self.W = dolfinx.fem.functionspace(mesh, u_el)
            self.U = self.W
        self.w = dolfinx.fem.Function(self.W, name="unknown")
        self._scalar_element = basix.ufl.element("Lagrange", cell, spec.u_degree)
        self.p = self.volume_change = self.p_start = None
        if spec.mixed:
            self.du, scalar_field = ufl.split(self.w)
            if spec.pressure:
                self.p = scalar_field
            else:
                self.volume_change = scalar_field
            if spec.pressure or start_pressure:
                self.p_start = dolfinx.fem.Function(self.Q[0], name="p_start")
        else:
            self.du = self.w
        # Scalar subspaces, each collapsed once, to pin the dofs no point reaches.
        scalar = [self.U.sub(c) for c in range(g)]
        if spec.mixed:
            second = self.W.sub(1)
            scalar += [second.sub(z) for z in range(self.zones)] if self.zones > 1 else [second]
        self._pinnable = []
        for sub in scalar:
            collapsed, to_parent = collapse(sub)
            zero = dolfinx.fem.Constant(mesh, 0.0)
            self._pinnable.append((sub, collapsed, to_parent, zero))

    def displacement_dofs_of(self, cells: np.ndarray) -> np.ndarray:
        """The entries of Δu in ``w.x.array`` on ``cells`` (k,): (k, nodes, g)."""
        g = self.W.mesh.geometry.dim
        return np.stack(
            [
                to_parent[collapsed.dofmap.list[cells]]
                for _, collapsed, to_parent, _ in self._pinnable[:g]
            ],
            axis=2,
        )

    def scalar_dofs_of(self, cells: np.ndarray) -> np.ndarray:
        """The entries of p (or the first zone's θ) in ``w.x.array`` on ``cells`` (k,)."""
        g = self.W.mesh.geometry.dim
        _, collapsed, to_parent, _ = self._pinnable[g]
        return to_parent[collapsed.dofmap.list[cells]]

    def pin_unsupported(
        self, occupied: np.ndarray, zone_cells: list[np.ndarray] | None = None
    ) -> list[dolfinx.fem.DirichletBC]:
        """Zero conditions on every dof outside the occupied cells (they have no equation).

        Args:
            occupied: The cells that hold points.
            zone_cells: With one θ per zone, the cells that hold each zone's points:
                a zone's θ has no equation at the nodes none of its points reaches.
        """
        g = self.W.mesh.geometry.dim
        if self.zones > 1 and (zone_cells is None or len(zone_cells) != self.zones):
            raise ValueError(
                f"pin_unsupported: NB-VA keeps {self.zones} zones' θ, give their cells"
            )
        bcs = []
        for k, (sub, collapsed, to_parent, zero) in enumerate(self._pinnable):
            cells = zone_cells[k - g] if self.zones > 1 and k >= g else occupied
            # A node on a rank boundary is supported if a cell of either rank is occupied.
            supported = touched_nodes(collapsed, cells)
            bcs.append(dolfinx.fem.dirichletbc(zero, to_parent[~supported], sub))
        return bcs

    def displacement_at(
        self, cells: np.ndarray, bary: np.ndarray, values: np.ndarray | None = None
    ) -> np.ndarray:
        """Δu (n, g) in m at barycentric coordinates ``bary`` (n, g + 1) in ``cells`` (n,).

        P1 or P2; coordinates outside [0, 1] extrapolate the cell's polynomial.
        ``values``, an array shaped as ``w.x.array``, is read in place of Δu (the
        displacement field whose nodal values it holds).
        """
        if len(cells) == 0:  # (basix tabulates no empty set)
            return np.zeros((0, self.W.mesh.geometry.dim))
        if self.spec.u_degree == 1:
            basis = bary  # the P1 shape functions are the barycentric coordinates
        else:
            basis = self._scalar_element.tabulate(0, np.ascontiguousarray(bary[:, 1:]))[0]
        values = self.w.x.array if values is None else values
        nodal = values[self.displacement_dofs_of(cells)]  # (n, nodes, g)
        return np.einsum("nv,nvc->nc", basis, nodal)

    def start_from_rest(
        self, cells: np.ndarray, bary: np.ndarray, mass: np.ndarray, stress: np.ndarray
    ) -> None:
        """Newton's start: Δu = 0, and the pressure projected from the points (Eq. 5.20).

        ``p_I = Σ_p N_I(x_p) m_p p_p / Σ_p N_I(x_p) m_p``, mass weighted, with the
        point pressure ``p_p = −tr(σ_p)/3`` of the last step; also kept as
        :attr:`p_start`.

        Args:
            cells: The points' cells (n,).
            bary: Their barycentric coordinates there (n, g + 1).
            mass: Their masses (n,) in kg.
            stress: Their Cauchy stresses (n, 3, 3) in Pa.
        """
        self.w.x.array[:] = 0.0
        if self.p_start is not None:
            p_p = -np.trace(stress, axis1=1, axis2=2) / 3.0
            nodal, _ = mass_weighted_projection(self.Q[0], cells, bary, mass, p_p[:, None])
            if self.spec.pressure:
                self.set_pressure(nodal[:, 0])
            self.p_start.x.array[:] = nodal[:, 0]

    def pressure_volume(self, cells: np.ndarray, bary: np.ndarray, volume: np.ndarray) -> float:
        """‖V‖: the points' volumes (n,) gathered on the scalar field's nodes (m³; m² in 2D).

        The scale of the rows of the pressure (or θ) in the Newton test, whose
        equations are volume × strain; 0 without a scalar field.
        """
        if not self.spec.mixed:
            return 0.0
        return nodal_sum_norm(self.Q[0], cells, bary, volume)

    def set_pressure(self, values: np.ndarray) -> None:
        """Write nodal pressures (P1 dof order of :attr:`Q`) into ``w``."""
        self.w.x.array[self.Q[1]] = values

    def pressure_values(self) -> np.ndarray:
        """Nodal pressures of ``w`` in the P1 dof order of :attr:`Q`."""
        return self.w.x.array[self.Q[1]].copy()


def collapse(sub: dolfinx.fem.FunctionSpace) -> tuple[dolfinx.fem.FunctionSpace, np.ndarray]:
    """A subspace as a space of its own, and the parent dof of each of its dofs."""
    space, maps = sub.collapse()
    return space, np.asarray(maps[0] if isinstance(maps, list) else maps, dtype=np.int32)


def constrained_space(U: dolfinx.fem.FunctionSpace, component: int | None):
    """The (sub)space a Dirichlet condition acts on, and whether it is a subspace."""
    target = U if component is None else U.sub(component)
    return target, len(target.component()) > 0
