"""The implicit MPM step and time loop (Iaconeta 2019, Algorithm 1), in one place.

Each step:

1. **Track**: locate every material point in the (undeformed) grid.
2. **Pack**: number the points of each cell into entities and slots and write
   their data (offset, volume, F_n, density) as the slot fields' values.
3. **Solve**: Newton for the grid displacement increment Δu, assembling only
   the occupied cells; grid nodes with no material support are pinned.
4. **Convect**: evaluate Δu, ΔF and the stress at the points and update
   ``x += Δu``, ``F = ΔF F_n``, ``V = det(ΔF) V_n``. The grid is reset simply by
   never moving it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

import dolfinx.fem.petsc
import numpy as np
import ufl

from fe_mpm._dolfinx import dolfinx
from fe_mpm.boundary import (
    Dirichlet,
    PointDirichlet,
    PointTraction,
    Traction,
)
from fe_mpm.boundary_points import BoundaryPoints, BoundaryPointStep
from fe_mpm.checks import check_choice, check_finite, check_range
from fe_mpm.dynamics import NewmarkDynamics
from fe_mpm.errors import ConvergenceError, PointsOutsideError, warn
from fe_mpm.forms import mixed_up
from fe_mpm.formulations import FORMULATIONS, GridFields
from fe_mpm.grid_conditions import GridConditions
from fe_mpm.materials import Linearisation, ReturnMapResult
from fe_mpm.materials.protocol import Law, MixedLaw, missing_members
from fe_mpm.newton import NewtonSolver
from fe_mpm.output import SimulationOutput
from fe_mpm.particles import MaterialPoints, simplex_cell_type
from fe_mpm.quadrature import (
    OCCUPIED,
    SlotLayout,
)
from fe_mpm.report import StepReport
from fe_mpm.retry import RetryLadder, StepLength
from fe_mpm.step_forms import StepForms
from fe_mpm.tracker import Tracker
from fe_mpm.tracking import PointTracking, check_points_per_cell, hinge_diagnosis
from fe_mpm.transfer import mass_weighted_projection, nodal_sum_norm, second_moments


def _take_density(material, points: MaterialPoints) -> None:
    """Give the points the law's density, or check that theirs agrees with it.

    The mass of a point is what body forces and inertia use; the law's
    ``density`` only fills it in when :func:`~fe_mpm.seed` was given none.
    """
    rho = material.density
    if rho is None:
        return
    reference_volume = points.volume / np.linalg.det(points.F)
    if not points.density_given:
        points.mass = rho * reference_volume
        points.density_given = True
        return
    rho_points = points.mass / reference_volume
    off = np.abs(rho_points - rho) > 1e-9 * rho
    if np.any(off):
        first = np.flatnonzero(off)[0]
        raise ValueError(
            f"Simulation: the material's density {rho:g} kg/m³ differs from the points' "
            f"{rho_points[first]:g} kg/m³ (point {first}; from seed(..., density=...) or "
            "their masses). Give the density in one place: seed(..., density=...) for "
            "zones of different densities, or the law's density alone.")


class Simulation:
    """An implicit MPM simulation on a fixed background grid.

    Example::

        scene = meshes.cook_membrane(n=16)
        points = fe_mpm.seed(scene.mesh, per_cell=1)
        sim = fe_mpm.Simulation(
            scene.mesh, points, NeoHookean(E=70.0, nu=0.33), formulation="u",
            facet_tags=scene.facet_tags,
            dirichlet=[Dirichlet(meshes.COOK_CLAMPED)],
            tractions=[Traction(meshes.COOK_LOADED, (0.0, 1 / 16))],
        )
        sim.add_marker("A", (48.0, 60.0))
        sim.run(n_steps=1)

    Args:
        mesh: Background grid: affine triangles (plane strain) or tetrahedra.
        points: The material points (moved and updated in place).
        material: Constitutive law (see :mod:`fe_mpm.materials`); its internal
            variables are added to ``points.history`` if missing.
        formulation: ``"u"`` (irreducible), ``"up"`` (mixed P1/P1 with PPP),
            ``"up-nostab"`` (mixed P1/P1) or ``"up-p2p1"`` (mixed Taylor–Hood);
            see :mod:`fe_mpm.formulations`.
        dirichlet: Prescribed grid displacements.
        tractions: Surface tractions on grid facets.
        point_dirichlet: Prescribed displacements at boundary points that the grid
            does not follow (e.g. a rigid footing), imposed by a penalty; their
            forces on the body are reported in ``StepReport.reactions``.
        point_tractions: Tractions carried by boundary points that move with the
            body (a grid ``Traction`` stays on its facets); their forces are
            reported in ``StepReport.reactions`` too.
        body_force: Body force per unit mass (m/s², length g), e.g. gravity.
        body_force_scale: Load factor of the body force as a function of time,
            ``t -> float``; constant 1 if None (e.g. ``lambda t: t`` to ramp
            self-weight over static load steps).
        facet_tags: Facet tags for ``Dirichlet``/``Traction`` given by tag.
        petsc_options: Overrides of the Newton options (:data:`fe_mpm.newton.NEWTON_OPTIONS`)
            and of the linear solver's (:data:`fe_mpm.newton.LINEAR_SOLVERS`).
        points_leaving: ``"raise"`` (default) stops when points leave the grid;
            ``"drop"`` removes them with a warning and counts them in ``dropped``.
        output_dir: Folder for ParaView output (``particles.pvd`` and ``grid.bp``);
            nothing is written if None.
        output_every: Write every this many steps (the last step is always written).
        ppp_alpha: PPP coefficient α of the thesis (``up`` only), ≥ 0. The form uses
            α times Kratos's factor (8 in 2D, 10 in 3D); α = 1 reproduces the thesis.
        dynamic: Implicit Newmark dynamics (β = 1/4, γ = 1/2); False (default) is a
            static analysis with no inertia at all.
        mass: ``"consistent"`` (default, as in the thesis) or ``"lumped"`` (row-sum)
            mass matrix of the points, dynamic only.
        damping: Mass-proportional Rayleigh damping α_R (1/s), dynamic only; off (0)
            by default. The thesis uses 1.5 for the granular collapse.
        reactions: Boundaries whose reaction force is computed after every step,
            name -> facet tag or marker (see ``StepReport.reactions``).
        min_step: Smallest step :meth:`run` may cut to after Newton failures (s);
            default 1/1024 of the nominal step.
        fallback_line_search: SNES line search with which a failed step is retried
            from its start before it is cut (None: cut at once). Full Newton steps
            (the default) can diverge from a poor start, and a backtracking search
            (``"bt"``, the default here) can crawl where full steps converge: on
            the strip footing each of the two alone stopped short of s/B = 2, on
            different grids, and together they reach it.
        fallback_hold_cells: When a static step fails, :meth:`run` retries it once
            with the points in the cells they were in during the last step (no
            re-binning) before it cuts the step; see :meth:`step`. Not in dynamic
            analyses, whose mass projection would weigh the held points by negative
            shape function values.
        linear_solver: ``"direct"`` (default: MUMPS LU) or ``"iterative"`` (GMRES
            with algebraic multigrid; a Schur field split for u-p), see
            :data:`fe_mpm.newton.LINEAR_SOLVERS`.
        max_step_cells: In a static run, a step that moves any point farther than
            this many sizes of its cell is rejected (and cut): such a jump comes
            from a grid value that blew up at a nearly unsupported node, not from
            the loads. Dynamic runs are not checked. > 0; default 10.
    """

    def __init__(
        self,
        mesh: dolfinx.mesh.Mesh,
        points: MaterialPoints,
        material,
        formulation: str = "u",
        *,
        dirichlet: Sequence[Dirichlet] = (),
        tractions: Sequence[Traction] = (),
        point_dirichlet: Sequence[PointDirichlet] = (),
        point_tractions: Sequence[PointTraction] = (),
        body_force: Sequence[float] | None = None,
        body_force_scale: Callable[[float], float] | None = None,
        facet_tags: dolfinx.mesh.MeshTags | None = None,
        petsc_options: dict | None = None,
        points_leaving: str = "raise",
        output_dir: str | Path | None = None,
        output_every: int = 1,
        ppp_alpha: float = 1.0,
        dynamic: bool = False,
        damping: float = 0.0,
        mass: str = "consistent",
        reactions: dict[str, int | Callable] | None = None,
        min_step: float | None = None,
        fallback_line_search: str | None = "bt",
        fallback_hold_cells: bool = True,
        linear_solver: str = "direct",
        max_step_cells: float = 10.0,
    ):
        if mesh.comm.size > 1:
            # Every rank constructs the simulation, so every rank stops here: no hang.
            raise NotImplementedError(
                f"Simulation: fe-mpm runs on one MPI rank for now, and this mesh is "
                f"distributed over {mesh.comm.size}. Run without mpiexec, or build the "
                "mesh on MPI.COMM_SELF to run independent serial simulations per rank.")
        check_choice("Simulation", "formulation", formulation, tuple(FORMULATIONS))
        self.max_step_cells = check_range("Simulation", "max_step_cells", max_step_cells,
                                          lo=0.0, lo_open=True)
        check_range("Simulation", "ppp_alpha", ppp_alpha, lo=0.0)
        check_range("Simulation", "damping", damping, lo=0.0)
        check_choice("Simulation", "mass", mass, ("consistent", "lumped"))
        check_choice("Simulation", "points_leaving", points_leaving, ("raise", "drop"))
        if fallback_line_search is not None:
            check_choice("Simulation", "fallback_line_search", fallback_line_search,
                         ("basic", "bt", "l2", "cp"))
        check_range("Simulation", "output_every", output_every, lo=1)
        check_choice("Simulation", "linear_solver", linear_solver, ("direct", "iterative"))
        self.linear_solver = linear_solver
        tdim = mesh.topology.dim
        if mesh.topology.index_map(tdim).size_global == 0:
            raise ValueError("Simulation: the mesh is empty (it has no cells)")
        simplex_cell_type(mesh)
        if len(points) == 0:
            raise ValueError("Simulation: there are no material points")
        if points.gdim != mesh.geometry.dim:
            raise ValueError(
                f"Simulation: points are {points.gdim}D but the mesh is {mesh.geometry.dim}D"
            )
        missing = missing_members(material, Law)
        if missing:
            raise TypeError(
                f"Simulation: material {type(material).__name__} is not a law: it lacks "
                f"{', '.join(missing)} (fe_mpm.materials.protocol.Law says what a law provides)")
        self.mesh = mesh
        self.points = points
        self.material = material
        _take_density(material, points)
        self.formulation = formulation
        self.spec = FORMULATIONS[formulation]
        if self.spec.pressure and not isinstance(material, MixedLaw):
            raise ValueError(
                f"Simulation: formulation {formulation!r} needs a material with a "
                "deviatoric response (kirchhoff_deviatoric, see "
                "fe_mpm.materials.protocol.MixedLaw)"
            )
        check_formulation = getattr(material, "check_formulation", None)
        if check_formulation is not None:
            check_formulation(self.spec.pressure)
        self.gdim = g = mesh.geometry.dim
        for name, h in material.history.items():
            if name not in points.history:
                points.history[name] = h.initial_values(len(points))
        self.petsc_options = petsc_options
        self.timings: dict[str, float] = {}
        self.history: list[StepReport] = []
        self.t = 0.0
        self.step_number = 0

        t0 = time.perf_counter()
        self.tracker = Tracker(mesh)
        self.tracking = PointTracking(self.tracker, points_leaving)
        self.fields = GridFields(mesh, self.spec)
        self.dynamic = bool(dynamic)
        self.min_step = min_step
        self.ladder = RetryLadder(fallback_line_search, bool(fallback_hold_cells))
        self._cells_of_last_step: np.ndarray | None = None
        self.dynamics: NewmarkDynamics | None = None
        if self.dynamic:
            if self.spec.u_degree != 1:
                raise ValueError(
                    f"Simulation: dynamic analysis needs a P1 displacement; formulation "
                    f"{formulation!r} is P{self.spec.u_degree}"
                )
            self.dynamics = NewmarkDynamics(self.fields, damping, linear_solver, petsc_options)
        elif damping:
            raise ValueError("Simulation: damping needs dynamic=True")
        elif mass != "consistent":
            raise ValueError("Simulation: mass='lumped' needs dynamic=True")
        self.mass = mass
        self.conditions = GridConditions(self.fields, dirichlet, tractions, body_force,
                                         body_force_scale, reactions, facet_tags)

        conditions = [*point_dirichlet, *point_tractions]
        self._boundary_points = BoundaryPoints(conditions, g) if conditions else None
        self._boundary = (None if self._boundary_points is None
                          else BoundaryPointStep(self._boundary_points, self.tracker))

        self._ppp = None
        if self.spec.ppp:
            dg0 = dolfinx.fem.functionspace(mesh, ("DG", 0))
            dg0_vec = dolfinx.fem.functionspace(mesh, ("DG", 0, (g,)))
            centroid = dolfinx.fem.Function(dg0_vec, name="centroid")
            cells = np.arange(self.tracker.num_cells)
            centroid.x.array.reshape(-1, g)[dg0_vec.dofmap.list[cells, 0]] = self.tracker.centroids
            fill = dolfinx.fem.Function(dg0, name="fill")
            # In the material-point subdomain, so one kernel does both; the fill
            # is packed per entity (zero on a cell's copies), so each cell counts once.
            dx2 = ufl.Measure("dx", domain=mesh, subdomain_id=OCCUPIED,
                              metadata={"quadrature_degree": 2})
            alpha = mixed_up.effective_alpha(ppp_alpha, g)
            self._ppp = mixed_up.PPPData(alpha, centroid, fill, dx2)

        self._forms: dict[tuple[int, int], StepForms] = {}  # by slots of points, boundary
        self._refreshed: dict | None = None  # the iterate of the last return map
        self._newton: NewtonSolver | None = None
        self._markers: dict[str, tuple[np.ndarray, int]] = {}  # name -> (x, host point)
        self._add_time("setup", t0)

        self.output = None if output_dir is None else SimulationOutput(
            output_dir, self.fields, output_every)

        # Locate the points once now, so a bad initial layout fails at set-up.
        self._track()

    # -- public API ------------------------------------------------------------

    def add_marker(self, name: str, x: Sequence[float]) -> None:
        """Follow a point that moves with the body but carries no volume or mass.

        The marker is attached to the material point nearest to it and moves
        with that point's affine motion, ``x_m += Δu_p + (ΔF_p − I)(x_m − x_p)``:
        the grid increment of the host's cell, extended linearly to the marker.
        A marker on a vertex of its host's cell therefore moves exactly with
        that grid node in a step, and never reads an empty cell. Read it from
        ``history[k].markers[name]`` or :meth:`marker`.
        """
        # A copy: the marker moves, the caller's array must not.
        xm = check_finite("Simulation.add_marker", f"x of marker {name!r}", x).reshape(
            self.gdim).copy()
        if self.tracker.locate(xm[None, :])[0] < 0:
            raise PointsOutsideError(f"marker {name!r} at {xm} is outside the grid")
        host = int(np.argmin(np.linalg.norm(self.points.x - xm, axis=1)))
        self._markers[name] = (xm, host)

    def marker(self, name: str) -> np.ndarray:
        """Current position of a marker, shape (g,)."""
        return self._markers[name][0].copy()

    def run(
        self,
        t_end: float = 1.0,
        n_steps: int = 1,
        *,
        progress: bool = True,
        on_step: Callable[[StepReport], None] | None = None,
    ) -> list[StepReport]:
        """Advance from the current time to ``t_end`` in ``n_steps`` equal steps.

        In a static analysis ``t`` is a pseudo-time that only drives the loads
        and the prescribed displacements. When Newton fails, the step is retried
        as :mod:`fe_mpm.retry` lists (:attr:`ladder`: ``fallback_line_search``, then
        the points held in their last cells, ``fallback_hold_cells``), then halved,
        and grown back (doubling, up to the nominal step) after two successes. Below
        ``min_step`` the run stops with the last failure's message.
        ``on_step(report)`` is called after every accepted step, with the points
        updated (e.g. to record a front position).
        """
        check_range("Simulation.run", "n_steps", n_steps, lo=1)
        check_range("Simulation.run", "t_end", t_end, lo=self.t, lo_open=True)
        nominal = (t_end - self.t) / int(n_steps)
        floor = self.min_step if self.min_step is not None else nominal / 1024
        length = StepLength(nominal, floor)
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=int(n_steps), desc="fe-mpm", unit="step", leave=False)
        reports = []
        if self.step_number == 0:
            self._write_output(force=True)  # the initial state as the t = 0 frame
        try:
            while t_end - self.t > 1e-12 * nominal:
                t_new = min(self.t + length.dt, t_end)
                if t_end - t_new < 1e-9 * nominal:
                    t_new = t_end
                try:
                    report = self._step_with_fallbacks(t_new)
                except ConvergenceError as err:
                    if not length.cut():
                        raise ConvergenceError(
                            f"{err} The step was cut to {2 * length.dt:.3g} without success, "
                            f"and the floor is min_step = {floor:.3g}."
                        ) from None
                    continue
                reports.append(report)
                if on_step is not None:
                    on_step(report)
                length.accepted()
                if bar is not None:
                    bar.set_postfix(t=f"{report.t:.4g}", newton=report.newton_iterations)
                    bar.update(report.dt / nominal)
        finally:
            if bar is not None:
                bar.close()
        self._write_output(force=True)
        return reports

    def _step_with_fallbacks(self, t_new: float) -> StepReport:
        """:meth:`step` with each placement of :attr:`ladder` until one succeeds."""
        can_hold = self._cells_of_last_step is not None and not self.dynamic
        placements = self.ladder.placements(can_hold)
        for rebin in placements[:-1]:
            try:
                return self.step(t_new, rebin=rebin)
            except ConvergenceError:
                pass
        return self.step(t_new, rebin=placements[-1])

    def step(self, t_new: float, rebin: bool = True) -> StepReport:
        """Take one implicit step from the current time to ``t_new``.

        With ``rebin=False`` every point stays in the cell it was in during the
        last step, as long as it lies within half a cell of it (its barycentric
        coordinates there are all ≥ −1/2); a P1 field is linear, so the point then
        reads its old cell's field extended beyond the cell. This is a fallback
        for a step that fails right after re-binning: the points that crossed
        cells change the grid's discrete equilibrium at once, and on a perfectly
        plastic body that change can leave Newton with no nearby solution,
        however short the step. Holding them integrates one more step as a
        finite element method with moving quadrature points would; they are
        re-binned at the next step.
        """
        if not t_new > self.t:
            raise ValueError(f"Simulation.step: t_new must exceed the current time {self.t}")
        k = self.step_number + 1
        if k == 2 and self.spec.u_degree == 2:
            warn(
                f"Simulation: {self.formulation!r} beyond its first step is not yet "
                "trustworthy: points away from their Gauss positions do not integrate "
                "the gradients of the P2 shape functions exactly, and a homogeneous "
                "stress then leaves spurious nodal forces (the patch test fails; README, "
                "'P2/P1 once the points have moved'). Use 'up' for runs of many steps.")
        forms, layout, R, J, bcs = self.prepare_step(t_new, rebin=rebin)
        dt = t_new - self.t
        if self.dynamics is not None and self.step_number == 0:
            self._consistent_initial_acceleration(forms, layout, R, bcs, dt)
        self._initial_guess(layout)
        hooks = {}
        if forms.pointwise:
            hooks = {"before_residual": lambda: self.refresh_material(tangent=False),
                     "before_jacobian": self.refresh_material}
        hooks["loads"] = self._step_loads
        hooks["pressure_volume"] = self._pressure_volume(layout)
        solver = self._newton_solver(forms)
        result = None
        for search in self.ladder.line_searches(solver.line_search):
            if result is not None:  # a retry from the same start
                self._initial_guess(layout)
            attempt = solver.solve(R, J, bcs, **hooks, line_search=search)
            if result is not None:
                attempt.residual_norms = result.residual_norms + attempt.residual_norms
                attempt.iterations += result.iterations
            result = attempt
            if result.converged:
                break
        if not result.converged or not np.all(np.isfinite(self.w.x.array)):
            norms = ", ".join(f"{r:.3e}" for r in result.residual_norms)
            hinges = hinge_diagnosis(self.mesh, layout, self.tracker.centroids)
            raise ConvergenceError(
                f"Newton failed in step {k} (t = {self.t:g} -> {t_new:g}) after "
                f"{result.iterations} iterations: {result.reason}; ‖R‖ history: [{norms}] "
                f"against the force scale {result.force_scale:.3e} (accepted: ‖R‖ <= "
                f"{result.tolerance:.3e}). {hinges}"
                "Points were not updated and nothing was written for this step."
            )

        self.refresh_material(tangent=False)  # the converged iterate's, for reactions and history
        reactions = self.conditions.reactions(R.assemble_vector)
        t0 = time.perf_counter()
        self._convect(forms, layout, step=k, t=t_new, dt=dt)  # may still reject the step
        if self._boundary is not None:
            reactions.update(self._boundary.convect(forms, t_new))
        self._add_time("update", t0)

        self._cells_of_last_step = layout.cell.copy()
        self.t = t_new
        self.step_number = k
        report = StepReport(
            step=k, t=t_new, newton_iterations=result.iterations,
            residual_norms=result.residual_norms,
            markers={name: xm.copy() for name, (xm, _) in self._markers.items()},
            nslot=forms.q.nslot, occupied_cells=layout.occupied.size, dt=dt,
            reactions=reactions, held_points=self.tracking.held_points,
            converged_reason=result.reason, force_scale=result.force_scale,
            relative_residual=result.relative_residual,
            lost_load={f"Traction {i - 1}": share for i, share in self.conditions.lost_load.items()
                       if share > 0},
        )
        self.history.append(report)
        self._write_output()
        return report

    def prepare_step(self, t_new: float, rebin: bool = True):
        """Track, pack and bind the forms of the step to ``t_new`` without solving.

        ``rebin=False`` holds the points in their last cells (see :meth:`step`).

        Returns:
            ``(forms, layout, R, J, bcs)``: the slot forms, the slot layout, the
            residual and Jacobian (:class:`~fe_mpm.packing.BoundForm`, with
            ``assemble_vector``/``assemble_matrix``) and the boundary conditions. The
            Taylor tests use this to check every residual/Jacobian pair (with
            :meth:`refresh_material` before each assembly for a pointwise law).
        """
        layout = self._track(step=self.step_number + 1, t=t_new,
                             hold=None if rebin else self._cells_of_last_step)
        check_points_per_cell(layout, self.spec.min_points_per_cell, self.formulation,
                              self.step_number, self.tracker.centroids)
        if self.step_number == 0 and not self.dynamic:
            self._check_supports(layout)
        self.conditions.check_loaded_facets(layout.occupied, t_new)

        t0 = time.perf_counter()
        boundary = None if self._boundary is None else self._boundary.locate(layout.occupied, t_new)
        nslot_b = boundary.nslot if boundary is not None else 0
        forms = self._forms.get((layout.nslot, nslot_b)) or self._compile(layout.nslot, nslot_b)
        self._add_time("compile", t0)

        t0 = time.perf_counter()
        q, pts = forms.q, self.points
        q.pack_geometry(pts.x, pts.volume, layout, self.tracker.centroids, self.tracker.volumes)
        q.pack(forms.F_n, layout, pts.F, empty=np.eye(self.gdim))
        q.pack(forms.density, layout, pts.density)
        for name, h in self.material.history.items():
            q.pack(forms.history[name], layout, pts.history[name], empty=h.initial)
        if forms.lumping is not None:
            vertices = self.mesh.geometry.x[self.mesh.geometry.dofmaps[0][layout.cell], :self.gdim]
            q.pack(forms.lumping, layout, second_moments(vertices, pts.x, self._bary(layout)))
        if self._ppp is not None:
            volume = np.bincount(layout.cell, weights=pts.volume, minlength=self.tracker.num_cells)
            q.pack_cell_field(self._ppp.fill, layout, volume / self.tracker.volumes)
        if boundary is not None:
            self._boundary.pack(forms, t_new)
        R = forms.residual.bind(layout, boundary)
        J = forms.jacobian.bind(layout, boundary)
        self._step_loads = None if forms.loads is None else forms.loads.bind(layout, boundary)
        bcs = self.conditions.impose(layout.occupied, self.t, t_new)
        if self.dynamics is not None:
            self.dynamics.project(layout.cell, self._bary(layout), pts.mass, pts.velocity,
                                  pts.acceleration, t_new - self.t)
        self._add_time("packing", t0)
        self._current = (forms, layout)
        self._refreshed = None  # new points and history: no return map is current
        return forms, layout, R, J, bcs

    def refresh_material(self, tangent: bool = True) -> ReturnMapResult | None:
        """Evaluate a pointwise law's return map at the current grid unknown.

        The law's stress, ΔF and (if ``tangent``) tangent at the points go into
        the slot fields of its linearisation, so the next residual (and Jacobian)
        assembled are the law's own at this iterate. The solver calls this before
        every residual without the tangent, and again before every Jacobian; call
        it yourself after changing :attr:`w` by hand (e.g. in a Taylor test).
        At an iterate already evaluated nothing is recomputed.
        Returns the return map's result, or None for laws written in UFL.
        """
        forms, layout = self._current
        if not forms.pointwise:
            return None
        t0 = time.perf_counter()
        g, q, lin = self.gdim, forms.q, forms.linearisation
        done = self._refreshed
        if done is None or not np.array_equal(done["w"], self.w.x.array):
            dF = forms.dF_at_points.evaluate(layout).reshape(-1, g, g)
            result = self.material.return_map(dF, self.points.history)
            q.pack(lin.tau, layout, result.tau)
            q.pack(lin.dF, layout, dF, empty=np.eye(g))
            # The residual reads D_k only times ΔF − ΔF_k = 0: an old one must not
            # linger (it may belong to another step's entities), none is needed.
            q.values.pop(lin.tangent, None)
            done = self._refreshed = {"w": self.w.x.array.copy(), "tangent": False}
            self._last_return = result
        if tangent and not done["tangent"]:
            q.pack(lin.tangent, layout, Linearisation.flat_tangent(self._last_return.tangent))
            done["tangent"] = True
        self._add_time("return_map", t0)
        return self._last_return

    # -- the phases of a step --------------------------------------------------

    def _track(self, step: int = 0, t: float = 0.0, hold: np.ndarray | None = None) -> SlotLayout:
        t0 = time.perf_counter()
        layout = self.tracking.track(self.points, self._markers, step, t, hold)
        self._add_time("tracking", t0)
        return layout

    def _compile(self, nslot: int, nslot_boundary: int) -> StepForms:
        newmark = None if self.dynamics is None else self.dynamics.data
        forms = StepForms(self.fields, self.spec, self.material, nslot, nslot_boundary,
                          conditions=self.conditions, ppp=self._ppp, newmark=newmark,
                          lumped=self.mass == "lumped")
        self._forms[(nslot, nslot_boundary)] = forms
        return forms

    def _newton_solver(self, forms: StepForms) -> NewtonSolver:
        if self._newton is None:
            all_cells = np.arange(self.tracker.num_cells, dtype=np.int32)
            self._newton = NewtonSolver(
                self.w, forms.jacobian.bind_cells(all_cells),
                prefix=f"fe_mpm_{self.formulation.replace('-', '_')}_",
                petsc_options=self.petsc_options, timings=self.timings,
                linear_solver=self.linear_solver, displacement=self.fields.U,
                length=float(self.tracker.sizes.max()),
            )
        return self._newton

    def _bary(self, layout: SlotLayout) -> np.ndarray:
        """The points' barycentric coordinates in their cells of ``layout`` (n, g + 1)."""
        return self.tracker.barycentric(self.points.x, layout.cell)

    def _consistent_initial_acceleration(
        self, forms: StepForms, layout: SlotLayout, R, bcs: list, dt: float
    ) -> None:
        """Start the points from accelerations in equilibrium with the loads; project them.

        See :meth:`~fe_mpm.dynamics.NewmarkDynamics.initial_acceleration`.
        The displacement dofs the step's ``bcs`` constrain (Dirichlet and unsupported
        nodes) get a₀ = 0.
        """
        def residual_at_rest() -> np.ndarray:
            self._initial_guess(layout)  # Δu = 0 (and the projected pressure)
            self.refresh_material(tangent=False)
            return R.assemble_vector()

        constrained = np.zeros(self.w.x.array.size, dtype=bool)
        for bc in bcs:
            constrained[bc.dof_indices()[0]] = True
        pts, bary = self.points, self._bary(layout)
        pts.acceleration = self.dynamics.initial_acceleration(
            residual_at_rest, forms.mass_matrix, np.arange(self.tracker.num_cells, dtype=np.int32),
            layout, constrained, layout.cell, bary)
        self.dynamics.project(layout.cell, bary, pts.mass, pts.velocity, pts.acceleration, dt)

    def _initial_guess(self, layout: SlotLayout) -> None:
        """Δu = 0, and the pressure projected from the points (thesis Eq. 5.20).

        ``p_I = Σ_p N_I(x_p) m_p p_p / Σ_p N_I(x_p) m_p``, mass weighted, with the
        particle pressure ``p_p = −tr(σ_p)/3`` of the last step.
        """
        self.w.x.array[:] = 0.0
        if not self.spec.pressure:
            return
        p_p = -np.trace(self.points.stress, axis1=1, axis2=2) / 3.0
        nodal, _ = mass_weighted_projection(self.fields.Q[0], layout.cell, self._bary(layout),
                                            self.points.mass, p_p[:, None])
        self.fields.set_pressure(nodal[:, 0])

    def _pressure_volume(self, layout: SlotLayout) -> float:
        """‖V‖: the norm of the points' volumes gathered on the pressure nodes (m³; m² in 2D).

        The scale of the pressure rows in the Newton test (0 without pressure).
        """
        if not self.spec.pressure:
            return 0.0
        return nodal_sum_norm(self.fields.Q[0], layout.cell, self._bary(layout),
                              self.points.volume)

    def _check_supports(self, layout: SlotLayout) -> None:
        """Refuse a static model whose supports leave a rigid translation free.

        Without inertia, a body that nothing holds in some direction has a singular
        tangent (a rigid-body mode): Newton would fail with no hint. Supports count
        only where they reach material: nodes outside the occupied cells are pinned.
        A model with no loads and no conditions at all is left alone: it stays at rest.
        """
        if not (self.conditions.loads_or_supports or self._boundary_points is not None):
            return
        held = self.conditions.held_components(layout.occupied)
        pp = self._boundary_points
        if pp is not None:
            for condition in pp.conditions:
                if isinstance(condition, PointDirichlet):
                    held[list(condition.components or range(self.gdim))] = True
        if not held.all():
            free = ", ".join("xyz"[c] for c in np.flatnonzero(~held))
            raise ValueError(
                f"Simulation: a static model needs supports that stop every rigid "
                f"translation, but nothing holds the material in {free}: no Dirichlet "
                "condition (or PointDirichlet) on that component touches a node of an "
                "occupied cell. The tangent would be singular (a rigid-body mode). Add a "
                "support, or pass dynamic=True.")

    def _convect(
        self, forms: StepForms, layout: SlotLayout, step: int, t: float, dt: float
    ) -> None:
        g = self.gdim
        values = forms.update.evaluate(layout)
        if not np.all(np.isfinite(values)):
            bad = np.flatnonzero(~np.all(np.isfinite(values), axis=1))
            raise ConvergenceError(
                f"non-finite state at {bad.size} material point(s) in step {step} (t = {t:g}); "
                f"first: point {bad[0]} at x = {self.points.x[bad[0]]}. Nothing was updated."
            )
        new = forms.update_layout.decode(values)
        du_p, dF = new.du, new.dF
        det_dF = np.linalg.det(dF)
        if self.dynamics is None:
            cells_moved = np.linalg.norm(du_p, axis=1) / self.tracker.sizes[layout.cell]
            far = int(np.argmax(cells_moved))
            if cells_moved[far] > self.max_step_cells:
                raise ConvergenceError(
                    f"point {far} (x = {self.points.x[far]}) would move "
                    f"{cells_moved[far]:.3g} cell sizes ({np.linalg.norm(du_p[far]):.3g} m) in "
                    f"static step {step} (t = {t:g}), more than max_step_cells = "
                    f"{self.max_step_cells:g}: a grid value blew up (e.g. at a node with "
                    "almost no material). Nothing was updated.")
        if np.any(det_dF <= 0):
            bad = np.flatnonzero(det_dF <= 0)[0]
            raise ConvergenceError(
                f"det(ΔF) <= 0 at point {bad} (x = {self.points.x[bad]}) in step {step} "
                f"(t = {t:g}): the step inverts material; take smaller steps."
            )
        pts = self.points
        for xm, host in self._markers.values():
            xm += du_p[host] + (dF[host] - np.eye(g)) @ (xm - pts.x[host])
        pts.x += du_p
        pts.F = dF @ pts.F
        pts.volume *= det_dF
        pts.stress = new.stress
        if self.dynamics is not None:
            pts.velocity = self.dynamics.updated_velocity(pts.velocity, pts.acceleration,
                                                          new.acceleration, dt)
            pts.acceleration = new.acceleration
        for name, value in new.history.items():
            pts.history[name] = value.reshape(pts.history[name].shape)
        if forms.pointwise:
            pts.history.update(self._last_return.history)

    def _write_output(self, force: bool = False) -> None:
        if self.output is None:
            return
        t0 = time.perf_counter()
        if self.output.write(self.step_number, self.t, self.points, force=force):
            self._add_time("output", t0)

    @property
    def dropped(self) -> int:
        """Points removed so far because they left the grid (``points_leaving="drop"``)."""
        return self.tracking.dropped

    @property
    def w(self) -> dolfinx.fem.Function:
        """The grid unknown of the last step: Δu, or (Δu, p) for the mixed forms."""
        return self.fields.w

    def _add_time(self, key: str, t0: float) -> None:
        self.timings[key] = self.timings.get(key, 0.0) + time.perf_counter() - t0

    def close(self) -> None:
        """Close output files and free PETSc objects."""
        if self.output is not None:
            self.output.close()
        if self._newton is not None:
            self._newton.destroy()
            self._newton = None
