"""Newton's method through PETSc SNES, with forms that change from step to step.

DOLFINx's ``NonlinearProblem`` fixes its forms at construction. An MPM step
integrates a different set of cells every step, so this solver keeps one SNES,
one matrix (built once on the sparsity of all cells, a superset of every step's)
and one residual vector, and takes the step's forms and boundary conditions in
:meth:`NewtonSolver.solve`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem.petsc as fem_petsc

from fe_mpm._dolfinx import dolfinx

#: Full Newton (no line search) with MUMPS LU; quadratic convergence is checked, not hoped for.
#: The step test (stol) ends a solve whose residual sits at its round-off floor: in
#: dynamics the inertia terms scale as 4/Δt², and that floor can exceed rtol·‖R₀‖.
#: After a Newton correction of relative size 1e-10 the error is far below it.
#: The divergence test (‖R‖ > 1e4 ‖R₀‖) is off: under a prescribed displacement
#: ‖R₀‖ is the boundary gap in metres while later residuals are forces, so it
#: stopped sound solves after one iteration; a diverging solve ends at snes_max_it.
#: PCREDISTRIBUTE drops the constrained rows (Dirichlet and the pinned dofs of empty
#: cells) before MUMPS sees the matrix, so empty grid costs no factorisation time.
DEFAULT_PETSC_OPTIONS = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",
    "snes_rtol": 1e-10,
    "snes_atol": 1e-12,
    "snes_stol": 1e-10,
    "snes_max_it": 25,
    "snes_divergence_tolerance": "unlimited",
    "ksp_type": "preonly",
    "pc_type": "redistribute",
    "redistribute_ksp_type": "preonly",
    "redistribute_pc_type": "lu",
    "redistribute_pc_factor_mat_solver_type": "mumps",
}

_REASONS = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if isinstance(v, int)}


@dataclass
class NewtonResult:
    """Outcome of one Newton solve."""

    converged: bool
    iterations: int
    reason: str
    residual_norms: list[float]


class NewtonSolver:
    """SNES Newton for ``R(u) = 0`` with a tangent from the same UFL form.

    Args:
        u: The unknown; its vector is the SNES solution.
        sparsity_form: A bilinear form over all cells, to build the matrix once; its
            coefficients must hold finite values (they only fill the pattern).
        prefix: PETSc options prefix, e.g. ``"fe_mpm_u_"``; ``-fe_mpm_u_snes_monitor`` works.
        petsc_options: Overrides of :data:`DEFAULT_PETSC_OPTIONS`.
        timings: Dict to which assembly and total solve seconds are added.
    """

    def __init__(
        self,
        u: dolfinx.fem.Function,
        sparsity_form: dolfinx.fem.Form,
        prefix: str,
        petsc_options: dict | None = None,
        timings: dict | None = None,
    ):
        self.u = u
        self.A = fem_petsc.create_matrix(sparsity_form)
        # PETSc squeezes out preallocated entries never set before the first final
        # assembly, and later steps occupy cells that were empty in the first. So
        # set every entry of the pattern once (empty slots give explicit zeros),
        # and make any entry outside the pattern an error instead of a silent drop.
        fem_petsc.assemble_matrix(self.A, sparsity_form)
        self.A.assemble()
        self.A.setOption(PETSc.Mat.Option.NEW_NONZERO_LOCATION_ERR, True)
        self.b = fem_petsc.create_vector(u.function_space)
        self.x = fem_petsc.create_vector(u.function_space)
        self._gap = fem_petsc.create_vector(u.function_space)
        self.timings = timings if timings is not None else {}
        self.snes = PETSc.SNES().create(MPI.COMM_WORLD)
        self.snes.setFunction(self._residual, self.b)
        self.snes.setJacobian(self._jacobian, self.A)
        self.snes.setOptionsPrefix(prefix)
        self.A.setOptionsPrefix(f"{prefix}A_")
        self._prefix = prefix
        self._options = {**DEFAULT_PETSC_OPTIONS, **(petsc_options or {})}
        self._with_options(self.snes.setFromOptions)
        self.norms: list[float] = []
        self.snes.setMonitor(lambda _snes, _it, norm: self.norms.append(norm))
        self._F = self._J = None
        self._bcs: Sequence = ()
        self._before_residual: Callable[[], None] | None = None
        self._before_jacobian: Callable[[], None] | None = None

    @property
    def line_search(self) -> str:
        """The configured SNES line-search type (e.g. ``"basic"``)."""
        return self.snes.getLineSearch().getType()

    def _with_options(self, configure) -> None:
        """Call ``configure()`` with this solver's options in PETSc's database, then remove them."""
        opts = PETSc.Options()
        opts.prefixPush(self._prefix)
        for k, v in self._options.items():
            opts[k] = v
        try:
            configure()
        finally:
            for k in self._options:
                del opts[k]
            opts.prefixPop()

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
        t0 = time.perf_counter()
        with b.localForm() as b_local:
            b_local.set(0.0)
        fem_petsc.assemble_vector(b, self._F)
        if self._needs_lifting(x):
            fem_petsc.apply_lifting(b, [self._J], bcs=[self._bcs], x0=[x], alpha=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(b, self._bcs, x, -1.0)
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
        return gap.norm(PETSc.NormType.INFINITY) > 1e-13 * g_max

    def _jacobian(self, snes, x, A, P) -> None:
        if self._before_jacobian is not None:
            x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            dolfinx.fem.petsc.assign(x, self.u)
            self._before_jacobian()
        t0 = time.perf_counter()
        fem_petsc.assemble_jacobian(snes, x, A, P, self.u, self._J, None, self._bcs)
        self._add_time("assembly", t0)

    def solve(
        self,
        F: dolfinx.fem.Form,
        J: dolfinx.fem.Form,
        bcs: Sequence[dolfinx.fem.DirichletBC],
        before_residual: Callable[[], None] | None = None,
        line_search: str | None = None,
        before_jacobian: Callable[[], None] | None = None,
    ) -> NewtonResult:
        """Solve from the current value of ``u``; on return ``u`` holds the last iterate.

        ``before_residual`` and ``before_jacobian`` are called with ``u`` set to
        each iterate, before its residual or Jacobian is assembled.
        ``line_search`` (a SNES line-search type, e.g. ``"bt"``) replaces the
        configured one for this solve only.

        With ``pc_type redistribute`` every solve gets a fresh linear solver: the
        constrained dofs it removes change from step to step, but the matrix
        pattern does not, so PETSc would keep the last step's reduced system.
        """
        self._F, self._J, self._bcs = F, J, bcs
        self._before_residual = before_residual
        self._before_jacobian = before_jacobian
        if self._options.get("pc_type") == "redistribute":
            self._fresh_ksp()
        self.norms = []
        dolfinx.fem.petsc.assign(self.u, self.x)
        search = self.snes.getLineSearch()
        configured = search.getType()
        if line_search is not None:
            search.setType(line_search)
        t0 = time.perf_counter()
        try:
            self.snes.solve(None, self.x)
        finally:
            search.setType(configured)
        self._add_time("newton", t0)
        dolfinx.fem.petsc.assign(self.x, self.u)
        self.u.x.scatter_forward()
        reason = self.snes.getConvergedReason()
        return NewtonResult(
            converged=reason > 0,
            iterations=self.snes.getIterationNumber(),
            reason=_REASONS.get(reason, str(reason)),
            residual_norms=list(self.norms),
        )

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for obj in (self.snes, self.A, self.b, self.x, self._gap):
            obj.destroy()
