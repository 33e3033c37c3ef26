"""Fixed rigid walls on the grid's boundary: their springs, their state and their forces.

A :class:`~fe_mpm.boundary.RigidWall` is a plane of exterior grid facets that the
body presses on, slides along with Coulomb friction, or leaves
(:mod:`fe_mpm.forms.contact` is the law). :class:`RigidWalls` sets them up for a
grid: each wall's normal (checked to be one plane), its penalty, the spring
extension each node keeps from step to step, and after a step the force the wall
puts on the body, node by node.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import ufl

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.boundary import RigidWall, boundary_facets, check_exterior
from fe_mpm.errors import warn
from fe_mpm.forms import contact
from fe_mpm.io import write_csv_rows
from fe_mpm.materials.elastic import young_modulus
from fe_mpm.transfer import touched_nodes

#: The default penalty is this many times E / h (E the law's Young's modulus, h the
#: wall's facet size): a body pressing with p enters the wall by p h / (10³ E).
PENALTY_FACTOR = 1e3

#: The default slip scale of friction is this many times h (h the wall's facet size).
SLIP_SCALE_FACTOR = 1e-3

#: Facet normals of one wall may differ by this much (a plane, up to round-off).
PLANE_TOLERANCE = 1e-8

#: ``StepForms`` numbers the walls' facet subdomains from here (tractions count from 1).
FIRST_WALL_ID = 1000


@dataclass(frozen=True)
class WallForces:
    """The force a rigid wall put on the body at the end of a step.

    In 2D forces are per unit thickness (N/m), else N. Under MPI every attribute is
    the whole wall's, the same on every rank (gathered): do not sum them over ranks.

    Attributes:
        total: The whole force (g,).
        normal: Its normal part, the body's push on the wall (≥ 0): −total·n.
        tangential: Its part along the wall (g,): the friction.
        nodes: Positions of the wall's grid nodes that carry a force (k, g), m.
        nodal: The force at each of them (k, g).
        direction: The wall's unit normal n (g,), pointing into the wall.
        areas: Each of those nodes' share of the wall's face (k,): m² (m in 2D), the
            weights of the vertex rule that integrates the springs.
    """

    total: np.ndarray
    normal: float
    tangential: np.ndarray
    nodes: np.ndarray
    nodal: np.ndarray
    direction: np.ndarray
    areas: np.ndarray

    @property
    def pressure(self) -> np.ndarray:
        """The push at each node over its share of the face (k,), Pa: a contact pressure.

        Node by node it scatters about the pressure it stands for (read its moments or
        a fitted profile; ``docs/simulation.md``).
        """
        return -(self.nodal @ self.direction) / self.areas


def wall_plane(mesh: dolfinx.mesh.Mesh, facets: np.ndarray, owner: str) -> tuple[np.ndarray, float]:
    """The plane of exterior ``facets``: unit outward normal n (g,) and n·x on it (m).

    Raise if they are no plane.

    Raises:
        ValueError: The facets' normals differ by more than :data:`PLANE_TOLERANCE`.
    """
    g, tdim = mesh.geometry.dim, mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    x = mesh.geometry.x[:, :g]
    corners = x[dolfinx.mesh.entities_to_geometry(mesh, tdim - 1, facets)]  # (nf, g, g)
    cells = mesh.topology.connectivity(tdim - 1, tdim)
    owner_cells = np.array([cells.links(f)[0] for f in facets], dtype=np.int32)
    centroids = x[dolfinx.mesh.entities_to_geometry(mesh, tdim, owner_cells)].mean(axis=1)
    edges = corners[:, 1:] - corners[:, :1]
    if g == 2:
        n = np.column_stack([edges[:, 0, 1], -edges[:, 0, 0]])
    else:
        n = np.cross(edges[:, 0], edges[:, 1])
    n /= np.linalg.norm(n, axis=1)[:, None]
    outward = np.einsum("fi,fi->f", n, corners.mean(axis=1) - centroids)
    n *= np.sign(outward)[:, None]
    every = parallel.gathered(mesh.comm, n.reshape(-1)).reshape(-1, g)
    spread = np.abs(every - every[0]).max()
    if spread > PLANE_TOLERANCE:
        raise ValueError(
            f"{owner}: its facets are not on one plane (their normals differ by up to "
            f"{spread:.3g}); give each planar face its own RigidWall"
        )
    normal = every[0] / np.linalg.norm(every[0])
    on_plane = parallel.gathered(mesh.comm, corners.reshape(-1, g) @ normal)
    return normal, float(np.mean(on_plane))


def _check_apart(walls: list, comm) -> None:
    """Refuse two walls on one facet: each would push with its own springs, twice.

    Found 2026-12-06 by a helper: a dynamic run took two walls on the same facets,
    doubled their penalty and reported half the push on each, without a word.
    """
    error = None
    for i, first in enumerate(walls):
        for second in walls[i + 1 :]:
            shared = np.intersect1d(first.facets, second.facets)
            if shared.size and error is None:
                error = ValueError(
                    f"RigidWall {second.spec.name!r} lies on {shared.size} facet(s) of "
                    f"RigidWall {first.spec.name!r}: give each facet to one wall"
                )
    parallel.raise_together(comm, error)


class _Wall:
    """One wall on the grid: facets, normal, stiffness, friction and spring extension."""

    def __init__(
        self,
        spec: RigidWall,
        facets: np.ndarray,
        space,
        gap_space,
        gap_coordinates: np.ndarray,
        E: float,
        subdomain: int,
    ):
        mesh = space.mesh
        g, fdim = mesh.geometry.dim, mesh.topology.dim - 1
        owner = f"RigidWall {spec.name!r}"
        self.spec, self.facets, self.subdomain = spec, facets, subdomain
        self.normal, self.offset = wall_plane(mesh, facets, owner)
        facet_nodes = dolfinx.mesh.entities_to_geometry(mesh, fdim, facets)
        corners = mesh.geometry.x[facet_nodes, :g]
        each = np.linalg.norm(corners[:, 1] - corners[:, 0], axis=1)  # an edge of each facet
        # Each facet once: given by tag, a wall holds the tagged facets of ghost cells too
        # (point domains ask for two layers of them), which the ranks that own them count.
        sizes = each[facets < mesh.topology.index_map(fdim).size_local]
        count = parallel.total(mesh.comm, int(sizes.size))
        h = parallel.total(mesh.comm, float(sizes.sum())) / count
        self.penalty = spec.penalty if spec.penalty is not None else PENALTY_FACTOR * E / h
        self.slip_scale = spec.slip_scale if spec.slip_scale is not None else SLIP_SCALE_FACTOR * h
        beta = dolfinx.fem.Constant(mesh, float(self.penalty))
        if spec.friction in (0.0, math.inf):
            mu = spec.friction
        else:
            mu = dolfinx.fem.Constant(mesh, float(spec.friction))
        n = dolfinx.fem.Constant(mesh, self.normal)
        s = dolfinx.fem.Constant(mesh, float(self.slip_scale))
        self.size = h
        self.gap = dolfinx.fem.Function(gap_space, name=f"gap {spec.name}")
        self.gap_nodes = dolfinx.fem.locate_dofs_topological(gap_space, fdim, facets)
        self.gap_positions = gap_coordinates[self.gap_nodes]
        longest = np.max(  # each facet's longest edge, the reach of its nodes
            [np.linalg.norm(corners[:, i] - corners[:, j], axis=1) for i, j in _EDGES[g]],
            axis=0,
        )
        self.reach = _node_sizes(mesh.comm, gap_space, facet_nodes, longest)[self.gap_nodes]
        self.law = contact.WallLaw(
            normal=n, stiffness=beta, friction=mu, slip_scale=s, gap=self.gap
        )
        self.extension = dolfinx.fem.Function(space, name=f"extension {spec.name}")
        self.dofs = dolfinx.fem.locate_dofs_topological(space, fdim, facets)  # blocked
        cells = mesh.topology.connectivity(fdim, fdim + 1)
        self.cells = np.unique(np.concatenate([cells.links(f) for f in facets] or [[]]))
        self.cells = self.cells.astype(np.int32)
        # The step forms bind the facets to this id themselves (StepForm's facet_domains).
        self.ds = ufl.Measure("ds", domain=mesh, metadata=contact.VERTEX_RULE)(subdomain)
        order = np.argsort(facets)
        tags = dolfinx.mesh.meshtags(
            mesh, fdim, facets[order], np.full(facets.size, subdomain, dtype=np.int32)
        )
        self.ds_tagged = ufl.Measure(
            "ds", domain=mesh, subdomain_data=tags, metadata=contact.VERTEX_RULE
        )(subdomain)


def _exterior_facets(mesh: dolfinx.mesh.Mesh, where, facet_tags, owner: str) -> np.ndarray:
    """A wall's facets, refused inside the grid.

    A tag may name facets inside the grid (a line gmsh's fragment kept between two
    regions), where a facet has no outward normal: found 2026-12-07 by a helper, a
    wall on such a line took its normal from whichever of each facet's cells came
    first, reported no force, and on one grid let a block fall through it, every step
    converged.
    """
    facets = boundary_facets(mesh, where, facet_tags, owner)
    owned = facets[facets < mesh.topology.index_map(mesh.topology.dim - 1).size_local]
    check_exterior(
        mesh,
        owned,
        owner,
        "where a facet has no outward normal: a wall is the grid's outer boundary, with "
        "the body on one side and no grid on the other. Leave the region beyond it out of "
        "the gmsh model (cut it away rather than fragment it)",
    )
    return facets


class RigidWalls:
    """The rigid walls of a grid.

    Args:
        du: The grid displacement increment (UFL, P1).
        walls: The walls.
        mesh: The grid.
        facet_tags: Facet tags for walls given by tag.
        material: The law (its E sets the default penalty).

    Attributes:
        facet_domains: ``ds`` subdomain id -> the exterior facets of each wall.
    """

    def __init__(
        self,
        du: ufl.core.expr.Expr,
        walls: Sequence[RigidWall],
        mesh: dolfinx.mesh.Mesh,
        facet_tags: dolfinx.mesh.MeshTags | None,
        material,
    ):
        g = mesh.geometry.dim
        self.mesh, self.du = mesh, du
        self.space = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (g,)))
        gaps = dolfinx.fem.functionspace(mesh, ("Lagrange", 1))
        gap_coordinates = gaps.tabulate_dof_coordinates()[:, :g]
        # The node positions, once: the spaces share the grid's P1 nodes.
        self.coordinates = self.space.tabulate_dof_coordinates()[:, :g]
        # And their grid input indices (a P1 cell lists its dofs in its nodes' order),
        # by which checkpoints and repartitions carry the springs.
        node_of_dof = np.empty(self.coordinates.shape[0], dtype=np.int64)
        node_of_dof[self.space.dofmap.list.reshape(-1)] = mesh.geometry.dofmaps[0].reshape(-1)
        inputs = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)
        self._node_inputs = inputs[node_of_dof]
        # E only for a default penalty: a fluid may have no shear scale to give it.
        E = young_modulus(material) if any(s.penalty is None for s in walls) else 0.0
        self.walls = [
            _Wall(
                spec,
                _exterior_facets(mesh, spec.where, facet_tags, f"RigidWall {spec.name!r}"),
                self.space,
                gaps,
                gap_coordinates,
                E,
                i,
            )
            for i, spec in enumerate(walls, start=FIRST_WALL_ID)
        ]
        self.facet_domains = {wall.subdomain: wall.facets for wall in self.walls}
        _check_apart(self.walls, mesh.comm)
        v = ufl.TestFunction(self.space)
        points = self.space.element.interpolation_points
        self._kept, self._traction, self._forces = [], [], []
        # Each node's share of a wall's area by the vertex rule (preload, and the
        # pressure node by node), at the owned nodes: the grid is reset every step, so
        # they are the same all run long (a repartition builds the walls anew).
        self._areas = []
        for wall in self.walls:
            area = dolfinx.fem.assemble_vector(
                dolfinx.fem.form(ufl.TestFunction(gaps) * wall.ds_tagged)
            )
            area.scatter_reverse(dolfinx.la.InsertMode.add)
            self._areas.append(area.array.copy())
        self._next = dolfinx.fem.Function(self.space)
        self._converged = dolfinx.fem.Function(self.space)  # a wall's traction at the end
        for wall in self.walls:
            d = wall.extension + du
            self._kept.append(dolfinx.fem.Expression(contact.kept_extension(d, wall.law), points))
            self._traction.append(
                dolfinx.fem.Expression(contact.wall_traction(d, wall.law), points)
            )
            # The wall's nodal forces on the body: the vertex rule, as in the residual.
            self._forces.append(dolfinx.fem.form(ufl.dot(self._converged, v) * wall.ds_tagged))

    def __bool__(self) -> bool:
        return bool(self.walls)

    def shared_with(self, conditions) -> list[str]:
        """Warnings for walls whose nodes a Dirichlet condition also holds along their normal.

        A node that a condition holds takes no spring: the condition's reaction carries
        the body's push there, and the wall's reported force leaves that node's share
        out. A retaining wall on a clamped base (a new user's scene, 2026-12-07: a layer
        2 m deep at rest on cells of 0.2 m) reported 9.7 % less than ½ K₀ γ H², about
        the corner node's share; a wall on the facets of a roller reported nothing.
        Collective.

        Args:
            conditions: The grid's conditions (:class:`~fe_mpm.grid_conditions.GridConditions`).

        Returns:
            One message per wall that shares nodes, naming the wall, the conditions, how
            many of its nodes they hold and where the first is.
        """
        comm = self.mesh.comm
        owned = self.space.dofmap.index_map.size_local
        # The walls' nodes that each condition's entities hold (blocked, as wall.dofs).
        condition_dofs = [
            dolfinx.fem.locate_dofs_topological(self.space, dim, entities)
            for dim, entities in conditions.dirichlet_entities
        ]
        messages = []
        for wall in self.walls:
            mine = wall.dofs[wall.dofs < owned]
            places = self.coordinates[mine]
            held, by = np.zeros(len(mine), dtype=bool), []
            for k, ((spec, _, _), dofs) in enumerate(
                zip(conditions.dirichlet, condition_dofs, strict=True)
            ):
                if spec.component is not None and not _along(wall.normal)[spec.component]:
                    continue
                there = np.isin(mine, dofs)
                if parallel.any_rank(comm, bool(np.any(there))):
                    by.append(f"Dirichlet {k}")
                held |= there
            count = parallel.total(comm, int(held.sum()))
            if not count:
                continue
            # The example: the least held node by its coordinates, whatever the ranks
            # (rounded as printed, so that −0.0 and 1e-18 are 0 and sort as 0).
            least = min(map(tuple, (0.0 + places[held].round(6)).tolist()), default=None)
            first = list(min(x for x in comm.allgather(least) if x is not None))
            total = parallel.total(comm, len(mine))
            messages.append(
                f"RigidWall {wall.spec.name!r}: {count} of its {total} grid nodes (the first "
                f"at x = {first}) are also held by {' and '.join(by)} along the wall's "
                "normal. A held node takes no spring: the condition's reaction carries the "
                "body's push there, and the wall's force leaves that node's share out (a "
                "retaining wall on a clamped base reports about h/H less than its earth "
                "pressure). End the condition short of the wall's plane, or give that face "
                "to the wall alone."
            )
        return messages

    def residual(self, w: ufl.core.expr.Expr) -> ufl.Form | None:
        """The walls' share of the residual with displacement test function ``w``, or None."""
        terms = [
            contact.residual(self.du, w, wall.extension, wall.law, wall.ds) for wall in self.walls
        ]
        return sum(terms[1:], terms[0]) if terms else None

    def unloaded_tangent(self, trial: ufl.core.expr.Expr, w: ufl.core.expr.Expr) -> ufl.Form | None:
        """The Jacobian's term for nodes touching a frictional wall unloaded, or None.

        See :func:`fe_mpm.forms.contact.unloaded_tangent`; ``trial`` is the
        displacement part of the Jacobian's trial function, ``w`` the test function.
        """
        terms = [
            contact.unloaded_tangent(self.du, trial, w, wall.extension, wall.law, wall.ds)
            for wall in self.walls
        ]
        terms = [t for t in terms if t is not None]
        return sum(terms[1:], terms[0]) if terms else None

    def held_places(self, occupied: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Where and in which direction the walls hold the material, on this rank.

        Each item: the wall's nodes that an ``occupied`` cell touches (n, g), m, and a
        direction (g,) they hold: the normal, and with friction each of the plane's.
        """
        held = []
        touched = touched_nodes(self.space, occupied)
        for wall in self.walls:
            at = self.coordinates[wall.dofs[touched[wall.dofs]]]
            held.append((at, wall.normal))
            if wall.spec.friction > 0.0:
                held.extend((at, t) for t in np.linalg.svd(wall.normal[None, :])[2][1:])
        return held

    def start_step(self, occupied: np.ndarray, x: np.ndarray, volume: np.ndarray) -> None:
        """Set each node's gap to the body, and release the springs the body has left.

        Grid-node contact acts on a node as soon as a point of the cells around it
        moves toward the wall, a cell before the body itself arrives: a rolling disk
        then rides on the nodes ahead of it. So each node's spring waits for the
        body: its gap is the least distance from the wall of the points within its
        own facets' size of it (along the wall), less each point's half-width
        V_p^{1/g} / 2, and at least 0. A body that rests on the wall has none; a node
        with no point within reach and twice the wall's mean facet size of the wall
        takes that distance. Found 2026-12-07 by a helper's Hertz contacts: with the
        wall's mean facet as every node's reach, 2.7 to 7 cells on a graded grid, a
        node took the lowest point of a curved body well beyond it, and the contact
        came out 31 % too wide (b/R = 0.05, cells of b/10); and with point domains, a
        node that no point reached pushed with gap 0 where the body was 0.09 m clear
        of the wall (the half-width 4 times Hertz's).

        Args:
            occupied: The cells that hold points: nodes no such cell touches are released.
            x: The points' positions (n, g) at the start of the step (m); with
                point domains the pieces' (their centroids).
            volume: Their volumes (n,) (m³; m² in 2D).
        """
        if not self.walls:
            return
        g, comm = self.mesh.geometry.dim, self.mesh.comm
        half_width = 0.5 * volume ** (1.0 / g)
        idle = ~touched_nodes(self.space, occupied)
        for wall in self.walls:
            distance = wall.offset - x @ wall.normal - half_width  # ≤ 0: at the wall
            near = distance < 2.0 * wall.size
            near_x = parallel.gathered(comm, x[near].reshape(-1)).reshape(-1, g)
            near_d = parallel.gathered(comm, distance[near])
            wall.gap.x.array[:] = 0.0
            wall.gap.x.array[wall.gap_nodes] = _least_distances(
                wall.gap_positions, near_x, near_d, wall.normal, wall.reach, 2.0 * wall.size
            )
            wall.extension.x.array.reshape(-1, g)[idle] = 0.0

    def preload(self, residual: np.ndarray, constrained: np.ndarray, space) -> bool:
        """Load the springs of the nodes that touch a wall with the body's push on them.

        For a body started with its stress at rest in a dynamic run: without it the
        springs start unloaded, the nodes on the wall carry the body's weight against
        nothing at t = 0, and the first steps ring (a layer's base carried 1.7 times
        its weight after its first step). Each node that touches a wall (gap 0) takes
        the entry that balances what ``residual`` still pushes into the wall with:
        its entry grows by −R·n / (a β), a the node's share of the wall's area (the
        vertex rule's weight), and stays ≥ 0; along the wall nothing. The residual
        includes the springs' own force, so a second call (a retried first step)
        changes nothing. Nodes where a Dirichlet condition holds a component along
        the wall's normal are left alone: the condition carries the push there.
        Collective. Where two walls meet at a node each takes its own normal's share,
        which balances the push only where their normals are orthogonal.

        Args:
            residual: The residual's displacement part at rest, f_int − f_ext (N), on
                the P1 vector ``space`` (its local array, owned and ghost).
            constrained: Which entries of ``residual`` a condition fixes (bool).
            space: Its function space: a P1 vector space on this grid.

        Returns:
            Whether any spring changed, on any rank.
        """
        g = self.mesh.geometry.dim
        same = _same_nodes(self.coordinates, space)
        force = residual.reshape(-1, g)[same]
        fixed = constrained.reshape(-1, g)[same]
        owned = self.space.dofmap.index_map.size_local
        changed = False
        for wall, area in zip(self.walls, self._areas, strict=True):
            nodes = wall.dofs[wall.dofs < owned]
            a = area[nodes]
            held = np.any(fixed[nodes][:, _along(wall.normal)], axis=1)
            touching = (wall.gap.x.array[nodes] == 0.0) & (a > 0.0) & ~held
            nodes, a = nodes[touching], a[touching]
            e = wall.extension.x.array.reshape(-1, g)
            entry = e[nodes] @ wall.normal
            push = -force[nodes] @ wall.normal
            new = np.maximum(entry + push / (a * wall.law.stiffness.value), 0.0)
            changed = changed or bool(np.any(new != entry))
            e[nodes] = new[:, None] * wall.normal
            wall.extension.x.scatter_forward()
        return parallel.any_rank(self.mesh.comm, changed)

    def springs(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Each wall's spring extensions (m) by node, gathered on every rank; collective.

        The nodes are known by their grid input indices, which a repartitioned grid
        keeps: name -> (input indices (k,), extensions (k, g)).
        """
        g, comm = self.mesh.geometry.dim, self.mesh.comm
        owned = self.space.dofmap.index_map.size_local
        out = {}
        for wall in self.walls:
            mine = wall.dofs[wall.dofs < owned]
            values = wall.extension.x.array.reshape(-1, g)[mine]
            out[wall.spec.name] = (
                parallel.gathered(comm, self._node_inputs[mine]).astype(np.int64),
                parallel.gathered(comm, values.reshape(-1)).reshape(-1, g),
            )
        return out

    def set_springs(self, springs: dict[str, tuple[np.ndarray, np.ndarray]]) -> None:
        """Give the walls the extensions of :meth:`springs` (from this grid or a repartition).

        A wall missing from ``springs`` keeps its springs.
        """
        g = self.mesh.geometry.dim
        for wall in self.walls:
            if wall.spec.name not in springs:
                continue
            inputs, values = springs[wall.spec.name]
            order = np.argsort(inputs)
            inputs, values = np.asarray(inputs)[order], np.asarray(values).reshape(-1, g)[order]
            wanted = self._node_inputs[wall.dofs]
            at = np.clip(np.searchsorted(inputs, wanted), 0, max(inputs.size - 1, 0))
            found = inputs[at] == wanted if inputs.size else np.zeros(wanted.size, dtype=bool)
            e = wall.extension.x.array.reshape(-1, g)
            e[wall.dofs[found]] = values[at[found]]
            wall.extension.x.scatter_forward()

    def finish_step(self) -> dict[str, WallForces]:
        """Keep the springs' extension at the converged Δu, and report each wall's force."""
        forces = {}
        g, comm = self.mesh.geometry.dim, self.mesh.comm
        owned, coords = self.space.dofmap.index_map.size_local, self.coordinates
        for wall, kept, traction, force, area in zip(
            self.walls, self._kept, self._traction, self._forces, self._areas, strict=True
        ):
            self._converged.x.array[:] = 0.0
            self._converged.interpolate(traction, cells0=wall.cells)
            self._converged.x.scatter_forward()
            b = dolfinx.fem.assemble_vector(force)
            b.scatter_reverse(dolfinx.la.InsertMode.add)
            self._next.x.array[:] = 0.0
            self._next.interpolate(kept, cells0=wall.cells)
            e = wall.extension.x.array.reshape(-1, g)
            e[:] = 0.0
            e[wall.dofs] = self._next.x.array.reshape(-1, g)[wall.dofs]
            wall.extension.x.scatter_forward()
            nodal = b.array.reshape(-1, g)
            mine = wall.dofs[wall.dofs < owned]
            touching = mine[np.abs(nodal[mine]).sum(axis=1) > 0.0]
            total = np.array([parallel.total(comm, float(nodal[mine, c].sum())) for c in range(g)])
            normal_part = float(total @ wall.normal)
            forces[wall.spec.name] = WallForces(
                total=total,
                normal=0.0 - normal_part,  # not −0.0 on a wall nothing touches
                tangential=total - normal_part * wall.normal,
                nodes=parallel.gathered(comm, coords[touching].reshape(-1)).reshape(-1, g),
                nodal=parallel.gathered(comm, nodal[touching].reshape(-1)).reshape(-1, g),
                direction=wall.normal.copy(),
                areas=parallel.gathered(comm, area[touching]),
            )
        return forces


def _along(normal: np.ndarray) -> np.ndarray:
    """The components a wall's normal has, (g,) bool.

    A condition that holds one of them at a node on the wall holds the body against
    the wall there (its reaction carries the push, not the wall's spring).
    """
    return np.abs(normal) > PLANE_TOLERANCE


def _same_nodes(coordinates: np.ndarray, space) -> np.ndarray:
    """For each node at ``coordinates`` (k, g), its node in the P1 ``space`` (k,).

    The walls' spaces and the step's displacement space share the grid's nodes but
    may number them apart (a collapsed sub-space); matched by position.
    """
    g = coordinates.shape[1]
    other = space.tabulate_dof_coordinates()[:, :g]
    mine, theirs = np.lexsort(coordinates.T[::-1]), np.lexsort(other.T[::-1])
    if not np.array_equal(coordinates[mine], other[theirs]):
        raise RuntimeError("RigidWalls: the displacement space's nodes are not the walls'")
    found = np.empty(len(coordinates), dtype=np.int64)
    found[mine] = theirs
    return found


#: At most this many (node, point) pairs at a time in :func:`_least_distances`.
PAIRS_AT_ONCE = 2_000_000


def _least_distances(
    nodes: np.ndarray,
    x: np.ndarray,
    distance: np.ndarray,
    normal: np.ndarray,
    reach: np.ndarray,
    beyond: float,
) -> np.ndarray:
    """Each node's gap to the body (k,), m.

    The least ``distance`` of the points ``x`` (n, g) within ``reach`` (k,) of each
    node along the wall (normal ``normal``), at least 0; ``beyond`` where no point is
    (the points were kept only where nearer the wall than that).
    """
    gaps = np.full(len(nodes), float(beyond))
    if not len(nodes) or not len(x):
        return gaps
    chunk = max(1, PAIRS_AT_ONCE // len(x))  # bounds the memory of a long wall
    for start in range(0, len(nodes), chunk):
        offset = x[None, :, :] - nodes[start : start + chunk, None, :]
        along = offset - np.einsum("npg,g->np", offset, normal)[..., None] * normal
        around = np.linalg.norm(along, axis=2) < reach[start : start + chunk, None]
        least = np.where(around, distance[None, :], np.inf).min(axis=1)
        gaps[start : start + chunk] = np.where(np.isfinite(least), np.maximum(least, 0.0), beyond)
    return gaps


#: The edges of a wall's facet by the grid's dimension: a segment, a triangle.
_EDGES = {2: ((0, 1),), 3: ((0, 1), (1, 2), (2, 0))}


def _node_sizes(comm, space, facet_nodes: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """The largest of ``sizes`` (k,) of the facets ``facet_nodes`` (k, g) at each dof.

    Over the facets of every rank: a rank may hold only some of a shared node's
    facets, and a node that two ranks gave two reaches took two gaps, so that the
    answer moved with the partition (a reviewer, 2026-12-07). 0 at nodes of no
    facet. ``space`` is P1, whose cells list their dofs in their geometry nodes'
    order. Collective.
    """
    mesh = space.mesh
    dof_of_node = np.empty(mesh.geometry.x.shape[0], dtype=np.int32)
    dof_of_node[mesh.geometry.dofmaps[0].reshape(-1)] = space.dofmap.list.reshape(-1)
    index_map = space.dofmap.index_map
    local = dof_of_node[facet_nodes].reshape(-1)
    every = parallel.gathered(comm, index_map.local_to_global(local))
    each = parallel.gathered(comm, np.repeat(sizes, facet_nodes.shape[1]))
    nodes, which = np.unique(every, return_inverse=True)
    largest = np.zeros(nodes.size)
    np.maximum.at(largest, which, each)
    mine = index_map.local_to_global(
        np.arange(index_map.size_local + index_map.num_ghosts, dtype=np.int32)
    )
    at = np.clip(np.searchsorted(nodes, mine), 0, max(nodes.size - 1, 0))
    found = nodes[at] == mine if nodes.size else np.zeros(mine.size, dtype=bool)
    return np.where(found, largest[at] if nodes.size else 0.0, 0.0)


#: A wall's contact that ends after this many steps or fewer is warned about in
#: dynamics (once a run). Measured 2026-12-07 (a helper's scene, then
#: ``/tmp``-scripts): a Neo-Hookean disk (R = 0.2 m, E = 10 MPa, ρ = 1000 kg/m³)
#: dropped 0.3 m onto a smooth wall, bossak_alpha = −0.3, cells of R/4, whose
#: contact lasts 13.6 ms by Hertz: with steps of 12.5 ms the wall pushed for two
#: steps and the disk rebounded to 133 %, then 154 %, of its drop; with 5 ms, two
#: steps again, it kept 0.44 of its energy; with 2.5 ms five steps and 0.74, with
#: 1.25 ms nine steps and 0.84. The springs switch on within a step, and no time
#: rule integrates that work when the whole contact is a step or two.
SHORT_CONTACT_STEPS = 2


class ContactWatch:
    """Warn once a run where a dynamic contact with a wall lasts too few steps.

    Attributes:
        steps: Each wall's steps in contact so far, by name (absent: not in contact).
        since: When each of those contacts began (s).
        warned: Whether the run was warned.
    """

    def __init__(self) -> None:
        self.steps: dict[str, int] = {}
        self.since: dict[str, float] = {}
        self.warned = False

    def look(self, forces: dict[str, WallForces], t_start: float) -> None:
        """Count the step that began at ``t_start`` (s), with each wall's ``forces``.

        A short contact handed over to another wall, whose contact began while it
        lasted, is no impact: a disk sliding round a bowl of one wall per facet (the
        docs' way to build a curved wall) left each after two steps and was told to
        take steps five times shorter (a helper, 2026-12-08).
        """
        for name, force in forces.items():
            if force.normal > 0.0:
                self.since.setdefault(name, t_start)
                self.steps[name] = self.steps.get(name, 0) + 1
        for name, force in forces.items():
            if force.normal > 0.0:
                continue
            count, began = self.steps.pop(name, 0), self.since.pop(name, t_start)
            handed_over = any(start >= began for start in self.since.values())
            if 0 < count <= SHORT_CONTACT_STEPS and not handed_over and not self.warned:
                self.warned = True
                warn(
                    f"RigidWall {name!r}: a contact lasted only {count} step(s), from t = "
                    f"{began:g} to {t_start:g} s, which does not resolve it: the body may "
                    "leave with more energy than it brought, Bossak's dissipation or not, or "
                    "with far less (an elastic disk dropped on a smooth floor, "
                    "bossak_alpha=-0.3, two steps in contact: rebounded to 133 % of its "
                    "drop with one step length, kept 0.44 of its energy with another; nine "
                    "steps in contact kept 0.84). Take steps of a fifth of the contact or "
                    "shorter (said once)."
                )


def write_wall_forces(history: Sequence, path: str | Path, first: int = 0) -> Path:
    """Write every wall's force after every step of ``history`` as CSV; returns the path.

    Columns: ``step, t, wall, F_x, F_y[, F_z], normal, tangential`` (the friction's
    magnitude); forces as in :class:`WallForces`. Every rank's reports carry the same
    totals, so call it on one.

    Args:
        history: The :class:`~fe_mpm.StepReport` objects of a run (``Simulation.history``).
        path: The CSV file to write.
        first: 0 writes the file anew; k > 0 appends the rows of ``history[k:]`` to
            it, as a run does at each output (each step's rows written once).
    """
    g = next((f.total.size for r in history for f in r.walls.values()), 0)
    header = ["step", "t", "wall", *(f"F_{c}" for c in "xyz"[:g]), "normal", "tangential"]
    lines = []
    for report in history[first:]:
        for name, force in report.walls.items():
            values = [*force.total, force.normal, np.linalg.norm(force.tangential)]
            lines.append(
                ",".join([str(report.step), repr(report.t), name, *map(repr, map(float, values))])
            )
    return write_csv_rows(path, header, lines, first)


def write_wall_distribution(report, path: str | Path) -> Path:
    """Write each wall's force node by node after one step as CSV; returns the path.

    Columns: ``wall, x, y[, z], F_x, F_y[, F_z], push, area, pressure``: the node's
    position (m), its force on the body (N; N/m in 2D), the push −F·n, its share of
    the face (m²; m in 2D) and the push over it (Pa), from
    :class:`WallForces`. Every rank's report carries the whole walls, so call it on one.

    Args:
        report: A :class:`~fe_mpm.StepReport` (``Simulation.history[-1]``: the end).
        path: The CSV file to write.
    """
    g = next((f.nodes.shape[1] for f in report.walls.values()), 0)
    header = ["wall", *"xyz"[:g], *(f"F_{c}" for c in "xyz"[:g]), "push", "area", "pressure"]
    lines = []
    for name, force in report.walls.items():
        push = -force.nodal @ force.direction
        for row in zip(force.nodes, force.nodal, push, force.areas, force.pressure, strict=True):
            values = [*row[0], *row[1], *row[2:]]
            lines.append(",".join([name, *map(repr, map(float, values))]))
    return write_csv_rows(path, header, lines, 0)


def plot_wall_forces(history: Sequence, path: str | Path, pyplot) -> Path:
    """Plot each wall's push and friction against time, and node by node at the end.

    Args:
        history: The :class:`~fe_mpm.StepReport` objects of a run.
        path: The image file to write.
        pyplot: ``matplotlib.pyplot`` (see :func:`fe_mpm.plotting.pyplot`).

    The right panel's friction is each node's magnitude, which opposite nodal
    frictions do not cancel in: their sum can exceed the wall's total.

    Raises:
        ValueError: ``history`` is empty or its last step has no walls.
    """
    if not history or not history[-1].walls:
        raise ValueError("plot_wall_forces: history holds no step with wall forces")
    fig, (over_time, along) = pyplot.subplots(1, 2, figsize=(10, 3.6))
    t = [report.t for report in history]
    axes = set()
    for name in history[-1].walls:
        forces = [report.walls[name] for report in history]
        over_time.plot(t, [f.normal for f in forces], label=f"{name}: push")
        friction = [np.linalg.norm(f.tangential) for f in forces]
        over_time.plot(t, friction, "--", label=f"{name}: friction")
        last = forces[-1]
        if len(last.nodes):
            axis = int(np.argmax(np.ptp(last.nodes, axis=0)))  # the face's longest extent
            order = np.argsort(last.nodes[:, axis])
            push = -last.nodal[order] @ last.direction
            along_wall = np.linalg.norm(last.nodal[order] + np.outer(push, last.direction), axis=1)
            x = last.nodes[order, axis]
            # Walls that face different ways run along different axes: each is named.
            along.plot(x, push, "o", ms=3, label=f"{name}: push, along {'xyz'[axis]}")
            along.plot(x, along_wall, "s", ms=3, mfc="none", label=f"{name}: |friction|")
            axes.add("xyz"[axis])
    along.set_xlabel(" or ".join(sorted(axes)) + " (m), along each wall's face")
    over_time.set_xlabel("t (s; a static run's load time)")
    over_time.set_ylabel("force on the body (N; N/m in 2D)")
    over_time.legend(fontsize=7)
    along.set_ylabel("nodal force at the end (N; N/m in 2D)")
    along.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    pyplot.close(fig)
    return Path(path)
