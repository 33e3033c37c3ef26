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

The :math:`\bar p` part is taken on the grid of the step's start (it is a load of
the step, not linearised): the facet vector is assembled once per step.

In u-p the rest is :math:`p - \chi\bar p` with p the pressure field
(:func:`fe_mpm.forms.mixed_up.residual`). NB-VA (``"u-nbva"``) has no pressure
field: its pressure is the law's at each point's averaged volume, and :math:`\bar p`
the projection of the points' pressures; its points' Kirchhoff stress gives up
:math:`\chi\bar p` the same way, :math:`\tau + \chi J \bar p I`
(:func:`fe_mpm.forms.volume_average.without_start_pressure`).
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
        self.vector = fem_petsc.create_vector(fields.W)

    def update(self, occupied: np.ndarray) -> np.ndarray:
        """χ of every owned cell from the cells that hold points on this rank.

        Args:
            occupied: This rank's owned cells that hold points (local indices).

        Returns:
            χ (owned cells,) as bool: occupied, and no vertex shared with an empty
            cell of any rank.
        """
        empty = np.ones(self._num_cells, dtype=bool)
        empty[occupied] = False
        bordering = touched_nodes(self._nodes, np.flatnonzero(empty))
        vertices = self._nodes.dofmap.list[: self._num_cells]
        interior = ~empty & ~bordering[vertices].any(axis=1)
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
