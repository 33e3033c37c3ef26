"""Forms compiled once and re-bound to the entities of every step.

The points move, so the set of cells to integrate changes every step while the
integrand does not. FFCx compiles the UFL form once (per slot count); each step
only builds a DOLFINx ``Form`` over the new entities, which is cheap, and
:mod:`fe_mpm.packing` supplies its coefficients.
"""

from __future__ import annotations

import numpy as np
import ufl

from fe_mpm._dolfinx import FormFactory, dolfinx
from fe_mpm.packing import BoundForm, coefficient_columns
from fe_mpm.quadrature import BOUNDARY_POINTS, OCCUPIED, MaterialPointQuadrature, SlotLayout

IntegralType = dolfinx.fem.IntegralType


class StepForm:
    """A UFL form compiled once and bound to a step's entities on demand.

    Args:
        form: The UFL form. Its material-point integrals use subdomain id
            :data:`~fe_mpm.quadrature.OCCUPIED` (and
            :data:`~fe_mpm.quadrature.BOUNDARY_POINTS` for boundary points), and
            exterior-facet integrals the ids in ``facet_domains``. Other cell
            integrals in those subdomains (PPP's) see every entity, so they must
            be proportional to a field packed by ``pack_cell_field``.
        mesh: The mesh of the form.
        facet_domains: Map from ``ds`` subdomain id to the exterior facets (local indices).
        quadratures: Subdomain id -> the rule of that point integral.
        dynamic: Slot fields that change during Newton (see :class:`~fe_mpm.packing.BoundForm`).
        jit_options: Passed to the DOLFINx JIT.
    """

    def __init__(
        self,
        form: ufl.Form,
        mesh: dolfinx.mesh.Mesh,
        facet_domains: dict[int, np.ndarray] | None = None,
        quadratures: dict[int, MaterialPointQuadrature] | None = None,
        dynamic: set | None = None,
        jit_options: dict | None = None,
    ):
        self.mesh = mesh
        self.ufl_form = form
        self.compiled = dolfinx.fem.compile_form(mesh.comm, form, jit_options=jit_options)
        self.columns, self.width = coefficient_columns(form, self.compiled.ufcx_form)
        arguments = sorted(form.arguments(), key=lambda a: a.number())
        self.spaces = [a.ufl_function_space() for a in arguments]
        self._factory = FormFactory(
            self.compiled,
            self.spaces,
            mesh,
            {c: c for c in form.coefficients()},
            {c: c for c in ufl.algorithms.analysis.extract_constants(form)},
        )
        self.quadratures = quadratures or {}
        self.dynamic = dynamic or set()
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        mesh.topology.create_connectivity(tdim, tdim - 1)
        self._facets = [
            (
                tag,
                dolfinx.fem.compute_integration_domains(
                    IntegralType.exterior_facet, mesh.topology, np.asarray(facets, dtype=np.int32)
                ),
            )
            for tag, facets in sorted((facet_domains or {}).items())
        ]

    def bind(self, layout: SlotLayout, boundary: SlotLayout | None = None) -> BoundForm:
        """The form over the points of ``layout`` (and the boundary points of ``boundary``).

        Its coefficients are packed from the rules' slot data.
        """
        cells = {OCCUPIED: layout.entities}
        if boundary is not None:
            cells[BOUNDARY_POINTS] = boundary.entities
        return BoundForm(
            self._create(cells), self.columns, self.width, self.quadratures, self.dynamic
        )

    def bind_cells(self, cells: np.ndarray) -> dolfinx.fem.Form:
        """A plain DOLFINx form with every integral over ``cells`` once.

        DOLFINx packs its slot fields from the Functions' placeholder values:
        for a sparsity pattern, not for numbers.
        """
        return self._create({OCCUPIED: cells, BOUNDARY_POINTS: cells})

    def _create(self, cells: dict[int, np.ndarray]) -> dolfinx.fem.Form:
        subdomains = {
            IntegralType.cell: [
                (i, np.asarray(c, dtype=np.int32)) for i, c in sorted(cells.items())
            ],
            IntegralType.exterior_facet: list(self._facets),
        }
        return self._factory(subdomains)
