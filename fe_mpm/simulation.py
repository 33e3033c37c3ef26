"""The implicit MPM step and time loop (Iaconeta 2019, Algorithm 1), in one place.

Each step:

1. **Track**: locate every material point in the (undeformed) grid.
2. **Pack**: number the points of each cell into slots and write their data
   (offset, volume, F_n, density) into the slot fields of the forms.
3. **Solve**: Newton for the grid displacement increment Δu, assembling only
   the occupied cells; grid nodes with no material support are pinned.
4. **Convect**: evaluate Δu, ΔF and the stress at the points and update
   ``x += Δu``, ``F = ΔF F_n``, ``V = det(ΔF) V_n``. The grid is reset simply by
   never moving it.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import ufl

from fe_mpm._dolfinx import dolfinx
from fe_mpm.assembly import StepForm
from fe_mpm.boundary import Dirichlet, Traction, boundary_facets
from fe_mpm.checks import check_choice, check_range
from fe_mpm.errors import ConvergenceError, PointsOutsideError
from fe_mpm.forms import displacement
from fe_mpm.io import ParticleWriter
from fe_mpm.newton import NewtonSolver
from fe_mpm.particles import MaterialPoints, simplex_cell_type
from fe_mpm.quadrature import MaterialPointQuadrature, SlotLayout, bucket
from fe_mpm.tracker import Tracker

#: Formulations that run today.
FORMULATIONS = ("u",)
#: Formulations that are planned but not built yet.
PLANNED_FORMULATIONS = ("up", "up-nostab")


@dataclass
class StepReport:
    """What one step did.

    Attributes:
        step: Step number, from 1.
        t: Time at the end of the step (s, or pseudo-time in static runs).
        newton_iterations: Newton iterations of the step.
        residual_norms: ‖R‖ at each Newton iterate.
        markers: Position of every marker at ``t``, name -> array (g,).
        nslot: Slots per cell used in the step.
        occupied_cells: Number of cells holding points.
    """

    step: int
    t: float
    newton_iterations: int
    residual_norms: list[float]
    markers: dict[str, np.ndarray] = field(default_factory=dict)
    nslot: int = 0
    occupied_cells: int = 0


class _SlotForms:
    """Everything that depends on the slot count: quadrature, data fields, compiled forms."""

    def __init__(self, sim: Simulation, nslot: int):
        mesh, g = sim.mesh, sim.gdim
        self.q = q = MaterialPointQuadrature(mesh, nslot)
        self.F_n = q.function((g, g), "F_n")
        self.density = q.function((), "density")
        w = ufl.TestFunction(sim.V)
        du = sim.du
        kirchhoff = sim.material.kirchhoff
        R = displacement.residual(
            du, w, q, self.F_n, self.density, kirchhoff, sim._body_force, sim._traction_terms
        )
        J = ufl.derivative(R, du, ufl.TrialFunction(sim.V))
        self.residual = StepForm(R, mesh, sim._traction_facets)
        self.jacobian = StepForm(J, mesh, sim._traction_facets)
        # Per-point values after convergence: Δu_p, ΔF_p and the 3x3 Cauchy stress.
        dF = displacement.deformation_increment(q, du)
        sigma = displacement.cauchy_stress_3d(kirchhoff, dF * self.F_n)
        du_p = q.at_points(du)
        values = [du_p[i] for i in range(g)]
        values += [dF[i, j] for i in range(g) for j in range(g)]
        values += [sigma[i, j] for i in range(3) for j in range(3)]
        self.update = dolfinx.fem.Expression(ufl.as_vector(values), q.points)


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
        material: Constitutive law with ``kirchhoff(F)``.
        formulation: ``"u"`` (irreducible). ``"up"``/``"up-nostab"`` are planned.
        dirichlet: Prescribed grid displacements.
        tractions: Surface tractions on grid facets.
        body_force: Body force per unit mass (m/s², length g), e.g. gravity.
        facet_tags: Facet tags for ``Dirichlet``/``Traction`` given by tag.
        petsc_options: Overrides of :data:`fe_mpm.newton.DEFAULT_PETSC_OPTIONS`.
        points_leaving: ``"raise"`` (default) stops when points leave the grid;
            ``"drop"`` removes them with a warning and counts them in ``dropped``.
        output_dir: Folder for ParaView output (``particles.pvd`` and ``grid.bp``);
            nothing is written if None.
        output_every: Write every this many steps (the last step is always written).
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
        body_force: Sequence[float] | None = None,
        facet_tags: dolfinx.mesh.MeshTags | None = None,
        petsc_options: dict | None = None,
        points_leaving: str = "raise",
        output_dir: str | Path | None = None,
        output_every: int = 1,
    ):
        if formulation in PLANNED_FORMULATIONS:
            raise NotImplementedError(
                f"Simulation: formulation {formulation!r} is not implemented yet; "
                f"available: {', '.join(FORMULATIONS)}"
            )
        check_choice("Simulation", "formulation", formulation, FORMULATIONS)
        check_choice("Simulation", "points_leaving", points_leaving, ("raise", "drop"))
        check_range("Simulation", "output_every", output_every, lo=1)
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
        self.mesh = mesh
        self.points = points
        self.material = material
        self.formulation = formulation
        self.gdim = g = mesh.geometry.dim
        self.points_leaving = points_leaving
        self.petsc_options = petsc_options
        self.timings: dict[str, float] = {}
        self.history: list[StepReport] = []
        self.dropped = 0
        self.t = 0.0
        self.step_number = 0

        t0 = time.perf_counter()
        self.tracker = Tracker(mesh)
        self.V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (g,)))
        self.du = dolfinx.fem.Function(self.V, name="du")
        fdim = tdim - 1
        mesh.topology.create_connectivity(fdim, tdim)

        self._dirichlet = []  # (spec, Constant or Function, DirichletBC)
        for spec in dirichlet:
            facets = boundary_facets(mesh, spec.where, facet_tags)
            if spec.component is None:
                space = self.V
                shape = (g,)
            else:
                check_range("Dirichlet", "component", spec.component, lo=0, hi=g - 1)
                space = self.V.sub(spec.component)
                shape = ()
            if spec.profile is None:
                value = dolfinx.fem.Constant(mesh, np.zeros(shape))
                dofs = dolfinx.fem.locate_dofs_topological(space, fdim, facets)
                bc = dolfinx.fem.dirichletbc(value, dofs, space)
            elif spec.component is None:
                value = dolfinx.fem.Function(space)
                dofs = dolfinx.fem.locate_dofs_topological(space, fdim, facets)
                bc = dolfinx.fem.dirichletbc(value, dofs)
            else:
                collapsed, _ = space.collapse()
                value = dolfinx.fem.Function(collapsed)
                dofs = dolfinx.fem.locate_dofs_topological((space, collapsed), fdim, facets)
                bc = dolfinx.fem.dirichletbc(value, dofs, space)
            self._dirichlet.append((spec, value, bc))

        self._tractions = []  # (spec, Constant)
        self._traction_facets: dict[int, np.ndarray] = {}
        self._traction_terms = []
        ds = ufl.Measure("ds", domain=mesh)
        for i, spec in enumerate(tractions, start=1):
            if len(spec.value) != g:
                raise ValueError(f"Traction: value must have {g} components, got {len(spec.value)}")
            value = dolfinx.fem.Constant(mesh, np.zeros(g))
            self._traction_facets[i] = boundary_facets(mesh, spec.where, facet_tags)
            self._traction_terms.append((value, ds(i)))
            self._tractions.append((spec, value))

        self._body_force = None
        if body_force is not None:
            if len(body_force) != g:
                raise ValueError(f"Simulation: body_force must have {g} components")
            self._body_force = dolfinx.fem.Constant(mesh, np.asarray(body_force, dtype=float))

        self._forms: dict[int, _SlotForms] = {}
        self._newton: NewtonSolver | None = None
        self._markers: dict[str, tuple[np.ndarray, int]] = {}  # name -> (x, host point)
        self._add_time("setup", t0)

        self._particle_writer = self._grid_writer = None
        self._written_step = -1
        self.output_every = int(output_every)
        if output_dir is not None:
            self.output_dir = Path(output_dir)
            self._particle_writer = ParticleWriter(self.output_dir)
            self._grid_writer = dolfinx.io.VTXWriter(
                mesh.comm, self.output_dir / "grid.bp", [self.du], engine="BP4"
            )

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
        xm = np.asarray(x, dtype=np.float64).reshape(self.gdim)
        if self.tracker.locate(xm[None, :])[0] < 0:
            raise PointsOutsideError(f"marker {name!r} at {xm} is outside the grid")
        host = int(np.argmin(np.linalg.norm(self.points.x - xm, axis=1)))
        self._markers[name] = (xm, host)

    def marker(self, name: str) -> np.ndarray:
        """Current position of a marker, shape (g,)."""
        return self._markers[name][0].copy()

    def run(
        self, t_end: float = 1.0, n_steps: int = 1, *, progress: bool = True
    ) -> list[StepReport]:
        """Advance from the current time to ``t_end`` in ``n_steps`` equal steps.

        In a static analysis ``t`` is a pseudo-time that only drives the loads
        and the prescribed displacements.
        """
        check_range("Simulation.run", "n_steps", n_steps, lo=1)
        check_range("Simulation.run", "t_end", t_end, lo=self.t, lo_open=True)
        times = np.linspace(self.t, t_end, int(n_steps) + 1)[1:]
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(times), desc="fe-mpm", unit="step", leave=False)
        reports = []
        try:
            for t_new in times:
                report = self.step(float(t_new))
                reports.append(report)
                if bar is not None:
                    bar.set_postfix(t=f"{report.t:.4g}", newton=report.newton_iterations)
                    bar.update()
        finally:
            if bar is not None:
                bar.close()
        self._write_output(force=True)
        return reports

    def step(self, t_new: float) -> StepReport:
        """Take one implicit step from the current time to ``t_new``."""
        if not t_new > self.t:
            raise ValueError(f"Simulation.step: t_new must exceed the current time {self.t}")
        k = self.step_number + 1
        forms, layout, R, J, bcs = self.prepare_step(t_new)
        self.du.x.array[:] = 0.0
        result = self._newton_solver(forms).solve(R, J, bcs)
        if not result.converged or not np.all(np.isfinite(self.du.x.array)):
            norms = ", ".join(f"{r:.3e}" for r in result.residual_norms)
            raise ConvergenceError(
                f"Newton failed in step {k} (t = {self.t:g} -> {t_new:g}) after "
                f"{result.iterations} iterations: {result.reason}; ‖R‖ history: [{norms}]. "
                f"{self._hinge_diagnosis(layout)}"
                "Points were not updated and nothing was written for this step."
            )

        t0 = time.perf_counter()
        self._convect(forms, layout, step=k, t=t_new)
        self._add_time("update", t0)

        self.t = t_new
        self.step_number = k
        report = StepReport(
            step=k, t=t_new, newton_iterations=result.iterations,
            residual_norms=result.residual_norms,
            markers={name: xm.copy() for name, (xm, _) in self._markers.items()},
            nslot=forms.q.nslot, occupied_cells=layout.occupied.size,
        )
        self.history.append(report)
        self._write_output()
        return report

    def prepare_step(self, t_new: float):
        """Track, pack and bind the forms of the step to ``t_new`` without solving.

        Returns:
            ``(forms, layout, R, J, bcs)``: the slot forms, the slot layout, the
            residual and Jacobian DOLFINx forms and the boundary conditions. The
            Taylor tests use this to check every residual/Jacobian pair.
        """
        layout = self._track(step=self.step_number + 1, t=t_new)

        t0 = time.perf_counter()
        nslot = bucket(layout.max_count)
        forms = self._forms.get(nslot) or self._compile(nslot)
        self._add_time("compile", t0)

        t0 = time.perf_counter()
        q, pts = forms.q, self.points
        q.pack_geometry(pts, layout, self.tracker.centroids, self.tracker.volumes)
        q.pack(forms.F_n, layout, pts.F, empty=np.eye(self.gdim))
        q.pack(forms.density, layout, pts.density)
        R = forms.residual.bind(layout.occupied)
        J = forms.jacobian.bind(layout.occupied)
        bcs = self._boundary_conditions(layout, self.t, t_new)
        self._add_time("packing", t0)
        return forms, layout, R, J, bcs

    # -- the phases of a step --------------------------------------------------

    def _track(self, step: int = 0, t: float = 0.0) -> SlotLayout:
        t0 = time.perf_counter()
        pts = self.points
        cells = self.tracker.locate(pts.x, pts.cell)
        outside = np.flatnonzero(cells < 0)
        if outside.size:
            where = f"step {step} (t = {t:g})" if step else "set-up"
            first = outside[0]
            msg = (f"{outside.size} material point(s) left the grid at {where}; first: "
                   f"point {first} at x = {pts.x[first]}")
            if self.points_leaving == "raise":
                raise PointsOutsideError(msg + ". Pass points_leaving='drop' to remove them.")
            warnings.warn(msg + "; dropped.", stacklevel=3)
            keep = cells >= 0
            new_index = np.cumsum(keep) - 1
            for name, (xm, host) in self._markers.items():
                if not keep[host]:
                    raise PointsOutsideError(f"the host point of marker {name!r} left the grid")
                self._markers[name] = (xm, int(new_index[host]))
            pts.keep(keep)
            cells = cells[keep]
            self.dropped += outside.size
            if len(pts) == 0:
                raise PointsOutsideError(f"all material points have left the grid at {where}")
        pts.cell = cells
        self._add_time("tracking", t0)
        return SlotLayout.from_cells(cells)

    def _hinge_diagnosis(self, layout: SlotLayout) -> str:
        """Explain a singular tangent by occupied cells hinged to the rest at one node.

        A P1 simplex has a constant strain whatever number of points it holds, so
        an occupied cell that shares at most one node with the other occupied
        cells can rotate freely about it: a mechanism of quasi-static MPM that
        appears when points cross into empty cells.
        """
        nodes = self.V.dofmap.list[layout.occupied]
        uses = np.bincount(nodes.ravel(), minlength=self.du.x.array.size // self.gdim)
        shared = (uses[nodes] > 1).sum(axis=1)
        hinged = layout.occupied[shared <= 1]
        if hinged.size == 0:
            return ""
        where = self.tracker.centroids[hinged[0]]
        return (
            f"{hinged.size} occupied cell(s) share at most one node with the rest of the "
            f"material (first near x = {where}); such a cell can swing about that node, so "
            "the static tangent is singular there. This typically follows points crossing "
            "into otherwise empty cells; a coarser grid or a dynamic analysis avoids it. "
        )

    def _compile(self, nslot: int) -> _SlotForms:
        forms = _SlotForms(self, nslot)
        self._forms[nslot] = forms
        return forms

    def _newton_solver(self, forms: _SlotForms) -> NewtonSolver:
        if self._newton is None:
            all_cells = np.arange(self.tracker.num_cells, dtype=np.int32)
            self._newton = NewtonSolver(
                self.du, forms.jacobian.bind(all_cells), prefix=f"fe_mpm_{self.formulation}_",
                petsc_options=self.petsc_options, timings=self.timings,
            )
        return self._newton

    def _boundary_conditions(self, layout: SlotLayout, t_old: float, t_new: float) -> list:
        for spec, value, _ in self._dirichlet:
            if spec.profile is None:
                value.value = spec.at(t_new) - spec.at(t_old)
            else:
                value.interpolate(lambda x: spec.profile(x, t_new) - spec.profile(x, t_old))
        for spec, value in self._tractions:
            value.value = spec.at(t_new)
        # Grid nodes no material point reaches get no equation: pin them.
        dofmap = self.V.dofmap
        n_nodes = dofmap.index_map.size_local + dofmap.index_map.num_ghosts
        supported = np.zeros(n_nodes, dtype=bool)
        supported[dofmap.list[layout.occupied].ravel()] = True
        free = np.flatnonzero(~supported).astype(np.int32)
        pin = dolfinx.fem.dirichletbc(np.zeros(self.gdim), free, self.V)
        return [bc for _, _, bc in self._dirichlet] + [pin]

    def _convect(self, forms: _SlotForms, layout: SlotLayout, step: int, t: float) -> None:
        g = self.gdim
        values = forms.q.evaluate(forms.update, layout)
        if not np.all(np.isfinite(values)):
            bad = np.flatnonzero(~np.all(np.isfinite(values), axis=1))
            raise ConvergenceError(
                f"non-finite state at {bad.size} material point(s) in step {step} (t = {t:g}); "
                f"first: point {bad[0]} at x = {self.points.x[bad[0]]}. Nothing was updated."
            )
        du_p = values[:, :g]
        dF = values[:, g : g + g * g].reshape(-1, g, g)
        sigma = values[:, g + g * g :].reshape(-1, 3, 3)
        det_dF = np.linalg.det(dF)
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
        pts.stress = sigma

    def _write_output(self, force: bool = False) -> None:
        if self._particle_writer is None or self.step_number in (0, self._written_step):
            return
        if not force and self.step_number % self.output_every:
            return
        self._written_step = self.step_number
        t0 = time.perf_counter()
        self._particle_writer.write(self.t, self.points)
        self._grid_writer.write(self.t)
        self._add_time("output", t0)

    def _add_time(self, key: str, t0: float) -> None:
        self.timings[key] = self.timings.get(key, 0.0) + time.perf_counter() - t0

    def close(self) -> None:
        """Close output files and free PETSc objects."""
        if self._grid_writer is not None:
            self._grid_writer.close()
            self._grid_writer = None
        if self._newton is not None:
            self._newton.destroy()
            self._newton = None
