"""Material points as the quadrature of UFL forms (design note: material-point-quadrature.md).

Every cell gets ``nslot`` *slots*: a custom FFCx rule of ``nslot`` coincident
points at the reference centroid with weights ``w_s = |K̂| / nslot``. Particle
data live in quadrature-element functions on that rule, one value per
(cell, slot). Two per-slot fields make the rule exact for the particle set:

- the offset ``d = x_p − x_c`` of the point from the slot (centroid) position, and
- the scale ``s = V_p / (w_s |det J_K|)``, which turns the slot weight into the
  particle volume (zero in empty slots).

A P1 field is linear on an affine cell, so ``u(x_p) = u(x_c) + ∇u · d`` exactly and
``∇u(x_p) = ∇u``. With these, ``Σ_slots w_s |det J| s f(u(x_p), ∇u(x_p))`` equals
``Σ_p V_p f(...)`` to round-off, and ``ufl.derivative`` sees straight through it.
"""

from __future__ import annotations

from dataclasses import dataclass

import basix
import basix.ufl
import numpy as np
import ufl

from fe_mpm._dolfinx import dolfinx

#: Slot counts are rounded up to one of these, so a slowly growing maximum
#: count per cell recompiles rarely and hits the FFCx disk cache.
SLOT_BUCKETS = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256)

#: Subdomain id of the occupied cells in every material-point integral.
OCCUPIED = 1
#: Subdomain id of the cells holding boundary (penalty) points.
BOUNDARY_POINTS = 2


def bucket(count: int) -> int:
    """Smallest slot count in :data:`SLOT_BUCKETS` that holds ``count`` points."""
    for b in SLOT_BUCKETS:
        if b >= count:
            return b
    raise ValueError(
        f"{count} material points in one cell exceeds the supported {SLOT_BUCKETS[-1]}; "
        "refine the background grid"
    )


@dataclass
class SlotLayout:
    """Which (cell, slot) each point occupies in one step.

    Attributes:
        cell: Cell of each point, shape ``(n,)``.
        slot: Slot of each point within its cell, shape ``(n,)``.
        occupied: Sorted unique cells holding points, shape ``(n_occ,)``.
        max_count: Largest number of points in one cell.
    """

    cell: np.ndarray
    slot: np.ndarray
    occupied: np.ndarray
    max_count: int

    @classmethod
    def from_cells(cls, cells: np.ndarray) -> SlotLayout:
        """Number the points of each cell 0, 1, ... in their input order."""
        order = np.argsort(cells, kind="stable")
        sorted_cells = cells[order]
        occupied, first, counts = np.unique(sorted_cells, return_index=True, return_counts=True)
        slot = np.empty_like(cells)
        slot[order] = np.arange(cells.size) - np.repeat(first, counts)
        return cls(cells, slot, occupied.astype(np.int32), int(counts.max(initial=0)))


class MaterialPointQuadrature:
    """The slot rule of one slot count on one mesh, and the UFL to integrate with it.

    Use :meth:`sum` for ``Σ_p V_p f(x_p)`` and :meth:`at_points` /
    :meth:`grad_at_points` to evaluate a P1 field at the points inside ``f``.

    Args:
        mesh: Affine triangle or tetrahedron mesh.
        nslot: Slots per cell (≥ the largest number of points in a cell).
        subdomain_id: Cell subdomain id of the integral (:data:`OCCUPIED` for the
            material points, :data:`BOUNDARY_POINTS` for penalty points).
    """

    def __init__(self, mesh: dolfinx.mesh.Mesh, nslot: int, subdomain_id: int = OCCUPIED):
        self.mesh = mesh
        self.nslot = nslot
        cell = basix.CellType[mesh.topology.cell_name()]
        tdim = mesh.topology.dim
        self._ref_volume = basix.cell.volume(cell)
        centroid = basix.geometry(cell).mean(axis=0)
        self.points = np.tile(centroid, (nslot, 1))  # reference slot points, (nslot, tdim)
        self.weights = np.full(nslot, self._ref_volume / nslot)
        self.dx = ufl.Measure(
            "dx",
            domain=mesh,
            subdomain_id=subdomain_id,
            metadata={
                "quadrature_rule": "custom",
                "quadrature_points": self.points,
                "quadrature_weights": self.weights,
            },
        )
        gdim = mesh.geometry.dim
        self.offset = self.function((gdim,), "offset")  # d = x_p - x_slot (m)
        self.scale = self.function((), "volume_scale")  # V_p / (w_s |det J|)
        self._tdim = tdim

    def element(self, value_shape: tuple[int, ...] = ()) -> basix.ufl._ElementBase:
        """Quadrature element on the slot rule with the given value shape."""
        return basix.ufl.quadrature_element(
            self.mesh.topology.cell_name(),
            value_shape=value_shape,
            scheme="custom",
            points=self.points,
            weights=self.weights,
        )

    def function(self, value_shape: tuple[int, ...], name: str) -> dolfinx.fem.Function:
        """A per-slot data field (one value of ``value_shape`` per cell and slot)."""
        V = dolfinx.fem.functionspace(self.mesh, self.element(value_shape))
        return dolfinx.fem.Function(V, name=name)

    def sum(self, integrand: ufl.core.expr.Expr) -> ufl.Form:
        """The form ``Σ_p V_p integrand(x_p)`` over the occupied cells."""
        return integrand * self.scale * self.dx

    def at_points(self, u: ufl.core.expr.Expr, degree: int = 1) -> ufl.core.expr.Expr:
        """Value at the material points of a field of polynomial degree 1 or 2.

        On an affine cell the Taylor series about the slot point ends at the
        degree: ``u + ∇u·d`` for P1, ``+ ½ d·H·d`` (H = ∇∇u, constant) for P2. Exact.
        """
        d = self.offset
        value = u + ufl.dot(ufl.grad(u), d)
        if degree == 2:
            value += 0.5 * ufl.dot(ufl.dot(ufl.grad(ufl.grad(u)), d), d)
        elif degree != 1:
            raise ValueError(f"at_points: degree must be 1 or 2, got {degree}")
        return value

    def grad_at_points(self, u: ufl.core.expr.Expr, degree: int = 1) -> ufl.core.expr.Expr:
        """Gradient at the material points: ``∇u`` for P1, ``∇u + H d`` for P2 (exact)."""
        if degree == 2:
            return ufl.grad(u) + ufl.dot(ufl.grad(ufl.grad(u)), self.offset)
        if degree != 1:
            raise ValueError(f"grad_at_points: degree must be 1 or 2, got {degree}")
        return ufl.grad(u)

    # -- packing -------------------------------------------------------------

    def slot_dofs(self, f: dolfinx.fem.Function, layout: SlotLayout) -> np.ndarray:
        """Index of each point's slot in ``f.x.array.reshape(-1, bs)``, shape ``(n,)``."""
        return f.function_space.dofmap.list[layout.cell, layout.slot]

    def pack(
        self,
        f: dolfinx.fem.Function,
        layout: SlotLayout,
        values: np.ndarray,
        empty: float | np.ndarray = 0.0,
    ) -> None:
        """Write per-point ``values`` (n, *value_shape) into ``f``.

        Empty slots carry zero weight but are still evaluated, so they get the
        harmless value ``empty`` (e.g. the identity for a deformation gradient,
        where zero would give ``ln det F = nan`` and ``nan * 0 = nan``).
        """
        bs = f.function_space.dofmap.bs
        arr = f.x.array.reshape(-1, bs)
        arr[:] = np.reshape(empty, (-1,))
        arr[self.slot_dofs(f, layout)] = values.reshape(values.shape[0], bs)

    def pack_geometry(
        self,
        x: np.ndarray,
        weights: np.ndarray,
        layout: SlotLayout,
        centroids: np.ndarray,
        volumes: np.ndarray,
    ) -> None:
        """Set the offset and volume scale of every slot from the points.

        Args:
            x: Point positions, shape ``(n, g)`` (m).
            weights: What :meth:`sum` weighs each point by, shape ``(n,)``: the
                volume ``V_p`` of a material point, or the length/area of a
                boundary point.
            layout: Their cells and slots.
            centroids: Physical centroid of every cell, shape ``(ncells, g)``.
            volumes: Volume ``|K|`` of every cell, shape ``(ncells,)``.
        """
        self.pack(self.offset, layout, x - centroids[layout.cell])
        # w_s |det J| = |K| / nslot
        self.pack(self.scale, layout, weights * self.nslot / volumes[layout.cell])

    def evaluate(
        self, expression: dolfinx.fem.Expression, layout: SlotLayout
    ) -> np.ndarray:
        """Evaluate an expression compiled at :attr:`points` at every material point.

        Returns:
            Array of shape ``(n, value_size)``.
        """
        values = expression.eval(self.mesh, layout.occupied)
        values = values.reshape(layout.occupied.size, self.nslot, -1)
        row = np.searchsorted(layout.occupied, layout.cell)
        return values[row, layout.slot]
