r"""A fluid's pressure at the step's start, integrated by parts where cells are full.

A point that crosses a facet moves its share :math:`V_p\,p` of the pressure's force
:math:`-\int p\,\nabla\cdot w` from one cell's shape-function gradients to the next's at
once: a jump of about :math:`V_p\,p/h` on the nodes. A solid's shear stiffness takes
it up; a fluid has none, the jumps do work, and water under its own hydrostatic
pressure speeds up as its points cross (``benchmarks/fluid_energy.py``: a gentle
vortex in a closed tank gains 186 times its kinetic energy in a second).

The pressure is split into :math:`\bar p`, the points' pressures at the step's start
projected onto the nodes, and the rest. In the cells whose every vertex is shared only
with occupied cells (χ = 1: the fluid's inside, away from its free surface),
:math:`\bar p` is integrated by parts, cell by cell,

.. math:: -\int_T \bar p\,\nabla\cdot w = \int_T w\cdot\nabla\bar p
          - \oint_{\partial T} \bar p\, w\cdot n,

the volume term at the points (its integrand barely jumps across a facet where the
pressure is smooth) and the facet terms exactly; between two such cells they cancel,
so only the facets on the boundary of the χ = 1 region remain,
:math:`-\int_F \bar p\, w\cdot[\![\chi n]\!]`. The rest, :math:`p - \chi\bar p`, keeps
the usual form. With exact quadrature the sum is the usual residual at the step's
start (Δu = 0) for any :math:`\bar p`, so water at rest stays in balance; the cells
at the free surface, partly filled, keep the usual form, and their pressure is
small.

The points are not an exact rule: where they do not fill a cell, :math:`\sum_p V_p
\ne |T|`, the split puts a net force :math:`(\sum_p V_p - |T|)\nabla\bar p` on the
cell's nodes that the usual form does not. While :math:`\nabla\bar p` is the
weight's :math:`\rho\mathbf b` the points' own mass balances it, but at an impact it
is not: a drop thrown onto a floor had cells filled from 26 to 133 % under gradients
of 4e7 Pa/m, and one step added 45 % of its energy (2026-12-06). So a cell also
needs :math:`|\sum_p V_p - |T||\,|\nabla\bar p - \rho\mathbf b| \le` :data:`SPLIT_FORCE`
:math:`|T|\rho|\mathbf b|` to take χ = 1 (:meth:`PressureByParts.update`): the
vortex and the slosh of ``benchmarks/fluid_energy.py`` keep their energies to the
digits printed, and the drop gains at most 2.9 % in a step (1.9 % without the
split). Without a body force the bound is 0: the split then acts only in cells
whose points fill them exactly or where p̄ is uniform (a fluid's pressure without
gravity is small, and the usual form kept a vortex without gravity to 0.997).

Only the part of :math:`\bar p`'s work that does not depend on the step's Δu,
:math:`-\int\chi\bar p\,\nabla\cdot w` on the grid of the step's start, is taken
by parts: the facet vector is assembled once per step. Its geometric part,
:math:`-\chi\bar p\,(\det\Delta F\,\Delta F^{-T} - I) : \nabla w`, linear in Δu
and barely jumping as points cross facets, stays at the points
(:func:`fe_mpm.forms.loads.start_pressure_by_parts`). Until 2026-12-08 it was left
out, so that p̄ acted on the geometry of the step's start, a step late, and a dam break
gained energy at first order in the step (+3.0, +1.3, +0.6 % of the energy its collapse
frees with steps of 2, 1 and 0.5 ms; now −0.72 and −0.15 % with 2 and 1 ms).

In u-p the rest is :math:`p - \chi\bar p` with p the pressure field
(:func:`fe_mpm.forms.mixed_up.residual`). NB-VA (``"u-nbva"``) has no pressure
field: its pressure is the law's at each point's averaged volume, and :math:`\bar p`
the projection of the points' pressures; its points' Kirchhoff stress gives up
:math:`\chi\bar p` the same way, :math:`\tau + \chi J \bar p I`
(:func:`fe_mpm.forms.volume_average.without_start_pressure`); the geometric part
added back takes the grid's det ΔF, not the averaged det ΔF̄ given up: the two agree
at Δu = 0, and with ΔF̄ a closed vortex gained 13 % of its energy in 0.5 s.
"""

from __future__ import annotations

from petsc4py import PETSc

import dolfinx.fem.petsc as fem_petsc
import numpy as np
import ufl

from fe_mpm._dolfinx import dolfinx
from fe_mpm.formulations import GridFields
from fe_mpm.ghost import require_facet_ghosts
from fe_mpm.transfer import touched_nodes

#: A cell takes p̄ by parts while the net force this puts on its nodes beyond the
#: usual form's, ``|Σ V_p − |T|| |∇p̄ − ρ b|``, is at most this share of its weight
#: ``|T| ρ |b|``. Measured (2026-12-06): 0.01 let the closed vortex of
#: ``tests/test_fluid.py`` gain 17.6-fold (the projected p̄'s own noise exceeds it);
#: 0.3 and 1 keep the benchmark's energies unchanged and the drop's impact tame.
SPLIT_FORCE = 1.0


class PressureByParts:
    """The χ = 1 cells of a step and the facet terms of p̄ on their boundary.

    Args:
        fields: The grid unknown of a mixed formulation (u-p or NB-VA); its
            ``p_start`` holds p̄ once :meth:`GridFields.start_from_rest` has run.

    Attributes:
        chi: χ as a DG0 function (owned and ghost cells), for the facet terms.
        vector: The facet terms (a PETSc vector over the grid unknown): added to
            every residual of the step.
    """

    def __init__(self, fields: GridFields):
        mesh = fields.W.mesh
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        require_facet_ghosts(
            mesh, "a fluid's pressure by parts (pressure_by_parts; False goes without it)"
        )
        self._nodes = fields.Q[0]
        self._num_cells = mesh.topology.index_map(tdim).size_local
        self.chi = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("DG", 0)), name="chi")
        w = ufl.TestFunctions(fields.W)[0]
        n = ufl.FacetNormal(mesh)
        p0 = fields.p_start
        facets = -p0("+") * ufl.dot(w("+"), ufl.jump(self.chi, n)) * ufl.dS
        facets -= self.chi * p0 * ufl.dot(w, n) * ufl.ds
        self._form = dolfinx.fem.form(facets)
        centre = np.full((1, tdim), 1.0 / (tdim + 1))  # ∇p̄ is constant in a P1 cell
        self._gradient = dolfinx.fem.Expression(ufl.grad(p0), centre)
        self._cells = np.arange(self._num_cells, dtype=np.int32)
        self.vector = fem_petsc.create_vector(fields.W)

    def update(
        self,
        occupied: np.ndarray,
        cell: np.ndarray,
        volume: np.ndarray,
        mass: np.ndarray,
        cell_volumes: np.ndarray,
        body_force: np.ndarray,
    ) -> np.ndarray:
        """χ of every owned cell from the cells that hold points on this rank.

        Call it once p̄ is projected. Where the points do not fill a cell, ``Σ V_p ≠ |T|``,
        the cell's part of the split puts a net force ``(Σ V_p − |T|) ∇p̄`` on its nodes
        that the usual form does not: harmless while ∇p̄ is the weight's ρ b, which the
        points' own mass balances, but at an impact, where ∇p̄ reached 4e7 Pa/m in
        cells filled from 26 to 133 %, it threw a drop's points out at 14 m/s and
        added 45 % of its energy in one step (a helper's scene, 2026-12-06). Such a
        cell keeps the usual form: χ = 0 where ``|Σ V_p − |T|| |∇p̄ − ρ b|`` exceeds
        :data:`SPLIT_FORCE` × ``|T| ρ |b|``.

        Args:
            occupied: This rank's owned cells that hold points (local indices).
            cell: Each point's cell (n,).
            volume: The points' volumes (n,), m³ (m² in 2D).
            mass: Their masses (n,), kg.
            cell_volumes: Every cell's volume ``|T|`` (owned first), m³ (m² in 2D).
            body_force: The body force b (g,), m/s².

        Returns:
            χ (owned cells,) as bool: occupied, no vertex shared with an empty cell
            of any rank, and the split's net force within its bound.
        """
        empty = np.ones(self._num_cells, dtype=bool)
        empty[occupied] = False
        bordering = touched_nodes(self._nodes, np.flatnonzero(empty))
        vertices = self._nodes.dofmap.list[: self._num_cells]
        interior = ~empty & ~bordering[vertices].any(axis=1)
        n = self._num_cells
        held = np.bincount(cell, weights=volume, minlength=n)[:n]
        weight = np.bincount(cell, weights=mass, minlength=n)[:n]
        density = weight / np.where(held > 0.0, held, 1.0)
        gradient = self._gradient.eval(self._nodes.mesh, self._cells).reshape(n, -1)
        dynamic = np.linalg.norm(gradient - density[:, None] * body_force, axis=1)
        excess = np.abs(held - cell_volumes[:n]) * dynamic
        interior &= excess <= SPLIT_FORCE * cell_volumes[:n] * density * np.linalg.norm(body_force)
        dofs = self.chi.function_space.dofmap.list[: self._num_cells, 0]
        self.chi.x.array[:] = 0.0
        self.chi.x.array[dofs] = interior
        self.chi.x.scatter_forward()  # the facets on a rank boundary see both sides
        return interior

    def assemble(self) -> PETSc.Vec:
        """The facet terms at the current p̄ (call after the initial guess)."""
        with self.vector.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(self.vector, self._form)
        self.vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return self.vector

    def destroy(self) -> None:
        """Free the PETSc vector."""
        self.vector.destroy()
