"""Ghost stabilisation in a step: which facets, and the penalty's matrices there.

``Simulation(ghost_penalty=γ)`` adds the ghost penalty of :mod:`fe_mpm.forms.ghost`
on every interior facet between two occupied cells at least one of which the
material fills less than :data:`POORLY_FILLED` (the points' volume over the cell's)
or that holds fewer points than its displacement needs (3 for P2).
The penalty is linear in Δu, so each step assembles it once: as ``full`` (no
conditions, for the residual ``G Δu``) and as ``constrained`` (the rows and
columns of Dirichlet dofs zeroed, to add to the tangent).

Under MPI a facet between two ranks joins an owned cell to a ghost: the grid needs
DOLFINx's shared-facet ghost layer (the default of ``create_rectangle`` and
``create_box``, and of fe-mpm's gmsh scenes; :class:`~fe_mpm.Simulation` adds it to
a grid built without it, :func:`fe_mpm.balance.with_facet_ghosts`). The points' fill of each cell is
summed on the rank that owns it and sent to the ranks that hold it as a ghost, so
every rank picks the same facets; each facet is assembled by the rank that owns it.
"""

from __future__ import annotations

from petsc4py import PETSc

import dolfinx.fem.petsc as fem_petsc
import numpy as np
import ufl

from fe_mpm import balance, parallel
from fe_mpm._dolfinx import FormFactory, dolfinx
from fe_mpm.forms.ghost import GHOST_FACETS, ghost_penalty
from fe_mpm.formulations import GridFields
from fe_mpm.transfer import summed_over_ranks

#: A cell filled less than this (points' volume / cell volume) is poorly filled.
POORLY_FILLED = 0.5
#: Fills within this relative margin below :data:`POORLY_FILLED` count as filled: on
#: a regular grid two of four equal points fill a cell by exactly one half, give or
#: take the round-off of their volumes, which would otherwise decide the facets
#: differently from one run (or rank count) to the next.
FILL_MARGIN = 1e-9
#: γ when point domains are on and ``ghost_penalty`` is not given, by the
#: displacement's degree. P1, measured on Cook at 5 N, n = 32: without it the tip
#: drifts on with the number of steps (1.3649, 1.3769, 1.3924, 1.4358 after 20, 80,
#: 160, 320 steps), with it it settles (1.3529, 1.3597, 1.3616, 1.3613; converged
#: FEM 1.3542). P2, Cook at 10 N, n = 16, one point per cell: without it Newton
#: fails in step 157 of 160; 0.01 finishes (−1.3 %, 0.1 gives −1.7 %), and costs
#: 0.5 % at 5 N over 20 steps (1.3357 against 1.3422).
WITH_DOMAINS = {1: 0.1, 2: 0.01}
#: γ when point domains are on in a dynamic run (P1 only) and ``ghost_penalty`` is
#: not given. The penalty acts on each step's increment Δu = v Δt and is forgotten
#: at the next step, so in dynamics it resists motion like a dashpot. Measured
#: 2026-12-05: the granular collapse of ``demos/column_collapse.py`` (a = 3, h =
#: 0.015, three points per cell) runs out −26.5 % short of Lube et al. with γ = 0.1
#: and −14.9 % with 0; a free elastic square ringing in its own modes (8 cells
#: across, u-p, Δt = 1 ms, ``projection_passes=8``) keeps 0.906 of its energy after
#: 0.1 s with γ = 0.1 and 1.010 with 0. So 0 was the default until 2026-12-06, when
#: a layer started geostatic in u-p under empty cells stopped in its third step: its
#: domains rose into the cells above by a fraction of a millimetre (PPP's motion of
#: a geostatic u-p layer), and a sliver of a domain holds the far nodes of its cell
#: with almost no mass, so the consistent mass matrix does not keep the step's matrix
#: regular there. γ = 0.001 ties them and costs little (2026-12-06): the same
#: collapse −17.0 % against −16.7 % with 0, Newton at most 8 iterations a step
#: against 37; a square ringing in its modes (8 cells across, u-p, Δt = 1 ms, 8
#: passes) keeps a peak kinetic energy of 0.833 of the start's over its last 20 ms
#: against 0.834 with 0 and 0.811 with γ = 0.1.
WITH_DOMAINS_DYNAMIC = 0.001


class GhostStabilisation:
    """The ghost penalty of one grid, re-bound to the facets of every step.

    Args:
        fields: The grid unknown (displacement, alone or with a pressure).
        gamma: The penalty factor γ > 0 (dimensionless).
        mu: The shear modulus μ of the material (Pa).

    Attributes:
        pattern: The penalty over the step's facets (a bilinear form, the pattern
            the step's matrix must hold as well).
        full: G on the step's facets (PETSc matrix).
        constrained: The same with the Dirichlet rows and columns zeroed.
        facets: The step's ghost facets that this rank owns and assembles (local indices).
    """

    def __init__(self, fields: GridFields, gamma: float, mu: float):
        W = fields.W
        mesh = W.mesh
        trial, test = ufl.TrialFunction(W), ufl.TestFunction(W)
        if fields.spec.mixed:
            trial, test = ufl.split(trial)[0], ufl.split(test)[0]
        self.scale = dolfinx.fem.Constant(mesh, 2.0 * gamma * mu)
        form = ghost_penalty(trial, test, self.scale, fields.spec.u_degree)
        compiled = dolfinx.fem.compile_form(mesh.comm, form)
        self._factory = FormFactory(compiled, [W, W], mesh, {}, {self.scale: self.scale})
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        mesh.topology.create_connectivity(tdim, tdim - 1)
        self._topology = mesh.topology
        self._comm = mesh.comm
        require_facet_ghosts(mesh)
        facet_cells = mesh.topology.connectivity(tdim - 1, tdim)
        owned = mesh.topology.index_map(tdim - 1).size_local
        offsets = facet_cells.offsets
        # Every facet between two cells this rank holds (ghosts included), to join
        # cells into groups; the owned ones among them are integrated here.
        self._links = np.flatnonzero(np.diff(offsets) == 2).astype(np.int32)
        first = offsets[self._links]
        self._cells = np.column_stack([facet_cells.array[first], facet_cells.array[first + 1]])
        self._owned = self._links < owned
        self._interior = self._links[self._owned]  # every owned interior facet (for checks)
        cell_map = mesh.topology.index_map(tdim)
        self._owned_cells = cell_map.size_local
        self._num_cells = cell_map.size_local + cell_map.num_ghosts
        self._cell_map = cell_map
        self._cell_values = dolfinx.la.vector(cell_map, bs=2)  # fill, count
        self._force = dolfinx.fem.Function(W)
        self.facets = np.zeros(0, dtype=np.int32)
        self.pattern = self._bind(self.facets)
        self.full = fem_petsc.create_matrix(self.pattern)
        self.constrained = fem_petsc.create_matrix(self.pattern)
        for matrix in (self.full, self.constrained):
            matrix.assemble()
        #: Whether the last :meth:`update` changed the facets on some rank, so that
        #: the step's matrix needs the new :attr:`pattern` (collective: the same on
        #: every rank).
        self.changed = True
        self._tied = np.zeros(0, dtype=np.int32)

    def _bind(self, facets: np.ndarray) -> dolfinx.fem.Form:
        entities = dolfinx.fem.compute_integration_domains(
            dolfinx.fem.IntegralType.interior_facet, self._topology, facets
        )
        return self._factory({dolfinx.fem.IntegralType.interior_facet: [(GHOST_FACETS, entities)]})

    def update(
        self,
        cells: np.ndarray,
        volume: np.ndarray,
        cell_volume: np.ndarray,
        bcs: list,
        min_points: int = 1,
    ) -> None:
        """Pick the step's ghost facets and assemble G there.

        Args:
            cells: The cell of each of this rank's points (n,): owned, or with point
                domains a ghost too (another rank's, whose pieces lie there).
            volume: The points' volumes (n,).
            cell_volume: The volume of every cell ``cells`` may name (nc,), the owned
                ones first.
            bcs: The step's Dirichlet conditions.
            min_points: A cell with fewer points than this is poorly filled too
                (3 for P2: fewer leave some of its strain modes unseen).
        """
        local = len(cell_volume)
        values = np.zeros((self._num_cells, 2))
        values[:local, 0] = np.bincount(cells, weights=volume, minlength=local) / cell_volume
        values[:local, 1] = np.bincount(cells, minlength=local)
        fill, count = summed_over_ranks(self._cell_map, values).T
        poor = (fill < POORLY_FILLED * (1.0 - FILL_MARGIN)) | (count < min_points)
        a, b = self._cells[:, 0], self._cells[:, 1]
        ghost = (count[a] > 0) & (count[b] > 0) & (poor[a] | poor[b])
        previous = self.facets
        self.facets = self._links[ghost & self._owned]
        edges = self._cells[ghost]
        tied = np.unique(edges)
        if min_points > 1:
            # The penalty makes the cells it joins share one polynomial, so a cell
            # with too few points is held only if its group has a cell with enough.
            held = self._held(edges, count >= min_points)
            tied = tied[held[tied]]
        self._tied = tied
        changed = not np.array_equal(self.facets, previous)
        self.changed = self.changed or parallel.any_rank(self._comm, changed)
        # The matrices hold the step's facets only: over every interior facet their
        # explicit zeros reached the step's matrix, and MUMPS factorised them.
        self.pattern = self._bind(self.facets)
        self.destroy()
        self.full = fem_petsc.create_matrix(self.pattern)
        fem_petsc.assemble_matrix(self.full, self.pattern)
        self.full.assemble()
        # A Dirichlet dof's zeroed row and column, and its zero diagonal, may lie
        # outside the facets' pattern: zeros make no entries here (a subset of
        # the step's matrix, which holds the whole pattern).
        self.constrained = fem_petsc.create_matrix(self.pattern)
        self.constrained.setOption(PETSc.Mat.Option.IGNORE_ZERO_ENTRIES, True)
        fem_petsc.assemble_matrix(self.constrained, self.pattern, bcs=bcs, diag=0.0)
        self.constrained.assemble()

    def _with_ghosts(self, values: np.ndarray) -> np.ndarray:
        """Per-cell values (owned cells, 2) extended to the ghosts by their owners."""
        data = self._cell_values.array
        data[: values.size] = values.ravel()
        self._cell_values.scatter_forward()
        return data.reshape(-1, 2)[: self._num_cells].copy()

    def _held(self, edges: np.ndarray, enough: np.ndarray) -> np.ndarray:
        """Whether each cell's group (cells joined by ``edges``) has one with enough points.

        On many ranks a group may cross several, so each rank passes what it found
        to its neighbours' ghosts until no rank learns more.
        """
        held = enough.copy()
        while True:
            group = connected_groups(edges, self._num_cells)
            found = np.zeros(self._num_cells, dtype=bool)
            found[group[held]] = True
            found = found[group]
            if self._comm.size == 1:
                return found
            spread = self._with_ghosts(np.repeat(found[: self._owned_cells], 2)) > 0.5
            found = spread[:, 0] | found  # a ghost keeps what it was told here too
            if not parallel.any_rank(self._comm, bool(np.any(found != held))):
                return found
            held = found

    def tied_cells(self) -> np.ndarray:
        """The cells held by the penalty this step (sorted).

        Those on a ghost facet whose group of cells joined by ghost facets holds a
        cell with enough points.
        """
        return self._tied

    def force(self, w: dolfinx.fem.Function) -> np.ndarray:
        """The penalty's nodal force G Δu at the unknown ``w`` (owned and ghost dofs)."""
        y = self._force.x
        self.full.mult(w.x.petsc_vec, y.petsc_vec)
        y.scatter_forward()
        return y.array.copy()

    def destroy(self) -> None:
        """Free the PETSc matrices."""
        self.full.destroy()
        self.constrained.destroy()


def require_facet_ghosts(mesh: dolfinx.mesh.Mesh, what: str = "the ghost penalty") -> None:
    """Refuse, on every rank, a distributed grid without shared-facet ghost cells.

    ``what`` names the facet integrals that need them, for the message.

    Raises:
        ValueError: Some facet between two ranks has its cell on one side only.
    """
    if not balance.has_facet_ghosts(mesh):
        raise ValueError(
            f"Simulation: {what} on a grid distributed over "
            f"{mesh.comm.size} MPI ranks needs the cells across each rank's facets "
            "(DOLFINx's ghost mode shared_facet); this grid has none. Build it with "
            "ghost_mode=dolfinx.mesh.GhostMode.shared_facet (create_rectangle/create_box) "
            "or partitioner=dolfinx.mesh.create_cell_partitioner("
            "dolfinx.mesh.GhostMode.shared_facet, 2) (create_mesh, gmsh's model_to_mesh)"
        )


def connected_groups(edges: np.ndarray, n: int) -> np.ndarray:
    """The group of each of ``n`` nodes joined by ``edges`` (k, 2): its lowest member.

    Label propagation with pointer jumping, vectorised over the edges.
    """
    label = np.arange(n)
    while True:
        low = np.minimum(label[edges[:, 0]], label[edges[:, 1]])
        new = label.copy()
        np.minimum.at(new, edges[:, 0], low)
        np.minimum.at(new, edges[:, 1], low)
        new = new[new]
        if np.array_equal(new, label):
            return label
        label = new
