"""Material points as the quadrature of UFL forms (design note: material-point-quadrature.md).

A rule of ``nslot`` *slots*: a custom FFCx rule of ``nslot`` coincident points at
the reference centroid with weights ``w_s = |K̂| / nslot``. Particle data live
in quadrature-element fields on that rule, one value per slot. Two per-slot
fields make the rule exact for the particle set:

- the offset ``d = x_p − x_c`` of the point from the slot (centroid) position, and
- the scale ``s = V_p / (w_s |det J_K|)``, which turns the slot weight into the
  particle volume (zero in empty slots).

A P1 field is linear on an affine cell, so ``u(x_p) = u(x_c) + ∇u · d`` exactly and
``∇u(x_p) = ∇u``. With these, ``Σ_slots w_s |det J| s f(u(x_p), ∇u(x_p))`` equals
``Σ_p V_p f(...)`` to round-off, and ``ufl.derivative`` sees straight through it.

**Entities.** The integral runs over *entities*, not cells: a cell holding k
points appears ``ceil(k / nslot)`` times, each copy with up to ``nslot`` of its
points. So one compiled rule serves every layout (a cell filling up needs no
recompilation), and a grid seeded unevenly (12 points per cell in one zone, 3 in
another) carries few empty slots. The slot data are numpy arrays with a row per
entity (:attr:`MaterialPointQuadrature.values`), written into the kernels'
coefficient arrays by :mod:`fe_mpm.packing`.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field

from mpi4py import MPI

import basix
import basix.ufl
import numpy as np
import ufl

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx

#: Slot counts are rounded up to one of these, so a slowly growing maximum
#: count per cell recompiles rarely and hits the FFCx disk cache.
SLOT_BUCKETS = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256)

#: Subdomain id of the material-point integral (its entities, see the module docstring).
OCCUPIED = 1
#: Subdomain id of the boundary (penalty) points' integral, over their entities.
BOUNDARY_POINTS = 2

#: Cost of an entity, in slots, when choosing the slot count: the per-entity work
#: of a kernel call (geometry, the dofs' gather and scatter) against a slot's.
ENTITY_COST = 2.0
#: A new slot count replaces the current one only if it costs at most this fraction
#: of the current's: each change recompiles the step's forms.
SLOT_CHANGE_SAVING = 0.8


#: What too many points in one cell means, and what to do: material points by default.
MATERIAL_POINTS = (
    "material points",
    "refine the background grid, or seed fewer points per cell (seed(level_set=...) puts "
    "per_cell points on each piece of a cell its level sets cut, many in a cell that "
    "several faces cut)",
)


def bucket(count: int, what: tuple[str, str] = MATERIAL_POINTS) -> int:
    """Smallest slot count in :data:`SLOT_BUCKETS` that holds ``count`` points.

    ``what``: the points' name and the cure, for the message.
    """
    for b in SLOT_BUCKETS:
        if b >= count:
            return b
    raise ValueError(
        f"{count} {what[0]} in one cell exceeds the supported {SLOT_BUCKETS[-1]}; {what[1]}"
    )


def slot_count(
    counts: np.ndarray,
    current: int | None = None,
    comm: MPI.Comm | None = None,
    what: tuple[str, str] = MATERIAL_POINTS,
) -> int:
    """Slots per entity for cells holding ``counts`` points.

    Minimises ``slots + ENTITY_COST · entities`` over :data:`SLOT_BUCKETS` (up to the
    fullest cell's bucket). The ``current`` count is kept unless another saves a
    fifth of that cost, so a changing layout seldom recompiles. With ``comm``, the
    cells of every rank count, so every rank gets the same answer (its forms are
    compiled collectively). ``what`` names the points for the message of a cell
    that holds too many.
    """
    comm = MPI.COMM_SELF if comm is None else comm
    counts = np.asarray(counts)
    counts = counts[counts > 0]
    error = None
    if counts.size and counts.max() > SLOT_BUCKETS[-1]:
        try:
            bucket(int(counts.max()), what)
        except ValueError as err:
            error = err
    parallel.raise_together(comm, error)
    # Cells by number of points: the cost depends on nothing else, and sums over ranks.
    cells_holding = parallel.total(comm, np.bincount(counts, minlength=SLOT_BUCKETS[-1] + 1))
    held = np.flatnonzero(cells_holding)
    if held.size == 0:
        return current or 1

    def cost(nslot: int) -> float:
        entities = (cells_holding[held] * np.ceil(held / nslot)).sum()
        return entities * (nslot + ENTITY_COST)

    candidates = [b for b in SLOT_BUCKETS if b <= bucket(int(held.max()))]
    best = min(candidates, key=cost)
    if current is not None and cost(best) > SLOT_CHANGE_SAVING * cost(current):
        return current
    return best


#: The slot fields (:meth:`MaterialPointQuadrature.function`) and the cell fields packed
#: per entity (:meth:`MaterialPointQuadrature.pack_cell_field`): :mod:`fe_mpm.packing`
#: asks these, kept beside the DOLFINx Functions rather than as attributes set on them.
#: Weak sets: a field dies with its forms. (Not a dict from field to rule: the rule holds
#: its own fields, so no entry would ever die, nor any simulation with them.)
SLOT_FIELDS: weakref.WeakSet = weakref.WeakSet()
PER_ENTITY_FIELDS: weakref.WeakSet = weakref.WeakSet()


@dataclass
class SlotLayout:
    """Which entity and slot each point occupies in one step.

    Attributes:
        cell: Cell of each point, shape ``(n,)``.
        slot: Slot of each point within its entity, shape ``(n,)``.
        entity: Entity (row of :attr:`entities`) of each point, shape ``(n,)``.
        entities: Cell of each entity, sorted; a cell with k points appears
            ``ceil(k / nslot)`` times, shape ``(E,)``.
        occupied: Sorted unique cells holding points, shape ``(n_occ,)``.
        max_count: Largest number of points in one cell.
        nslot: Slots per entity.
    """

    cell: np.ndarray
    slot: np.ndarray
    entity: np.ndarray
    entities: np.ndarray
    occupied: np.ndarray
    max_count: int
    nslot: int
    _slot_rows: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @classmethod
    def from_cells(cls, cells: np.ndarray, nslot: int | None = None) -> SlotLayout:
        """Number the points of each cell 0, 1, ... in their input order, ``nslot`` per entity.

        ``nslot`` defaults to the fullest cell's count (one entity per cell).
        """
        cells = np.asarray(cells)
        order = np.argsort(cells, kind="stable")
        sorted_cells = cells[order]
        first = (
            np.flatnonzero(np.r_[True, sorted_cells[1:] != sorted_cells[:-1]])
            if cells.size
            else np.zeros(0, dtype=np.int64)
        )
        occupied = sorted_cells[first]
        counts = np.diff(np.r_[first, cells.size])
        max_count = int(counts.max(initial=0))
        nslot = nslot or max(max_count, 1)
        rank = np.empty_like(cells)
        rank[order] = np.arange(cells.size) - np.repeat(first, counts)
        per_cell = -(-counts // nslot)  # entities of each occupied cell
        first_entity = (np.cumsum(per_cell) - per_cell).astype(np.int64)
        entity = np.empty(cells.size, dtype=np.int64)
        entity[order] = np.repeat(first_entity, counts)
        entity += rank // nslot
        return cls(
            cells,
            rank % nslot,
            entity,
            np.repeat(occupied, per_cell).astype(np.int32),
            occupied.astype(np.int32),
            max_count,
            nslot,
        )

    @property
    def num_entities(self) -> int:
        """Number of entities E."""
        return self.entities.size

    def slot_rows(self, nslot: int) -> tuple[np.ndarray, np.ndarray]:
        """Rows of the points and of the vacant slots among E · ``nslot`` slot rows.

        A point's row is ``entity · nslot + slot``, shape ``(n,)``; the vacant rows are
        the rest, sorted. Kept per ``nslot`` (a rule may have more slots than the
        layout fills).
        """
        rows = self._slot_rows.get(nslot)
        if rows is None:
            taken = np.zeros(self.num_entities * nslot, dtype=bool)
            points = self.entity * nslot + self.slot
            taken[points] = True
            rows = self._slot_rows[nslot] = (points, np.flatnonzero(~taken))
        return rows


class PointValues:
    """A slot field's values per point, placed in the slots by the kernels that read them.

    What :meth:`MaterialPointQuadrature.pack` keeps for a field that Newton changes
    at every iterate (``per_iterate=True``): each kernel writes the points' rows
    straight into its own coefficient array (:meth:`scatter`), instead of a copy of
    every slot being made here and copied again into each kernel's array. The
    values are not copied: they must not change once packed.

    Args:
        values: One row per point (n, ...), size values each.
        layout: The points' slot layout.
        nslot: Slots per entity of the rule.
        empty: What the vacant slots hold (size,): the field's value size.
    """

    def __init__(self, values: np.ndarray, layout: SlotLayout, nslot: int, empty: np.ndarray):
        if len(values) != layout.entity.size:  # the scatter would write out of bounds
            raise ValueError(
                f"per-iterate slot values: {len(values)} rows for {layout.entity.size} points"
            )
        self.values = values.reshape(len(values), empty.size)  # explicit: a rank may hold none
        self.layout, self.nslot, self.empty = layout, nslot, empty
        self._slots: np.ndarray | None = None

    @property
    def slots(self) -> np.ndarray:
        """Every slot's value, one row per entity (E, nslot · size), made once."""
        if self._slots is None:
            # One flat row per slot: a single index array scatters the points (twice
            # as fast as indexing by entity and slot), only the vacant slots get empty.
            size = self.values.shape[1]
            points, vacant = self.layout.slot_rows(self.nslot)
            data = np.empty((self.layout.num_entities * self.nslot, size))
            data[points] = self.values
            data[vacant] = self.empty
            self._slots = data.reshape(self.layout.num_entities, self.nslot * size)
        return self._slots

    def fills_like(self, other: object) -> bool:
        """Whether ``other`` leaves the same vacant slots, with the same value."""
        return (
            isinstance(other, PointValues)
            and other.layout is self.layout
            and other.nslot == self.nslot
            and np.array_equal(other.empty, self.empty)
        )

    def scatter(self, array: np.ndarray, columns: slice) -> None:
        """Write the points' rows into ``columns`` of ``array`` (E, width), a kernel's.

        Its vacant slots are left as they are. Without numba (whose absence
        :mod:`fe_mpm.materials.route` allows) numpy does it, slower.
        """
        try:
            from fe_mpm.slot_scatter import scatter_rows
        except ImportError:
            size = self.values.shape[1]
            block = array[:, columns].reshape(self.layout.num_entities, self.nslot, size)
            block[self.layout.entity, self.layout.slot] = self.values
            return
        scatter_rows(array, columns.start, self.layout.entity, self.layout.slot, self.values)


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
        #: Slot data of this step by field: (E, nslot · value size) arrays, or
        #: :class:`PointValues` for the fields that change at every iterate.
        self.values: dict[dolfinx.fem.Function, np.ndarray | PointValues] = {}
        self.offset = self.function((gdim,), "offset")  # d = x_p - x_slot (m)
        self.scale = self.function((), "volume_scale")  # V_p / (w_s |det J|)

    def element(self, value_shape: tuple[int, ...] = ()) -> basix.ufl._ElementBase:
        """Quadrature element on the slot rule with the given value shape."""
        return basix.ufl.quadrature_element(
            self.mesh.topology.cell_name(),
            value_shape=value_shape,
            scheme="custom",
            points=self.points,
            weights=self.weights,
        )

    def function(
        self, value_shape: tuple[int, ...], name: str, empty: float | np.ndarray = 0.0
    ) -> dolfinx.fem.Function:
        """A per-slot data field (one value of ``value_shape`` per entity and slot).

        Its data go to :attr:`values` (see :meth:`pack`); the Function itself only
        stands for the field in UFL, and holds ``empty`` in every slot of every
        cell (finite values for assembling a sparsity pattern over all cells).
        """
        V = dolfinx.fem.functionspace(self.mesh, self.element(value_shape))
        f = dolfinx.fem.Function(V, name=name)
        bs = V.dofmap.bs
        f.x.array.reshape(-1, bs)[:] = np.reshape(empty, (-1,))
        SLOT_FIELDS.add(f)
        return f

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

    def pack(
        self,
        f: dolfinx.fem.Function,
        layout: SlotLayout,
        values: np.ndarray,
        empty: float | np.ndarray = 0.0,
        per_iterate: bool = False,
    ) -> None:
        """Set the slot data of ``f`` from per-point ``values`` ``(n, *value_shape)``.

        Empty slots carry zero weight but are still evaluated, so they get the
        harmless value ``empty`` (e.g. the identity for a deformation gradient,
        where zero would give ``ln det F = nan`` and ``nan * 0 = nan``). With
        ``per_iterate`` (a field Newton changes at every iterate, such as a
        pointwise law's stress), ``values`` are kept as they are
        (:class:`PointValues`) and must not change afterwards.
        """
        size = f.function_space.dofmap.bs
        empty = np.broadcast_to(np.asarray(empty, dtype=float).reshape(-1), (size,))
        data = PointValues(values, layout, self.nslot, empty)
        self.values[f] = data if per_iterate else data.slots

    def pack_cell_field(
        self, f: dolfinx.fem.Function, layout: SlotLayout, values: np.ndarray
    ) -> None:
        """Give a DG0 field ``f`` its per-cell ``values`` (ncells,) on first entities only.

        A cell's copies get zero, so a cell integral in the material-point
        subdomain (another rule, e.g. PPP's) proportional to ``f`` counts every
        cell once.
        """
        entities = layout.entities
        first = np.ones(entities.size, dtype=bool)
        first[1:] = entities[1:] != entities[:-1]  # entities are sorted by cell
        self.values[f] = np.where(first, values[entities], 0.0)[:, None]
        PER_ENTITY_FIELDS.add(f)  # packed from these values, not gathered per cell

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
            layout: Their cells, entities and slots.
            centroids: Physical centroid of every cell, shape ``(ncells, g)``.
            volumes: Volume ``|K|`` of every cell, shape ``(ncells,)``.
        """
        if layout.nslot != self.nslot:
            raise ValueError(f"layout has {layout.nslot} slots per entity, the rule {self.nslot}")
        self.pack(self.offset, layout, x - centroids[layout.cell])
        # w_s |det J| = |K| / nslot
        self.pack(self.scale, layout, weights * self.nslot / volumes[layout.cell])
