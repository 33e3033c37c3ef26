"""The conditions a step imposes on the grid: displacements, tractions, body force.

They stay on the grid while the body moves through it, unlike the boundary
points of :mod:`fe_mpm.boundary_points`. :class:`GridConditions` sets them up
once and, for each step, gives the Dirichlet increments, the loads at the new
time, the warning when a traction's nodes carry no material, and the reaction
forces of named boundaries.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import ufl

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.boundary import (
    Dirichlet,
    Pressure,
    Traction,
    boundary_facets,
    check_exterior,
    dirichlet_entities,
)
from fe_mpm.checks import check_range
from fe_mpm.errors import warn
from fe_mpm.formulations import GridFields, constrained_space
from fe_mpm.transfer import summed_over_ranks

#: A traction's lost share is warned about again when it grows by this much.
LOST_LOAD_WARNING_STEP = 0.005


def facet_node_weights(
    mesh: dolfinx.mesh.Mesh, facets: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The grid nodes of ``facets`` and each one's share of a uniform load on them.

    A P1 node of a simplex facet carries 1/g of the facet's measure. ``facets`` are
    the ones this rank owns, so that the shares over all ranks count each facet once.

    Returns:
        ``(nodes, weights)``: geometry node indices (k,) and their shares (k,), summing to 1.
    """
    g = mesh.geometry.dim
    nodes_of = dolfinx.mesh.entities_to_geometry(mesh, g - 1, facets)  # (nf, g)
    X = mesh.geometry.x[:, :g][nodes_of]
    edges = X[:, 1:] - X[:, :1]
    if g == 2:
        measure = np.linalg.norm(edges[:, 0], axis=1)
    else:
        measure = 0.5 * np.linalg.norm(np.cross(edges[:, 0], edges[:, 1]), axis=1)
    nodes, index = np.unique(nodes_of, return_inverse=True)
    weights = np.bincount(index.ravel(), weights=np.repeat(measure / g, g), minlength=nodes.size)
    return nodes, weights / parallel.total(mesh.comm, float(weights.sum()))


def body_force_at(body_force, t: float, g: int) -> np.ndarray:
    """The body force (g,) in m/s² at time ``t``: ``body_force`` itself, or its value.

    A callable ``t -> vector`` gives a force whose direction changes in time (gravity
    with an earthquake's horizontal acceleration in the base's frame), which
    ``body_force_scale``, one factor for the whole vector, cannot (a helper's sliding
    block, 2026-12-06).

    Raises:
        ValueError: It has not ``g`` components or one is not finite.
    """
    value = body_force(t) if callable(body_force) else body_force
    where = f"body_force(t = {t:g})" if callable(body_force) else "body_force"
    if np.ndim(value) != 1 or len(value) != g:
        raise ValueError(f"Simulation: {where} must have {g} components, got {value!r}")
    for c, component in enumerate(value):
        check_range("Simulation", f"{where}[{c}]", component)
    return np.asarray(value, dtype=float)


#: A moving grid Dirichlet warns once it has moved its nodes further than this many
#: times the smallest cell beside them.
MOVED_PAST_CELLS = 1.0

#: A reaction boundary of whose nodes Dirichlet conditions hold less than this share
#: in every component is warned about: it reports a corner's share of another
#: boundary's reaction.
HELD_SHARE = 0.5


def follow_the_body(label: str) -> str:
    """What carries the load of the grid condition ``label`` on the body instead."""
    kind = "PointPressure" if label.startswith("Pressure") else "PointTraction"
    carries = "a pressure" if kind == "PointPressure" else "a fixed traction"
    return (
        f"A grid load stays on the grid; {kind} carries {carries} on points that follow the body."
    )


class GridConditions:
    """Dirichlet conditions, tractions, body force and reaction boundaries of a grid.

    Args:
        fields: The grid unknowns.
        dirichlet: Prescribed grid displacements.
        tractions: Surface tractions and pressures on grid facets.
        body_force: Body force per unit mass (m/s², length g), or None.
        body_force_scale: Its load factor ``t -> float``; constant 1 if None.
        reactions: Boundaries whose reaction force is wanted, name -> tag or marker.
        facet_tags: Facet tags for conditions given by tag.

    Attributes:
        traction_terms: ``(t̄, ds(i))`` pairs for the weak forms (Pa): the traction,
            or −p n for a :class:`Pressure`.
        traction_facets: Subdomain id i -> the exterior facets of ``tractions[i − 1]``.
        traction_labels: Subdomain id i -> its name in messages (``"Pressure 1"``).
        body_force: The body force as a Constant the forms read, or None.
        lost_load: Traction id -> the share of its load whose nodes carried no
            material at the last step.
    """

    def __init__(
        self,
        fields: GridFields,
        dirichlet: Sequence[Dirichlet] = (),
        tractions: Sequence[Traction | Pressure] = (),
        body_force: Sequence[float] | Callable[[float], Sequence[float]] | None = None,
        body_force_scale: Callable[[float], float] | None = None,
        reactions: dict[str, int | Callable] | None = None,
        facet_tags: dolfinx.mesh.MeshTags | None = None,
    ):
        mesh = fields.W.mesh
        self.mesh, self.fields = mesh, fields
        g, fdim = mesh.geometry.dim, mesh.topology.dim - 1
        mesh.topology.create_connectivity(fdim, fdim + 1)

        self.dirichlet = []  # (spec, value Function, DirichletBC)
        self._conflict_warned = False
        self.dirichlet_nodes = []  # grid nodes of each condition's facets
        self.dirichlet_entities = []  # (dim, entities) each condition holds
        # The size of the smallest cell beside each condition's nodes: one that moves
        # them further than that no longer holds the body's face (MOVED_PAST_CELLS).
        self._cell_beside = np.full(len(dirichlet), np.inf)
        self._travel_warned = np.zeros(len(dirichlet), dtype=bool)
        self._flat_normals = []  # the normal of each condition's nodes' plane, or None
        self._value_dofs = []  # each condition's entries of its value Function
        for k, spec in enumerate(dirichlet):
            dim, entities = dirichlet_entities(mesh, spec.where, facet_tags, f"Dirichlet {k}")
            if spec.component is not None:
                check_range(f"Dirichlet {k}", "component", spec.component, lo=0, hi=g - 1)
            if spec.profile is None and not callable(spec.value):
                _check_dirichlet_size(k, spec, spec.at(0.0).size, g)
            value, bc, value_dofs = self._dirichlet_bc(spec.component, dim, entities)
            self.dirichlet.append((spec, value, bc))
            self._value_dofs.append(value_dofs)
            self.dirichlet_nodes.append(
                np.unique(dolfinx.mesh.entities_to_geometry(mesh, dim, entities))
            )
            self.dirichlet_entities.append((dim, entities))
            self._cell_beside[k] = _smallest_cell_beside(mesh, dim, entities)
            # Only a set of facets is a face that can slide along itself (not pins or
            # an edge of a 3D grid, whose normal is not one direction).
            face = dim == mesh.topology.dim - 1
            self._flat_normals.append(_flat_normal(mesh, self.dirichlet_nodes[-1], face))

        self.tractions = []  # (spec, Constant)
        self.traction_terms = []
        self.traction_facets: dict[int, np.ndarray] = {}
        self.traction_labels: dict[int, str] = {}
        self._traction_nodes: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.lost_load: dict[int, float] = {}
        self._warned_share: dict[int, float] = {}  # the largest share warned about so far
        ds = ufl.Measure("ds", domain=mesh)
        for i, spec in enumerate(tractions, start=1):
            label = f"{type(spec).__name__} {i - 1}"
            hint = (
                "; a load on a face inside the grid, where the body's edge lies between "
                "grid lines or moves, is a PointTraction or PointPressure on points along "
                "it (meshes.facet_points gives them for grid facets)"
            )
            facets = boundary_facets(mesh, spec.where, facet_tags, label, hint)
            # A rank's facets by tag include its ghosts, which their owner counts.
            owned = facets[facets < mesh.topology.index_map(fdim).size_local]
            pressure = isinstance(spec, Pressure)
            # (a Traction by tag of facets inside the grid ran on, its load left on that
            # grid line as the face moved off it: 15 % short, a helper's plate, 2026-12-07)
            kind, carrier = (
                ("Pressure", "PointPressure") if pressure else ("Traction", "PointTraction")
            )
            why = (
                "where a facet has no outward normal to push along"
                if pressure
                else "where the load stays on that grid line as the body's face moves off it"
            )
            check_exterior(
                mesh,
                owned,
                label,
                f"{why}; a {kind} acts on the grid's outer boundary, so make the loaded face "
                "a boundary of the grid (a hole in it, as meshes.quarter_ring does, or no "
                f"grid beyond it), or load it with a {carrier} on points along the face "
                "(meshes.facet_points)",
            )
            if pressure:
                value = dolfinx.fem.Constant(mesh, 0.0)
                term = -value * ufl.FacetNormal(mesh)
            else:
                if len(spec.value) != g:
                    raise ValueError(
                        f"{label}: value must have {g} components, got {len(spec.value)}"
                    )
                value = term = dolfinx.fem.Constant(mesh, np.zeros(g))
            self.traction_facets[i], self.traction_labels[i] = facets, label
            self._traction_nodes[i] = facet_node_weights(mesh, owned)
            self.traction_terms.append((term, ds(i)))
            self.tractions.append((spec, value))

        self.reaction_dofs = {}  # name -> W dofs of each displacement component
        self._held_masks: dict[str | None, np.ndarray] | None = None  # (held_shares)
        for name, where in (reactions or {}).items():
            dim, entities = dirichlet_entities(mesh, where, facet_tags, f"reactions[{name!r}]")
            comps = []
            for c in range(g):
                sub_c = fields.U.sub(c)
                collapsed, _ = sub_c.collapse()
                dofs = dolfinx.fem.locate_dofs_topological((sub_c, collapsed), dim, entities)
                comps.append(np.asarray(dofs[0], dtype=np.int32))
            self.reaction_dofs[name] = comps
        self._check_reactions_held()

        self.body_force = None
        self._body_force_of_time = body_force if callable(body_force) else None
        if body_force is not None:
            self._body_force_value = body_force_at(body_force, 0.0, g)
            self.body_force = dolfinx.fem.Constant(mesh, self._body_force_value.copy())
        self._body_force_scale = body_force_scale

    def _check_reactions_held(self) -> None:
        """Refuse a reaction boundary that no Dirichlet condition holds; collective.

        At a converged step the residual vanishes at every free dof, so a boundary
        whose dofs nothing holds reports zero at every step, and one that meets a held
        edge only at a corner reports the corner's share of the edge's reaction (a
        helper's probes, 2026-12-07: the grid's empty top and the free side of a block
        on its base, without a word). The latter is warned about where, in every
        component, less than :data:`HELD_SHARE` of its nodes are held (a roller face
        holds all of them in one component) and it holds no condition whole (a marker
        of the grid's whole boundary holds the base).
        """
        owned = self.fields.W.dofmap.index_map.size_local * self.fields.W.dofmap.index_map_bs
        each = [bc.dof_indices()[0] for *_, bc in self.dirichlet]
        each = [dofs[dofs < owned] for dofs in each]
        held = np.concatenate([np.zeros(0, np.int32), *each])
        comm = self.mesh.comm
        for name, comps in self.reaction_dofs.items():
            dofs = np.concatenate(comps)
            # Conditions it holds whole (the base, inside a marker of the whole boundary).
            whole = np.array([[np.isin(d, dofs).sum(), d.size] for d in each], np.int64)
            whole = parallel.total(comm, whole.reshape(-1, 2))
            holds_one = bool(np.any((whole[:, 0] == whole[:, 1]) & (whole[:, 1] > 0)))
            counts = np.array(
                [[np.isin(d[d < owned], held).sum(), np.count_nonzero(d < owned)] for d in comps],
                dtype=np.int64,
            )
            on, nodes = parallel.total(comm, counts).T  # per component
            if not on.any():
                raise ValueError(
                    f"reactions[{name!r}]: no Dirichlet condition holds any of its "
                    f"{int(nodes.sum())} displacement dofs, so its reaction is zero at "
                    "every converged step (the residual vanishes where nothing is held). "
                    "Name a boundary that a Dirichlet condition holds; a PointDirichlet's "
                    "force is reported under its own name, a RigidWall's in "
                    "StepReport.walls"
                )
            if np.all(on < HELD_SHARE * nodes) and not holds_one:
                warn(
                    f"reactions[{name!r}]: Dirichlet conditions hold only {int(on.max())} of "
                    f"its {int(nodes.max())} nodes (a corner shared with a held edge): it "
                    "reports their share of that edge's reaction, not a force on a face of "
                    "its own"
                )

    def _dirichlet_bc(self, component: int | None, dim: int, entities: np.ndarray):
        """A condition's value Function, its DirichletBC and its entries of the value.

        On the ``dim``-entities ``entities``; the entries index the value Function's
        array (unrolled), where the condition's increment is set.
        """
        target, is_sub = constrained_space(self.fields.U, component)
        if is_sub:
            collapsed, _ = target.collapse()
            value = dolfinx.fem.Function(collapsed)
            dofs = dolfinx.fem.locate_dofs_topological((target, collapsed), dim, entities)
            return value, dolfinx.fem.dirichletbc(value, dofs, target), dofs[1]
        value = dolfinx.fem.Function(target)
        dofs = dolfinx.fem.locate_dofs_topological(target, dim, entities)
        bs = target.dofmap.bs  # blocks here, unrolled entries of a collapsed space above
        return value, dolfinx.fem.dirichletbc(value, dofs), (dofs[:, None] * bs + np.arange(bs))

    @property
    def loads_or_supports(self) -> bool:
        """Whether any condition or load acts on the grid."""
        return bool(self.dirichlet or self.tractions or self.body_force is not None)

    def impose(
        self,
        occupied: np.ndarray,
        t_old: float,
        t_new: float,
        zone_cells: list[np.ndarray] | None = None,
    ) -> list:
        """The step's boundary conditions, with the loads set to their values at ``t_new``.

        Args:
            occupied: The cells that hold material points: grid dofs no point reaches
                get no equation, so they are pinned.
            t_old: The time the step starts from (s).
            t_new: The time it ends at (s).
            zone_cells: The cells of each zone's points, where NB-VA keeps one θ per
                zone (:meth:`~fe_mpm.formulations.GridFields.pin_unsupported`).

        Returns:
            The Dirichlet conditions on the increment t_old → t_new, then the pins.
        """
        for k, (spec, value, _) in enumerate(self.dirichlet):
            self._fill(k, value, t_old, t_new)
        self.set_loads(t_new)
        if len(self.dirichlet) > 1 and not self._conflict_warned:  # the same on every rank
            self._warn_conflicts(t_old, t_new)
        pins = self.fields.pin_unsupported(occupied, zone_cells)
        return [bc for _, _, bc in self.dirichlet] + pins

    def _fill(self, k: int, value: dolfinx.fem.Function, t_from: float, t_to: float) -> None:
        """Set ``value`` to condition k's motion from ``t_from`` to ``t_to`` (m)."""
        spec = self.dirichlet[k][0]
        if spec.profile is not None:
            bs = value.function_space.dofmap.bs

            def motion(x: np.ndarray) -> np.ndarray:
                # (held components, points): checked, or dolfinx stops without a name
                shape = (x.shape[1],) if bs == 1 else (bs, x.shape[1])
                moved = np.asarray(spec.profile(x, t_to), dtype=float) - np.asarray(
                    spec.profile(x, t_from), dtype=float
                )
                if bs == 1 and moved.size == 1:  # a uniform motion of the component
                    moved = np.full(shape, float(moved.reshape(-1)[0]))
                if moved.shape != shape:
                    held = "one component (component= given)" if bs == 1 else f"{bs} components"
                    raise ValueError(
                        f"Dirichlet {k}: profile(x, t) must return shape {shape} for {held} "
                        f"at the {x.shape[1]} points of x (x has shape (3, n)), got "
                        f"{moved.shape}"
                    )
                return moved

            # Checked on every rank together: raised on one alone, the others waited
            # for ever (a helper's profile was NaN at one rank's corner node), and
            # only at the condition's own entries, which are all it sets.
            error = None
            try:
                value.interpolate(motion)
            except Exception as err:  # a user's function may raise anything, on one rank
                # Raised inside dolfinx's own `except TypeError` (its overloads): shown
                # behind that unrelated TypeError until 2026-12-07 (a helper's script).
                err.__suppress_context__ = True
                error = err
            if error is None:
                held = self._value_dofs[k].ravel()
                bad = np.flatnonzero(~np.isfinite(value.x.array[held]))
                if bad.size:
                    node = held[bad[0]] // value.function_space.dofmap.bs
                    x = value.function_space.tabulate_dof_coordinates()[node]
                    error = ValueError(
                        f"Dirichlet {k}: profile(x, t) is not finite at x = "
                        f"{[round(float(v), 9) for v in x[: self.mesh.geometry.dim]]} "
                        f"(t = {t_from:g} or {t_to:g})"
                    )
            parallel.raise_together(self.mesh.comm, error)
        else:
            increment = spec.at(t_to) - spec.at(t_from)
            _check_dirichlet_size(k, spec, increment.size, self.mesh.geometry.dim)
            bs = value.function_space.dofmap.bs
            value.x.array.reshape(-1, bs)[:] = increment.reshape(-1)

    def warn_travel(self, t: float) -> None:
        """Warn once per condition that has moved its nodes past a cell by ``t`` (collective).

        Called after each accepted step. The grid is reset after every step, so a
        moving condition stays on the same nodes while the body's face moves on: it
        then holds whatever material lies there. A new user's strip pulled to three
        times its length by a grid ``Dirichlet`` (40 cells) ended at x = 1.985 m for
        3 m, its force 65 % over and then 29 % under the exact one, and nothing was
        said (2026-12-07). How far: the condition's motion from t = 0 to ``t``, the
        largest component over its own entries (the first version added up each
        try's increment, and a helper's trapdoor, its steps cut three times, was
        told 0.127 m for 0.030 m). Nodes on one line (a plane in 3D) count only their
        motion across it: a plate sliding along itself (Couette's moving wall) holds
        the same face wherever it goes, and was warned of (a helper, 2026-12-08).
        """
        if not self.dirichlet or self._travel_warned.all():
            return
        here = np.zeros(len(self.dirichlet))
        for k, (_, value, _) in enumerate(self.dirichlet):
            if self._travel_warned[k]:
                continue
            total = value.copy()  # (the step's increment stays in value)
            self._fill(k, total, 0.0, t)
            here[k] = self._motion_across(k, total)
        travel = parallel.largest(self.mesh.comm, here)
        for k in np.flatnonzero(
            (travel > MOVED_PAST_CELLS * self._cell_beside) & ~self._travel_warned
        ):
            self._travel_warned[k] = True
            warn(
                f"Dirichlet {k} has moved its grid nodes by {travel[k]:.3g} m by "
                f"t = {t:g}, more than the cells beside them ({self._cell_beside[k]:.3g} "
                "m): the grid is reset after every step, so the condition stays on the "
                "same nodes while the body moves on, and it holds whatever lies there now. "
                "A support or a pull that follows the body is a PointDirichlet "
                "(meshes.facet_points gives its points)."
            )

    def _motion_across(self, k: int, total: dolfinx.fem.Function) -> float:
        """Condition ``k``'s largest motion ``total`` (m), across its nodes' plane if flat."""
        dofs = self._value_dofs[k].ravel()
        values = total.x.array[dofs]
        normal, component = self._flat_normals[k], self.dirichlet[k][0].component
        if normal is None:
            return float(np.abs(values).max(initial=0.0))
        if component is not None:
            return float(np.abs(values).max(initial=0.0) * abs(normal[component]))
        bs = total.function_space.dofmap.bs  # unrolled entries: node = dof // bs
        across = np.bincount(dofs // bs, weights=values * normal[dofs % bs])
        return float(np.abs(across).max(initial=0.0))

    def _warn_conflicts(self, t_old: float, t_new: float) -> None:
        """Warn once (collective) where two conditions prescribe different increments.

        On a dof that two conditions hold, the later one in the list wins: a new user's
        trapdoor, lowered beside a fixed base, moved its edge nodes by −9.6 mm or
        −0.4 mm depending on which came last, without a word (2026-12-07).
        """
        n = self.fields.w.x.array.size
        owned = self.fields.W.dofmap.index_map.size_local * self.fields.W.dofmap.index_map_bs
        values = []
        for _, _, bc in self.dirichlet:
            x = np.full(n, np.nan)
            bc.set(x)
            values.append(x[:owned])
        comm = self.mesh.comm
        # Against the largest increment of any condition on any rank: a profile that
        # vanishes at a fixed wall gives round-off there (1e-19 against 0), not a clash.
        largest = max((float(np.nanmax(np.abs(v), initial=0.0)) for v in values), default=0.0)
        tolerance = 1e-9 * parallel.largest(comm, largest)
        k = len(values)
        counts = np.zeros((k, k), dtype=np.int64)
        for i in range(k):
            for j in range(i + 1, k):
                both = ~np.isnan(values[i]) & ~np.isnan(values[j])
                counts[i, j] = np.count_nonzero(
                    np.abs(values[i][both] - values[j][both]) > tolerance
                )
        counts = comm.allreduce(counts) if comm.size > 1 else counts
        if not counts.any():
            return
        self._conflict_warned = True
        i, j = (int(v) for v in np.argwhere(counts)[0])
        differ = int(counts[i, j])
        warn(
            f"Simulation: Dirichlet {i} and Dirichlet {j} prescribe different increments on "
            f"{differ} dof(s) that both hold (the step t = {t_old:g} → {t_new:g}): the later "
            "in the list wins there. Give the nodes they share (a trapdoor's edge beside a "
            "fixed base) to one of them."
        )

    def set_loads(self, t: float) -> None:
        """Set the grid tractions and the body force to their values at time ``t``.

        :meth:`impose` sets them at the step's end; a dynamic run's accelerations in
        equilibrium at the step's start read them there (they read the end's, and a
        free block under a horizontal acceleration growing as t started a step ahead:
        0.0202 m/s against 0.02 after 0.2 s).
        """
        for spec, value in self.tractions:
            value.value = spec.at(t)
        if self.body_force is not None:
            self.body_force.value = self.body_force_value(t)

    def body_force_value(self, t: float) -> np.ndarray:
        """The body force (g,) in m/s² at time ``t``, scale included; zero without one."""
        g = self.mesh.geometry.dim
        if self.body_force is None:
            return np.zeros(g)
        value = self._body_force_value
        if self._body_force_of_time is not None:
            value = body_force_at(self._body_force_of_time, t, g)
        factor = 1.0
        if self._body_force_scale is not None:
            factor = check_range(
                "Simulation", f"body_force_scale(t = {t:g})", self._body_force_scale(t)
            )
        return value * factor

    def check_loaded_facets(self, occupied: np.ndarray, t_new: float) -> None:
        """Warn when a grid traction's nodes have no material: their load acts on nothing.

        Nodes that no point reaches are pinned, so the load the facets put there is lost;
        :attr:`lost_load` records the share.
        """
        if not self._traction_nodes:
            return
        uses = np.bincount(
            self.mesh.geometry.dofmaps[0][occupied].ravel(),
            minlength=self.mesh.geometry.x.shape[0],
        ).astype(np.float64)
        active = summed_over_ranks(self.mesh.geometry.index_map(), uses) > 0
        for i, (nodes, weights) in self._traction_nodes.items():
            idle = ~active[nodes]
            share = float(parallel.total(self.mesh.comm, float(weights[idle].sum())))
            self.lost_load[i] = share
            if share > self._warned_share.get(i, 0.0) + LOST_LOAD_WARNING_STEP:
                self._warned_share[i] = share
                owned = nodes < self.mesh.geometry.index_map().size_local  # each node once
                n_idle, n_nodes = (
                    parallel.total(self.mesh.comm, int(k)) for k in (idle[owned].sum(), owned.sum())
                )
                warn(
                    f"{self.traction_labels[i]}: {n_idle} of its {n_nodes} grid nodes carry "
                    f"no material at the step to t = {t_new:g}, so {100 * share:.1f} % of its "
                    "load is lost (StepReport.lost_load). "
                    + follow_the_body(self.traction_labels[i])
                )

    def lost_loads(self) -> dict[str, float]:
        """The share of each grid load that the last step lost, by label, where > 0."""
        return {self.traction_labels[i]: share for i, share in self.lost_load.items() if share > 0}

    def reactions(self, residual: Callable[[], np.ndarray]) -> dict[str, np.ndarray]:
        """The force (g,) each named boundary exerts on the body, in N (N/m in 2D).

        It is the sum of the residual (internal − external + inertial forces) over the
        boundary's dofs; ``residual`` assembles it, and is called only if a boundary
        is named.
        """
        if not self.reaction_dofs:
            return {}
        b = residual()
        owned = self.fields.W.dofmap.index_map.size_local * self.fields.W.dofmap.index_map_bs
        comm = self.mesh.comm
        return {  # each dof once: ghost rows hold partial sums
            name: np.array([parallel.total(comm, float(b[d[d < owned]].sum())) for d in comps])
            for name, comps in self.reaction_dofs.items()
        }

    def held_shares(
        self, cells: np.ndarray, bary: np.ndarray
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """The share of a point load that lands on held nodes, per component.

        A force ``f`` at a point puts ``N_I f`` on each node of its cell; on a node a
        Dirichlet condition holds, that share passes straight into the support. This
        returns ``Σ_I N_I`` over the held nodes, shape (n, g) for points at
        barycentric coordinates ``bary`` (n, g + 1) in this rank's ``cells`` (n,),
        and the same over the held nodes of each reaction boundary, by name.
        """
        if self._held_masks is None:
            held = np.zeros(self.fields.w.x.array.size)
            for *_, bc in self.dirichlet:  # (local indices, ghosts included)
                held[bc.dof_indices()[0]] = 1.0
            self._held_masks = {None: held}
            for name, comps in self.reaction_dofs.items():
                mask = np.zeros_like(held)
                dofs = np.concatenate(comps)
                mask[dofs] = held[dofs]
                self._held_masks[name] = mask
        share = {
            name: self.fields.displacement_at(cells, bary, mask)
            for name, mask in self._held_masks.items()
        }
        return share.pop(None), share


def _flat_normal(mesh: dolfinx.mesh.Mesh, nodes: np.ndarray, face: bool) -> np.ndarray | None:
    """The unit normal (g,) of the line (plane in 3D) that a face's ``nodes`` lie on, or None.

    Collective (every rank calls it alike): from the nodes' second moments about their
    centroid over every rank. None where ``face`` is False (pins, or edges of a 3D
    grid), for nodes off one line or plane by more than about 1e-6 of their spread
    (the eigenvalues' own round-off is ε of the largest), and for nodes on a line in
    3D (no single normal).
    """
    g = mesh.geometry.dim
    x = mesh.geometry.x[nodes, :g]
    sums = parallel.total(mesh.comm, np.concatenate([[len(x)], x.sum(axis=0)]))
    if not face or sums[0] < g:
        return None
    # About the centroid: E[xxᵀ] − x̄x̄ᵀ left ε|x̄|² of round-off on a line y = 1.9, far
    # above the flatness bound (a reviewer, 2026-12-08).
    r = x - sums[1:] / sums[0]
    spread = parallel.total(mesh.comm, (r.T @ r).ravel()).reshape(g, g)
    variance, axes = np.linalg.eigh(spread)
    flat = 1e-12 * variance[-1]
    if variance[-1] <= 0.0 or variance[0] > flat or (g == 3 and variance[1] <= flat):
        return None
    return axes[:, 0]


def _smallest_cell_beside(mesh: dolfinx.mesh.Mesh, dim: int, entities: np.ndarray) -> float:
    """The size (m) of the smallest cell touching the ``dim``-entities, over the ranks.

    The size is the cell's longest edge; inf where no cell touches them.
    """
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(dim, tdim)
    cells = dolfinx.mesh.compute_incident_entities(
        mesh.topology, np.asarray(entities, dtype=np.int32), dim, tdim
    )
    size = float(dolfinx.cpp.mesh.h(mesh._cpp_object, tdim, cells).min(initial=np.inf))
    return float(parallel.smallest(mesh.comm, size))


def _check_dirichlet_size(k: int, spec, size: int, g: int) -> None:
    """Refuse a value of the wrong size for Dirichlet ``k``.

    One number with a ``component``; without, one number (it moves every component)
    or ``g`` of them.
    """
    if spec.component is not None and size != 1:
        raise ValueError(
            f"Dirichlet {k}: value must be one number with component={spec.component}, "
            f"got {size} components"
        )
    if spec.component is None and size not in (1, g):
        raise ValueError(
            f"Dirichlet {k}: value must be one number or a vector of {g} components, got {size}"
        )
