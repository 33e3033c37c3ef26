"""The implicit MPM step and time loop (Iaconeta 2019, Algorithm 1), in one place.

:meth:`Simulation.step` takes one step as the thesis's Algorithm 1 does; each
phase lives in the module that owns its state:

=====================  ===============================================================
phase                  module
=====================  ===============================================================
track                  :mod:`fe_mpm.tracking`: each point's cell, the slot layout
lay out and pack       :mod:`fe_mpm.step_forms`: the compiled forms of a slot count;
                       the points' data written as the slot fields' values
impose                 :mod:`fe_mpm.grid_conditions` (grid Dirichlet increments,
                       tractions, body force, reactions) and
                       :mod:`fe_mpm.boundary_points` (penalty points)
project (dynamics)     :mod:`fe_mpm.dynamics` with :mod:`fe_mpm.transfer`
solve                  :mod:`fe_mpm.newton`, retried as :mod:`fe_mpm.retry` lists
update the points      :mod:`fe_mpm.point_update`; the grid is reset by never moving it
report and write       :mod:`fe_mpm.report`, :mod:`fe_mpm.output`
=====================  ===============================================================
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from fe_mpm._dolfinx import dolfinx
from fe_mpm.boundary import Dirichlet, PointDirichlet, PointTraction, Traction
from fe_mpm.boundary_points import BoundaryPoints, BoundaryPointStep
from fe_mpm.checks import check_finite, check_range
from fe_mpm.dynamics import NewmarkDynamics
from fe_mpm.errors import ConvergenceError, PointsOutsideError, warn
from fe_mpm.forms.mixed_up import PPPData
from fe_mpm.formulations import FORMULATIONS, GridFields
from fe_mpm.grid_conditions import GridConditions
from fe_mpm.markers import Markers
from fe_mpm.materials import ReturnMapResult
from fe_mpm.model_checks import (
    check_grid_and_points,
    check_law,
    check_options,
    check_supports,
    take_density,
)
from fe_mpm.newton import NewtonResult, NewtonSolver
from fe_mpm.output import SimulationOutput
from fe_mpm.particles import MaterialPoints
from fe_mpm.point_update import apply_update, checked_update
from fe_mpm.quadrature import SlotLayout
from fe_mpm.report import StepReport, newton_failure
from fe_mpm.retry import RetryLadder, StepLength
from fe_mpm.step_forms import ReturnMapAtIterate, StepForms, StepInProgress
from fe_mpm.tracker import Tracker
from fe_mpm.tracking import PointTracking, check_points_per_cell

#: A run ends when less than this fraction of its nominal step is left to ``t_end``.
END_OF_RUN = 1e-12
#: A last step shorter than this fraction of the nominal step is merged into the one before.
MERGE_LAST_STEP = 1e-9


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
        check_grid_and_points(mesh, points)
        check_options(formulation=formulation, max_step_cells=max_step_cells,
                      ppp_alpha=ppp_alpha, damping=damping, mass=mass,
                      points_leaving=points_leaving, fallback_line_search=fallback_line_search,
                      output_every=output_every, linear_solver=linear_solver, dynamic=dynamic)
        self.spec = FORMULATIONS[formulation]
        check_law(material, self.spec, formulation)
        take_density(material, points)
        for name, h in material.history.items():
            points.history.setdefault(name, h.initial_values(len(points)))
        self.mesh, self.points, self.material = mesh, points, material
        self.formulation = formulation
        self.gdim = mesh.geometry.dim
        self.petsc_options, self.linear_solver = petsc_options, linear_solver
        self.max_step_cells, self.min_step, self.mass = max_step_cells, min_step, mass
        self.dynamic = bool(dynamic)
        self.timings: dict[str, float] = {}
        self.history: list[StepReport] = []
        self.t, self.step_number = 0.0, 0

        t0 = time.perf_counter()
        self.tracker = Tracker(mesh)
        self.tracking = PointTracking(self.tracker, points_leaving)
        self.fields = GridFields(mesh, self.spec)
        self.ladder = RetryLadder(fallback_line_search, bool(fallback_hold_cells))
        self.dynamics = (NewmarkDynamics(self.fields, damping, linear_solver, petsc_options)
                         if self.dynamic else None)
        self.conditions = GridConditions(self.fields, dirichlet, tractions, body_force,
                                         body_force_scale, reactions, facet_tags)
        point_conditions = [*point_dirichlet, *point_tractions]
        self._boundary_points = (BoundaryPoints(point_conditions, self.gdim)
                                 if point_conditions else None)
        self._boundary = (None if self._boundary_points is None
                          else BoundaryPointStep(self._boundary_points, self.tracker))
        self._ppp = (PPPData.on_grid(mesh, self.tracker.centroids, ppp_alpha)
                     if self.spec.ppp else None)
        self._forms: dict[tuple[int, int], StepForms] = {}  # by slots of points, boundary
        self._current: StepInProgress | None = None
        self._cells_of_last_step: np.ndarray | None = None
        self._newton: NewtonSolver | None = None
        self.markers = Markers()
        self._add_time("setup", t0)
        self.output = None if output_dir is None else SimulationOutput(
            output_dir, self.fields, output_every)
        self._track()  # once now, so a bad initial layout fails at set-up

    # -- public API ------------------------------------------------------------

    def add_marker(self, name: str, x: Sequence[float]) -> None:
        """Follow a point that moves with the body but carries no volume or mass.

        The marker is attached to the material point nearest to it and moves
        with that point's affine motion, ``x_m += Δu_p + (ΔF_p − I)(x_m − x_p)``
        (:mod:`fe_mpm.markers`). A marker on a vertex of its host's cell therefore
        moves exactly with that grid node in a step, and never reads an empty
        cell. Read it from ``history[k].markers[name]`` or :meth:`marker`.
        """
        xm = check_finite("Simulation.add_marker", f"x of marker {name!r}", x).reshape(self.gdim)
        if self.tracker.locate(xm[None, :])[0] < 0:
            raise PointsOutsideError(f"marker {name!r} at {xm} is outside the grid")
        self.markers.add(name, xm, self.points.x)

    def marker(self, name: str) -> np.ndarray:
        """Current position of a marker, shape (g,)."""
        return self.markers.position(name)

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
            while t_end - self.t > END_OF_RUN * nominal:
                t_new = min(self.t + length.dt, t_end)
                if t_end - t_new < MERGE_LAST_STEP * nominal:
                    t_new = t_end
                try:
                    report = self._step_with_fallbacks(t_new)
                except ConvergenceError as err:
                    if not length.cut():
                        raise ConvergenceError(
                            f"{err} The step was cut to {2 * length.dt:.3g} without success, "
                            f"and the floor is min_step = {floor:.3g}.") from None
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
        """Take one implicit step from the current time to ``t_new`` (Algorithm 1).

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
        k, dt = self.step_number + 1, t_new - self.t
        if k == 2 and self.spec.u_degree == 2:
            warn(self.spec.multi_step_warning())
        # Track, lay out, pack, impose (and project, in dynamics).
        forms, layout, R, J, bcs = self.prepare_step(t_new, rebin=rebin)
        if self.dynamics is not None and k == 1:
            self._consistent_initial_acceleration(forms, layout, R, bcs, dt)
        # Solve: Newton on the grid, from Δu = 0.
        result = self._solve(forms, layout, R, J, bcs)
        if not result.converged or not np.all(np.isfinite(self.w.x.array)):
            raise newton_failure(result, k, self.t, t_new, self.mesh, layout,
                                 self.tracker.centroids)
        self.refresh_material(tangent=False)  # the converged iterate's, for reactions and history
        reactions = self.conditions.reactions(R.assemble_vector)
        # Update the points (which may still reject the step); the grid is reset.
        t0 = time.perf_counter()
        self._update_points(forms, layout, k, t_new, dt)
        if self._boundary is not None:
            reactions.update(self._boundary.convect(forms, t_new))
        self._add_time("update", t0)
        self._cells_of_last_step = layout.cell.copy()
        self.t, self.step_number = t_new, k
        report = StepReport.of_step(k, t_new, dt, result, forms.q.nslot, layout, reactions,
                                    self.markers.positions(), self.tracking.held_points,
                                    self.conditions.lost_load)
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
        pts = self.points
        bary = self.tracker.barycentric(pts.x, layout.cell)
        forms.pack(layout, pts, self.tracker, bary)
        if boundary is not None:
            self._boundary.pack(forms, t_new)
        R = forms.residual.bind(layout, boundary)
        J = forms.jacobian.bind(layout, boundary)
        self._step_loads = None if forms.loads is None else forms.loads.bind(layout, boundary)
        bcs = self.conditions.impose(layout.occupied, self.t, t_new)
        if self.dynamics is not None:
            self.dynamics.project(layout.cell, bary, pts.mass, pts.velocity,
                                  pts.acceleration, t_new - self.t)
        self._add_time("packing", t0)
        return_map = (ReturnMapAtIterate(forms, layout, pts, self.w) if forms.pointwise
                      else None)
        self._current = StepInProgress(forms, layout, bary, return_map)
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
        if self._current.return_map is None:
            return None
        t0 = time.perf_counter()
        result = self._current.return_map.refresh(tangent)
        self._add_time("return_map", t0)
        return result

    # -- the phases of a step --------------------------------------------------

    def _track(self, step: int = 0, t: float = 0.0, hold: np.ndarray | None = None) -> SlotLayout:
        t0 = time.perf_counter()
        layout = self.tracking.track(self.points, self.markers, step, t, hold)
        self._add_time("tracking", t0)
        return layout

    def _check_supports(self, layout: SlotLayout) -> None:
        """A static model's supports stop every rigid translation (:func:`check_supports`)."""
        point_conditions = [] if self._boundary_points is None else self._boundary_points.conditions
        if self.conditions.loads_or_supports or point_conditions:
            check_supports(self.conditions.held_components(layout.occupied), point_conditions)

    def _compile(self, nslot: int, nslot_boundary: int) -> StepForms:
        newmark = None if self.dynamics is None else self.dynamics.data
        forms = StepForms(self.fields, self.spec, self.material, nslot, nslot_boundary,
                          conditions=self.conditions, ppp=self._ppp, newmark=newmark,
                          lumped=self.mass == "lumped")
        self._forms[(nslot, nslot_boundary)] = forms
        return forms

    def _solve(self, forms: StepForms, layout: SlotLayout, R, J, bcs: list) -> NewtonResult:
        """Newton from Δu = 0 with each line search of :attr:`ladder` until one converges."""
        hooks = {"loads": self._step_loads, "pressure_volume": self._pressure_volume(layout)}
        if forms.pointwise:
            hooks |= {"before_residual": lambda: self.refresh_material(tangent=False),
                      "before_jacobian": self.refresh_material}
        solver = self._newton_solver(forms)

        def attempt(search: str | None) -> NewtonResult:
            self._initial_guess(layout)
            return solver.solve(R, J, bcs, **hooks, line_search=search)

        return self.ladder.solve(attempt, solver.line_search)

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
        """The points' barycentric coordinates in the cells of ``layout`` (n, g + 1)."""
        current = self._current
        if current is not None and current.layout is layout:
            return current.bary
        return self.tracker.barycentric(self.points.x, layout.cell)

    def _consistent_initial_acceleration(
        self, forms: StepForms, layout: SlotLayout, R, bcs: list, dt: float
    ) -> None:
        """Start from accelerations in equilibrium (:meth:`NewmarkDynamics.start`)."""
        def residual_at_rest() -> np.ndarray:
            self._initial_guess(layout)
            self.refresh_material(tangent=False)
            return R.assemble_vector()

        self.dynamics.start(residual_at_rest, forms.mass_matrix, layout, bcs, self._bary(layout),
                            self.points, dt)

    def _initial_guess(self, layout: SlotLayout) -> None:
        """Δu = 0 and the projected pressure (:meth:`GridFields.start_from_rest`)."""
        pts = self.points
        self.fields.start_from_rest(layout.cell, self._bary(layout), pts.mass, pts.stress)

    def _pressure_volume(self, layout: SlotLayout) -> float:
        """‖V‖ of the pressure rows (:meth:`GridFields.pressure_volume`)."""
        return self.fields.pressure_volume(layout.cell, self._bary(layout), self.points.volume)

    def _update_points(self, forms: StepForms, layout: SlotLayout, step: int, t: float,
                       dt: float) -> None:
        """The points take the converged state (:mod:`fe_mpm.point_update`)."""
        new = checked_update(forms.update.evaluate(layout), forms.update_layout, self.points,
                             self.tracker.sizes[layout.cell],
                             None if self.dynamic else self.max_step_cells, step, t)
        return_map = self._current.return_map
        apply_update(self.points, new, self.markers, self.dynamics, dt,
                     None if return_map is None else return_map.result.history)

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
