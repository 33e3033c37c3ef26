"""The implicit MPM step and time loop (Iaconeta 2019, Algorithm 1), in one place.

:meth:`Simulation.step` takes one step as Algorithm 1 does; each phase lives in
the module that owns its state:

1. **track**: :mod:`fe_mpm.tracking` finds each point's cell and lays the points out in slots;
2. **pack**: :mod:`fe_mpm.step_forms` compiles the forms of a slot count and writes the
   points' data as their slot fields' values;
3. **impose**: :mod:`fe_mpm.grid_conditions` (Dirichlet increments, tractions, body force,
   reactions) and :mod:`fe_mpm.boundary_points` (penalty points); in dynamics
   :mod:`fe_mpm.dynamics` projects the points' motion to the grid (:mod:`fe_mpm.transfer`);
4. **solve**: :mod:`fe_mpm.newton`, retried as :mod:`fe_mpm.retry` lists;
5. **update**: :mod:`fe_mpm.point_update` moves the points; the grid is reset by never moving;
6. **report**: :mod:`fe_mpm.report` and :mod:`fe_mpm.output`.
"""

from __future__ import annotations

import os
import shutil
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from petsc4py import PETSc

import numpy as np
import numpy.typing as npt

from fe_mpm import balance, checkpoint, model_checks, parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.bodies import TearWatch
from fe_mpm.boundary import (
    Dirichlet,
    PointDirichlet,
    PointPressure,
    PointTraction,
    Pressure,
    RigidWall,
    Traction,
)
from fe_mpm.boundary_points import BoundaryPointStep
from fe_mpm.checks import as_number, check_finite, check_int, check_range
from fe_mpm.domains import (
    DOMAIN_GHOST_LAYERS,
    PointDomains,
    keeps_mean_increment,
    step_with_domains,
)
from fe_mpm.dynamics import NewmarkDynamics
from fe_mpm.errors import (
    ConvergenceError,
    PointsOutsideError,
    StepLeavesGridError,
    interrupts_deferred,
    warn,
)
from fe_mpm.forms.mixed_up import PPPData, PressureFloor
from fe_mpm.formulations import FORMULATIONS, GridFields
from fe_mpm.ghost import GhostStabilisation
from fe_mpm.grid_conditions import GridConditions, body_force_at
from fe_mpm.initial_stress import start_stressed
from fe_mpm.io import drop_rows_after
from fe_mpm.markers import Markers
from fe_mpm.materials import ReturnMapResult
from fe_mpm.materials.elastic import p_wave_modulus
from fe_mpm.materials.mixed_return import MixedReturnResult
from fe_mpm.materials.zones import MATERIAL, laws_of
from fe_mpm.newton import NewtonResult, NewtonSolver
from fe_mpm.output import SimulationOutput, earlier_run_files
from fe_mpm.particles import MaterialPoints, coincident
from fe_mpm.point_update import (
    apply_update,
    checked_update,
    keep_volume_of_pressure,
    volume_of_average,
    volume_of_pressure,
)
from fe_mpm.pressure_by_parts import PressureByParts
from fe_mpm.quadrature import SlotLayout
from fe_mpm.report import (
    ProgressBar,
    StepReport,
    imbalance,
    newton_failure,
    steps_header,
    write_steps,
)
from fe_mpm.retry import RetryLadder, StepLength
from fe_mpm.shared_increment import SharedIncrement
from fe_mpm.step_forms import (
    FormsBySlotCount,
    ReturnMapAtIterate,
    StepForms,
    StepInProgress,
)
from fe_mpm.tracker import Tracker
from fe_mpm.tracking import (
    PointTracking,
    cell_fill_anywhere,
    check_points_per_cell,
    hinged_cells,
)
from fe_mpm.walls import ContactWatch, RigidWalls, write_wall_forces

#: A run ends when less than this fraction of its nominal step is left to ``t_end``.
END_OF_RUN = 1e-12
#: A last step shorter than this fraction of the nominal step is merged into the one before.
MERGE_LAST_STEP = 1e-9
#: ``min_step`` when none is given: this fraction of the nominal step.
DEFAULT_MIN_STEP = 1 / 1024


#: Projection passes times c Δt / h above which a free body's spurious stress grew.
PASSES_TIMES_COURANT = 100.0


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
        mesh: Background grid: affine triangles (plane strain) or tetrahedra. Under
            MPI, where the run needs ghost cells the grid lacks (point domains, the
            ghost penalty, a fluid's pressure by parts), ``sim.mesh`` is the same grid
            rebuilt with them.
        points: The material points (moved and updated in place).
        material: Constitutive law (see :mod:`fe_mpm.materials`), or a list of laws
            for a body of several materials: a point seeded with ``material=k``
            follows the k-th (:mod:`fe_mpm.materials.zones`). The internal variables
            are added to ``points.history`` if missing (with several laws, also
            ``"material"``, each point's law).
        formulation: ``"u"`` (irreducible), ``"u-nbva"`` (irreducible with
            node-based volumetric averaging), ``"up"`` (mixed P1/P1 with PPP),
            ``"up-nostab"`` (mixed P1/P1) or ``"up-p2p1"`` (mixed Taylor–Hood);
            see :mod:`fe_mpm.formulations`.
        dirichlet: Prescribed grid displacements.
        tractions: Loads on grid facets: tractions (one vector, :class:`~fe_mpm.Traction`)
            and normal pressures (:class:`~fe_mpm.Pressure`, along each facet's normal).
        point_dirichlet: Displacements prescribed by a penalty at boundary points the
            grid does not follow (a rigid footing); forces in ``StepReport.reactions``.
        point_tractions: Loads on boundary points that move with the body (a grid
            ``Traction`` or ``Pressure`` stays on its facets): tractions
            (:class:`~fe_mpm.PointTraction`, a dead load) and pressures on the body's
            face as it deforms (:class:`~fe_mpm.PointPressure`, a follower load);
            forces in ``StepReport.reactions``.
        walls: Fixed rigid faces of the grid's boundary that the body presses on,
            slides along with Coulomb friction, or leaves (:class:`~fe_mpm.RigidWall`);
            their forces in ``StepReport.reactions`` and ``StepReport.walls``.
        body_force: Body force per unit mass (m/s², length g), e.g. gravity; or a
            function ``t -> vector`` for one whose direction changes (gravity plus an
            earthquake's horizontal acceleration in the base's frame,
            ``lambda t: (-a(t), -9.81)``).
        body_force_scale: Load factor of the body force, ``t -> float``; 1 if None
            (``lambda t: t`` ramps self-weight over static load steps).
        facet_tags: Facet tags for ``Dirichlet``, ``Traction`` and ``Pressure`` given by tag.
        petsc_options: Overrides of the Newton options (:data:`fe_mpm.newton.NEWTON_OPTIONS`)
            and of the linear solver's (:data:`fe_mpm.newton.LINEAR_SOLVERS`).
        points_leaving: ``"raise"`` (default) stops when points leave the grid; ``"drop"``
            removes them with a warning and counts them in ``dropped`` (with point
            domains: a point whose domain is less than half inside after a step).
        output_dir: Folder for ParaView output (``particles.pvd``, ``grid.bp``),
            ``steps.csv`` with every step's time, Newton iterations, reactions and
            markers (:func:`fe_mpm.report.write_steps`: a load–displacement curve),
            and ``walls.csv`` with the walls' forces after every step, or None.
        output_every: Write every this many steps (and always the last).
        ppp_alpha: The thesis's PPP coefficient α ≥ 0 (``up``), times Kratos's factor
            (8 in 2D, 10 in 3D) in the form; α = 1 reproduces the thesis. Default: 1,
            or 0 for a law that keeps no shape (``NewtonianFluid``: PPP resists the
            hydrostatic gradient, see :mod:`fe_mpm.materials.fluid`). Refused > 0
            with another formulation, which has no PPP.
        dynamic: Implicit Newmark dynamics (β = 1/4, γ = 1/2 unless ``bossak_alpha``
            is set), with a P1 displacement ("up-p2p1" is refused); False (default):
            static.
        mass: ``"consistent"`` (default, as the thesis) or ``"lumped"`` (dynamic only).
        damping: Mass-proportional Rayleigh damping α_R ≥ 0 (1/s), dynamic only;
            default 0 (the thesis uses 1.5 for the granular collapse). A mode of
            circular frequency ω is damped at the ratio ζ = α_R/(2ω): the slow ones.
        stiffness_damping: Stiffness-proportional Rayleigh damping β_R ≥ 0 (s),
            dynamic only, for a law with elastic moduli (not a fluid, whose
            viscosity damps it); default 0. The force is β_R K v with K the points'
            linear elastic stiffness (λ, μ of each point's law), not the current
            tangent (:func:`fe_mpm.forms.inertia.stiffness_damping`): ζ = β_R ω/2, the
            fast modes. Kratos MPM's ``rayleigh_alpha`` and ``rayleigh_beta`` are
            ``damping`` and ``stiffness_damping``; for ζ at two frequencies ω₁, ω₂
            take α_R = 2ζω₁ω₂/(ω₁ + ω₂), β_R = 2ζ/(ω₁ + ω₂).
        bossak_alpha: Bossak's α_B in [−1/3, 0], dynamic only: numerical dissipation of
            the modes the step cannot resolve (a reaction that rings from step to step),
            second-order accurate. 0 (the default, None) is the thesis's trapezoidal
            rule, which dissipates nothing; left None in a dynamic run with rigid walls
            it warns (a body landing on a wall can gain energy under it). Kratos MPM's
            implicit dynamic solver defaults to Bossak with −0.3.
            Take −0.3 where a body lands on a rigid wall (released unstressed, or
            dropped): it rings on the wall's springs at a frequency no step resolves,
            and on a frictional wall the ringing walks it (a block at rest on a 30°
            slope with μ = 0.8, ``demos/sliding_block.py``: 9.1 mm in 1 s with 0,
            at most 0.32 mm with −0.3).
        projection_passes: Passes k ≥ 1 with which the points' velocity and
            acceleration are projected to the grid at each step, dynamic only
            (:func:`fe_mpm.transfer.consistent_projection`, FMPM(k)): 1 is
            the thesis's mass-weighted projection (Eqs. 2.6–2.9), which smooths the
            velocity at every step and so dissipates the energy of a vibrating body;
            more passes approach the consistent-mass projection, which keeps that
            energy (docs/dynamics.md). Default 1; more need the consistent mass,
            and with rigid walls ``bossak_alpha`` < 0 (a contact rings under the
            trapezoidal rule once the projection no longer smooths it).
        reactions: Boundaries whose reaction force is computed after every step,
            name -> facet tag or marker (see ``StepReport.reactions``).
        min_step: Shortest step :meth:`run` may cut to (s); default 1/1024 of nominal.
        line_search: Newton's SNES line search: ``"basic"`` (full steps), ``"bt"``
            (backtracking on ‖R‖²), ``"l2"``, ``"cp"``, or ``"auto"`` (default):
            ``"bt"`` for a law with internal variables (plasticity: the active set
            chatters under full steps), ``"basic"`` otherwise (an elastic step
            converges quadratically from the first iterate). ``petsc_options``'s
            ``snes_linesearch_type`` overrides it.
        fallback_line_search: SNES line search with which a failed step is retried
            from its start before it is cut (None: cut at once; ``"auto"``, default:
            ``"basic"`` after ``"bt"``, else ``"bt"``; see :mod:`fe_mpm.retry`).
        fallback_hold_cells: Whether :meth:`run` retries a failed static step with the
            points held in their last step's cells before it cuts the step.
        fallback_from_best: Whether the retry with the fallback line search starts
            from the failed solve's iterate of smallest ‖R‖ (True) or from the
            step's start (False, default). The same equations, solved from nearer
            their solution; ``docs/dynamics.md`` says where it pays.
        linear_solver: ``"direct"`` (MUMPS LU, default) or ``"iterative"`` (GMRES and
            algebraic multigrid), see :data:`fe_mpm.newton.LINEAR_SOLVERS`.
        max_step_cells: A static step that moves a point farther than this many sizes
            of its cell (> 0, default 10) is rejected (``run()`` then cuts it, ``step()``
            raises): most often a grid value blew up at a nearly unsupported node
            (:func:`fe_mpm.point_update.checked_update`); raise it for a large
            deformation taken in a few steps.
        point_domains: True: each point's volume is spread over the cells its
            convected domain covers (:mod:`fe_mpm.domains`; P2 in 2D only), against the
            cell-crossing error; False (default): standard MPM. At set-up the domains
            tile the cells their points fill, and each point there moves to its tile's
            centroid (its ``x`` and ``x0`` change by up to a point spacing: take
            positions after ``Simulation(...)``; ``docs/cell_crossing.md``). Under
            MPI the grid is then rebuilt at set-up with the ghost cells the domains
            need (:data:`fe_mpm.domains.DOMAIN_GHOST_LAYERS`).
        shared_increment: With point domains, whether every piece of a domain takes
            its point's increment, the mean of the grid's over the pieces, with the
            exact Jacobian (:mod:`fe_mpm.shared_increment`; P1 only); False
            (default): each piece takes its own cell's.
        pressure_by_parts: Whether the pressure at the step's start is integrated by
            parts in the cells whose neighbours all hold material
            (:mod:`fe_mpm.pressure_by_parts`), so that a flowing fluid does not gain
            energy as its points cross cells; the u-p formulations and ``"u-nbva"``
            (its pressure the law's, projected), without point domains. None
            (default): True for a law that keeps no shape (``NewtonianFluid``) there,
            else False.
        ghost_penalty: γ ≥ 0 of the ghost penalty on the facets of poorly filled
            cells (:mod:`fe_mpm.ghost`); 0: none. Default:
            :data:`fe_mpm.ghost.WITH_DOMAINS` with point domains in a static run (0.1
            for P1, 0.01 for P2), :data:`fe_mpm.ghost.WITH_DOMAINS_DYNAMIC` (0.001)
            with point domains in a dynamic run (there the penalty, which acts on
            each step's increment, damps the motion like a dashpot), else 0.
        checkpoint_dir: Folder for a checkpoint every ``checkpoint_every`` steps
            and at the end of each :meth:`run` (the latest of these kept;
            :mod:`fe_mpm.checkpoint`; :meth:`restore` continues from one); None
            (default): none.
        checkpoint_every: Steps between checkpoints, ≥ 1.
        rebalance_above: Under MPI, repartition the grid by its points
            (:meth:`rebalance`) at set-up and after a step in which the most points
            on a rank exceed this multiple (> 1) of the mean, once the time lost to
            the imbalance has paid for the last repartition (e.g. 1.25); None
            (default): never. It pays where the points' own work (return map,
            packing, assembly over occupied cells) dominates a step; see
            docs/limitations.md. Serial runs never repartition.
        initial_stress: Cauchy stress (Pa) of each of this rank's points at t = 0,
            shape ``(n, 3, 3)``, e.g. :func:`fe_mpm.geostatic_stress`; carried as
            an elastic strain of a Hencky law (:mod:`fe_mpm.initial_stress`). None
            (default): the points start unstressed.

    Attributes:
        t: The time the points have reached (s; a pseudo-time in a static run): 0 at
            set-up, the checkpoint's after :meth:`restore`.
        step_number: The steps accepted so far, the checkpoint's after :meth:`restore`.
        history: The :class:`~fe_mpm.report.StepReport` of every step this object
            took (empty after a restore in a new process: the earlier steps' rows are
            in ``steps.csv``).
        points: The material points, moved and updated in place.
        mesh: The background grid (see ``mesh`` above).
    """

    def __init__(
        self,
        mesh: dolfinx.mesh.Mesh,
        points: MaterialPoints,
        material,
        formulation: str = "u",
        *,
        dirichlet: Sequence[Dirichlet] = (),
        tractions: Sequence[Traction | Pressure] = (),
        point_dirichlet: Sequence[PointDirichlet] = (),
        point_tractions: Sequence[PointTraction | PointPressure] = (),
        walls: Sequence[RigidWall] = (),
        body_force: Sequence[float] | Callable[[float], Sequence[float]] | None = None,
        body_force_scale: Callable[[float], float] | None = None,
        facet_tags: dolfinx.mesh.MeshTags | None = None,
        petsc_options: dict | None = None,
        points_leaving: str = "raise",
        output_dir: str | Path | None = None,
        output_every: int = 1,
        ppp_alpha: float | None = None,
        dynamic: bool = False,
        damping: float = 0.0,
        stiffness_damping: float = 0.0,
        bossak_alpha: float | None = None,
        projection_passes: int = 1,
        mass: str = "consistent",
        reactions: dict[str, int | Callable] | None = None,
        min_step: float | None = None,
        line_search: str = "auto",
        fallback_line_search: str | None = "auto",
        fallback_hold_cells: bool = True,
        fallback_from_best: bool = False,
        linear_solver: str = "direct",
        max_step_cells: float = 10.0,
        point_domains: bool = False,
        shared_increment: bool = False,
        pressure_by_parts: bool | None = None,
        ghost_penalty: float | None = None,
        checkpoint_dir: str | Path | None = None,
        checkpoint_every: int = 10,
        rebalance_above: float | None = None,
        initial_stress: np.ndarray | None = None,
    ):
        model_checks.check_grid_and_points(mesh, points)
        model_checks.check_flags(dynamic=dynamic)
        model_checks.check_body_force_scale(body_force, body_force_scale)
        model_checks.check_petsc_options(petsc_options)
        lists = model_checks.condition_lists(
            dirichlet=dirichlet,
            tractions=tractions,
            point_dirichlet=point_dirichlet,
            point_tractions=point_tractions,
            walls=walls,
        )
        dirichlet, tractions = lists["dirichlet"], lists["tractions"]
        point_dirichlet, point_tractions = lists["point_dirichlet"], lists["point_tractions"]
        walls = lists["walls"]
        _check_points(mesh.comm, points.check_state)  # a script may change them after seeding
        material = model_checks.laws_of_zones(material, points, mesh.comm)
        #: Whether the points come from an earlier Simulation (a later stage).
        self._later_stage = parallel.any_rank(mesh.comm, points.simulated_to is not None)
        if self._later_stage:
            # A stage's output in the folder of the stage before replaces it at its first
            # frame (a helper's staged run lost its first stage so, 2026-12-07).
            earlier = earlier_run_files(output_dir) if mesh.comm.rank == 0 else []
            earlier = mesh.comm.bcast(earlier, root=0)
            replaced = (
                f" Its output_dir already holds an earlier run's files ({', '.join(earlier[:3])}"
                f"{', ...' if len(earlier) > 3 else ''}), which this run's first frame "
                "replaces: give each stage a folder of its own to keep them."
                if earlier
                else ""
            )
            warn(
                "Simulation: these points were already stepped by another Simulation (to "
                f"t = {points.simulated_to}), so they start deformed, with their stresses "
                "and internal variables: a staged analysis. For a fresh start, seed them "
                f"again.{replaced}"
            )
        parallel.one_thread_per_rank(mesh.comm)
        model_checks.check_choices(
            formulation, mass, points_leaving, linear_solver, line_search, fallback_line_search
        )
        # A fluid keeps no shape (fe_mpm.materials.fluid): no PPP by default, and in
        # the mixed forms its points take the volume of their pressure after a step.
        keeps_shape = getattr(material, "keeps_shape", True)
        if ppp_alpha is None:
            ppp_alpha = 1.0 if keeps_shape and FORMULATIONS[formulation].ppp else 0.0
        model_checks.check_ranges(max_step_cells, ppp_alpha, damping, output_every)
        model_checks.check_ppp(ppp_alpha, FORMULATIONS[formulation])
        model_checks.check_output_dir(output_dir)
        model_checks.check_facet_tags(mesh, facet_tags)
        alpha_left = bossak_alpha is None  # the trapezoidal rule, not chosen
        bossak_alpha = 0.0 if alpha_left else bossak_alpha
        model_checks.check_dynamics(dynamic, formulation, damping, mass, bossak_alpha)
        model_checks.check_stiffness_damping(stiffness_damping, dynamic, keeps_shape)
        if alpha_left:
            model_checks.warn_trapezoid_on_walls(dynamic, walls)
        if dynamic:  # before any point migrates; step() checks again (set after this)
            _check_points(mesh.comm, points.check_motion)
        self.spec = FORMULATIONS[formulation]
        self._volume_of_pressure = self.spec.pressure and not keeps_shape
        self._volume_of_average = self.spec.volume_average and not keeps_shape
        model_checks.check_domains(point_domains, ghost_penalty, points, self.spec)
        model_checks.check_shared_increment(shared_increment, point_domains, self.spec)
        self._pressure_by_parts = model_checks.pressure_by_parts(
            pressure_by_parts, keeps_shape, point_domains, self.spec
        )
        model_checks.check_serial_only(
            mesh.comm,
            {"shared_increment=True": bool(shared_increment)},
        )
        model_checks.check_law(material, self.spec, formulation)
        model_checks.warn_dilatant_averaging(material, self.spec, dynamic)
        model_checks.warn_plastic_locking(material, self.spec)
        model_checks.warn_static_fluid(material, keeps_shape, dynamic)
        model_checks.take_density(material, points)
        # The body force at the start, checked here (its length, finite components).
        start_body_force = (
            None if body_force is None else body_force_at(body_force, 0.0, mesh.geometry.dim)
        )
        model_checks.check_weight_of_initial_stress(
            mesh.comm, points, initial_stress is not None, start_body_force
        )
        model_checks.warn_placeholder_density(mesh.comm, points, body_force, dynamic)
        self._started_stressed = initial_stress is not None
        if initial_stress is not None:  # refused on every rank if on one
            parallel.check_together(
                mesh.comm, start_stressed, points, material, initial_stress, self.spec.pressure
            )
            model_checks.warn_unbalanced_initial_stress(
                mesh.comm, points, initial_stress, start_body_force
            )
        started = {}  # a later stage's new law: its elastic tensors, and from what
        for name, h in material.history.items():
            if name not in points.history and h.convected:
                started[name] = h.counterpart_in(points.history)
                start = h.elastic_values(points.F, points.history)
            else:
                start = h.initial_values(len(points))
            given = points.history.setdefault(name, start)
            # A later stage's, or set by a script: checked on every rank together.
            parallel.check_together(
                mesh.comm, _check_history, name, given, start.shape, kinds=(ValueError,)
            )
        model_checks.warn_elastic_tensors_started(mesh.comm, points, material, started)
        if MATERIAL in material.history:  # several laws: the label reaches the slots
            points.history[MATERIAL] = points.material.astype(np.float64)
        else:  # one law after a stage of several: no stale labels in the output
            points.history.pop(MATERIAL, None)
        if initial_stress is not None:  # (its history complete)
            model_checks.warn_initial_stress_outside_yield(mesh.comm, points, material)
        #: Whether the law keeps internal variables (plasticity), besides a point's law.
        self._plastic = bool(set(material.history) - {MATERIAL})
        # Elastic solids do not come apart, static or not; in dynamics a splash or a
        # grain of a plastic or fluid body may fly off, so only those are watched.
        self._watches_tears = not dynamic or (keeps_shape and not self._plastic)
        #: The number of laws: NB-VA averages each zone's volume change on its own.
        self._zones = len(material.laws) if MATERIAL in material.history else 1
        self.mesh, self.points, self.material = mesh, points, material
        self.formulation, self.gdim, self.dynamic = formulation, mesh.geometry.dim, bool(dynamic)
        if line_search == "auto":
            line_search = "bt" if self._plastic else "basic"
        self.petsc_options = {"snes_linesearch_type": line_search, **(petsc_options or {})}
        self._given_petsc_options = dict(petsc_options or {})
        self._options_checked = not self._given_petsc_options
        self.linear_solver = linear_solver
        if min_step is not None:  # a step of 0 s or less would be cut to for ever
            check_range("Simulation", "min_step", min_step, lo=0.0, lo_open=True)
        self.max_step_cells, self.min_step = max_step_cells, min_step
        self.checkpoint_dir = checkpoint_dir
        self.checkpoint_every = check_int("Simulation", "checkpoint_every", checkpoint_every, lo=1)
        self.timings: dict[str, float] = {}
        self.history: list[StepReport] = []
        self.t, self.step_number = 0.0, 0
        self._restored_from: str | None = None  # the checkpoint restore() read, said in errors
        #: The step after which points were last added or removed (a stage), or None.
        self._staged_at: int | None = None
        self._off_cadence: Path | None = None  # the last run-end checkpoint (one is kept)

        t0 = time.perf_counter()
        self.markers = Markers(mesh.comm)
        self.ladder = RetryLadder(
            fallback_line_search, bool(fallback_hold_cells), bool(fallback_from_best)
        )
        walls = model_checks.check_walls(walls, self.spec, formulation)
        self._force_names = model_checks.check_force_names(
            reactions, walls, [*point_dirichlet, *point_tractions]
        )
        passes = model_checks.check_projection_passes(
            projection_passes, dynamic, mass, walls, bossak_alpha, [*dirichlet, *point_dirichlet]
        )
        # What the grid's objects are built from, again after a repartition.
        self._given = {
            "conditions": (dirichlet, tractions, body_force, body_force_scale, reactions),
            "walls": walls,
            "boundary": [*point_dirichlet, *point_tractions],
            "dynamics": (damping, bossak_alpha, petsc_options, passes, stiffness_damping),
            "ppp_alpha": ppp_alpha,
            "mass": mass,
            "points_leaving": points_leaving,
        }
        # A static standard run that stops names point domains, where they would be
        # taken; not in dynamics, where they cut a flow's run-out (docs/cell_crossing.md).
        self._domains_would_do = (
            not point_domains
            and not dynamic
            and model_checks.domains_would_be_taken(
                points, self.spec, pressure_by_parts, keeps_shape
            )
        )
        self.tracking: PointTracking | None = None
        self._boundary: BoundaryPointStep | None = None
        self._conditions_warned: dict[int, float] = {}
        self._travel_warned: np.ndarray | None = None  # each grid Dirichlet's, once per run
        self._iterations_of_old_grids = 0  # Newton iterations on grids since repartitioned
        self.output = None
        # The steps whose CSV rows are not yet written, and the step whose columns the
        # CSV has: kept apart from ``history``, which a long run's script may shorten.
        self._unwritten: list[StepReport] = []
        self._writes_csv = output_dir is not None
        self._check_supports_again = False  # points were removed or added since
        # Projection passes against the step's length: the longest step checked, and
        # whether the run was warned (once).
        self._passes_checked_dt, self._passes_warned = 0.0, False
        self._nonfinite_warned = False  # said once: a NaN in a Jacobian, not its residual
        self._hinge_warned = False  # said once: a static step's hinged cells
        self._crossing_warned = False  # said once: a static standard run's points crossed
        self._tears = TearWatch()  # the material came apart (said once)
        self._contacts = ContactWatch()  # a dynamic contact of a step or two (said once)
        self._restart_dynamics = False  # points were added: accelerations anew
        self._csv_head: StepReport | None = None
        self._grid_is_a_step = True  # the grid's fields are the last step's (or zero)
        self._cells_of_grid = True  # points.cell numbers this grid's cells (not after rebalance)
        self._shared = bool(shared_increment)
        self._shift: SharedIncrement | None = None
        self._by_parts: PressureByParts | None = None
        # Under MPI a point's domain covers cells past its rank's, across a vertex too.
        self._ghost_layers = DOMAIN_GHOST_LAYERS if point_domains and mesh.comm.size > 1 else 0
        self.domains = None
        self._ghost_factor = model_checks.ghost_factor(
            ghost_penalty, point_domains, self.spec.u_degree, self.dynamic
        )
        needs_facet_ghosts = self._pressure_by_parts or (self._ghost_factor and not point_domains)
        if needs_facet_ghosts and not balance.has_facet_ghosts(mesh):
            mesh, facet_tags = self._with_facet_ghosts(mesh, facet_tags)
        self._set_grid(mesh, facet_tags)
        for message in self.walls.shared_with(self.conditions):
            warn(message)
        model_checks.warn_ppp_against_weight(
            mesh.comm,
            self.tracker.sizes,
            points,
            material,
            self.spec,
            ppp_alpha,
            start_body_force,
        )
        model_checks.warn_stiff_penalties(
            mesh.comm, material, point_dirichlet, walls, self.tracker.sizes
        )
        self._add_time("setup", t0)
        layout = self._track()  # once now, so a bad initial layout fails at set-up
        model_checks.check_distinct_points(self.mesh.comm, points)
        model_checks.warn_overfull_nodes(
            self.mesh, points, self.tracker.barycentric(points.x, points.cell), self.tracker.volumes
        )
        model_checks.check_passes_between_bodies(passes, bossak_alpha, self.mesh, points.cell)
        self.ghost = None
        #: Grid repartitions so far (:meth:`rebalance`).
        self.repartitions = 0
        if self._ghost_layers:  # the grid again, with the ghost cells the domains need
            self.rebalance()
            layout = self._track()
        if point_domains:
            most = 0  # points in the fullest cell of any rank, which only P2 asks for
            if self.spec.u_degree == 2:
                here = np.bincount(self.points.cell[self.points.cell >= 0]).max(initial=0)
                most = parallel.largest(mesh.comm, int(here))
            self.domains = PointDomains(
                points,
                self.domain_tracker,
                self.spec.u_degree,
                self.spec.volume_average,
                self._shared,
                keeps_mean_increment(self.spec.u_degree, most),
                keeps_no_shape=self._volume_of_pressure or self._volume_of_average,
                drop_leaving=points_leaving == "drop",
            )
            if initial_stress is not None:
                # The domains moved the points and carried their stress, affine in each
                # cell, to the new places; the law's elastic state follows it again (a
                # fitted one is off by the square of the strain).
                points.F[:] = np.eye(points.gdim)  # undeformed, as start_stressed found them
                start_stressed(points, material, points.stress.copy(), self.spec.pressure)
        self._set_ghost_penalty()
        if (
            self.ghost is None
            and self.domains is None
            and self.spec.min_points_per_cell(self.gdim) > 1
        ):
            # P2/P1 with too few points per cell is refused here, not at the first step
            # (docs: "refused at once"; a helper, 2026-12-08); a ghost penalty may tie them.
            check_points_per_cell(layout, self.spec, 0, self.tracker.centroids, None, mesh.comm)
        self.rebalancing = balance.RebalanceRule(model_checks.check_rebalance(rebalance_above))
        if self._rebalance_if_due(imbalance(mesh.comm, len(points))):
            self._track()
        if output_dir is not None:  # on the grid the run starts on
            self.output = SimulationOutput(
                output_dir, self.fields, output_every, domains=self.domains is not None
            )

    def _with_facet_ghosts(self, mesh: dolfinx.mesh.Mesh, facet_tags):
        """The grid again with the cells across each rank's facets, and its facet tags.

        The ghost penalty and a fluid's pressure by parts integrate over facets
        between ranks, which a grid built without ghost cells (``model_to_mesh`` and
        ``create_mesh`` by default) does not hold. Every cell stays on its rank
        (:func:`fe_mpm.balance.with_facet_ghosts`), so each point keeps its rank and
        takes its cell's new local index.
        """
        ghosted = balance.with_facet_ghosts(mesh)
        return ghosted, self._carried_onto(mesh, ghosted, facet_tags)

    def _carried_onto(self, old: dolfinx.mesh.Mesh, new: dolfinx.mesh.Mesh, facet_tags):
        """Move the points' cells and ``facet_tags`` from ``old`` to ``new``, its rebuild.

        Collective. A cell is known by its original index on both grids; a point keeps
        its cell's local index on ``new`` where this rank owns that cell, else −1 (the
        next tracking sends it to its new rank). Returns the tags on ``new`` (or None).
        """
        comm, cell = old.comm, self.points.cell
        found = np.flatnonzero(cell >= 0)  # all but after a rebalance untracked
        here = np.column_stack([np.full(found.size, comm.rank), cell[found]])
        where = balance.owners_of_original_cells(new, balance.original_indices(old, here))
        cell[:] = -1
        cell[found] = np.where(where[:, 0] == comm.rank, where[:, 1], -1)
        if facet_tags is None:
            return None
        return balance.carried_facet_tags(facet_tags, old, new)

    def _set_ghost_penalty(self) -> None:
        """The ghost penalty on the current grid (none if its factor is 0)."""
        if self.ghost is not None:
            self.ghost.destroy()
        gamma = self._ghost_factor
        self.ghost = GhostStabilisation(self.fields, gamma, self.material.mu) if gamma else None

    def _set_grid(self, mesh: dolfinx.mesh.Mesh, facet_tags) -> None:
        """Build everything that lives on the grid: at set-up and after a repartition.

        The point tracking and the boundary points keep their state and take the new
        grid's tracker; the rest is new.
        """
        self.mesh, self.facet_tags = mesh, facet_tags
        self.tracker = Tracker(mesh)
        #: The tracker that cuts the point domains: with this rank's ghost cells under MPI.
        self.domain_tracker = Tracker(mesh, ghosts=True) if self._ghost_layers else self.tracker
        if self.domains is not None:
            self.domains.regrid(self.domain_tracker)
        if self.tracking is None:
            self.tracking = PointTracking(self.tracker, self._given["points_leaving"])
        else:
            self.tracking.tracker = self.tracker
        self.fields = GridFields(
            mesh, self.spec, start_pressure=self._pressure_by_parts, zones=self._zones
        )
        self.dynamics = None
        if self.dynamic:
            damping, bossak_alpha, petsc_options, passes, beta_R = self._given["dynamics"]
            self.dynamics = NewmarkDynamics(
                self.fields,
                damping,
                bossak_alpha,
                self.linear_solver,
                petsc_options,
                passes,
                stiffness_damping=beta_R,
            )
        self.conditions = GridConditions(self.fields, *self._given["conditions"], facet_tags)
        self.conditions._warned_share = self._conditions_warned  # warned once per run
        if self._travel_warned is None:  # (kept when a repartition builds them anew)
            self._travel_warned = self.conditions._travel_warned
        self.conditions._travel_warned = self._travel_warned
        self.walls = RigidWalls(
            self.fields.du, self._given["walls"], mesh, facet_tags, self.material
        )
        if self._boundary is None:
            self._boundary = BoundaryPointStep.of(
                self._given["boundary"], self.tracker, self.spec.u_degree
            )
        else:
            self._boundary.tracker = self.tracker
        ppp = floor = None
        if self.spec.ppp and self._given["ppp_alpha"] > 0:  # α = 0: no term at all
            ppp = PPPData.on_grid(mesh, self.tracker.centroids, self._given["ppp_alpha"])
        elif self.spec.pressure and self.spec.name != "up-nostab":  # the bare pair
            floor = PressureFloor.on_grid(mesh, self.tracker.centroids)
        self._forms = FormsBySlotCount(
            self.fields,
            self.spec,
            self.material,
            self.conditions,
            ppp,
            self.dynamics,
            self._given["mass"],
            self.walls,
            shared_increment=self._shared,
            pressure_by_parts=self._pressure_by_parts,
            point_pressure=any(isinstance(c, PointPressure) for c in self._given["boundary"]),
            floor=floor,
        )
        if self._by_parts is not None:
            self._by_parts.destroy()
        self._by_parts = PressureByParts(self.fields) if self._pressure_by_parts else None
        self._current: StepInProgress | None = None
        self._newton: NewtonSolver | None = None

    # -- public API ------------------------------------------------------------

    def add_marker(self, name: str, x: Sequence[float]) -> None:
        """Follow a point that moves with the body but carries no volume or mass.

        The marker moves with the affine motion of its host, the material point
        nearest to it (:mod:`fe_mpm.markers`), so it never reads an empty cell.
        Read it from ``history[k].markers[name]`` or :meth:`marker`.
        """
        model_checks.check_column_name("Simulation.add_marker: the marker", name)
        xm = check_finite("Simulation.add_marker", f"x of marker {name!r}", x)
        if xm.size != self.gdim:
            raise ValueError(
                f"Simulation.add_marker: x of marker {name!r} must have {self.gdim} "
                f"coordinates on this {self.gdim}D grid, got {xm.size}"
            )
        xm = xm.reshape(self.gdim)
        # A marker's columns in steps.csv are its name's, as a force's are.
        if name in self.markers.names or name in self._force_names:
            used = "another marker" if name in self.markers.names else "a force"
            raise ValueError(f"Simulation.add_marker: {name!r} already names {used}")
        cell = self.tracker.locate(xm[None, :])[0]
        if not parallel.any_rank(self.mesh.comm, cell >= 0):
            raise PointsOutsideError(f"marker {name!r} at {xm} is outside the grid")
        out = self.output
        if out is not None and (self._csv_head is not None or self._unwritten):
            # steps.csv keeps the columns of its first row (a helper's late marker,
            # 2026-12-07, was in the history but never in the file).
            warn(
                f"Simulation.add_marker: marker {name!r} is added after steps.csv was "
                "started, whose columns stay those of its first row: read it from "
                "sim.history or sim.marker(), or add markers before the first step"
            )
        elif out is not None and out.continues:
            warn(
                f"Simulation.add_marker: marker {name!r} is not in the steps.csv of the run "
                "this one continues: if it is new there, this run's rows start a new "
                "steps.csv, the earlier one kept as steps_before_step_N.csv"
            )
        distance = self.markers.add(name, xm, self.points.x)
        # A mistyped coordinate inside the grid would follow a far host's motion extended
        # over the distance, without a word (a helper's cantilever tip, 2026-12-07).
        size = parallel.largest(
            self.mesh.comm, float(self.tracker.sizes[cell]) if cell >= 0 else 0.0
        )
        if distance > size:
            warn(
                f"Simulation.add_marker: marker {name!r} at {xm} lies {distance:.3g} m from "
                f"the nearest material point, more than its cell's size ({size:.3g} m): it "
                "follows that point's motion extended over the distance. Is it on the body?"
            )

    def remove_marker(self, name: str) -> None:
        """Remove the marker ``name`` between steps (its host may then be excavated).

        Its columns in ``steps.csv`` read NaN from the next step on, and later
        :class:`StepReport` objects leave it out. Collective: every rank calls it.

        Raises:
            KeyError: No marker has that name.
        """
        if name not in self.markers.names:
            known = ", ".join(map(repr, self.markers.names)) or "none"
            raise KeyError(f"Simulation.remove_marker: no marker {name!r}; the markers: {known}")
        self.markers.remove(name)

    def remove_points(self, remove: npt.ArrayLike) -> int:
        """Remove this rank's points where ``remove`` is true, between steps (excavation).

        What follows the points follows: the markers' hosts and the cells a retry
        may hold the points in are renumbered, and the next frame and checkpoint hold
        the points that stay. A script that called ``sim.points.keep(mask)`` itself
        left them on the old numbering: a marker moved with another point, or the
        next step failed with an ``IndexError`` (a helper's trench, 2026-12-06).
        Collective: every rank calls it, with a mask of its own points.

        Args:
            remove: Boolean mask over this rank's points, shape (n,).

        Returns:
            The number of points removed on all ranks.

        Raises:
            ValueError: The mask is not boolean of shape (n,), it removes a marker's
                host point or every point, or the run has point domains (their
                tiling has no hole: build a new Simulation from the points kept).
        """
        remove = np.asarray(remove)
        n = len(self.points)
        if n == 0 and remove.size == 0:  # a rank with no points: np.array([]) is float
            remove = np.zeros(0, dtype=bool)
        error = None
        if remove.dtype != bool or remove.shape != (n,):
            error = ValueError(
                f"Simulation.remove_points: remove must be a boolean mask of shape ({n},) "
                f"over this rank's points, got dtype {remove.dtype} and shape {remove.shape}"
            )
        parallel.raise_together(self.mesh.comm, error)
        if self.domains is not None:
            raise ValueError(
                "Simulation.remove_points: the points have domains, which tile the body "
                "and cannot leave a hole; keep the points (sim.points.keep(~remove)) and "
                "build a new Simulation from them"
            )
        hosts = [name for name, host in self.markers.hosts().items() if remove[host]]
        error = None
        if hosts:
            error = ValueError(
                f"Simulation.remove_points: it removes the host point of marker "
                f"{hosts[0]!r}; a marker moves with its host. Remove the marker first "
                f"(sim.remove_marker({hosts[0]!r})), or keep its host"
            )
        parallel.raise_together(self.mesh.comm, error)
        removed = int(parallel.total(self.mesh.comm, int(remove.sum())))
        if removed == parallel.total(self.mesh.comm, n):
            raise ValueError("Simulation.remove_points: it removes every point")
        keep = ~remove
        self.markers.keep_hosts(keep)
        self.points.keep(keep)
        self.tracking.keep(keep)
        self._check_supports_again = True  # what is left may hang free
        self._tears.bodies_at_start = None  # counted anew at the next step
        self._staged_at = self.step_number  # the next step's load comes at once
        return removed

    def add_points(self, new: MaterialPoints) -> int:
        """Add points between steps (staged construction: a layer placed on a body).

        The new points start as they are given (seeded: undeformed, unstressed, at
        rest), their internal variables at the law's initial values; they go after
        this rank's points, so the markers keep their hosts. Collective: every rank
        calls it with its own new points (none on some ranks is fine).

        Args:
            new: The points to add, e.g. from :func:`~fe_mpm.seed` with ``cells=``.

        Returns:
            The number of points added on all ranks.

        Raises:
            ValueError: The points' dimension is not the grid's, they lie outside the
                grid, one of their values is out of range, their masses were
                given with a density where the run's were not (or the reverse), they
                hold internal variables the law does not, or the run has point
                domains (build a new Simulation from the points merged).
        """
        if not isinstance(new, MaterialPoints):
            raise TypeError(
                f"Simulation.add_points: new must be MaterialPoints, got {type(new).__name__}"
            )
        if self.domains is not None:
            raise ValueError(
                "Simulation.add_points: the points have domains, which tile the body as it "
                "was seeded; merge the points (fe_mpm.merge(sim.points, new)) and build a "
                "new Simulation from them"
            )
        if new.gdim != self.gdim:
            raise ValueError(
                f"Simulation.add_points: the new points are {new.gdim}D, the grid {self.gdim}D"
            )
        comm = self.mesh.comm
        if parallel.total(comm, len(new)) == 0:
            return 0
        _check_points(comm, new.check_state)
        _check_points(comm, new.check_motion)

        def material_labels() -> None:
            new.material = new._checked_material(len(new))

        parallel.check_together(comm, material_labels, kinds=(TypeError, ValueError))
        highest = parallel.largest(comm, int(new.material.max(initial=0)))
        if highest >= self._zones:
            raise ValueError(
                f"Simulation.add_points: the new points are seeded with material={highest}, "
                f"but the simulation has {self._zones} law(s), material 0 to {self._zones - 1}"
            )
        parallel.check_together(comm, model_checks.take_density, self.material, new)
        given = parallel.all_ranks(comm, new.density_given or len(new) == 0)
        if given != self.points.density_given:
            raise ValueError(
                "Simulation.add_points: the run's points have masses from a density "
                f"({'given' if self.points.density_given else 'none given'}) and the new "
                f"ones {'do' if given else 'do not'}: seed both with seed(..., density=...) "
                "or give the law a density"
            )
        unknown = sorted(set(new.history) - set(self.points.history))
        if unknown:
            raise ValueError(
                f"Simulation.add_points: the new points hold internal variables {unknown} "
                f"that the law does not ({sorted(self.points.history)})"
            )
        _refuse_misplaced(comm, self.tracker, self.points.x, new.x)
        stepped = parallel.largest(comm, -np.inf if new.simulated_to is None else new.simulated_to)
        if np.isfinite(stepped):
            warn(
                "Simulation.add_points: the new points were stepped by another Simulation "
                f"(to t = {stepped:g}), so they come deformed, with their stresses"
            )
        for name, h in self.material.history.items():
            new.history.setdefault(name, h.initial_values(len(new)))
        if MATERIAL in new.history:
            new.history[MATERIAL] = new.material.astype(np.float64)
        added = int(parallel.total(comm, len(new)))
        self.points.extend(new)
        # The new points have no cell of a last step. Without their rows, migrating
        # them to another rank indexed past the old points' (an IndexError on one
        # rank, the other hung; a reviewer's two-rank script, 2026-12-06).
        self.tracking.extend_home(len(new))
        layout = self._track(self.step_number, self.t)
        if self.step_number > 0:  # a retry may hold every point where it is now
            self.tracking.remember(layout.cell)
        pts = self.points
        model_checks.warn_overfull_nodes(
            self.mesh,
            pts,
            self.tracker.barycentric(pts.x, pts.cell),
            self.tracker.volumes,
            added_cells=self.tracker.locate(new.x),
        )
        self._check_supports_again = True
        self._tears.bodies_at_start = None  # counted anew at the next step
        self._staged_at = self.step_number  # the next step's load comes at once
        # The new points' accelerations in equilibrium, as a run's first step gives
        # (from 0, a body added in free fall lagged g Δt / 2 behind for ever).
        self._restart_dynamics = self.dynamic
        if not self.dynamic:
            self._warn_static_velocities()
        return added

    def checkpoint(self, directory: str | Path | None = None) -> Path:
        """Write the run's state after the current step (collective); return its folder.

        Into ``directory`` (default: ``checkpoint_dir``), as :mod:`fe_mpm.checkpoint` says.
        """
        directory = self.checkpoint_dir if directory is None else directory
        if directory is None:
            raise ValueError("Simulation.checkpoint: give a directory (or checkpoint_dir)")
        folder = self._write_checkpoint(directory)
        if folder == self._off_cadence:  # asked for by name: kept
            self._off_cadence = None
        return folder

    def _write_checkpoint(self, directory: str | Path) -> Path:
        """:meth:`checkpoint`, with the rows of the steps so far written (collective).

        A restore in a new process continues the output where ``steps.csv`` has the
        checkpoint's row (:meth:`~fe_mpm.output.SimulationOutput.continue_earlier_run`),
        which an ``output_every`` > 1 would otherwise hold back (a reviewer, 2026-12-07).
        """
        t0 = time.perf_counter()
        if self.output is not None and self.output.started:
            self._write_rows(self.output)
        folder = checkpoint.write(self, directory)
        self._add_time("checkpoint", t0)
        return folder

    def restore(self, path: str | Path) -> None:
        """Continue from a checkpoint (a folder, or a directory: its latest); collective.

        Build the simulation with the script that wrote the checkpoint, on any number
        of ranks, then restore and :meth:`run` on to the end time. Time, step count,
        points, markers and boundary points become the checkpoint's.

        Raises:
            CheckpointError: It is of another fe-mpm version or scene, or corrupted.
        """
        if not isinstance(path, str | os.PathLike):
            raise TypeError(
                f"Simulation.restore: path must be a checkpoint folder's path (str or "
                f"pathlib.Path), got {type(path).__name__}"
            )
        before = self.step_number
        # (with what add_points left due for the next step)
        self._restored_from = str(checkpoint.read(self, path))
        self._grid_is_a_step = False  # the grid's fields are not the restored step's
        out = self.output
        if out is not None and not out.started:
            # A new process continuing a run: its output folder holds that run's frames
            # and rows, which this run's first frame would clear. Its series goes on
            # where it is that run's; anything else there is kept aside.
            continued, undone = out.continue_earlier_run(self.t, self.step_number)
            if continued:
                if undone is not None:
                    warn(
                        f"Simulation.restore: what the earlier run in {out.folder} wrote "
                        f"after step {self.step_number} (t = {self.t:g}), frames and rows, "
                        f"is moved into {undone}; this run takes those steps again"
                    )
            else:
                kept = out.set_aside_earlier_run(self.step_number)
                if kept is not None:
                    warn(
                        f"Simulation.restore: the output already in {out.folder} is kept "
                        f"in {kept}: its steps.csv has no row of step {self.step_number} at "
                        f"t = {self.t:g} (another run's, or one that a checkpoint of "
                        "before 2026-12-07 evening had not written yet); this run writes "
                        "its own"
                    )
        if before > self.step_number:
            # This simulation had stepped past the checkpoint: those steps are undone
            # (found 2026-12-06 by a helper: the history read 1, 2, 3, 4, 3, 4), also
            # in the CSV files, whatever a script kept of the history.
            step = self.step_number
            self.history = [report for report in self.history if report.step <= step]
            self._unwritten = [report for report in self._unwritten if report.step <= step]
            self._undo_files_after(step)
        self.rebalancing.restart()  # a partition for these points
        if self._rebalance_if_due(imbalance(self.mesh.comm, len(self.points))):
            self._track(self.step_number, self.t)

    def _undo_files_after(self, step: int) -> None:
        """Drop the CSV rows and frames after ``step``, and set aside later checkpoints.

        Collective; the files' work is rank 0's, and an error there stops every rank.
        """
        comm, error, moved = self.mesh.comm, None, []
        if parallel.on_rank_zero(comm):
            try:
                if self.output is not None:
                    for name in ("steps.csv", "walls.csv"):
                        drop_rows_after(self.output.folder / name, step)
                if self.checkpoint_dir is not None:
                    moved = checkpoint.set_aside_after(self.checkpoint_dir, step)
            except OSError as err:
                error = OSError(f"Simulation.restore: {err}")
        parallel.raise_together(comm, error)
        if self.output is not None:
            self.output.rewind(self.t, step)
        if moved:
            warn(
                f"Simulation.restore: the checkpoints of the steps undone, "
                f"{', '.join(p.name for p in moved)}, are set aside as such in "
                f"{self.checkpoint_dir}: a restore from that folder continues this run"
            )

    def rebalance(self) -> None:
        """Repartition the grid so that the ranks hold about equal numbers of points.

        Collective; between steps. The grid is built again from the same cells and
        nodes with a partition weighted by the points in each cell
        (:mod:`fe_mpm.balance`); at the next step's tracking every point moves to the
        rank that now owns its cell, with all it carries. :attr:`mesh` (and
        :attr:`facet_tags`) are then the new grid's; the answers change by round-off
        only. :meth:`run` calls this after a step whose ``point_imbalance`` exceeds
        ``rebalance_above`` when another step follows. On one rank nothing changes.
        """
        comm = self.mesh.comm
        if comm.size == 1:
            return
        t0 = time.perf_counter()
        old, home = self.mesh, self.tracking._home
        weights = balance.cell_weights(self.tracker.num_cells, self.points.cell)
        mesh = balance.repartitioned(old, weights, self._ghost_layers)
        # The next tracking starts from the cell each point was in, where this rank
        # owns it now; the others are searched for and sent to their new ranks.
        tags = self._carried_onto(old, mesh, self.facet_tags)
        keep_home = parallel.all_ranks(comm, home is not None)
        if keep_home:  # a retry of the next step may still hold the points there
            home = balance.original_indices(old, home)
        if self._newton is not None:
            self._iterations_of_old_grids += self._newton.iterations_total
            self._newton.destroy()
        springs = self.walls.springs()
        self._set_grid(mesh, tags)
        self._cells_of_grid = False  # the points' cells are the old grid's until tracked
        self.walls.set_springs(springs)
        self._set_ghost_penalty()
        if keep_home:
            self.tracking._home = balance.owners_of_original_cells(mesh, home)
        if self.output is not None:
            self.output.regrid(self.fields)
        self.repartitions += 1
        self._add_time("rebalance", t0)

    def _rebalance_if_due(self, point_imbalance: float, step_time: float = 0.0) -> bool:
        """:meth:`rebalance` if :class:`~fe_mpm.balance.RebalanceRule` says so; whether it did."""
        if not self.rebalancing.due(point_imbalance, step_time):
            return False
        self._rebalance_now()
        return True

    def _rebalance_now(self) -> None:
        """:meth:`rebalance`, and tell the rule what it cost (collective)."""
        t0 = time.perf_counter()
        self.rebalance()
        self.rebalancing.paid(parallel.largest(self.mesh.comm, time.perf_counter() - t0))

    def marker(self, name: str) -> np.ndarray:
        """Current position of a marker, shape (g,)."""
        if name not in self.markers.names:
            known = ", ".join(map(repr, self.markers.names)) or "none (add_marker adds one)"
            raise KeyError(f"Simulation.marker: no marker {name!r}; the markers: {known}")
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

        In a static analysis ``t`` is a pseudo-time that drives the loads. A step
        Newton fails is retried, then cut, as :mod:`fe_mpm.retry` says; below
        ``min_step`` the run stops with the last failure's message.
        ``on_step(report)`` is called after every accepted step, the points updated.
        """
        n_steps = check_int("Simulation.run", "n_steps", n_steps, lo=1)
        if on_step is not None and not callable(on_step):
            raise TypeError(
                f"Simulation.run: on_step must be a function of the step's report, got {on_step!r}"
            )
        if isinstance(t_end, int | float) and t_end <= self.t:  # (NaN: check_range)
            restored = (
                "" if self._restored_from is None else f", restored from {self._restored_from}"
            )
            raise ValueError(
                f"Simulation.run: t_end = {t_end:g} is not past the simulation's time "
                f"t = {self.t:g} (step {self.step_number}{restored}): give a later end "
                "time (sim.t is where the run stands)"
            )
        check_range("Simulation.run", "t_end", t_end, lo=self.t, lo_open=True)
        nominal = (t_end - self.t) / n_steps
        floor = DEFAULT_MIN_STEP * nominal if self.min_step is None else self.min_step
        length = StepLength(nominal, floor, self._failure_advice)
        can_hold = not self.dynamic and self.domains is None  # pieces differ per attempt
        bar, reports, cuts = ProgressBar(n_steps, progress), [], 0
        before = self.newton_iterations_total
        try:
            while t_end - self.t > END_OF_RUN * nominal:
                t_new = min(self.t + length.dt, t_end)
                if t_end - t_new < MERGE_LAST_STEP * nominal:
                    t_new = t_end
                started = time.perf_counter()
                try:
                    report = self.ladder.take_step(
                        lambda rebin: self.step(t_new, rebin),
                        can_hold and self.tracking.can_hold,
                    )
                except ConvergenceError as failure:
                    length.cut_after(failure)
                    cuts += 1
                    continue
                took = time.perf_counter() - started
                spent = self.newton_iterations_total - before
                report.failed_iterations = spent - report.newton_iterations
                before += spent
                reports.append(report)
                if self.rebalancing.on and t_end - self.t > END_OF_RUN * nominal:
                    took = parallel.largest(self.mesh.comm, took)  # the same on every rank
                    report.repartitioned = self.rebalancing.due(report.point_imbalance, took)
                if on_step is not None:  # on the grid of the step, told if it is replaced
                    on_step(report)
                if report.repartitioned:
                    self._rebalance_now()
                length.accepted()
                bar.update(report, nominal, cuts)
        except (ConvergenceError, StepLeavesGridError):
            # Raised on every rank together, the points as the last accepted step left
            # them: their frame and rows (a step that would carry points or a marker's
            # host out of the grid is refused before anything moved too; until
            # 2026-12-07 a helper's run lost its last accepted steps' rows there). Not
            # after any other PointsOutsideError: tracking may have sent points to other
            # ranks before it stopped, their cells not yet renumbered.
            self._write_output(force=True)
            raise
        finally:
            bar.close()
        if reports:
            self._look_for_a_tear_now()
        self._write_output(force=True)
        if reports and self.checkpoint_dir and self.step_number % self.checkpoint_every:
            # A run shorter than checkpoint_every would leave nothing to restore
            # (a new user's half run, 2026-12-07). Only the latest such one is kept:
            # a script's loop of short runs does not fill the disk.
            self._regular_checkpoint(off_cadence=True)
        return reports

    def _regular_checkpoint(self, off_cadence: bool = False) -> None:
        """A checkpoint into ``checkpoint_dir``, dropping the last off-cadence one (collective).

        ``off_cadence``: written at a run's end, between the ``checkpoint_every``-th
        steps; it goes once a later checkpoint is written.
        """
        path = self._write_checkpoint(self.checkpoint_dir)
        earlier, self._off_cadence = self._off_cadence, path if off_cadence else None
        if earlier is not None and earlier != path and parallel.on_rank_zero(self.mesh.comm):
            shutil.rmtree(earlier, ignore_errors=True)

    def _look_for_a_tear_now(self) -> None:
        """Count the bodies where the points lie now, after a run's last step (collective).

        Each step counts them at its start, so a tear in the last step was not told
        (a helper's strip). Not with domains, whose pieces are cut at a step's start.
        """
        if not self._watches_tears or self.domains is not None or self.step_number == 0:
            return
        cells = self.tracker.locate(self.points.x, self.points.cell)
        # A point that crossed into another rank's cells goes there at the next
        # step's tracking: found by that rank, or its cell would read as a gap.
        lost = parallel.gathered(self.mesh.comm, self.points.x[cells < 0])
        if self.mesh.comm.size > 1 and len(lost):
            cells = np.concatenate([cells, self.tracker.locate(lost)])
        self._tears.look(self.mesh, cells, self.t, domains=False)

    def _failure_advice(self) -> str:
        """What the message of a run that stops adds about its set-up (collective)."""
        _, tractions, body_force, body_force_scale, _ = self._given["conditions"]
        # A load past the limit: one that rises, or any load in the first step.
        loads_rise = bool(
            tractions
            or any(isinstance(b, PointTraction | PointPressure) for b in self._given["boundary"])
        )
        loads_rise |= body_force is not None and (
            callable(body_force) or body_force_scale is not None or self.step_number == 0
        )
        # Points added or removed before this step bring their weight, or take away
        # their support, whatever its length (a helper's embankment raised in lifts
        # was told of cell crossing and point domains, which add_points refuses).
        staged = self._staged_at == self.step_number
        return model_checks.failure_advice(
            self.domains is not None,
            self._ghost_factor,
            self._domains_would_do and self._points_crossed_cells() and self._staged_at is None,
            static_plastic=not self.dynamic and self._plastic and (loads_rise or staged),
            staged=staged and not self.dynamic,
            later_stage=not self.dynamic and self._later_stage and self.step_number == 0,
            sliding=""
            if self.dynamic
            else model_checks.sliding_on_walls(
                self.walls,
                None if self.conditions.body_force is None else self.conditions.body_force.value,
                np.unique(self.points.cell[self.points.cell >= 0]),
            ),
            lost_loads=self.conditions.lost_loads(),
            cohesionless_from_rest=not self.dynamic
            and self.step_number == 0
            and not self._started_stressed
            and any(getattr(law, "cohesion", None) == 0.0 for law in laws_of(self.material)),
        )

    def step(self, t_new: float, rebin: bool = True) -> StepReport:
        """Take one implicit step from the current time to ``t_new`` (Algorithm 1).

        ``rebin=False`` holds every point in the cell it was in during the last
        step while it lies within half a cell of it: the fallback of a step that
        fails right after re-binning (see :mod:`fe_mpm.retry`). A script may drive
        the steps itself: the output's t = 0 frame is written before the first step
        and the checkpoints after every ``checkpoint_every``-th, as in :meth:`run`.
        """
        t_new = as_number("Simulation.step", "t_new", t_new)
        if not (t_new > self.t and np.isfinite(t_new)):
            raise ValueError(
                f"Simulation.step: t_new must be finite and exceed the current time "
                f"{self.t}, got {t_new!r}"
            )
        if self.dynamic and self.step_number == 0:
            # A script gives a body its velocity by setting points.velocity after seeding.
            _check_points(self.mesh.comm, self.points.check_motion)
        if not self.dynamic and self.step_number == 0:
            self._warn_static_velocities()
        self._check_point_count()
        if self.step_number == 0 or (self.output is not None and not self.output.started):
            # The state the run starts from as its first frame: t = 0, or a restored
            # step (written once: the output skips a step it has written).
            self._write_output(force=True)
        self._grid_is_a_step = False  # until the step is accepted: an attempt's iterate
        if self.domains is not None:
            report = step_with_domains(self, t_new, rebin)
        else:
            report = self._step_points(t_new, rebin)
        self.points.simulated_to = self.t
        if self.checkpoint_dir and self.step_number % self.checkpoint_every == 0:
            self._regular_checkpoint()
        return report

    def _step_points(self, t_new: float, rebin: bool = True) -> StepReport:
        """:meth:`step` on the points as they are, without its frame and checkpoint.

        The points are the sub-points of domains (:func:`~fe_mpm.domains.step_with_domains`
        calls this) or the material points themselves.
        """
        k, dt, t_old = self.step_number + 1, t_new - self.t, self.t
        if k == 2 and self.spec.u_degree == 2 and self.domains is None:
            warn(self.spec.multi_step_warning())
        # Track, lay out, pack, impose (and project the points' motion, in dynamics).
        supports_due = (self.step_number == 0 or self._check_supports_again) and not self.dynamic
        if self.dynamic and not self._passes_warned and dt > self._passes_checked_dt:
            self._warn_passes_against_step(dt)
        forms, layout, R, J, bcs = self.prepare_step(t_new, rebin=rebin)
        if supports_due:  # each body apart, once the whole is held (prepare_step)
            model_checks.check_each_body(
                self.conditions, self._boundary, layout.occupied, self.walls
            )
            self._check_supports_again = False  # checked: not again until points change
        if self._watches_tears:
            self._tears.look(
                self.mesh,
                layout.occupied,
                self.t,
                domains=self.domains is not None,
                dynamic=self.dynamic,
            )
        if self.dynamics is not None and (k == 1 or self._restart_dynamics):
            # Equilibrium at the step's start: the grid loads there (the boundary
            # points' loads stay at its end; repacked, they were lost from the step).
            self.conditions.set_loads(self.t)
            self._consistent_initial_acceleration(forms, layout, R, bcs, dt)
            self.conditions.set_loads(t_new)
            self._restart_dynamics = False
        # Solve for the grid increment: Newton from Δu = 0.
        result = self._solve(forms, R, J, bcs)
        finite = not parallel.any_rank(self.mesh.comm, not np.all(np.isfinite(self.w.x.array)))
        if not result.converged or not finite:
            nonfinite = self._newton.nonfinite
            if self._newton.nonfinite_derivative and not self._nonfinite_warned:
                warn(
                    f"Newton's step {k} (t = {self.t:g} -> {t_new:g}): {nonfinite}. run() "
                    "retries and cuts such a step as any failed one, but a derivative that "
                    "fails is a defect to look into, not a step too long (said once)."
                )
                self._nonfinite_warned = True
            raise newton_failure(
                result,
                k,
                self.t,
                t_new,
                self.mesh,
                layout,
                self.tracker.centroids,
                self.dynamic,
                self._given["mass"] == "consistent",
                self.spec.u_degree,
                nonfinite,
                self._newton.where_it_failed(),
            )
        self.refresh_material(tangent=False)  # the converged iterate's, for reactions and history
        grid_energy = (
            0.0
            if self.dynamics is None
            else self.dynamics.grid_kinetic_energy(self.w.x.array, bcs, dt)
        )
        reactions = self.conditions.reactions(self._internal_force(R))
        # Accepted at once: a Ctrl-C in the middle waits for the end (errors.py).
        with interrupts_deferred():
            # Update the points (the last check may still reject the step); the grid is reset.
            t0 = time.perf_counter()
            leaving = self._update_points(forms, layout, k, t_new, dt)
            if self._boundary is not None:
                forces, passed = self._boundary.convect(
                    forms, t_new, self.fields.displacement_at, self.conditions.held_shares
                )
                for name, force in passed.items():  # penalty shares on held nodes
                    reactions[name] = reactions[name] + force
                reactions.update(forces)
            walls = self.walls.finish_step()
            if self.dynamic:
                self._contacts.look(walls, self.t)
            reactions.update({name: force.total for name, force in walls.items()})
            self._add_time("update", t0)
            if self._domains_would_do and not self._crossing_warned and self.spec.u_degree == 1:
                self._warn_crossing(k)  # (P2/P1 has its own warning at step 2)
            self.tracking.remember(layout.cell)
            self.tracking.drop(self.points, self.markers, leaving, k, t_new)
            self.t, self.step_number = t_new, k
            # Accepted: told only now (the points' update may still have refused it).
            if not self.dynamic and self.domains is None and not self._hinge_warned:
                self._warn_hinges(layout, k, t_old, t_new)
            if self.tracking.left:  # kept, and told: the next step's tracking stops the run
                warn(self.tracking.left)
            self.conditions.warn_travel(t_new)
            if not self._options_checked and self._newton and self._newton.iterations_total:
                self._options_checked = True  # after the first step that solved a system
                self._warn_unread_options()
            report = StepReport.of_step(
                k,
                t_new,
                result,
                self._current,
                reactions,
                self.markers,
                self.tracking,
                self.conditions,
            )
            report.walls, report.grid_kinetic_energy = walls, grid_energy
            if self._boundary is not None:
                report.lost_load.update(self._boundary.lost_load)
            self.history.append(report)
            if self._writes_csv:  # (with domains the output is set aside in the step)
                self._unwritten.append(report)
            self._grid_is_a_step = self._cells_of_grid = True  # accepted: its frame may be written
            self._write_output()
        return report

    def _warn_hinges(self, layout: SlotLayout, k: int, t_old: float, t_new: float) -> None:
        """Warn (once, collective) where a converged static step had hinged cells.

        A cell that shares one node with the rest of the body swings freely about it,
        and the static tangent is singular there; the solver then returns one of the
        swings and Newton converges on it. Found 2026-12-07 by a helper: a block
        turned rigidly through 90° in 16 steps by PointDirichlet points on two of its
        edges (cells of 0.1 m, three points each, u) ended with two corner points
        turned by −25° and 3.5 cm from where the turn put them, every step converged
        (one or four steps, or point domains: exact to 1e-11). A cell held by a
        Dirichlet condition at another node, or by a penalty point, is not hinged.
        """
        held = np.concatenate([np.zeros(0, np.int64), *self.conditions.dirichlet_nodes])
        tied = None if self._boundary is None else self._boundary.penalty_cells()[0]
        hinged, count = hinged_cells(self.mesh, layout.occupied, held, tied)
        if count == 0:
            return
        self._hinge_warned = True
        first = parallel.first_given(
            self.mesh.comm, self.tracker.centroids[hinged[0]] if hinged.size else None
        )
        warn(
            f"Static step {k} (t = {t_old:g} -> {t_new:g}): {count} occupied cell(s) "
            f"shared at most one node with the rest of the material (first near x = "
            f"{first}). Such a cell swings freely about that node, so the step's answer "
            "there is one swing of many, and its points' F and places may be wrong though "
            "the step converged (a block turned 90 degrees in 16 steps ended with two "
            "corner points turned by -25 degrees). point_domains=True, a coarser grid or "
            "dynamic=True avoids it (said once)."
        )

    def _warn_passes_against_step(self, dt: float) -> None:
        """Warn (once, collective) where projection passes meet too long a step.

        Checked at the first step and whenever a step is longer than any checked.

        Passes × c Δt / h above about 100 (c the P-wave speed, h the smallest cell's
        longest edge)
        leave a free body's spurious stress growing without bound: a Neo-Hookean
        square translating freely, eight passes, grew from 1e-9 to 9e-3 Pa in 200 steps
        at c Δt / h = 18 (and a disk spinning on gained energy 13 000-fold), stayed at
        1e-9 with four passes or at c Δt / h = 9, and grew with sixteen passes at 9 (a
        helper's scenes, 2026-12-06).
        """
        passes = self._given["dynamics"][3]
        first = self._passes_checked_dt == 0.0
        self._passes_checked_dt = dt  # a step as long or shorter needs no new check
        if passes == 1:
            return
        spin = spin_rate(self.mesh.comm, self.points) if first else 0.0
        if spin > 0.0:
            self._passes_warned = True
            warn(
                f"Simulation: projection_passes={passes} on a body that spins ({spin:.3g} "
                "rad/s about its mass centre): a free elastic disk spinning at 2.8 rad/s "
                "gained energy without bound with two passes (1.8-fold in its second "
                "revolution, 238-fold within 0.7 revolution with steps four times shorter), "
                "though passes x c dt / h was 4.7 to 19, and four passes threw points out "
                "of the grid (a helper's scene, 2026-12-07). Take one pass for a spinning "
                "body (docs/dynamics.md)."
            )
            return
        try:
            modulus = p_wave_modulus(self.material)
        except (AttributeError, TypeError, ValueError):
            return  # a law without the moduli to give a wave speed
        pts = self.points
        density = pts.mass / (pts.volume / np.linalg.det(pts.F)) if len(pts) else np.inf
        lightest = parallel.smallest(self.mesh.comm, float(np.min(density, initial=np.inf)))
        smallest = parallel.smallest(self.mesh.comm, float(self.tracker.sizes.min(initial=np.inf)))
        if not (lightest > 0.0 and np.isfinite(lightest)):
            return
        courant = np.sqrt(modulus / lightest) * dt / smallest
        if passes * courant > PASSES_TIMES_COURANT:
            self._passes_warned = True
            warn(
                f"Simulation: projection_passes={passes} with steps of c dt / h = "
                f"{courant:.3g} (c the P-wave speed, h the smallest cell's longest edge): "
                f"above passes x c dt / h = {PASSES_TIMES_COURANT:g} a free body's spurious "
                "stress grew without bound (eight passes at c dt / h = 18 by the cells' side: "
                "1e-9 to 9e-3 Pa in 200 steps; four passes there, or eight at 9, stayed at "
                "1e-9). Take fewer passes or shorter steps (docs/dynamics.md)."
            )

    def _check_point_count(self) -> None:
        """Refuse (collective) a step after a script added or removed points itself.

        ``sim.points.keep(mask)`` or points appended in place leave the markers,
        the cells a retry holds the points in and the domains on the old numbering:
        a marker followed another point, or the step failed with an ``IndexError``
        (a helper's trench, 2026-12-06). :meth:`remove_points` and :meth:`add_points`
        renumber them.
        """
        n = len(self.points)
        if self.domains is not None:
            known = len(self.domains.corners)
        else:
            home = self.tracking._home
            known = n if home is None else len(home)
        error = None
        if known != n:
            error = ValueError(
                f"Simulation.step: the points changed in number since the last step "
                f"({known} -> {n} on rank {self.mesh.comm.rank}) behind the simulation's "
                "back (points.keep, or arrays replaced): what follows the points (markers, "
                "cells, domains) is on the old numbering. Use sim.remove_points(mask) and "
                "sim.add_points(points), or build a new Simulation from the points."
            )
        parallel.raise_together(self.mesh.comm, error)

    def _warn_static_velocities(self) -> None:
        """Warn (collective) where a static run's points carry velocities it ignores.

        A script that sets ``points.velocity`` and forgets ``dynamic=True`` ran without
        a word, and the points kept their velocities (a helper's scene, 2026-12-06).
        """
        v = self.points.velocity
        fastest = np.sqrt(np.max(np.sum(v * v, axis=1))) if len(v) else 0.0
        fastest = parallel.largest(self.mesh.comm, float(fastest))
        if fastest > 0.0:
            warn(
                f"Simulation: the points carry velocities (the fastest {fastest:.3g} m/s) "
                "but the run is static (dynamic=False): a static step ignores them and "
                "leaves them as they are. Pass dynamic=True for them to act."
            )

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
        layout = self._track(self.step_number + 1, t_new, hold=not rebin)
        if (self.step_number == 0 or self._check_supports_again) and not self.dynamic:
            model_checks.check_supports(
                self.conditions, self._boundary, layout.occupied, self.walls
            )
        self.conditions.check_loaded_facets(layout.occupied, t_new)
        bcs = self.conditions.impose(layout.occupied, self.t, t_new, self._zone_cells(layout))
        self.walls.start_step(layout.occupied, self.points.x, self.points.volume)
        tied = None  # cells the ghost penalty ties to a neighbour need fewer points
        if self.ghost is not None:
            need, volume = self.spec.min_points_per_cell(self.gdim), self.points.volume
            self.ghost.update(layout.cell, volume, self.tracker.volumes, bcs, need)
            tied = self.ghost.tied_cells()
        check_points_per_cell(
            layout, self.spec, self.step_number, self.tracker.centroids, tied, self.mesh.comm
        )

        t0 = time.perf_counter()
        boundary = None
        if self._boundary is not None:  # in the owned cells that hold material on any rank
            owners = self._boundary.tracker
            fill = cell_fill_anywhere(
                self.mesh, layout.cell, self.points.volume, owners.volumes, owners.num_cells
            )
            # Measured in static runs, where the penalty holds a sliver firmly (γ = 0.1
            # with domains); a dynamic run's weak γ is left to the fill rule.
            held = tied if not self.dynamic else None
            boundary = self._boundary.locate(np.flatnonzero(fill > 0.0), t_new, fill, held)
        nslot_b = 0 if boundary is None else boundary.nslot
        forms = self._forms.get(layout.nslot, nslot_b)
        self._forms.set_step_length(t_new - self.t)
        self._add_time("compile", t0)

        t0, pts = time.perf_counter(), self.points
        bary = self.tracker.barycentric(pts.x, layout.cell)
        forms.pack(layout, pts, self.tracker, bary)
        if self._by_parts is not None:
            self.fields.start_from_rest(layout.cell, bary, pts.mass, pts.stress)  # p̄
            interior = self._by_parts.update(
                layout.occupied,
                layout.cell,
                pts.volume,
                pts.mass,
                self.tracker.volumes,
                self.conditions.body_force_value(self.t),  # the start's, as p̄'s
            )
            forms.q.pack(forms.interior, layout, interior[layout.cell].astype(np.float64))
        if boundary is not None:
            self._boundary.pack(forms, t_new)
        R, J = forms.residual.bind(layout, boundary), forms.jacobian.bind(layout, boundary)
        loads = None if forms.loads is None else forms.loads.bind(layout, boundary)
        if self.dynamics is not None:
            self.dynamics.project(
                layout.cell, bary, pts.mass, pts.velocity, pts.acceleration, t_new - self.t
            )
        self._add_time("packing", t0)
        return_map = ReturnMapAtIterate(forms, layout, pts, self.w) if forms.pointwise else None
        self._shift = None
        if forms.dF_shift is not None:
            pieces = self.domains.current
            self._shift = SharedIncrement(
                forms,
                layout,
                pieces.owner,
                pieces.share,
                pts.volume,
                layout.cell,
                bary,
                self.fields,
                self.tracker.p1_gradients,
            )
        self._current = StepInProgress(forms, layout, bary, return_map, loads, t_new - self.t)
        return forms, layout, R, J, bcs

    def refresh_material(self, tangent: bool = True) -> ReturnMapResult | MixedReturnResult | None:
        """Evaluate a pointwise law's return map at the current grid unknown.

        Newton calls this before every residual and (with the ``tangent``) every
        Jacobian (:class:`~fe_mpm.step_forms.ReturnMapAtIterate`); call it after
        changing :attr:`w` by hand (e.g. in a Taylor test). Returns the return map's
        result, or None for laws written in UFL.
        """
        if self._shift is not None:
            self._shift.refresh()
        if self._current.return_map is None:
            return None
        t0 = time.perf_counter()
        result = self._current.return_map.refresh(tangent)
        self._add_time("return_map", t0)
        return result

    # -- the phases of a step --------------------------------------------------

    def _warn_crossing(self, k: int) -> None:
        """Warn, once, that a static standard run's points have begun to cross cells.

        Found 2026-12-06: a cantilever under its weight (L = 2 m, H = 0.25 m, mixed
        Neo-Hookean, ν = 0.3, "up", three points per cell, four cells deep) bent 31 %
        further than a Taylor–Hood solve after 20 load steps and 39 % after 80, where
        one step gives 0.2 %; every step converged and nothing was said.
        """
        if not self._points_crossed_cells():  # (since their start: add_points hides nothing)
            return
        self._crossing_warned = True
        # With walls the contact is found step by step (each node's gap at the step's
        # start): a disk pressed on a wall took a contact width 9 % over Hertz's in one
        # step and 2 % in 20 (a new user's scene, 2026-12-07), so fewer steps are no cure.
        # A law with a history follows its load path, so fewer steps are no cure there
        # either (a J2 plate with a hole was told of elastic bodies; 2026-12-07).
        if self.walls:
            advice = (
                "A rigid wall's contact is found step by step, though, so a scene with "
                "walls needs its steps for that"
            )
        elif self.material.history:
            advice = "A law with a history follows its load path, so it needs its steps"
        else:
            advice = "An elastic body needs no more load steps than Newton does"
        warn(
            f"Static step {k}: points have crossed cells. In standard MPM a static answer "
            "then drifts with the number of load steps: a cantilever under its weight, "
            "four cells deep, bent 31 % too far after 20 steps in u-p, where one step was "
            "within 0.3 % (docs/limitations.md). point_domains=True cut that drift to 9 %. "
            "The crossings' noise can also seed a localisation where none belongs (a J2 "
            "strip 53 mm long necked 16 mm from its narrowest section in 35 steps, and "
            "at it in 70 and with point domains). "
            f"{advice} (said once)."
        )

    def _points_crossed_cells(self) -> bool:
        """Whether some point lies in another cell than the one it started in (collective).

        A point whose start lies in no cell of its rank (it migrated) counts as crossed.
        """
        pts = self.points
        inside = pts.cell >= 0
        start = self.tracker.locate(pts.x0[inside], pts.cell[inside])
        return parallel.any_rank(self.mesh.comm, bool(np.any(start != pts.cell[inside])))

    def _zone_cells(self, layout: SlotLayout) -> list[np.ndarray] | None:
        """The cells of each zone's points (or pieces) where NB-VA keeps a θ per zone."""
        if self.fields.zones == 1:
            return None
        label = np.rint(self.points.history[MATERIAL]).astype(np.int64)
        return [np.unique(layout.cell[label == z]) for z in range(self.fields.zones)]

    def _track(self, step: int = 0, t: float = 0.0, hold: bool = False) -> SlotLayout:
        t0 = time.perf_counter()
        if self.domains is not None and self.domains.active:  # pieces know their cells
            layout = self.tracking.lay_out(self.points.cell, step, t)
        else:
            layout = self.tracking.track(self.points, self.markers, step, t, hold)
            self._cells_of_grid = True
        self._add_time("tracking", t0)
        return layout

    def _solve(self, forms: StepForms, R, J, bcs: list) -> NewtonResult:
        """Newton from Δu = 0 with each line search of :attr:`ladder` until one converges."""
        current, pts = self._current, self.points
        volume = self.fields.pressure_volume(current.layout.cell, current.bary, pts.volume)
        hooks = {"loads": current.loads, "pressure_volume": volume}
        if self.dynamic:
            hooks["inertia"] = lambda: self.dynamics.inertia_force_norm(self.w.x.array)
        if forms.pointwise or self._shift is not None:
            hooks["before_residual"] = lambda: self.refresh_material(tangent=False)
            hooks["before_jacobian"] = self.refresh_material
        if self.ghost is not None:
            hooks["ghost"] = self.ghost
        if self._by_parts is not None:
            hooks["extra_force"] = self._by_parts.vector
        if self._shift is not None:
            self._shift.hold(bcs)
            hooks["after_jacobian"] = self._shift.correct
        coupling = None if self.ghost is None else self.ghost.pattern
        if self._newton is None:  # its matrix has the pattern of every cell of the grid
            prefix = f"fe_mpm_{self.formulation.replace('-', '_')}_"
            pattern = forms.jacobian.bind_cells(np.arange(self.tracker.num_cells, dtype=np.int32))
            options = (self.petsc_options, self.timings, self.linear_solver, self.fields.U)
            size = parallel.largest(self.mesh.comm, float(self.tracker.sizes.max()))
            self._newton = NewtonSolver(
                self.w,
                pattern,
                prefix,
                *options,
                size,
                coupling,
                strain_field=self.spec.volume_average,
            )
        elif self.ghost is not None and self.ghost.changed:  # and the step's ghost facets
            self._newton.couple(coupling)
        if self.ghost is not None:
            self.ghost.changed = False

        self._newton.clear_nonfinite()

        def attempt(search: str | None, resume: bool) -> NewtonResult:
            if resume:
                self._newton.resume_from_best()
            else:
                self._initial_guess()
            return self._newton.solve(
                R, J, bcs, **hooks, line_search=search, keep_best=self.ladder.resume
            )

        try:
            return self.ladder.solve(attempt, self._newton.line_search)
        except PETSc.Error as err:
            cause = err.__cause__
            if cause is None or isinstance(cause, PETSc.Error):
                raise
            # A Ctrl-C or an error of Python (a law of a user's that returned the wrong
            # shape) in a callback of SNES reaches here as PETSc's "error code 101", and
            # leaves SNES's vectors locked mid-solve: every later solve failed (error
            # 73). The next step builds a new solver; the points are as the last step
            # left them. The error is raised as itself, its own message on top.
            self._newton.destroy()
            self._newton = None
            if isinstance(cause, KeyboardInterrupt):
                raise KeyboardInterrupt from None
            raise cause from None

    def _internal_force(self, R) -> Callable[[], np.ndarray]:
        """The residual's assembly, with G Δu and the starting pressure's facet terms.

        The ghost penalty's force and :mod:`fe_mpm.pressure_by_parts`'s, where there are.
        """

        def force() -> np.ndarray:
            b = R.assemble_vector()
            if self.ghost is not None:
                b = b + self.ghost.force(self.w)
            if self._by_parts is not None:
                with self._by_parts.vector.localForm() as local:
                    b = b + local.array_r
            return b

        return force

    def _initial_guess(self) -> None:
        """Δu = 0 and the projected pressure (:meth:`GridFields.start_from_rest`)."""
        current, pts = self._current, self.points
        self.fields.start_from_rest(current.layout.cell, current.bary, pts.mass, pts.stress)
        if self._by_parts is not None:  # its facet terms at the new starting pressure
            self._by_parts.assemble()

    def _consistent_initial_acceleration(
        self, forms: StepForms, layout: SlotLayout, R, bcs: list, dt: float
    ) -> None:
        """Start from accelerations in equilibrium (:meth:`NewmarkDynamics.start`).

        The residual at rest is Newton's, with the starting pressure's facet terms
        (until 2026-12-05 they were left out here, so water started at its
        hydrostatic pressure was thrown by its first step).
        """
        internal_force = self._internal_force(R)

        def residual_at_rest() -> np.ndarray:
            self._initial_guess()
            self.refresh_material(tangent=False)
            return internal_force()

        preload = None
        if self.walls and self._started_stressed:  # springs that carry the stress at rest
            space = self.dynamics.space
            preload = lambda residual, fixed: self.walls.preload(residual, fixed, space)  # noqa: E731
        self.dynamics.start(
            residual_at_rest,
            forms.mass_matrix,
            layout,
            bcs,
            self._current.bary,
            self.points,
            dt,
            preload,
        )

    def _warn_unread_options(self) -> None:
        """Warn of the user's ``petsc_options`` that PETSc has not read by now.

        Called after the first step that took a Newton iteration: a step that starts in
        equilibrium solves nothing, and MUMPS reads its options only when it factorises.

        A misspelt key (``snes_rtoll``) was ignored without a word (a helper's trapdoor,
        2026-12-07); so is one meant for a solver the run does not use (MUMPS's ICNTL with
        ``linear_solver="iterative"``). Every rank read the same options, so rank 0 says it.
        """
        given = {key.lstrip("-") for key in self._given_petsc_options}
        read = set(self._newton.read_options) if self._newton is not None else set()
        if self.dynamics is not None:
            read |= self.dynamics.read_options
        unread = sorted(given - read)
        if unread:
            hint = ""
            if self.linear_solver == "direct" and any(
                key.startswith(("mat_mumps", "pc_factor")) for key in unread
            ):
                hint = (
                    " The direct solver's LU (MUMPS) lies behind PCREDISTRIBUTE and reads "
                    "its options with the prefix redistribute_ (redistribute_mat_mumps_icntl_14)."
                )
            warn(
                f"Simulation: petsc_options {unread} were not read by PETSc in the first "
                "step that solved a system: misspelt (PETSc's names, e.g. snes_rtol, "
                "ksp_type), or meant for a solver this run does not use. They have no "
                "effect." + hint
            )

    def _update_points(
        self, forms: StepForms, layout: SlotLayout, step: int, t: float, dt: float
    ) -> np.ndarray:
        """The points take the converged state (:mod:`fe_mpm.point_update`).

        Returns:
            With ``points_leaving="drop"``, the points the step carried out of the grid
            (indices, to drop once the step is done); else none.
        """
        if self.domains is not None:  # the sub-points' step: check their domains first
            self.domains.move_corners(self.fields.displacement_at, self.tracker, step, t)
        values, pts, rm = forms.update.evaluate(layout), self.points, self._current.return_map
        limit = None if self.dynamic else self.max_step_cells
        sizes = self.tracker.sizes[layout.cell]
        new = checked_update(
            values, forms.update_layout, pts, sizes, limit, step, t, self.mesh.comm
        )
        # Kept apart from the pressure field's (or, in NB-VA, the averaged volume's), a
        # fluid point's own volume drifts and the water churns (fe_mpm.materials.fluid).
        if self._volume_of_pressure:
            J = volume_of_pressure(new, self.material.bulk_modulus, step, t, self.mesh.comm)
        elif self._volume_of_average:
            own = np.linalg.det(new.dF) * np.linalg.det(pts.F)
            bary = self._current.bary
            J = volume_of_average(self.fields.Q[0], layout.cell, bary, pts.mass, own, step, t)
        # Points leaving: found before anything moves, dropped once it has ("drop") or
        # told of once the step is kept ("raise").
        # A domain's sub-points are not dropped: its point goes if the domain leaves
        # (PointDomains.drop_left).
        leaving = (
            np.zeros(0, dtype=np.int64)
            if self.domains is not None
            else self.tracking.leaving(pts, self.markers, pts.x + new.du, step, t)
        )
        apply_update(pts, new, self.markers, self.dynamics, dt, rm and rm.result.history)
        if self._volume_of_pressure or self._volume_of_average:
            keep_volume_of_pressure(pts, J)
        return leaving

    def _write_output(self, force: bool = False) -> None:
        """Write the frame of the current step if due (``force``: now), with its CSV rows.

        Collective. After a step that failed (a run that stops, or a script's own
        loop that caught the error) the points are the last accepted step's and are
        written; the grid's fields are the failed attempt's and are not.
        """
        t0, out = time.perf_counter(), self.output
        corners = None if self.domains is None else self.domains.corners
        grid = self._grid_is_a_step
        if out is not None and out.write(
            self.step_number, self.t, self.points, force, corners, grid, self._cells_of_grid
        ):
            self._write_rows(out)
            self._add_time("output", t0)

    def _write_rows(self, out: SimulationOutput) -> None:
        """Append the rows of the steps since the last ones written to the CSV files.

        A long run's files grow by their new steps, not rewritten whole; appended rows
        keep the columns of the first step written. A restored run's first rows go on
        after the rows of the run it continues (``SimulationOutput.continues``), under
        their header if it is theirs; a header that differs (a marker added after the
        restore) starts the file anew, the earlier one kept beside it.
        """
        if self._unwritten and parallel.on_rank_zero(self.mesh.comm):
            head = self._csv_head
            if head is None and out.continues:
                head = self._unwritten[0]
                steps = out.folder / "steps.csv"
                if steps.exists() and steps.read_text().split("\n", 1)[0] != steps_header(head):
                    steps.rename(out.folder / f"steps_before_step_{head.step}.csv")
            for name, write in [("steps.csv", write_steps), ("walls.csv", write_wall_forces)]:
                path = out.folder / name
                if name == "walls.csv" and not self.walls:
                    continue
                if head is not None and path.exists():
                    write([head, *self._unwritten], path, 1)
                else:
                    write(self._unwritten, path, 0)
        if self._unwritten:
            self._csv_head = self._csv_head or self._unwritten[0]
        self._unwritten = []

    def _add_time(self, key: str, t0: float) -> None:
        self.timings[key] = self.timings.get(key, 0.0) + time.perf_counter() - t0

    @property
    def newton_iterations_total(self) -> int:
        """Newton iterations of every solve so far, failed attempts included."""
        now = 0 if self._newton is None else self._newton.iterations_total
        return self._iterations_of_old_grids + now

    @property
    def dropped(self) -> int:
        """Points removed so far because they left the grid (``points_leaving="drop"``).

        The count over all ranks, known on each without a message, so that rank 0 alone
        may read it (``if comm.rank == 0: print(sim.dropped)``; until 2026-12-05 the
        other ranks then waited for it for ever).
        """
        return int(self.tracking.dropped)

    @property
    def w(self) -> dolfinx.fem.Function:
        """The grid unknown of the last step: Δu, or (Δu, p) for the mixed forms."""
        return self.fields.w

    def close(self) -> None:
        """Write the last step if it is not yet written; close output files and free PETSc objects.

        Collective. A script that drives :meth:`step` itself gets its last frame and
        ``steps.csv`` rows here, as :meth:`run` writes them at its end.
        """
        self._look_for_a_tear_now()  # (a script's own loop of step() calls)
        if self.output is not None:
            self._write_output(force=True)
            self.output.close()
        if self._newton is not None:
            self._newton.destroy()
            self._newton = None
        if self.ghost is not None:
            self.ghost.destroy()
        if self._by_parts is not None:
            self._by_parts.destroy()
            self._by_parts = None
        if self._shift is not None:
            self._shift.destroy()


def _refuse_misplaced(comm, tracker, x: np.ndarray, new: np.ndarray) -> None:
    """Refuse (collective) new points outside the grid or where a point already lies.

    Checked before they join the points, which a refusal leaves as they were (added
    first and tracked, points outside the grid stayed and failed every later step; a
    copy of the body doubled its weight; a helper's scenes, 2026-12-06).

    Args:
        comm: The grid's communicator.
        tracker: The grid's point locator.
        x: This rank's points (n, g).
        new: This rank's new points (m, g).
    """
    every_new = parallel.gathered(comm, new)
    found = parallel.total(comm, (tracker.locate(every_new) >= 0).astype(np.int64)) > 0
    error = None
    if not np.all(found):
        first = every_new[np.flatnonzero(~found)[0]]
        error = ValueError(
            f"Simulation.add_points: {int(np.sum(~found))} of the new points lie outside "
            f"the grid (first at x = {first.tolist()})"
        )
    else:
        twice = np.flatnonzero(coincident(np.vstack([x, every_new]))[len(x) :])
        if twice.size:
            error = ValueError(
                f"Simulation.add_points: {twice.size} of the new points lie where a point "
                f"already lies (first at x = {every_new[twice[0]].tolist()}), which counts "
                "the material twice"
            )
    parallel.raise_together(comm, error)


def _check_points(comm, check: Callable[[str, str], None]) -> None:
    """Refuse on every rank what a points' check refuses on one.

    ``check`` is ``points.check_state`` (x, volume, mass, F, stress) or
    ``points.check_motion`` (velocity, acceleration); the message names the field as
    a script sets it (``points.x``).
    """
    parallel.check_together(comm, check, "Simulation", "points.", kinds=(ValueError, TypeError))


def _check_history(name: str, given, shape: tuple) -> None:
    """Refuse a point field of the law's history of another shape, or not finite.

    NaN in a later stage's ``be`` stopped Newton with a message about its iterates, and
    ``plastic_strain = inf`` ran on into the output (a helper's probes, 2026-12-07).
    """
    given = np.asarray(given)
    if given.shape != shape:
        raise ValueError(
            f"Simulation: points.history[{name!r}] must have shape {shape} for this law, "
            f"got {given.shape}"
        )
    rows = given.reshape(shape[0], int(np.prod(shape[1:])))  # (a rank may hold none)
    bad = np.flatnonzero(~np.isfinite(rows).all(axis=1))
    if bad.size:
        raise ValueError(
            f"Simulation: points.history[{name!r}] must be finite; point {bad[0]} has "
            f"{given[bad[0]].ravel().tolist()}"
        )


def spin_rate(comm, points: MaterialPoints) -> float:
    """The points' rate of rigid spin about their mass centre (rad/s), 0 if negligible.

    ω = ‖L‖ / I with L = Σ m (x − x̄) × v and I = Σ m ‖x − x̄‖², over every rank; 0
    where the spin's speed at the radius of gyration, ω √(I/M), is under a tenth of
    the fastest point's speed relative to the mass centre's (a vibrating body, a
    flow), or where nothing moves.
    """
    g = points.x.shape[1]
    m, x, v = points.mass, points.x, points.velocity
    mass = parallel.total(comm, float(m.sum()))
    if not mass > 0.0:
        return 0.0
    centre = parallel.total(comm, m @ x) / mass
    drift = parallel.total(comm, m @ v) / mass
    r, w = x - centre, v - drift
    if g == 2:
        L = parallel.total(comm, float(m @ (r[:, 0] * w[:, 1] - r[:, 1] * w[:, 0])))
    else:
        L = float(np.linalg.norm(parallel.total(comm, m @ np.cross(r, w))))
    inertia = parallel.total(comm, float(m @ np.einsum("ij,ij->i", r, r)))
    fastest = parallel.largest(comm, float(np.linalg.norm(w, axis=1).max(initial=0.0)))
    if not (inertia > 0.0 and fastest > 0.0):
        return 0.0
    omega = abs(L) / inertia
    return omega if omega * np.sqrt(inertia / mass) > 0.1 * fastest else 0.0
