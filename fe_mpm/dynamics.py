"""Implicit Newmark dynamics of the points, with Bossak's numerical dissipation.

Iaconeta (2019) §2.3. Each step projects the points' velocity and acceleration
to the grid (mass weighted, Eqs. 2.6–2.9), sets Newmark's coefficients for the
step length, and after the solve updates the points' velocities (Eq. 2.16). The
first step starts from accelerations in equilibrium with the initial loads.
Bossak's α_B = 0 is the thesis's trapezoidal rule (β = 1/4, γ = 1/2); the weak-form
terms and the scheme are in :mod:`fe_mpm.forms.inertia`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from petsc4py import PETSc

import numpy as np

from fe_mpm._dolfinx import dolfinx
from fe_mpm.errors import ConvergenceError
from fe_mpm.forms import inertia
from fe_mpm.formulations import GridFields, collapse
from fe_mpm.solver_options import LINEAR_SOLVERS, with_petsc_options
from fe_mpm.transfer import consistent_projection


class NewmarkDynamics:
    """The grid state of Newmark's rule and the transfers that feed it.

    Args:
        fields: The grid unknowns; the displacement must be P1.
        damping: Mass-proportional Rayleigh coefficient α_R (1/s), ≥ 0.
        bossak_alpha: Bossak's α_B in [−1/3, 0]; 0 is the trapezoidal rule.
        linear_solver: ``"direct"`` or ``"iterative"``, as for Newton: the mass
            system of the initial acceleration is solved the same way.
        petsc_options: The user's PETSc overrides; those for the linear solver (all but
            ``snes_*``) apply to the mass system too.
        projection_passes: Passes k ≥ 1 of the consistent-mass projection of the
            points' velocity and acceleration
            (:func:`~fe_mpm.transfer.consistent_projection`): 1 is the thesis's
            mass-weighted projection (Eqs. 2.6–2.9).
        stiffness_damping: Stiffness-proportional Rayleigh coefficient β_R (s), ≥ 0
            (:func:`~fe_mpm.forms.inertia.stiffness_damping`).

    Attributes:
        data: The Newmark fields and constants the forms read.
        u_dofs: The displacement dofs within the grid unknown ``w``.
        grid_mass: Nodal masses ``Σ_p N_I m_p`` of the last projection (kg), or None.
    """

    #: PETSc options prefix of the mass system (``-fe_mpm_mass_ksp_view`` works).
    PREFIX = "fe_mpm_mass_"

    def __init__(
        self,
        fields: GridFields,
        damping: float,
        bossak_alpha: float = 0.0,
        linear_solver: str = "direct",
        petsc_options: dict | None = None,
        projection_passes: int = 1,
        stiffness_damping: float = 0.0,
    ):
        mesh = fields.W.mesh
        self.projection_passes = projection_passes
        self.n_unknowns = fields.w.x.array.size
        # The grid velocity/acceleration live on the displacement space itself.
        if fields.spec.mixed:
            V1, self.u_dofs = collapse(fields.W.sub(0))
        else:
            V1, self.u_dofs = fields.W, np.arange(fields.w.x.array.size)
        self.data = inertia.NewmarkData(
            v_n=dolfinx.fem.Function(V1, name="v_n"),
            a_n=dolfinx.fem.Function(V1, name="a_n"),
            **{name: dolfinx.fem.Constant(mesh, 0.0) for name in inertia.COEFFICIENTS},
            bossak=dolfinx.fem.Constant(mesh, float(bossak_alpha)),
            damping=dolfinx.fem.Constant(mesh, float(damping)),
            # β_R = 0 leaves the term out of the forms (no kernels of its own).
            stiffness_damping=dolfinx.fem.Constant(mesh, float(stiffness_damping))
            if stiffness_damping > 0.0
            else None,
        )
        self.grid_mass: np.ndarray | None = None
        #: The keys of the options that PETSc has read in the mass solves so far.
        self.read_options: set[str] = set()
        self._solver_options = {
            **LINEAR_SOLVERS[linear_solver, False],
            **{k: v for k, v in (petsc_options or {}).items() if not k.startswith("snes_")},
        }

    @property
    def space(self) -> dolfinx.fem.FunctionSpace:
        """The P1 vector space of the grid velocity and acceleration."""
        return self.data.v_n.function_space

    def project(
        self,
        cells: np.ndarray,
        bary: np.ndarray,
        mass: np.ndarray,
        velocity: np.ndarray,
        acceleration: np.ndarray,
        dt: float,
    ) -> None:
        """Project the points' velocity and acceleration to the nodes and set Δt.

        Mass weighted, ``ṽ_I = Σ_p N_I m_p v_p / Σ_p N_I m_p`` and likewise ã, then
        corrected towards the consistent-mass projection in ``projection_passes − 1``
        more passes; and Newmark's coefficients for a step of length ``dt`` (s).

        Args:
            cells: The points' cells (n,).
            bary: Their barycentric coordinates there (n, g + 1).
            mass: The points' masses (n,) in kg.
            velocity: The points' velocities (n, g) at t_n, m/s.
            acceleration: The points' accelerations (n, g) at t_n, m/s².
            dt: The step length (s), > 0.
        """
        g = velocity.shape[1]
        both = np.hstack([velocity, acceleration])
        nodal, self.grid_mass = consistent_projection(
            self.space, cells, bary, mass, both, self.projection_passes
        )
        self.data.v_n.x.array.reshape(-1, g)[:] = nodal[:, :g]
        self.data.a_n.x.array.reshape(-1, g)[:] = nodal[:, g:]
        self.data.set_step(dt)

    def initial_acceleration(
        self,
        residual_at_rest: Callable[[], np.ndarray],
        mass_matrix,
        layout,
        constrained: np.ndarray,
        bary: np.ndarray,
        preload: Callable[[np.ndarray, np.ndarray], bool] | None = None,
    ) -> np.ndarray:
        """Point accelerations in equilibrium at the start: ``M a₀ = f_ext − f_int − C v₀``.

        Starting Newmark's rule from a₀ = 0 instead leaves the velocity lagging by
        ``Δt/2`` times the true acceleration for the whole run (a first-order error
        in Δt).

        Args:
            residual_at_rest: Assembles the step's residual (over the whole unknown
                ``w``) at Δu = 0; called here with the Newmark terms reduced to
                the damping ``C ṽ = (α_R M + β_R K) ṽ`` (no acceleration, and
                v_{n+1} = ṽ), so that it returns ``f_int − f_ext + C ṽ``.
            mass_matrix: The step's mass form (:class:`~fe_mpm.assembly.StepForm`).
            layout: The step's slot layout, to bind the mass form; ``layout.cell``
                holds the points' cells (n,).
            constrained: Which dofs of ``w`` the step's conditions fix (bool): they
                get a₀ = 0.
            bary: The points' barycentric coordinates in their cells (n, g + 1).
            preload: Given the residual's displacement part at rest (on :attr:`space`)
                and which of its entries are constrained, may set what carries it (the
                walls' springs, :meth:`fe_mpm.walls.RigidWalls.preload`) and says
                whether it did; the residual is then assembled again.

        Returns:
            The points' accelerations (n, g) in m/s².
        """
        nm = self.data
        # With ã = 0 and every coefficient 0 but ṽ's weight in v_{n+1} (1), the
        # acceleration terms vanish and the damping terms are (α_R M + β_R K) ṽ.
        coefficients = [getattr(nm, name) for name in inertia.COEFFICIENTS]
        saved = [c.value.copy() for c in coefficients]
        for name, c in zip(inertia.COEFFICIENTS, coefficients, strict=True):
            c.value = 1.0 if name == "c_vv" else 0.0
        nm.a_n.x.array[:] = 0.0
        try:
            b = residual_at_rest()
            if preload is not None and preload(b[self.u_dofs], constrained[self.u_dofs]):
                b = residual_at_rest()
        finally:
            for c, value in zip(coefficients, saved, strict=True):
                c.value = value
        rhs = dolfinx.fem.Function(self.space)
        rhs.x.array[:] = -b[self.u_dofs]
        # The pattern of all cells (explicit zeros where empty) keeps every diagonal
        # entry for the constraint rows below.
        all_cells = np.arange(
            self.space.mesh.topology.index_map(self.space.mesh.topology.dim).size_local,
            dtype=np.int32,
        )
        M = dolfinx.fem.petsc.assemble_matrix(mass_matrix.bind_cells(all_cells))
        M.assemble()
        mass_matrix.bind(layout).assemble_matrix(M)
        rows = np.flatnonzero(constrained[self.u_dofs]).astype(np.int32)
        rhs.x.array[rows] = 0.0
        # PETSc numbers rows globally; each rank zeroes the rows it owns, which are
        # its local rows shifted by the start of its range.
        index_map, bs = self.space.dofmap.index_map, self.space.dofmap.index_map_bs
        owned = rows[rows < index_map.size_local * bs]
        M.zeroRowsColumns((M.getOwnershipRange()[0] + owned).astype(PETSc.IntType), 1.0)
        a0 = dolfinx.fem.Function(self.space)
        ksp = PETSc.KSP().create(M.comm)
        try:
            ksp.setOperators(M)
            ksp.setOptionsPrefix(self.PREFIX)

            def configure_and_solve() -> None:  # the preconditioner's set-up reads options too
                ksp.setFromOptions()
                ksp.solve(rhs.x.petsc_vec, a0.x.petsc_vec)

            with_petsc_options(
                self.PREFIX, self._solver_options, configure_and_solve, self.read_options
            )
            if ksp.getConvergedReason() < 0:
                raise ConvergenceError(
                    "step 1: the mass system of the initial acceleration did not converge "
                    f"(KSP reason {ksp.getConvergedReason()}); nothing was updated. A "
                    "consistent mass is singular where the points cannot tell a cell's "
                    "nodes apart (one point per tetrahedron): seed more points per cell "
                    "or pass mass='lumped'"
                )
        finally:
            ksp.destroy()
            M.destroy()
        a0.x.scatter_forward()
        g = self.space.dofmap.bs
        nodes = self.space.dofmap.list[layout.cell]
        return np.einsum("pv,pvg->pg", bary, a0.x.array.reshape(-1, g)[nodes])

    def start(
        self,
        residual_at_rest: Callable[[], np.ndarray],
        mass_matrix,
        layout,
        bcs: list,
        bary: np.ndarray,
        points,
        dt: float,
        preload: Callable[[np.ndarray, np.ndarray], bool] | None = None,
    ) -> None:
        """Give the points accelerations in equilibrium with the loads and project them.

        See :meth:`initial_acceleration`; the dofs of ``w`` that the step's ``bcs``
        constrain (Dirichlet and unsupported nodes) get a₀ = 0. ``points`` are the
        material points, whose acceleration is set; ``dt`` is the first step's length (s).
        """
        points.acceleration = self.initial_acceleration(
            residual_at_rest, mass_matrix, layout, self._held(bcs), bary, preload
        )
        self.project(layout.cell, bary, points.mass, points.velocity, points.acceleration, dt)

    def inertia_force_norm(self, w: np.ndarray) -> float:
        """The size of the step's inertia forces at the grid unknown ``w`` (local values), N.

        ``‖m_I ((1 − α_B) a_I + α_B ã_I + α_R v_I)‖`` over the owned nodes, with the
        nodal masses m_I = Σ_p N_I(x_p) m_p of the step's projection (the row-sum
        mass) and Newmark's a_{n+1}, v_{n+1} of the increment Δu in ``w``: the inertia
        term of the residual with the lumped mass, a measure of its size with the
        consistent one (N; N/m in 2D). Collective.
        """
        d = self.data
        _, a0, a, v = self._owned_newmark(w)
        alpha, damping = float(d.bossak.value), float(d.damping.value)
        mass = self.grid_mass[: len(a), None]
        force = mass * ((1.0 - alpha) * a + alpha * a0 + damping * v)
        squares = float(np.einsum("ij,ij->", force, force))
        return math.sqrt(self.space.mesh.comm.allreduce(squares))

    def grid_kinetic_energy(self, w: np.ndarray, bcs: list, dt: float) -> float:
        """The kinetic energy ``½ Σ_I m_I |v_I|²`` of the grid at the step's end (J; J/m in 2D).

        Newmark's v_{n+1} of the increment in ``w`` (local values), except at the
        nodes the step's ``bcs`` hold, which move at their prescribed rate Δu/Δt
        (Newmark would give a held node −ṽ there, the projection's velocity reversed);
        the row-sum nodal masses of the step's projection. The motion the grid
        carries: the points' own ``Σ ½ m_p |v_p|²`` also holds velocity the
        projection averages to zero, which a deposit at rest kept for ever (1.7 % of
        its peak energy, where this fell to 2e-5 of it). Collective.
        """
        du, _, _, v = self._owned_newmark(w)
        held = self._held(bcs)[self.u_dofs][: v.size].reshape(v.shape)
        v = np.where(held, du / dt, v)
        energy = 0.5 * float(self.grid_mass[: len(v)] @ np.einsum("ij,ij->i", v, v))
        return self.space.mesh.comm.allreduce(energy)

    def _held(self, bcs: list) -> np.ndarray:
        """Which dofs of ``w`` (local values) the step's ``bcs`` constrain (bool)."""
        held = np.zeros(self.n_unknowns, dtype=bool)
        for bc in bcs:
            held[bc.dof_indices()[0]] = True
        return held

    def _owned_newmark(
        self, w: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Δu in ``w``, ã_n, and Newmark's a_{n+1}, v_{n+1} of it, at the owned nodes."""
        d, space = self.data, self.space
        g = space.dofmap.index_map_bs
        nodes = space.dofmap.index_map.size_local
        du = w[self.u_dofs][: nodes * g].reshape(nodes, g)
        v0 = d.v_n.x.array[: nodes * g].reshape(nodes, g)
        a0 = d.a_n.x.array[: nodes * g].reshape(nodes, g)
        a = float(d.c_a.value) * du - float(d.c_av.value) * v0 - float(d.c_aa.value) * a0
        v = float(d.c_v.value) * du + float(d.c_vv.value) * v0 + float(d.c_va.value) * a0
        return du, a0, a, v

    def updated_velocity(
        self,
        velocity: np.ndarray,
        acceleration: np.ndarray,
        new_acceleration: np.ndarray,
        dt: float,
    ) -> np.ndarray:
        """``v_{n+1} = v_n + Δt ((1 − γ) a_n + γ a_{n+1})`` (Eq. 2.16), (n, g) in m/s."""
        gamma = self.data.gamma
        return velocity + dt * ((1.0 - gamma) * acceleration + gamma * new_acceleration)
