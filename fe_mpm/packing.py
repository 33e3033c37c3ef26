"""The coefficient arrays of the material-point kernels, packed by fe-mpm.

DOLFINx packs a form's coefficients cell by cell from the Functions' dof arrays.
The material-point integrals run over entities instead (a cell appears once per
``nslot`` of its points, see :mod:`fe_mpm.quadrature`), so the slot fields'
data come from :attr:`MaterialPointQuadrature.values`, one row per entity. The
finite element fields (the unknown, the PPP centroids, Newmark's nodal
velocity, ...) are gathered from their dof arrays cell by cell, as DOLFINx would.

A :class:`BoundForm` packs everything on its first assembly in a step, then
only what Newton changes: the finite element fields and the slot fields marked
*dynamic* (a pointwise law's linearisation).
"""

from __future__ import annotations

import dolfinx.fem.petsc as fem_petsc
import numpy as np
import ufl

from fe_mpm._dolfinx import (
    dolfinx,
    expression_kernel,
    form_integrals,
    original_coefficient_positions,
    tabulate_expression,
)
from fe_mpm.quadrature import (
    PER_ENTITY_FIELDS,
    SLOT_FIELDS,
    MaterialPointQuadrature,
    PointValues,
    SlotLayout,
)


def coefficient_columns(ufl_object, ufcx_object) -> tuple[dict, int]:
    """Columns of each coefficient in a kernel's packed array, and the array's width.

    The order is the compiled kernel's (``original_coefficient_positions``), as
    ``dolfinx.fem.create_form`` and ``Expression`` use it.
    """
    original = ufl.algorithms.extract_coefficients(ufl_object)
    columns, offset = {}, 0
    for position in original_coefficient_positions(ufcx_object):
        c = original[position]
        dofmap = c.function_space.dofmap
        width = dofmap.dof_layout.num_dofs * dofmap.bs
        columns[c] = slice(offset, offset + width)
        offset += width
    return columns, offset


def gather(f: dolfinx.fem.Function, cells: np.ndarray) -> np.ndarray:
    """The dof values of ``f`` on each of ``cells``, shape (len(cells), dofs per cell).

    Valid for elements without dof transformations (Lagrange, quadrature, and
    mixed elements of these on simplices), which is all fe-mpm uses.
    """
    dofmap = f.function_space.dofmap
    width = dofmap.dof_layout.num_dofs * dofmap.bs  # explicit: a rank may bind no cells
    return f.x.array.reshape(-1, dofmap.bs)[dofmap.list[cells]].reshape(len(cells), width)


def is_slot_field(c) -> bool:
    """Whether ``c`` is a slot field (made by :meth:`MaterialPointQuadrature.function`)."""
    return c in SLOT_FIELDS


def is_per_entity(c) -> bool:
    """Whether the rules' data give ``c`` per entity.

    That is a slot field, or a cell field packed by
    :meth:`MaterialPointQuadrature.pack_cell_field`.
    """
    return is_slot_field(c) or c in PER_ENTITY_FIELDS


class _Kernel:
    """One kernel's packed coefficients over its entities."""

    def __init__(
        self,
        columns: dict,
        width: int,
        cells: np.ndarray,
        quadrature: MaterialPointQuadrature | None,
    ):
        self.columns, self.width, self.cells = columns, width, cells
        self.quadrature = quadrature
        self.array: np.ndarray | None = None
        self._packed: dict = {}  # slot field -> the slot data last written
        self._gathered: dict = {}  # finite element field -> its dofs when last gathered

    def pack(self, only: frozenset[int] | None = None) -> np.ndarray:
        """Write the columns of every coefficient, or of those whose ``id`` is in ``only``.

        What has not changed since this kernel last wrote it is not written again:
        slot data packed once (the same object) and finite element fields whose
        dofs are the same.
        """
        if self.array is None:
            self.array = np.zeros((len(self.cells), self.width))
            only = None
        q = self.quadrature
        for c, cols in self.columns.items():
            # By identity: UFL's == on coefficients is a Python call per comparison,
            # and a membership test in a list of them cost 5 % of a plastic run.
            if only is not None and id(c) not in only:
                continue
            if q is not None and c in q.values:
                self._pack_slots(c, cols, q.values[c])
            elif not is_per_entity(c):
                dofs = c.x.array
                last = self._gathered.get(c)
                if last is None or not np.array_equal(last, dofs):
                    self.array[:, cols] = gather(c, self.cells)
                    self._gathered[c] = dofs.copy()
            # else: another rule's field, which this kernel does not read
        return self.array

    def _pack_slots(self, c, cols: slice, data) -> None:
        """Write slot field ``c``'s ``data`` (an array or PointValues) into its columns."""
        last = self._packed.get(c)
        if last is data:
            return
        if isinstance(data, PointValues):
            if data.fills_like(last):  # its vacant slots hold what they should
                data.scatter(self.array, cols)
            else:
                self.array[:, cols] = data.slots
        else:
            self.array[:, cols] = data
        self._packed[c] = data


class BoundForm:
    """A compiled form bound to one step's entities, with coefficients packed here.

    Args:
        form: The DOLFINx form (its cell integrals' entities may repeat cells).
        columns: Each coefficient's columns in the packed arrays
            (:func:`coefficient_columns`), and ``width`` their total.
        quadratures: Subdomain id -> the rule whose slot data its cell integral reads.
        dynamic: Slot fields that change during Newton (repacked at every assembly).
    """

    def __init__(
        self,
        form: dolfinx.fem.Form,
        columns: dict,
        width: int,
        quadratures: dict[int, MaterialPointQuadrature],
        dynamic: set,
    ):
        self.form = form
        self._changing = frozenset(id(c) for c in columns if not is_per_entity(c) or c in dynamic)
        self._kernels = {}
        for kind, i, subdomain, entities in form_integrals(form):
            cells = entities if entities.ndim == 1 else entities[:, 0]
            q = quadratures.get(subdomain) if kind == dolfinx.fem.IntegralType.cell else None
            self._kernels[(kind, i)] = _Kernel(columns, width, cells, q)

    def coefficients(self) -> dict:
        """The packed coefficients for DOLFINx's assemblers, current for this iterate."""
        return {
            key: kernel.pack(None if kernel.array is None else self._changing)
            for key, kernel in self._kernels.items()
        }

    def assemble_vector(self) -> np.ndarray:
        """The assembled vector (owned and ghost entries), for checks and reactions."""
        b = dolfinx.fem.assemble_vector(self.form, coeffs=self.coefficients())
        b.scatter_reverse(dolfinx.la.InsertMode.add)
        return b.array

    def assemble_matrix(self, A=None, bcs=()):
        """Assemble into the PETSc matrix ``A`` (a new one if None); returns it, assembled.

        Rows and columns of ``bcs`` get 1 on the diagonal and 0 elsewhere.
        """
        coeffs = self.coefficients()
        if A is None:
            A = fem_petsc.assemble_matrix(self.form, bcs=list(bcs), coeffs=coeffs)
        else:
            A.zeroEntries()
            fem_petsc.assemble_matrix(A, self.form, bcs=list(bcs), coeffs=coeffs)
        A.assemble()
        return A


class PointExpression:
    """A UFL expression evaluated at the material points of a rule.

    Args:
        expression: UFL expression (fields at the points via the rule's
            ``at_points``/``grad_at_points``).
        quadrature: The rule; its slot data are read at evaluation.
    """

    def __init__(self, expression: ufl.core.expr.Expr, quadrature: MaterialPointQuadrature):
        self.quadrature = quadrature
        self.expression = dolfinx.fem.Expression(expression, quadrature.points)
        self._columns, self._width = coefficient_columns(
            expression, expression_kernel(self.expression)
        )
        self._shape = self.expression.value_shape
        self._kernel: tuple[SlotLayout, _Kernel] | None = None  # that of the last layout

    def evaluate(self, layout: SlotLayout) -> np.ndarray:
        """Values at every point of ``layout``, shape ``(n, value size)``."""
        q = self.quadrature
        if self._kernel is None or self._kernel[0] is not layout:
            self._kernel = (layout, _Kernel(self._columns, self._width, layout.entities, q))
        values = np.zeros((layout.num_entities, q.nslot, *self._shape))
        coefficients = self._kernel[1].pack()  # what changed since the last evaluation
        tabulate_expression(self.expression, coefficients, q.mesh, layout.entities, values)
        width = int(np.prod(self._shape))  # explicit: a rank may hold no points
        points, _ = layout.slot_rows(q.nslot)
        return values.reshape(layout.num_entities * q.nslot, width)[points]
