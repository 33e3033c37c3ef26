"""The compiled forms of a step, and the per-point update they give after it.

Everything here depends on the slot count (points per entity, see
:mod:`fe_mpm.quadrature`), so a simulation keeps one :class:`StepForms` per slot
count it meets: the quadrature and its slot fields, the residual and Jacobian, the
loads alone (for Newton's force scale), the mass matrix (dynamics), and the update
expression that evaluates every point's new state once Newton has converged.
:class:`UpdateLayout` says where each value sits in that expression's output; it
both builds and reads it, so the order is written down once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import ufl

from fe_mpm._dolfinx import dolfinx
from fe_mpm.assembly import StepForm
from fe_mpm.forms import displacement, inertia, mixed_up, penalty, volume_average
from fe_mpm.forms import loads as loads_form
from fe_mpm.formulations import FormulationSpec, GridFields
from fe_mpm.grid_conditions import GridConditions
from fe_mpm.materials import Linearisation, PointState, ReturnMapResult, embed_3d
from fe_mpm.materials.linearised import MixedLinearisation
from fe_mpm.materials.mixed_return import MixedReturnResult
from fe_mpm.materials.protocol import PointwiseLaw, checked_stress
from fe_mpm.materials.runtime import with_runtime_parameters
from fe_mpm.materials.zones import MATERIAL, indicator, point_lame_moduli
from fe_mpm.packing import BoundForm, PointExpression
from fe_mpm.particles import MaterialPoints
from fe_mpm.quadrature import BOUNDARY_POINTS, OCCUPIED, MaterialPointQuadrature, SlotLayout
from fe_mpm.tracker import Tracker
from fe_mpm.transfer import second_moments
from fe_mpm.walls import RigidWalls


@dataclass(frozen=True)
class PointUpdate:
    """Every point's new state from a converged step (n points, g dimensions).

    Attributes:
        du: Displacement increment Δu_p (n, g) in m.
        dF: Deformation gradient increment ΔF_p (n, g, g).
        stress: Cauchy stress at t_{n+1} (n, 3, 3) in Pa, σ_33 included in 2D.
        acceleration: Acceleration at t_{n+1} (n, g) in m/s², or None (static).
        history: The law's internal variables at t_{n+1}, name -> (n, size) columns.
    """

    du: np.ndarray
    dF: np.ndarray
    stress: np.ndarray
    acceleration: np.ndarray | None
    history: dict[str, np.ndarray]


class UpdateLayout:
    """The columns of the update vector: Δu_p, ΔF_p, σ (3x3), [a_p], then the history.

    Args:
        g: Geometric dimension.
        dynamic: Whether the acceleration is part of it.
        history_shapes: The law's internal variables at t_{n+1}, name -> value shape.
    """

    def __init__(self, g: int, dynamic: bool, history_shapes: dict[str, tuple[int, ...]]):
        self.g, self.dynamic = g, dynamic
        self.history_shapes = dict(history_shapes)
        sizes = [("du", g), ("dF", g * g), ("stress", 9)]
        sizes += [("acceleration", g)] if dynamic else []
        sizes += [(name, int(np.prod(shape))) for name, shape in self.history_shapes.items()]
        self.columns: dict[str, slice] = {}
        start = 0
        for name, size in sizes:
            self.columns[name] = slice(start, start + size)
            start += size
        self.width = start

    def vector(self, du, dF, stress, acceleration, history: dict) -> ufl.core.expr.Expr:
        """The UFL vector of the update, its entries in this layout's order."""
        g = self.g
        values = [du[i] for i in range(g)]
        values += [dF[i, j] for i in range(g) for j in range(g)]
        values += [stress[i, j] for i in range(3) for j in range(3)]
        if self.dynamic:
            values += [acceleration[i] for i in range(g)]
        for name, shape in self.history_shapes.items():
            value = history[name]
            values += [value[idx] for idx in np.ndindex(*shape)] if shape else [value]
        return ufl.as_vector(values)

    def decode(self, values: np.ndarray) -> PointUpdate:
        """The point update from the evaluated vector ``values`` (n, width)."""
        g, col = self.g, self.columns
        return PointUpdate(
            du=values[:, col["du"]],
            dF=values[:, col["dF"]].reshape(-1, g, g),
            stress=values[:, col["stress"]].reshape(-1, 3, 3),
            acceleration=values[:, col["acceleration"]] if self.dynamic else None,
            history={name: values[:, col[name]] for name in self.history_shapes},
        )


class StepForms:
    """Everything that depends on the slot count: quadrature, slot fields, compiled forms.

    Args:
        fields: The grid unknowns.
        spec: The formulation.
        material: The law.
        nslot: Slots per entity of the material points.
        nslot_boundary: Slots per entity of the boundary points (0: none).
        conditions: The grid's loads (body force, tractions).
        ppp: PPP data (u-p), or None.
        floor: The pressure floor of a pressure field without PPP, or None.
        newmark: Newmark's fields and constants (dynamics), or None.
        lumped: Whether the mass matrix is lumped (dynamics).
        walls: The rigid walls of the grid, or None.
        step_length: The step's length Δt (s) as a constant, for rate-dependent laws.
        shared_increment: Whether a point domain's pieces share its increment.
        pressure_by_parts: Whether the starting pressure is integrated by parts in
            the cells of χ = 1 (:mod:`fe_mpm.pressure_by_parts`; u-p and NB-VA).
        point_pressure: Whether boundary points carry a follower pressure
            (:class:`~fe_mpm.boundary.PointPressure`).
    """

    def __init__(
        self,
        fields: GridFields,
        spec: FormulationSpec,
        material,
        nslot: int,
        nslot_boundary: int = 0,
        *,
        conditions: GridConditions,
        ppp: mixed_up.PPPData | None = None,
        floor: mixed_up.PressureFloor | None = None,
        newmark: inertia.NewmarkData | None = None,
        lumped: bool = False,
        walls: RigidWalls | None = None,
        step_length: ufl.Constant | None = None,
        shared_increment: bool = False,
        pressure_by_parts: bool = False,
        point_pressure: bool = False,
    ):
        mesh, g = fields.W.mesh, fields.W.mesh.geometry.dim
        self.mesh, self.spec, self.material, self.newmark = mesh, spec, material, newmark
        # The forms read the law's parameters as constants: one kernel for all values.
        self.law_in_forms = with_runtime_parameters(material, mesh)
        self.ppp, self.floor = ppp, floor
        self.q = q = MaterialPointQuadrature(mesh, nslot)
        self.F_n = q.function((g, g), "F_n", empty=np.eye(g))
        self.density = q.function((), "density")
        self.history = {
            name: q.function(h.shape, name, empty=h.initial) for name, h in material.history.items()
        }
        # ΔF of the grid's motion, and the ΔF the law sees (ΔF̄ with NB-VA).
        self.dF_grid = ufl.Identity(g) + q.grad_at_points(fields.du, spec.u_degree)
        self.dF = self.dF_grid
        # Point domains whose pieces share their point's increment: each piece's ΔF is
        # shifted to the share-weighted mean of its point's pieces (set per iterate).
        self.dF_shift = None
        if shared_increment:
            self.dF_shift = q.function((g, g), "dF_shift")
            self.dF_at_points = PointExpression(self.dF_grid, q)
            self.dF = self.dF_grid + self.dF_shift
        #: χ_z of each zone where NB-VA averages every zone on its own, else None.
        self.zones = None
        if spec.volume_average:
            if fields.zones > 1:
                label = self.history[MATERIAL]
                self.zones = [indicator(label, z) for z in range(fields.zones)]
            theta = volume_average.volume_change_at_points(q, fields.volume_change, self.zones)
            self.dF = volume_average.averaged_increment(self.dF_grid, theta)
        # The points' second moments C_p: the lumped mass and the average's lumping.
        moments = lumped or spec.volume_average
        self.second_moment = q.function((g, g), "second_moment") if moments else None
        # A pointwise law (numpy return map) enters the forms through its
        # linearisation at the current iterate, refreshed before every residual.
        self.pointwise = isinstance(material, PointwiseLaw)
        # In u-p a pressure-dependent law returns at the field's pressure.
        self.at_pressure = (
            self.pointwise and spec.pressure and getattr(material, "pressure_dependent", False)
        )
        self.linearisation, dynamic = None, set()
        mean_stress = self._field_mean_stress(self.dF, fields)
        if self.pointwise:
            kind = MixedLinearisation if self.at_pressure else Linearisation
            lin = self.linearisation = kind.on(q, g)
            dynamic = set(lin.slot_fields)  # they change during Newton
            self.values_at_points = PointExpression(lin.point_values(self.dF, mean_stress), q)
        if self.dF_shift is not None:
            dynamic = set(dynamic) | {self.dF_shift}
        self.state = PointState(self.dF, self.history, self.linearisation, mean_stress, step_length)
        self.increment_tangent = None
        if shared_increment:
            self.increment_tangent = self._increment_tangent(fields, step_length)
        w = ufl.TestFunctions(fields.W)[0] if spec.mixed else ufl.TestFunction(fields.W)
        #: χ of each point's cell (:mod:`fe_mpm.pressure_by_parts`), or None.
        self.interior = q.function((), "interior") if pressure_by_parts else None
        R = self._residual(fields, conditions, ppp)
        self.q_boundary = None
        self.boundary_pressure = self.dF_at_boundary = None
        if nslot_boundary:
            R += self._boundary_points(fields, w, nslot_boundary, point_pressure)
        facets = dict(conditions.traction_facets)
        if walls:
            R += walls.residual(w)
            facets.update(walls.facet_domains)
        rules = {OCCUPIED: q, BOUNDARY_POINTS: self.q_boundary}
        loads = self._loads(w, conditions)  # alone, for the Newton test's force scale
        self.loads = None
        if loads is not None:
            self.loads = StepForm(loads, mesh, conditions.traction_facets, rules)
        self.lumping = self.second_moment if lumped else None
        #: (λ_p, μ_p) of each point's law for stiffness-proportional damping, or None.
        self.elastic_moduli = None
        if newmark is not None:
            R += inertia.inertia(fields.du, w, q, self.density, newmark, self.lumping)
            if newmark.stiffness_damping is not None:
                self.elastic_moduli = q.function((2,), "elastic_moduli")
                R += inertia.stiffness_damping(fields.du, w, q, self.elastic_moduli, newmark)
            V1 = newmark.a_n.function_space
            a, v = ufl.TrialFunction(V1), ufl.TestFunction(V1)
            self.mass_matrix = StepForm(
                inertia.mass_product(a, v, q, self.density, self.lumping), mesh, quadratures=rules
            )
        trial = ufl.TrialFunction(fields.W)
        J = ufl.derivative(R, fields.w, trial)
        if walls and newmark is None:  # unloaded springs' friction holds the first iterate
            unloaded = walls.unloaded_tangent(ufl.split(trial)[0] if spec.mixed else trial, w)
            if unloaded is not None:
                J += unloaded
        self.residual = StepForm(R, mesh, facets, rules, dynamic)
        self.jacobian = StepForm(J, mesh, facets, rules, dynamic)
        self.update_layout, self.update = self._update(fields)

    def pack(
        self, layout: SlotLayout, points: MaterialPoints, tracker: Tracker, bary: np.ndarray
    ) -> None:
        """Write the points' data at t_n into the slot fields of ``layout``.

        Position, volume, ``F_n``, density and history; the second moments of a
        lumped mass; the PPP fill of each cell (volume of its points over its own), or
        the pressure floor's weight.

        Args:
            layout: The step's slot layout.
            points: The material points at t_n.
            tracker: The grid's cell geometry (centroids, volumes).
            bary: The points' barycentric coordinates in their cells (n, g + 1).
        """
        q, g = self.q, points.gdim
        q.pack_geometry(points.x, points.volume, layout, tracker.centroids, tracker.volumes)
        q.pack(self.F_n, layout, points.F, empty=np.eye(g))
        q.pack(self.density, layout, points.density)
        for name, h in self.material.history.items():
            q.pack(self.history[name], layout, points.history[name], empty=h.initial)
        if self.second_moment is not None:
            vertices = self.mesh.geometry.x[self.mesh.geometry.dofmaps[0][layout.cell], :g]
            q.pack(self.second_moment, layout, second_moments(vertices, points.x, bary))
        if self.ppp is not None:
            weights = points.volume
            point_mu = getattr(self.material, "point_shear_moduli", None)
            if point_mu is not None:  # several laws: PPP's 1/μ is each point's own
                weights = points.volume * (self.material.mu / point_mu(points.history))
            volume = np.bincount(layout.cell, weights=weights, minlength=tracker.num_cells)
            q.pack_cell_field(self.ppp.fill, layout, volume / tracker.volumes)
        if self.floor is not None:
            point_K = getattr(self.material, "point_bulk_moduli", None)
            K = self.material.bulk_modulus if point_K is None else point_K(points.history)
            cell_map = self.mesh.topology.index_map(self.mesh.topology.dim)
            weight = mixed_up.floor_weights(
                layout.cell, bary, points.volume, points.volume / K, cell_map, tracker.num_cells
            )
            q.pack_cell_field(self.floor.weight, layout, weight)
        if self.elastic_moduli is not None:
            q.pack(
                self.elastic_moduli,
                layout,
                point_lame_moduli(self.material, points.history, len(points)),
            )
        if self.dF_shift is not None:  # until the first iterate's (SharedIncrement)
            q.pack(self.dF_shift, layout, np.zeros((len(points), g, g)))

    def _residual(
        self, fields: GridFields, conditions: GridConditions, ppp: mixed_up.PPPData | None
    ) -> ufl.Form:
        """The static residual of the material points and the grid's loads."""
        q, material, state, deg = self.q, self.law_in_forms, self.state, self.spec.u_degree
        if self.spec.pressure:
            w, q_test = ufl.TestFunctions(fields.W)
            return mixed_up.residual(
                fields.du,
                fields.p,
                w,
                q_test,
                q,
                self.F_n,
                self.density,
                material,
                ppp,
                conditions.body_force,
                conditions.traction_terms,
                u_degree=deg,
                state=state,
                increment=None if self.dF_shift is None else self.dF,
                by_parts=None if self.interior is None else (fields.p_start, self.interior),
                floor=self.floor,
            )
        averaged = self.spec.volume_average
        if averaged:
            w, w_theta = ufl.TestFunctions(fields.W)
        else:
            w = ufl.TestFunction(fields.W)

        def kirchhoff(F):
            return checked_stress(material, "kirchhoff", material.kirchhoff(F, state), F)

        if self.interior is not None:
            kirchhoff = volume_average.without_start_pressure(
                kirchhoff, self.interior, q.at_points(fields.p_start)
            )
        R = displacement.residual(
            fields.du,
            w,
            q,
            self.F_n,
            self.density,
            kirchhoff,
            conditions.body_force,
            conditions.traction_terms,
            material_increment=self.dF if averaged else None,
            increment=None if self.dF_shift is None else self.dF,
        )
        if averaged:
            R += volume_average.projection_residual(
                q, self.dF_grid, fields.volume_change, w_theta, self.second_moment, self.zones
            )
        if self.interior is not None:
            # The geometric part with the grid's own det ΔF, not the averaged det ΔF̄
            # the stress gave up: with ΔF̄ a closed vortex gained 13 % of its energy in
            # 0.5 s, with ΔF it keeps it within 5 % (both equal at Δu = 0; a reviewer
            # asked for ΔF̄, 2026-12-08). Pressure by parts is refused with point
            # domains: no shared increment here.
            R += loads_form.start_pressure_by_parts(
                w, q, self.interior, fields.p_start, self.dF_grid
            )
        return R

    def _field_mean_stress(self, dF, fields: GridFields) -> ufl.core.expr.Expr | None:
        """The Kirchhoff mean stress −det(ΔF F_n) p (Pa) of a return at the field's pressure.

        None where the law returns on its own (not a pressure-dependent law in u-p).
        """
        if not self.at_pressure:
            return None
        return -ufl.det(embed_3d(dF * self.F_n)) * self.q.at_points(fields.p)

    def _increment_tangent(self, fields: GridFields, step_length) -> PointExpression:
        """∂/∂ΔF of what each point puts against ∇w (and q), at every slot.

        The derivatives (g⁴ entries, then g² for u-p's volumetric row) of
        :func:`~fe_mpm.forms.displacement.grid_stress` (or
        :func:`~fe_mpm.forms.mixed_up.point_terms`) with respect to the point's
        increment: what :mod:`fe_mpm.shared_increment` needs for the Jacobian's
        couplings across the cells of a domain.
        """
        q, g = self.q, fields.W.mesh.geometry.dim
        dF = ufl.variable(self.dF)
        mean_stress = self._field_mean_stress(dF, fields)
        state = PointState(dF, self.history, self.linearisation, mean_stress, step_length)
        law = self.law_in_forms
        if self.spec.pressure:
            p = q.at_points(fields.p)
            stress, volume = mixed_up.point_terms(law, dF, self.F_n, p, state)
        else:
            stress = displacement.grid_stress(lambda F: law.kirchhoff(F, state), dF, self.F_n)
            volume = None
        A = ufl.diff(stress, dF)
        values = [A[idx] for idx in np.ndindex(g, g, g, g)]
        if volume is not None:
            a = ufl.diff(volume, dF)
            values += [a[idx] for idx in np.ndindex(g, g)]
        return PointExpression(ufl.as_vector(values), q)

    def _boundary_points(
        self, fields: GridFields, w, nslot: int, point_pressure: bool = False
    ) -> ufl.Form:
        """The penalty and point loads of the boundary points, on their own rule."""
        mesh, deg = fields.W.mesh, self.spec.u_degree
        g = mesh.geometry.dim
        qb = self.q_boundary = MaterialPointQuadrature(mesh, nslot, BOUNDARY_POINTS)
        self.gap = qb.function((g,), "gap")
        self.penalty_stiffness = qb.function((g,), "penalty")
        self.boundary_traction = qb.function((g,), "boundary_traction")
        self.du_at_boundary = PointExpression(qb.at_points(fields.du, deg), qb)
        R = penalty.penalty(
            fields.du, w, qb, self.gap, self.penalty_stiffness, self.boundary_traction, deg
        )
        if point_pressure:  # a follower load: its face deforms with ΔF in the step
            self.boundary_pressure = qb.function((g,), "boundary_pressure")
            dF = ufl.Identity(g) + qb.grad_at_points(fields.du, deg)
            self.dF_at_boundary = PointExpression(dF, qb)
            R += penalty.follower_pressure(dF, w, qb, self.boundary_pressure, deg)
        return R

    def _loads(self, w, conditions: GridConditions) -> ufl.Form | None:
        """The external work of the body force, the tractions and the point loads."""
        deg = self.spec.u_degree
        loads = loads_form.external_work(
            w, self.q, self.density, conditions.body_force, conditions.traction_terms, deg
        )
        if self.q_boundary is not None:
            qb = self.q_boundary
            point_loads = qb.sum(ufl.dot(self.boundary_traction, qb.at_points(w, deg)))
            if self.boundary_pressure is not None:  # the pressure on the face at the start
                point_loads -= qb.sum(ufl.dot(self.boundary_pressure, qb.at_points(w, deg)))
            loads = point_loads if loads is None else loads + point_loads
        return loads

    def _update(self, fields: GridFields) -> tuple[UpdateLayout, PointExpression]:
        """Δu_p, ΔF_p, the 3x3 Cauchy stress, [a_p] and the history at t_{n+1}, per point."""
        q, material, state, g = self.q, self.law_in_forms, self.state, fields.W.mesh.geometry.dim
        F = self.dF * self.F_n
        if self.spec.pressure:
            sigma = mixed_up.cauchy_stress_3d(material, F, q.at_points(fields.p), state)
        else:
            sigma = displacement.cauchy_stress_3d(lambda F3: material.kirchhoff(F3, state), F)
        acceleration = None
        if self.newmark is not None:
            acceleration = q.at_points(inertia.acceleration(fields.du, self.newmark))
        history = material.updated_history(F, state)
        layout = UpdateLayout(
            g, self.newmark is not None, {name: ufl.shape(value) for name, value in history.items()}
        )
        du_p = q.at_points(fields.du, self.spec.u_degree)
        return layout, PointExpression(
            layout.vector(du_p, self.dF, sigma, acceleration, history), q
        )


class FormsBySlotCount:
    """The step forms of a simulation, compiled once for each slot count met.

    Args:
        fields: The grid unknowns.
        spec: The formulation.
        material: The law.
        conditions: The grid's loads.
        ppp: PPP data (u-p), or None.
        dynamics: Newmark's rule, or None (static).
        mass: ``"consistent"`` or ``"lumped"`` (dynamics).
        walls: The rigid walls of the grid, or None.
        shared_increment, pressure_by_parts, point_pressure, floor: As for :class:`StepForms`.
    """

    def __init__(
        self,
        fields: GridFields,
        spec: FormulationSpec,
        material,
        conditions: GridConditions,
        ppp: mixed_up.PPPData | None,
        dynamics,
        mass: str,
        walls: RigidWalls | None = None,
        shared_increment: bool = False,
        pressure_by_parts: bool = False,
        point_pressure: bool = False,
        floor: mixed_up.PressureFloor | None = None,
    ):
        self.fields, self.spec, self.material = fields, spec, material
        #: The step's length Δt (s), set before each step (:meth:`set_step_length`).
        self.step_length = dolfinx.fem.Constant(fields.W.mesh, 1.0)
        self.options = dict(
            shared_increment=shared_increment,
            pressure_by_parts=pressure_by_parts,
            point_pressure=point_pressure,
            walls=walls,
            conditions=conditions,
            ppp=ppp,
            floor=floor,
            lumped=mass == "lumped",
            newmark=None if dynamics is None else dynamics.data,
            step_length=self.step_length,
        )
        self._forms: dict[tuple[int, int], StepForms] = {}

    def set_step_length(self, dt: float) -> None:
        """The length (s) of the step the forms are bound for next."""
        self.step_length.value = dt

    def get(self, nslot: int, nslot_boundary: int) -> StepForms:
        """The forms for ``nslot`` slots per entity (``nslot_boundary`` of boundary points)."""
        key = (nslot, nslot_boundary)
        if key not in self._forms:
            self._forms[key] = StepForms(
                self.fields, self.spec, self.material, *key, **self.options
            )
        return self._forms[key]


class ReturnMapAtIterate:
    """A pointwise law's return map at the current grid unknown, evaluated once per iterate.

    The law's stress, ΔF and (on request) tangent at the points go into the slot
    fields of the forms' linearisation, so the next residual (and Jacobian)
    assembled are the law's own at this iterate. One per step: its points and
    history are those of t_n.

    Args:
        forms: The step's forms (a pointwise law's).
        layout: The step's slot layout.
        points: The material points at t_n (their history is read).
        w: The grid unknown.
    """

    def __init__(
        self, forms: StepForms, layout: SlotLayout, points: MaterialPoints, w: dolfinx.fem.Function
    ):
        self.forms, self.layout, self.points, self.w = forms, layout, points, w
        # At the iterate self._at; a MixedReturnResult for a return at the pressure.
        self.result: ReturnMapResult | MixedReturnResult | None = None
        self._at: np.ndarray | None = None
        self._has_tangent = False

    def refresh(self, tangent: bool = True) -> ReturnMapResult | MixedReturnResult:
        """Evaluate the return map at ``w`` unless done at this iterate; pack it.

        A pressure-dependent law in u-p returns at −J p (its linearisation says so).
        """
        forms, layout = self.forms, self.layout
        q, lin, eye = forms.q, forms.linearisation, np.eye(self.points.gdim)
        if self._at is None or not np.array_equal(self._at, self.w.x.array):
            values = forms.values_at_points.evaluate(layout)
            self.result, packed = lin.returned(forms.material, values, self.points.history)
            for field, array in packed.items():
                empty = eye if field is lin.dF else 0.0
                q.pack(field, layout, array, empty=empty, per_iterate=True)
            # The residual reads the tangent only times a difference from this
            # iterate, which is 0: an old one must not linger (it may belong to
            # another step's entities), and none is needed.
            for field in lin.slot_fields:
                if field not in packed:
                    q.values.pop(field, None)
            self._at, self._has_tangent = self.w.x.array.copy(), False
        if tangent and not self._has_tangent:
            for field, array in lin.tangent_values(self.result).items():
                q.pack(field, layout, array, per_iterate=True)
            self._has_tangent = True
        return self.result


@dataclass
class StepInProgress:
    """What the phases of the step being taken share (set by :meth:`Simulation.prepare_step`).

    Attributes:
        forms: The compiled forms of the step's slot count.
        layout: The points' slot layout.
        bary: The points' barycentric coordinates in their cells (n, g + 1).
        return_map: A pointwise law's return map at the current iterate, or None.
        loads: The external loads alone, bound to the step (Newton's force scale), or None.
        dt: The step's length (s).
    """

    forms: StepForms
    layout: SlotLayout
    bary: np.ndarray
    return_map: ReturnMapAtIterate | None
    loads: BoundForm | None
    dt: float
