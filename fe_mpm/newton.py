"""Newton's method through PETSc SNES, with forms that change from step to step.

DOLFINx's ``NonlinearProblem`` fixes its forms at construction. An MPM step
integrates a different set of cells every step, so this solver keeps one SNES,
one matrix (built once on the sparsity of all cells, a superset of every step's)
and one residual vector, and takes the step's forms and boundary conditions in
:meth:`NewtonSolver.solve`.
"""

from __future__ import annotations

import re
import time
import weakref
from collections.abc import Callable, Sequence

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem.petsc as fem_petsc
import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx, matrix_with_pattern_of
from fe_mpm.force_test import EPS, ROUND_OFF_FACTOR, ForceTest, NewtonResult
from fe_mpm.formulations import collapse
from fe_mpm.packing import BoundForm
from fe_mpm.solver_options import (
    LINEAR_SOLVERS,
    NEWTON_OPTIONS,
    rigid_body_modes,
    with_petsc_options,
)

__all__ = [
    "LINEAR_SOLVERS",
    "NEWTON_OPTIONS",
    "ROUND_OFF_FACTOR",
    "ForceTest",
    "NewtonResult",
    "NewtonSolver",
    "with_petsc_options",
]

#: A constrained dof counts as off its prescribed value when it misses it by more
#: than this fraction of the largest one (a full update misses by a few ulps).
BC_MISMATCH = 1e-13

_REASONS = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if isinstance(v, int)}


def _weak(method: Callable) -> Callable:
    """A callback that calls ``method`` without keeping its object alive."""
    ref = weakref.WeakMethod(method)

    def call(*args):
        return ref()(*args)

    return call


def _row_places(W: dolfinx.fem.FunctionSpace) -> np.ndarray:
    """Coordinates (k, 3) of the node of every local row of an unknown on ``W``.

    Unrolled rows (a blocked or mixed unknown's), as PETSc numbers them. Collective
    (collapsing a subspace is), so every rank calls it.
    """
    size = W.dofmap.index_map.size_local + W.dofmap.index_map.num_ghosts
    places = np.full((size * W.dofmap.index_map_bs, 3), np.nan)
    subspaces = [W.sub(i) for i in range(W.num_sub_spaces)] or [W]
    for sub in subspaces:
        V, dofs = collapse(sub) if sub is not W else (W, np.arange(places.shape[0]))
        coordinates = V.tabulate_dof_coordinates()
        per_node = max(1, dofs.size // max(1, coordinates.shape[0]))
        places[dofs] = coordinates[np.arange(dofs.size) // per_node]
    return places


def _gathered_place(comm, places: np.ndarray, rows: np.ndarray) -> list[float]:
    """The place (3,) of the first of ``rows`` on the first rank with one, on every rank.

    Collective; rounded to 1e-6 m; NaN where no rank has a row.
    """
    gathered = parallel.gathered(comm, places[rows[:1]].ravel())
    first = gathered.reshape(-1, 3)[0] if gathered.size else np.full(3, np.nan)
    return (np.round(first, 6) + 0.0).tolist()  # + 0.0: no "-0.0"


class NewtonSolver:
    """SNES Newton for ``R(u) = 0`` with a tangent from the same UFL form.

    Args:
        u: The unknown; its vector is the SNES solution.
        sparsity_form: A bilinear form over all cells, to build the matrix once; its
            coefficients must hold finite values (they only fill the pattern).
        prefix: PETSc options prefix, e.g. ``"fe_mpm_u_"``: ``PETSC_OPTIONS=-fe_mpm_u_snes_monitor``
            in the environment works (PETSc is started without the script's arguments).
        petsc_options: Overrides of :data:`NEWTON_OPTIONS` and the linear solver's options.
        timings: Dict to which assembly and total solve seconds are added.
        linear_solver: A name of :data:`LINEAR_SOLVERS`.
        displacement: The displacement's subspace of ``u``'s space (``u``'s own
            space for the u form); the iterative solvers need its rigid body
            modes, and for a mixed unknown its dofs.
        length: Largest cell size h (m), the length of :class:`ForceTest`'s
            round-off floor.
        coupling: A bilinear form whose entries the matrix must hold as well (the
            ghost penalty over the step's ghost facets, :meth:`couple`), or None.
        strain_field: Whether the scalar field of a mixed unknown is a strain (θ
            of volumetric averaging): its round-off then counts toward the floor
            of :class:`ForceTest` (see :meth:`_round_off`).
    """

    def __init__(
        self,
        u: dolfinx.fem.Function,
        sparsity_form: dolfinx.fem.Form,
        prefix: str,
        petsc_options: dict | None = None,
        timings: dict | None = None,
        linear_solver: str = "direct",
        displacement: dolfinx.fem.FunctionSpace | None = None,
        length: float = 1.0,
        coupling: dolfinx.fem.Form | None = None,
        strain_field: bool = False,
    ):
        self.u = u
        self.iterations_total = 0  # over every solve, converged or not
        self._near_null_space = None
        # PETSc squeezes out preallocated entries never set before the first final
        # assembly, and later steps occupy cells that were empty in the first. So
        # set every entry of the pattern once (empty slots give explicit zeros),
        # and make any entry outside the pattern an error instead of a silent drop.
        self._cells = matrix_with_pattern_of([sparsity_form])
        fem_petsc.assemble_matrix(self._cells, sparsity_form)
        self._cells.assemble()
        self.A = self._matrix(coupling)
        self.b = fem_petsc.create_vector(u.function_space)
        self.x = fem_petsc.create_vector(u.function_space)
        self._gap = fem_petsc.create_vector(u.function_space)
        self._loads = fem_petsc.create_vector(u.function_space)  # f_ext of the step
        self._scratch = fem_petsc.create_vector(u.function_space)
        self._diagonal = fem_petsc.create_vector(u.function_space)
        self._best = fem_petsc.create_vector(u.function_space)  # see resume_from_best
        self._best_norm = -np.inf  # ‖R‖ of the kept iterate; −inf: none kept
        self.timings = timings if timings is not None else {}
        self.snes = PETSc.SNES().create(self.A.comm)  # the mesh's: COMM_SELF runs per rank
        # SNES keeps its callbacks alive, and a bound method keeps this solver
        # alive: a cycle through PETSc that Python's collector cannot see. Every
        # solver would then leak, with its MPI communicators, until MPI runs out
        # of them (after a few hundred simulations in one process).
        self.snes.setFunction(_weak(self._residual), self.b)
        self.snes.setJacobian(_weak(self._jacobian), self.A)
        self.snes.setOptionsPrefix(prefix)
        self._prefix = prefix
        self.A.setOptionsPrefix(f"{prefix}A_")
        #: The keys of the options that PETSc has read so far, for unread ones to be found.
        self.read_options: set[str] = set()
        mixed = displacement is not None and displacement is not u.function_space
        self._options = {
            **NEWTON_OPTIONS,
            **LINEAR_SOLVERS[linear_solver, mixed],
            **(petsc_options or {}),
        }
        # The displacement's dofs in the unknown, once: the Newton test and the field
        # split both need them.
        split = collapse(displacement) if mixed else None
        self._u_rows, self._p_rows = self._owned_rows(split)
        self._free_u_rows = self._u_rows  # those no condition holds, set at each solve
        self._strain_probe = None
        if strain_field:
            # ±1 on the strain's rows, fixed: A times it samples the coupling of each
            # displacement row to the strain without the cancellation of a sum.
            self._strain_probe = fem_petsc.create_vector(u.function_space)
            signs = np.random.default_rng(0).choice([-1.0, 1.0], self._p_rows.size)
            self._strain_probe.array[:] = 0.0
            self._strain_probe.array[self._p_rows] = signs
        if linear_solver == "iterative":
            self._set_up_iterative(displacement or u.function_space, split)
        try:
            self._with_options(self.snes.setFromOptions)
        except PETSc.Error as err:  # (a helper's {"snes_rtol": "1e-8x"} met PETSc's stack)
            # PETSc's own words are the stack's lines that name no source file.
            lines = [re.sub(r"^\[\d+\] ", "", line).strip() for line in str(err).splitlines()]
            said = "; ".join(line for line in lines[1:] if " at /" not in line and line)
            raise ValueError(
                f"NewtonSolver: PETSc refused the solver options while setting Newton up "
                f"({said}); the options: {self._options}. Check Simulation's petsc_options "
                "(names and values as on PETSc's command line, without the prefix)"
            ) from err
        #: Where the first iterate to assemble a non-finite residual or Jacobian since
        #: :meth:`clear_nonfinite` did so, in words; "" if none did.
        self.nonfinite = ""
        #: Whether that was a Jacobian at an iterate whose residual was finite: a
        #: derivative that failed, which no shorter step cures.
        self.nonfinite_derivative = False
        self.test = ForceTest(
            float(self._options["snes_rtol"]),
            float(self._options["snes_atol"]),
            int(self._options["snes_max_it"]),
            length,
        )
        self.snes.setConvergenceTest(_weak(self.test.__call__))
        self.norms: list[float] = []
        self.snes.setMonitor(_weak(self._monitor))
        self._F = self._J = None
        self._bcs: Sequence = ()
        self._ghost = None
        self._extra_force = None
        self._before_residual: Callable[[], None] | None = None
        self._inertia: Callable[[], float] | None = None
        self._after_jacobian: Callable[[PETSc.Mat], None] | None = None
        self._before_jacobian: Callable[[], None] | None = None

    def _owned_rows(self, split) -> tuple[np.ndarray, np.ndarray]:
        """Owned local rows of the displacement and of the pressure (sorted).

        Args:
            split: :func:`~fe_mpm.formulations.collapse` of the displacement
                subspace of a mixed unknown, or None when the unknown is Δu alone.
        """
        W = self.u.function_space
        owned = W.dofmap.index_map.size_local * W.dofmap.index_map_bs
        if split is None:
            return np.arange(owned, dtype=np.int32), np.zeros(0, dtype=np.int32)
        u_dofs = split[1]
        u_rows = np.unique(u_dofs[u_dofs < owned])
        return u_rows, np.setdiff1d(np.arange(owned, dtype=np.int32), u_rows)

    def _norm(self, values: np.ndarray) -> float:
        """The global 2-norm of owned entries."""
        return float(np.sqrt(self.A.comm.tompi4py().allreduce(float(values @ values))))

    def _monitor(self, snes, iteration: int, norm: float) -> None:
        self.norms.append(norm)
        if norm < self._best_norm:  # the iterate a retry may resume from (keep_best)
            self._best_norm = norm
            snes.getSolution().copy(self._best)

    def resume_from_best(self) -> None:
        """Set ``u`` to the last solve's iterate of smallest ‖R‖, to start the next from.

        A retry of the same step (the same equations) with another line search then
        begins where the failed solve came closest, not from the step's start.

        Raises:
            RuntimeError: The last solve kept no iterate (``keep_best=False``).
        """
        if not np.isfinite(self._best_norm):
            raise RuntimeError("resume_from_best: the last solve kept no iterate (keep_best)")
        dolfinx.fem.petsc.assign(self._best, self.u)

    def _matrix(self, coupling: dolfinx.fem.Form | None) -> PETSc.Mat:
        """The step's matrix: every cell's entries, and ``coupling``'s where given."""
        A = self._cells.duplicate(copy=True)
        if coupling is not None:
            extra = fem_petsc.create_matrix(coupling)
            fem_petsc.assemble_matrix(extra, coupling)
            extra.assemble()
            extra.zeroEntries()  # its entries stay, as explicit zeros
            A.axpy(1.0, extra, PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
            extra.destroy()
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_LOCATION_ERR, True)
        return A

    def couple(self, coupling: dolfinx.fem.Form | None) -> None:
        """Give the matrix the pattern of the cells and of ``coupling`` (this step's).

        The ghost penalty joins the cells across the step's ghost facets only. A
        pattern over every interior facet, fixed for the run, held explicit zeros
        across all the others, which MUMPS factorises as entries: on Cook (n = 32,
        point domains, 20 steps) the linear solves took 1.33 s with it against 0.45 s
        without the penalty (2026-12-07).
        """
        old = self.A
        self.A = self._matrix(coupling)
        self.A.setOptionsPrefix(f"{self._prefix}A_")
        if self._near_null_space is not None:
            self.A.setNearNullSpace(self._near_null_space)
        self.snes.setJacobian(_weak(self._jacobian), self.A)
        old.destroy()

    def _set_up_iterative(self, V: dolfinx.fem.FunctionSpace, split) -> None:
        """Give AMG the rigid body modes, and a mixed unknown's field split its dofs.

        ``split`` is the collapsed displacement space and its dofs in the unknown
        for a mixed unknown (see :meth:`_owned_rows`), None otherwise.
        """
        pc = self.snes.getKSP().getPC()
        if split is None:
            self._near_null_space = rigid_body_modes(V, np.arange(self._u_rows.size))
            self.A.setNearNullSpace(self._near_null_space)
            return
        collapsed, u_dofs = split
        owned = collapsed.dofmap.index_map.size_local * collapsed.dofmap.index_map_bs
        u_dofs = u_dofs[:owned]  # the owned rows of the collapsed space are the first
        unexpected = not np.array_equal(np.sort(u_dofs), self._u_rows)
        parallel.raise_together(  # every rank stops, or none: collective calls follow
            self.A.comm.tompi4py(),
            RuntimeError("iterative solver: unexpected layout of the displacement dofs")
            if unexpected
            else None,
        )
        order = np.argsort(u_dofs)
        # PETSc's index sets take global rows.
        start = self.A.getOwnershipRange()[0]
        is_u = PETSc.IS().createGeneral(start + self._u_rows, comm=self.A.comm)
        is_p = PETSc.IS().createGeneral(start + self._p_rows, comm=self.A.comm)
        # PCFIELDSPLIT hands a near null space composed with a split's IS to its block.
        modes = rigid_body_modes(collapsed, order)
        is_u.compose("nearnullspace", modes)
        self._keep = (is_u, is_p, modes)  # PETSc holds references, Python must too
        pc.setType("fieldsplit")
        pc.setFieldSplitIS(("u", is_u), ("p", is_p))

    @property
    def line_search(self) -> str:
        """The configured SNES line-search type (e.g. ``"basic"``)."""
        return self.snes.getLineSearch().getType()

    def _with_options(self, act) -> None:
        """Call ``act()`` with this solver's options in PETSc's database, then restore it."""
        with_petsc_options(self._prefix, self._options, act, self.read_options)

    def _fresh_ksp(self) -> None:
        """Give SNES a new linear solver, so no set-up survives from an older active set."""
        ksp = PETSc.KSP().create(self.snes.comm)
        ksp.setOptionsPrefix(self._prefix)
        self._with_options(ksp.setFromOptions)
        self.snes.setKSP(ksp)
        ksp.destroy()  # SNES holds its own reference

    def _add_time(self, key: str, t0: float) -> None:
        self.timings[key] = self.timings.get(key, 0.0) + time.perf_counter() - t0

    def _residual(self, snes, x, b) -> None:
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        dolfinx.fem.petsc.assign(x, self.u)
        if self._before_residual is not None:
            self._before_residual()  # it reads u (e.g. a return map at this iterate)
        if self._inertia is not None:
            inertia = self._inertia()
            self.test.inertia = inertia if np.isfinite(inertia) else 0.0
        t0 = time.perf_counter()
        with b.localForm() as b_local:
            b_local.set(0.0)
        fem_petsc.assemble_vector(b, self._F.form, coeffs=self._F.coefficients())
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if self._extra_force is not None:
            b.axpy(1.0, self._extra_force)
        if self._ghost is not None:
            self._ghost.full.multAdd(x, b, b)  # G Δu, linear in the increment
        # Before the conditions overwrite them, supported rows hold their reactions.
        rows = self._u_rows
        self.test.record_internal(self._norm(b.array_r[rows] + self._loads.array_r[rows]))
        if self._needs_lifting(x):
            if self._before_jacobian is not None:
                # The lifting assembles the tangent at this iterate: a pointwise law
                # must have packed it (it is then reused by this iterate's Jacobian).
                self._before_jacobian()
            lift = self._scratch
            with lift.localForm() as local:
                local.set(0.0)
            fem_petsc.apply_lifting(
                lift,
                [self._J.form],
                bcs=[self._bcs],
                x0=[x],
                alpha=-1.0,
                coeffs=[self._J.coefficients()],
            )
            lift.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            b.axpy(1.0, lift)
            if self._ghost is not None:  # its part of the lifting, G (g − x) on the bc dofs
                self._ghost.full.multAdd(self._gap, b, b)
        fem_petsc.set_bc(b, self._bcs, x, -1.0)
        if not self.nonfinite:  # the same on every rank: set collectively
            bad = np.flatnonzero(~np.isfinite(b.array_r))
            if parallel.any_rank(self.A.comm.tompi4py(), bad.size > 0):
                self._note_nonfinite(
                    "residual", bad, "an iterate turned a point inside out, or a law failed there"
                )
        self.test.displacement_norm = self._norm(b.array_r[rows])
        self.test.pressure_norm = self._norm(b.array_r[self._p_rows])
        self._add_time("assembly", t0)

    def _needs_lifting(self, x: PETSc.Vec) -> bool:
        """Whether ``x`` misses a Dirichlet value by more than round-off.

        Lifting adds ``−A (g − x)`` to the residual; it assembles the whole
        Jacobian form once more, and after the first full Newton update the
        iterate holds the boundary values to round-off, where the term vanishes.
        """
        if not self._bcs:
            return False
        gap = self._gap
        with gap.localForm() as local:
            local.set(0.0)
        fem_petsc.set_bc(gap, self._bcs)
        g_max = gap.norm(PETSc.NormType.INFINITY)
        fem_petsc.set_bc(gap, self._bcs, x, 1.0)
        # After a full update x_bc = x − (x − g), which misses g by a few ulps of |g|.
        return gap.norm(PETSc.NormType.INFINITY) > BC_MISMATCH * g_max

    def _jacobian(self, snes, x, A, P) -> None:
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        dolfinx.fem.petsc.assign(x, self.u)
        if self._before_jacobian is not None:
            self._before_jacobian()
        t0 = time.perf_counter()
        self._J.assemble_matrix(A, self._bcs)
        if self._after_jacobian is not None:
            self._after_jacobian(A)
        if self._ghost is not None:
            A.axpy(1.0, self._ghost.constrained, PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        # Checked until a failed derivative is found, even after a residual's NaN
        # (a line search's inverted trial) was: that must not hide it.
        if not self.nonfinite_derivative and not np.isfinite(A.norm(PETSc.NormType.FROBENIUS)):
            indptr, _, values = A.getValuesCSR()
            row_of = np.repeat(np.arange(indptr.size - 1), np.diff(indptr))
            bad = np.unique(row_of[~np.isfinite(values)])
            # SNES's function vector holds the residual at this iterate: where it is
            # finite, the derivative itself failed.
            derivative = not parallel.any_rank(
                self.A.comm.tompi4py(), not np.all(np.isfinite(self.b.array_r))
            )
            noted = self._note_nonfinite(
                "Jacobian",
                bad,
                "at an iterate whose residual was finite: a law's or a condition's "
                "derivative failed there"
                if derivative
                else "a law or a condition failed there",
            )
            self.nonfinite_derivative = derivative and noted
        self.test.round_off = self._round_off(A)
        self._add_time("assembly", t0)

    def clear_nonfinite(self) -> None:
        """Forget where an earlier solve met a non-finite residual or Jacobian."""
        self.nonfinite, self.nonfinite_derivative = "", False

    def _note_nonfinite(self, what: str, rows: np.ndarray, cause: str) -> bool:
        """Say in :attr:`nonfinite` which nodes' rows of ``what`` hold NaN or inf (collective).

        ``rows``: this rank's owned rows that do; ``cause``: what may have made them,
        in words. A step cut for a failed derivative then says so (2026-12-06: a
        frictional wall's Jacobian held NaN beyond 710 slip scales, and the retry
        cut its steps without a word). Returns whether a rank had such a row (a
        Frobenius norm can overflow on finite entries).
        """
        comm = self.A.comm.tompi4py()
        owned = self.u.function_space.dofmap.index_map.size_local
        owned *= self.u.function_space.dofmap.index_map_bs
        rows = rows[rows < owned]
        count = comm.allreduce(int(rows.size))
        if count == 0:
            return False
        total = comm.allreduce(int(owned))
        first = _gathered_place(comm, _row_places(self.u.function_space), rows)
        # Spread over most rows (a non-finite update), the first row's place is any place.
        where = (
            f"first near x = {first}"
            if count <= total // 2
            else "most of them: the place where it began is lost"
        )
        self.nonfinite = f"the {what} held NaN or inf in {count} of {total} rows ({where}), {cause}"
        return True

    def where_it_failed(self) -> str:
        """Where the last iterate is furthest from balance and where it moved the grid most.

        In words, for a failed solve's message (collective): the displacement row of
        largest magnitude of the last residual, and that of the last increment Δu
        (one component each, not a node's vector), each with its node's place. Newton
        that fails on a few nodes a sparsely filled cell barely holds runs them away by
        metres (a punch in sand, 2026-12-06: one node moved 16.6 m where the rest moved
        millimetres), and neither the residual history nor a hinge check says which.
        """
        comm = self.A.comm.tompi4py()
        places, found = _row_places(self.u.function_space), []
        for vector in (self.b, self.x):
            values = np.abs(vector.array_r[self._u_rows])
            values[~np.isfinite(values)] = np.inf
            k = int(np.argmax(values)) if values.size else -1
            largest, owner = comm.allreduce(
                (float(values[k]) if k >= 0 else -1.0, comm.rank), op=MPI.MAXLOC
            )
            rows = self._u_rows[[k]] if comm.rank == owner and k >= 0 else self._u_rows[:0]
            found.append((largest, _gathered_place(comm, places, rows)))
        (force, at_force), (move, at_move) = found
        # A residual that is not finite (a line-search trial) is named by `nonfinite`.
        balance = (
            f"the largest out-of-balance force, {force:.3e}, acts at x = {at_force}, and "
            if np.isfinite(force)
            else ""
        )
        if not np.isfinite(move):
            return f"At the last iterate {balance}the grid's move was not finite at x = {at_move}. "
        return (
            f"At the last iterate {balance}the grid moved most at x = {at_move}, by "
            f"{move:.3e} m along an axis ({move / self.test.length:.3g} times the grid's "
            "largest cell). "
        )

    def _round_off(self, A: PETSc.Mat) -> float:
        """The round-off floor of the displacement rows, ``ROUND_OFF_FACTOR`` ε (h ‖diag K‖ + ‖c‖).

        ``h ‖diag K‖`` is the force of a displacement error of ε h, over the rows
        that no condition holds: a held row's diagonal is 1, in no unit, and counted it
        set the floor in a unit system where E is about 1 or less (a helper's block in
        m–kg–ns, E = 1e-11: steps accepted at iteration 0 with ‖R‖ at 36 % of the
        forces, 2026-12-07). With volumetric
        averaging the bulk stiffness is not on that diagonal: it couples Δu to the
        strain θ, whose round-off (about ε, as ε h is Δu's) then unbalances each
        displacement row by about its coupling c_I = (A s)_I, s = ±1 on the strain's
        rows (measured: without it Cook at ν = 0.499 stagnated at 3 times the floor).
        """
        A.getDiagonal(self._diagonal)
        floor = self.test.length * self._norm(np.abs(self._diagonal.array_r[self._free_u_rows]))
        if self._strain_probe is not None:
            A.mult(self._strain_probe, self._scratch)
            floor += self._norm(self._scratch.array_r[self._u_rows])
        return ROUND_OFF_FACTOR * EPS * floor

    def solve(
        self,
        F: BoundForm,
        J: BoundForm,
        bcs: Sequence[dolfinx.fem.DirichletBC],
        before_residual: Callable[[], None] | None = None,
        line_search: str | None = None,
        before_jacobian: Callable[[], None] | None = None,
        loads: BoundForm | None = None,
        pressure_volume: float = 0.0,
        ghost=None,
        keep_best: bool = False,
        after_jacobian: Callable[[PETSc.Mat], None] | None = None,
        extra_force: PETSc.Vec | None = None,
        inertia: Callable[[], float] | None = None,
    ) -> NewtonResult:
        """Solve from the current value of ``u``; on return ``u`` holds the last iterate.

        ``before_residual`` and ``before_jacobian`` are called with ``u`` set to
        each iterate, before its residual or Jacobian is assembled.
        ``line_search`` (a SNES line-search type, e.g. ``"bt"``) replaces the
        configured one for this solve only. ``loads`` is the step's external
        force form f_ext and ``pressure_volume`` the norm of the pressure nodes'
        volumes ‖V‖ (m³; m² in 2D), both for :class:`ForceTest`. ``ghost`` (a
        :class:`~fe_mpm.ghost.GhostStabilisation`, assembled for the step) adds its
        penalty to the residual and the tangent. ``keep_best`` keeps a copy of the
        iterate of smallest ‖R‖ for :meth:`resume_from_best`. ``after_jacobian(A)``
        adds what the forms cannot assemble to each Jacobian (couplings across cells,
        :mod:`fe_mpm.shared_increment`), the conditions' rows and columns left alone.
        ``extra_force`` is a force of the step that does not depend on Δu, added to
        every residual (the facet terms of :mod:`fe_mpm.pressure_by_parts`).
        ``inertia()`` (collective) gives the size of the step's inertia forces at
        the iterate in ``u`` (N), for :class:`ForceTest`'s scale; None in a static step.

        With ``pc_type redistribute`` every solve gets a fresh linear solver: the
        constrained dofs it removes change from step to step, but the matrix
        pattern does not, so PETSc would keep the last step's reduced system.
        """
        self._F, self._J, self._bcs, self._ghost = F, J, bcs, ghost
        held = np.concatenate([np.zeros(0, np.int32), *(bc.dof_indices()[0] for bc in bcs)])
        self._free_u_rows = self._u_rows[~np.isin(self._u_rows, held)]
        self._extra_force = extra_force
        self._before_residual = before_residual
        self._inertia = inertia
        self.test.inertia = 0.0
        self._before_jacobian = before_jacobian
        self._after_jacobian = after_jacobian
        if self._options.get("pc_type") == "redistribute":
            self._fresh_ksp()
        self.norms = []
        # A copy of every new best iterate, only when a retry may resume from it.
        self._best_norm = np.inf if keep_best else -np.inf
        with self._loads.localForm() as local:
            local.set(0.0)
        if loads is not None:
            fem_petsc.assemble_vector(self._loads, loads.form, coeffs=loads.coefficients())
            self._loads.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.test.loads = self._norm(self._loads.array_r[self._u_rows])
        self.test.volume = float(pressure_volume)
        self.test.verdict, self.test.passed = "", False
        self.test.finite_internal = 0.0  # this solve's, not the last one's
        if not np.isfinite(self.test.round_off):
            # A floor from a tangent that was not finite is forgotten: kept, it refused
            # every later attempt at iteration 0, before any new tangent.
            self.test.round_off = 0.0
        dolfinx.fem.petsc.assign(self.u, self.x)
        search = self.snes.getLineSearch()
        configured = search.getType()
        if line_search is not None:
            search.setType(line_search)
        t0 = time.perf_counter()
        try:
            # Under the options: the preconditioner's set-up reads some of them.
            self._with_options(lambda: self.snes.solve(None, self.x))
        finally:
            search.setType(configured)
            self.iterations_total += self.snes.getIterationNumber()
        self._add_time("newton", t0)
        dolfinx.fem.petsc.assign(self.x, self.u)
        self.u.x.scatter_forward()
        reason = self.snes.getConvergedReason()
        # Only ForceTest says converged; any other positive reason is not trusted.
        converged = reason > 0 and self.test.passed
        return NewtonResult(
            converged=converged,
            iterations=self.snes.getIterationNumber(),
            reason=self.test.verdict or _REASONS.get(reason, str(reason)),
            residual_norms=list(self.norms),
            force_scale=self.test.reported_scale,
            tolerance=self.test.tolerance_at(self.test.reported_scale),
            force_residual=self.test.reported_residual,
        )

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for obj in (
            self.snes,
            self.A,
            self._cells,
            self.b,
            self.x,
            self._gap,
            self._loads,
            self._scratch,
            self._diagonal,
            self._best,
            *([self._strain_probe] if self._strain_probe is not None else []),
        ):
            obj.destroy()
