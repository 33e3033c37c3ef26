"""Forms compiled once and re-bound to the occupied cells of every step.

The points move, so the set of cells to integrate changes every step while the
integrand does not. FFCx compiles the UFL form once (per slot count); each step
only builds a DOLFINx ``Form`` over the new occupied cells, which is cheap.
"""

from __future__ import annotations

import numpy as np
import ufl

from fe_mpm._dolfinx import dolfinx
from fe_mpm.quadrature import BOUNDARY_POINTS, OCCUPIED

IntegralType = dolfinx.fem.IntegralType


class StepForm:
    """A UFL form compiled once and bound to a cell set on demand.

    Args:
        form: The UFL form. Cell integrals must use subdomain id
            :data:`~fe_mpm.quadrature.OCCUPIED`; exterior-facet integrals use
            the ids in ``facet_domains``.
        mesh: The mesh of the form.
        facet_domains: Map from ``ds`` subdomain id to the exterior facets (local indices).
        jit_options: Passed to the DOLFINx JIT.
    """

    def __init__(
        self,
        form: ufl.Form,
        mesh: dolfinx.mesh.Mesh,
        facet_domains: dict[int, np.ndarray] | None = None,
        jit_options: dict | None = None,
    ):
        self.mesh = mesh
        self.ufl_form = form
        self.compiled = dolfinx.fem.compile_form(mesh.comm, form, jit_options=jit_options)
        arguments = sorted(form.arguments(), key=lambda a: a.number())
        self.spaces = [a.ufl_function_space() for a in arguments]
        self.coefficients = {c: c for c in form.coefficients()}
        self.constants = {c: c for c in ufl.algorithms.analysis.extract_constants(form)}
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        mesh.topology.create_connectivity(tdim, tdim - 1)
        self._facets = [
            (tag, dolfinx.fem.compute_integration_domains(
                IntegralType.exterior_facet, mesh.topology, np.asarray(facets, dtype=np.int32)))
            for tag, facets in sorted((facet_domains or {}).items())
        ]

    def bind(self, cells: np.ndarray, boundary_cells: np.ndarray | None = None) -> dolfinx.fem.Form:
        """The DOLFINx form integrating the material points of ``cells``.

        ``boundary_cells`` are the cells of the penalty boundary points (subdomain
        :data:`~fe_mpm.quadrature.BOUNDARY_POINTS`), for forms that have that integral.
        """
        cell_domains = [(OCCUPIED, np.asarray(cells, dtype=np.int32))]
        if boundary_cells is not None:
            cell_domains.append((BOUNDARY_POINTS, np.asarray(boundary_cells, dtype=np.int32)))
        subdomains = {
            IntegralType.cell: cell_domains,
            IntegralType.exterior_facet: list(self._facets),
        }
        return dolfinx.fem.create_form(
            self.compiled, self.spaces, self.mesh, subdomains, self.coefficients, self.constants
        )
