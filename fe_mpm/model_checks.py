"""What a model must satisfy before its first step, each check with a message that says why.

:class:`~fe_mpm.Simulation` runs these at set-up (and :func:`check_supports` at the
first static step, once it knows which cells hold material): the options in their
ranges, a grid and points that fit each other, a law that provides what the
formulation needs, one density, and supports that stop every rigid translation and
rotation.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping, Sequence

from mpi4py import MPI

import numpy as np

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.bodies import bodies_of_cells, count_bodies
from fe_mpm.boundary import (
    Dirichlet,
    PointDirichlet,
    PointPressure,
    PointTraction,
    Pressure,
    RigidWall,
    Traction,
    refuse_tags_of_other_entities,
)
from fe_mpm.checks import check_choice, check_int, check_range
from fe_mpm.errors import warn
from fe_mpm.formulations import FORMULATIONS, FormulationSpec
from fe_mpm.ghost import WITH_DOMAINS, WITH_DOMAINS_DYNAMIC
from fe_mpm.grid_conditions import follow_the_body
from fe_mpm.materials.drucker_prager import SmoothCapDruckerPrager
from fe_mpm.materials.elastic import is_builtin, young_modulus
from fe_mpm.materials.protocol import Law, MixedLaw, missing_members
from fe_mpm.materials.zones import laws_of, material_zones
from fe_mpm.particles import MaterialPoints, coincident, simplex_cell_type
from fe_mpm.transfer import summed_over_ranks, touched_nodes

#: Relative mismatch between the law's density and the points' that counts as a conflict.
DENSITY_RTOL = 1e-9

#: The SNES line searches a failed step may be retried with.
LINE_SEARCHES = ("basic", "bt", "l2", "cp")


def check_choices(
    formulation: str,
    mass: str,
    points_leaving: str,
    linear_solver: str,
    line_search: str,
    fallback_line_search: str | None,
) -> None:
    """Refuse an option that is not one of its choices, naming it and the choices."""
    check_choice("Simulation", "formulation", formulation, tuple(FORMULATIONS))
    check_choice("Simulation", "mass", mass, ("consistent", "lumped"))
    check_choice("Simulation", "points_leaving", points_leaving, ("raise", "drop"))
    check_choice("Simulation", "linear_solver", linear_solver, ("direct", "iterative"))
    check_choice("Simulation", "line_search", line_search, ("auto", *LINE_SEARCHES))
    if fallback_line_search is not None:
        check_choice(
            "Simulation", "fallback_line_search", fallback_line_search, ("auto", *LINE_SEARCHES)
        )


def check_ranges(
    max_step_cells: float, ppp_alpha: float, damping: float, output_every: int
) -> None:
    """Refuse a number outside its range, naming it and the range."""
    check_range("Simulation", "max_step_cells", max_step_cells, lo=0.0, lo_open=True)
    check_range("Simulation", "ppp_alpha", ppp_alpha, lo=0.0)
    if isinstance(damping, tuple | list):  # Rayleigh's pair, as other codes take it
        raise TypeError(
            "Simulation: damping is the mass-proportional α_R alone (1/s); give the "
            "stiffness-proportional β_R (s) as stiffness_damping=, e.g. "
            "Simulation(..., damping=α_R, stiffness_damping=β_R)"
        )
    check_range("Simulation", "damping", damping, lo=0.0)
    check_int("Simulation", "output_every", output_every, lo=1)  # 2.5 was taken as 2


def check_ppp(ppp_alpha: float, spec: FormulationSpec) -> None:
    """Refuse a PPP coefficient > 0 for a formulation that has no PPP term.

    ``Simulation(..., "up-p2p1", ppp_alpha=5.0)`` ran without a word and without
    PPP (found 2026-12-06 by a helper).
    """
    if ppp_alpha > 0.0 and not spec.ppp:
        raise ValueError(
            f"Simulation: ppp_alpha={ppp_alpha:g} acts only in 'up' (PPP, the pressure's "
            f"stabilisation), and formulation {spec.name!r} has none; leave ppp_alpha out "
            "or give 0"
        )


def check_output_dir(output_dir) -> None:
    """A folder's path (str or os.PathLike) or None; 123 stopped in pathlib."""
    if output_dir is not None and not isinstance(output_dir, str | os.PathLike):
        raise TypeError(
            "Simulation: output_dir must be a folder's path (str or pathlib.Path) or None, "
            f"got {type(output_dir).__name__}"
        )
    if isinstance(output_dir, str) and not output_dir.strip():
        # (argparse's "off" wrote the run into the working folder, over a user's
        # steps.csv: a helper's probes, 2026-12-07)
        raise ValueError(
            "Simulation: output_dir is an empty string; give a folder, or None for no output"
        )


def check_rebalance(rebalance_above: float | None) -> float | None:
    """None, or the imbalance (> 1) past which the grid is repartitioned."""
    if rebalance_above is None:
        return None
    return float(
        check_range("Simulation", "rebalance_above", rebalance_above, lo=1.0, lo_open=True)
    )


def check_dynamics(
    dynamic: bool, formulation: str, damping: float, mass: str, bossak_alpha: float = 0.0
) -> None:
    """Dynamics needs a P1 displacement; damping, Bossak's α and a lumped mass need it."""
    spec = FORMULATIONS[formulation]
    if dynamic and spec.u_degree != 1:
        raise ValueError(
            f"Simulation: dynamic analysis needs a P1 displacement; formulation "
            f"{formulation!r} is P{spec.u_degree}"
        )
    if not dynamic and damping:
        raise ValueError("Simulation: damping needs dynamic=True")
    # Below −1/3 Bossak's scheme loses unconditional stability.
    check_range("Simulation", "bossak_alpha", bossak_alpha, lo=-1.0 / 3.0, hi=0.0)
    if not dynamic and bossak_alpha:
        raise ValueError("Simulation: bossak_alpha needs dynamic=True")
    if not dynamic and mass != "consistent":
        raise ValueError("Simulation: mass='lumped' needs dynamic=True")


def check_stiffness_damping(stiffness_damping: float, dynamic: bool, keeps_shape: bool) -> None:
    """β_R ≥ 0 (s), only in dynamics and only for a law with a shear modulus."""
    check_range("Simulation", "stiffness_damping", stiffness_damping, lo=0.0)
    if not stiffness_damping:
        return
    if not dynamic:
        raise ValueError("Simulation: stiffness_damping needs dynamic=True")
    if not keeps_shape:
        raise ValueError(
            "Simulation: stiffness_damping (β_R K) needs a law with an elastic stiffness; "
            "a fluid has none (its viscosity damps it): give 0"
        )


def warn_trapezoid_on_walls(dynamic: bool, walls) -> None:
    """Warn that a body landing on a rigid wall may gain energy under the trapezoidal rule.

    For a run that left ``bossak_alpha`` at its default: a script that passes 0 has
    chosen the trapezoidal rule.

    Found 2026-12-07 by a helper: an elastic cube (Neo-Hookean, E = 1 MPa, 0.2 m)
    dropped onto a smooth `RigidWall` floor at 2 m/s with the defaults left it at 1.21
    times the speed it hit with, 26 % more energy in one bounce, and flew out of its
    grid; with Bossak's α_B = −0.3 (what the demos on walls take) it left at 0.86.
    The wall's springs switch on within a step, which the trapezoidal rule does not
    integrate conservatively.
    """
    if dynamic and walls:
        warn(
            "Simulation: a dynamic run with RigidWalls under the trapezoidal rule "
            "(bossak_alpha left at its default, 0): a body that lands on a wall can leave it "
            "faster than it came (an elastic cube dropped on a smooth floor gained 26 % "
            "of its energy in one bounce; with bossak_alpha=-0.3, as the demos on walls "
            "take, it lost some). Pass bossak_alpha=-0.3, or 0 where nothing lands, and "
            "take steps that put several in each contact (docs/dynamics.md)."
        )


def check_projection_passes(
    passes: int,
    dynamic: bool,
    mass: str,
    walls,
    bossak_alpha: float = 0.0,
    supports: Sequence = (),
) -> int:
    """Passes of the velocity projection: an int ≥ 1, more than one only in dynamics.

    More than one needs the consistent mass, and with rigid walls or grid supports
    that move (a ``Dirichlet`` among ``supports`` whose value or profile is a
    function of time) Bossak's dissipation. The consistent projection, unlike the
    mass-weighted one, does not smooth a jump of the velocity; at a contact the
    trapezoidal rule then leaves the contact's unresolved modes ringing (an elastic
    bar hitting a wall at v₀, eight passes: its push swings up to 69 % off ρ c v₀ and
    it leaves at 1.012 v₀; a block held by friction on a slope walks down). Bossak's
    α_B damps them: with −0.1 the push holds ρ c v₀ to 1.3 %, with −0.3 to 0.1 %, and
    the block stays. A plate set moving drives its body as a wall does: water started
    by a plate at U (Couette, eight passes, α_B = 0) still swung by ±5 μU/h at the
    fixed wall after 200 steps, where it should carry 0.986 μU/h, and its points moved
    across the flow at 10–20 % of U (a helper's scene, 2026-12-06); with α_B = −0.3
    the passes gave the best velocities of any setting.
    """
    passes = check_int("Simulation", "projection_passes", passes, lo=1)
    if passes == 1:
        return passes
    if not dynamic:
        raise ValueError("Simulation: projection_passes > 1 needs dynamic=True")
    if mass != "consistent":
        raise ValueError(
            "Simulation: projection_passes > 1 approaches the consistent-mass projection "
            "and needs mass='consistent'; use projection_passes=1 with mass='lumped'"
        )
    if walls and bossak_alpha == 0.0:
        raise ValueError(
            "Simulation: projection_passes > 1 with rigid walls needs Bossak's "
            "dissipation, bossak_alpha in [-1/3, 0) (e.g. -0.3): with the trapezoidal "
            "rule a contact rings and gains energy; or use projection_passes=1"
        )
    platens = [s for s in supports if isinstance(s, PointDirichlet)]
    if platens and bossak_alpha == 0.0:
        raise ValueError(
            f"Simulation: projection_passes > 1 with PointDirichlet {platens[0].name!r} "
            "needs Bossak's dissipation, bossak_alpha in [-1/3, 0) (e.g. -0.3): its "
            "penalty rings as a wall's does (a platen pushing a bar at V from rest, eight "
            "passes: its force swung between -0.74 and 2.65 rho c V A, against 0.77 to "
            "1.06 with one pass and 0.77 to 1.00 with bossak_alpha=-0.3); or use "
            "projection_passes=1"
        )
    moving = [
        s
        for s in supports
        if callable(getattr(s, "value", None)) or getattr(s, "profile", None) is not None
    ]
    if moving and bossak_alpha == 0.0:
        raise ValueError(
            "Simulation: projection_passes > 1 with a support that moves (a Dirichlet "
            "whose value or profile is a function of time) needs Bossak's dissipation, "
            "bossak_alpha in [-1/3, 0) "
            "(e.g. -0.3): with the trapezoidal rule the body it drives rings, as at a "
            "contact; or use projection_passes=1"
        )
    return passes


def check_passes_between_bodies(
    passes: int, bossak_alpha: float, mesh: dolfinx.mesh.Mesh, cells: np.ndarray
) -> None:
    """Refuse projection passes under the trapezoidal rule where bodies apart may meet.

    Two bodies meeting through the grid are a contact, as a rigid wall is
    (:func:`check_projection_passes`), and with more than one pass and α_B = 0 it rang
    and gained energy without bound. Found 2026-12-06 by a helper: two free
    Neo-Hookean blocks thrown at each other at 1 and 2 m/s, eight passes, ended with
    3104 times their energy and points at 591 m/s (4 passes: 2.85 times); with
    α_B = −0.1 no more than they started with. A single body, however it moves, is
    not refused (one with a velocity jump inside kept its energy to 2 %).

    Args:
        passes: The projection's passes (checked).
        bossak_alpha: Bossak's α_B.
        mesh: The grid.
        cells: Each point's cell on this rank (n,), at set-up.
    """
    if passes == 1 or bossak_alpha != 0.0:
        return
    bodies = count_bodies(mesh, cells)
    if bodies > 1:
        raise ValueError(
            f"Simulation: projection_passes > 1 with the trapezoidal rule, and the material "
            f"forms {bodies} bodies apart (cells that share no grid node): where they meet, "
            "the contact rings and gains energy as at a rigid wall. Pass bossak_alpha in "
            "[-1/3, 0) (e.g. -0.3), or projection_passes=1"
        )


def check_grid_and_points(mesh: dolfinx.mesh.Mesh, points: MaterialPoints) -> None:
    """A non-empty simplex grid, and points of its dimension (on some rank)."""
    if not isinstance(mesh, dolfinx.mesh.Mesh):
        hint = " (a scene's grid is its .mesh)" if hasattr(mesh, "mesh") else ""
        raise TypeError(
            "Simulation: the first argument, mesh, must be a dolfinx.mesh.Mesh, got "
            f"{type(mesh).__name__}{hint}; the order is Simulation(mesh, points, material)"
        )
    if not isinstance(points, MaterialPoints):
        raise TypeError(
            "Simulation: the second argument, points, must be fe_mpm.MaterialPoints (what "
            f"fe_mpm.seed returns), got {type(points).__name__}; the order is "
            "Simulation(mesh, points, material)"
        )
    simplex_cell_type(mesh)
    if mesh.topology.index_map(mesh.topology.dim).size_global == 0:
        raise ValueError("Simulation: the mesh is empty (it has no cells)")
    if parallel.total(mesh.comm, len(points)) == 0:
        raise ValueError("Simulation: there are no material points")
    if points.gdim != mesh.geometry.dim:
        raise ValueError(
            f"Simulation: points are {points.gdim}D but the mesh is {mesh.geometry.dim}D"
        )


def check_distinct_points(comm, points: MaterialPoints) -> None:
    """Refuse (collective) points at the same place as another on a rank, after tracking.

    Two points at one place count the material twice. Under ``mpiexec`` a body seeded
    on every rank from a mesh of its own (``meshes.disk`` on ``COMM_SELF``, the
    default) is that many copies: a helper's disk weighed twice as much on two ranks,
    silently (2026-12-06). Tracking has sent each copy to the rank of its cell.
    """
    error = None
    twice = np.flatnonzero(coincident(points.x))
    if twice.size:
        i = int(twice[0])
        j = int(np.flatnonzero(np.all(points.x == points.x[i], axis=1))[1])
        places = len(np.unique(points.x[twice], axis=0))  # the few that coincide
        error = ValueError(
            f"Simulation: {twice.size - places} material points lie "
            f"at the same place as another (first: points {i} and {j} at x = "
            f"{points.x[i].tolist()}), which counts the material twice. Under mpiexec, "
            "points seeded on every rank from a mesh of its own (meshes.disk or "
            "meshes.cylinder on COMM_SELF, their default) are copies: keep them on one "
            "rank (points.keep(...) on the others) or build that mesh on the grid's "
            "communicator."
        )
    parallel.raise_together(comm, error)


#: A grid node where the points hold more than this many times the volume of the
#: cells around it is overfull (:func:`warn_overfull_nodes`). Each share is weighted by
#: the node's shape function, so points seeded on a mesh of their own that does not
#: match the grid's (a disk of 0.05 m triangles on a grid of 0.05 m, three points
#: each) fill a node to 1.04 at most, where a single cell of that grid held 1.57 times
#: its area; two such disks seeded over each other fill their common nodes to 2.0.
OVERFULL = 1.5


def warn_overfull_nodes(
    mesh: dolfinx.mesh.Mesh,
    points: MaterialPoints,
    bary: np.ndarray,
    cell_volumes: np.ndarray,
    added_cells: np.ndarray | None = None,
) -> None:
    """Warn (collective) where the points around a node hold more volume than its cells.

    Two bodies seeded over each other count the material twice where they overlap,
    unless their points happen to coincide (:func:`check_distinct_points`): a helper's
    two overlapping disks, each seeded from ``meshes.disk``, ran with twice the
    material in their common cells, silently (2026-12-07). Compared at each node I:
    ``Σ_p N_I(x_p) V_p`` against ``Σ_c N_I |c|/(d + 1)`` over the cells around it.

    Points that an earlier simulation stepped are not checked, except at the nodes of
    ``added_cells``, the cells of points just added to a run
    (:meth:`~fe_mpm.Simulation.add_points`: a helper's seeding added over the body's
    own cells doubled its weight without a word, 2026-12-07).

    Args:
        mesh: The grid (affine simplices: its geometry's nodes are its vertices).
        points: The tracked material points, in this rank's owned cells.
        bary: Their barycentric coordinates in their cells (n, d + 1).
        cell_volumes: The local cells' areas (volumes) in m² (m³), owned first.
        added_cells: This rank's cells of added points (local indices), or None.
    """
    stepped = parallel.any_rank(mesh.comm, points.simulated_to is not None)
    if stepped and added_cells is None:
        # Stepped by an earlier simulation: a flow crowds its points (a dam break's
        # along its wall filled a node 1.91 times), which is no overlap.
        return
    nodes = mesh.geometry.dofmaps[0]
    index_map = mesh.geometry.index_map()
    n = index_map.size_local + index_map.num_ghosts
    owned = mesh.topology.index_map(mesh.topology.dim).size_local
    held = np.bincount(
        nodes[points.cell].ravel(), weights=(bary * points.volume[:, None]).ravel(), minlength=n
    )
    room = np.bincount(
        nodes[:owned].ravel(),
        weights=np.repeat(cell_volumes[:owned] / nodes.shape[1], nodes.shape[1]),
        minlength=n,
    )
    held, room = summed_over_ranks(index_map, held), summed_over_ranks(index_map, room)
    fill = np.divide(held, room, out=np.zeros(n), where=room > 0)
    if added_cells is not None:  # only where the added points lie
        near = np.zeros(n)
        near[nodes[added_cells[added_cells >= 0]].ravel()] = 1.0
        fill[summed_over_ranks(index_map, near) == 0.0] = 0.0
    fill = fill[: index_map.size_local]
    count = parallel.total(mesh.comm, int(np.count_nonzero(fill > OVERFULL)))
    if count == 0:
        return
    worst = int(np.argmax(fill)) if len(fill) else -1  # a rank may own no node
    most = float(fill[worst]) if len(fill) else -np.inf
    fullest, rank = mesh.comm.allreduce((most, mesh.comm.rank), op=MPI.MAXLOC)
    where = mesh.geometry.x[worst, : mesh.geometry.dim].tolist() if len(fill) else []
    where = mesh.comm.bcast(where, root=rank)
    warn(
        f"Simulation: at {count} grid node(s) the points hold more than {OVERFULL:g} times "
        f"the volume of the cells around them (the fullest {fullest:.3g} times, at x = "
        f"{[round(v, 6) for v in where]}): bodies seeded over each other count their "
        "material twice where they overlap, or the points are coarser than the grid."
    )


def check_serial_only(comm, features: dict[str, bool]) -> None:
    """Refuse, on every rank alike, what does not run on a distributed mesh yet.

    Every rank passes the same arguments, so every rank refuses: none waits for
    the others in a collective call.

    Args:
        comm: The mesh's communicator.
        features: What the simulation asks for, description -> whether it is used.
    """
    used = [name for name, on in features.items() if on]
    if comm.size > 1 and used:
        raise NotImplementedError(
            f"Simulation: on a mesh distributed over {comm.size} MPI ranks, fe-mpm runs "
            "static and dynamic u and up scenes with grid and point conditions; not yet "
            f"{', '.join(used)}. Run on one rank (without mpiexec) for these."
        )


def check_domains(
    point_domains: bool,
    ghost_penalty: float | None,
    points: MaterialPoints,
    spec: FormulationSpec,
) -> None:
    """Point domains: on or off, P2 in 2D only.

    Ghost penalty: γ ≥ 0.
    """
    if ghost_penalty is not None:
        check_range("Simulation", "ghost_penalty", ghost_penalty, lo=0.0)
    if not isinstance(point_domains, bool | np.bool_):
        raise TypeError(f"Simulation: point_domains must be True or False, got {point_domains!r}")
    if point_domains and points.gdim == 3 and spec.u_degree != 1:
        raise NotImplementedError(
            "Simulation: point_domains on tetrahedra works with P1 displacements "
            "(formulation 'u' or 'up') for now, not with P2 ('up-p2p1')"
        )


def check_shared_increment(shared: bool, point_domains: bool, spec: FormulationSpec) -> None:
    """A shared increment: a bool, with point domains, P1 displacements, not NB-VA."""
    if not isinstance(shared, bool | np.bool_):
        raise TypeError(f"Simulation: shared_increment must be True or False, got {shared!r}")
    if not shared:
        return
    if not point_domains:
        raise ValueError(
            "Simulation: shared_increment=True shares a point's increment among the pieces "
            "of its domain: it needs point_domains=True"
        )
    if spec.u_degree != 1 or spec.volume_average:
        raise NotImplementedError(
            f"Simulation: shared_increment with formulation {spec.name!r}: P1 "
            "displacements without volume averaging only ('u' or 'up')"
        )


def check_facet_tags(mesh: dolfinx.mesh.Mesh, facet_tags) -> None:
    """Refuse ``facet_tags`` that are not tags of the grid's facets.

    Cell tags given there were found only once a condition selected facets by tag
    (``find()`` gives cell indices); a model whose conditions all use markers ran on
    without a word (a helper, 2026-12-07).
    """
    if facet_tags is None:
        return
    if not (hasattr(facet_tags, "dim") and hasattr(facet_tags, "find")):
        raise TypeError(
            f"Simulation: facet_tags must be dolfinx MeshTags of the grid's facets, got "
            f"{type(facet_tags).__name__}"
        )
    refuse_tags_of_other_entities(mesh, facet_tags, "Simulation: ")
    own = getattr(mesh.topology, "_cpp_object", None)
    theirs = getattr(facet_tags, "topology", None)
    if own is not None and theirs is not None and theirs is not own:
        # (another grid's tags select its facet numbers here: the Cook grid's clamped
        # tag held a rectangle's right edge, a helper's probes, 2026-12-07)
        raise ValueError(
            "Simulation: facet_tags belong to another grid than mesh; pass the tags that "
            "came with this grid (e.g. model_to_mesh's facet_tags, or sim.facet_tags of "
            "a simulation whose sim.mesh this is)"
        )


def pressure_by_parts(
    given: bool | None, keeps_shape: bool, point_domains: bool, spec: FormulationSpec
) -> bool:
    """Whether the starting pressure is integrated by parts (:mod:`fe_mpm.pressure_by_parts`).

    None: for a law that keeps no shape (a fluid) in a mixed formulation (u-p, or NB-VA's
    u-θ) without point domains. True needs such a formulation and no point domains.
    """
    if given is None:
        return spec.mixed and not keeps_shape and not point_domains
    if not isinstance(given, bool | np.bool_):
        raise TypeError(f"Simulation: pressure_by_parts must be True, False or None, got {given!r}")
    if given and not spec.mixed:
        raise ValueError(
            f"Simulation: pressure_by_parts=True needs a pressure or an averaged "
            f"volume: formulation 'up', 'up-nostab', 'up-p2p1' or 'u-nbva', got {spec.name!r}"
        )
    if given and point_domains:
        raise NotImplementedError(
            "Simulation: pressure_by_parts=True with point_domains=True: not yet "
            "(a domain's pieces would need their cells' χ)"
        )
    return bool(given)


def ghost_factor(
    ghost_penalty: float | None, point_domains: bool, degree: int, dynamic: bool = False
) -> float:
    """γ of the ghost penalty: as given, else by the run's kind.

    With point domains :data:`~fe_mpm.ghost.WITH_DOMAINS` in a static run and
    :data:`~fe_mpm.ghost.WITH_DOMAINS_DYNAMIC` in a dynamic one; 0 without.
    """
    if ghost_penalty is None:
        if not point_domains:
            return 0.0
        return WITH_DOMAINS_DYNAMIC if dynamic else WITH_DOMAINS[degree]
    return float(ghost_penalty)


#: What a static run of a law that yields adds to its stop message.
LIMIT_LOAD_ADVICE = (
    "Its law yields, and a static load past what the body can carry (its limit load) has "
    "no solution at all, however short the step: if the load against a displacement "
    "(the StepReports) had flattened before this step, the body has failed; "
    "dynamic=True follows the collapse."
)


def sliding_on_walls(walls, body_force: np.ndarray | None, occupied: np.ndarray) -> str:
    """Advice for a static run that the body force pushes along a frictional wall (or "").

    Friction holds a body on a wall only while the load along the wall is at most μ
    times the load against it: past that a static run has no solution, unless
    something else holds the body (a block on a 20° slope with μ = 0.3 stopped in its
    first step, and the advice about cell crossing alone misled). Named for each wall
    that touches a node of an ``occupied`` cell (on some rank) and that the body
    force presses on (b·n > 0) and pushes along with ‖b_T‖ / (b·n) > μ.

    Args:
        walls: The simulation's :class:`~fe_mpm.walls.RigidWalls`.
        body_force: The body force per unit mass (g,), or None.
        occupied: The cells that hold points.
    """
    if body_force is None or not walls:
        return ""
    b = np.asarray(body_force, dtype=float)
    touched = touched_nodes(walls.space, occupied)
    sliding = []
    for wall in walls.walls:
        mu, n = wall.spec.friction, wall.normal
        against = float(b @ n)
        along = float(np.linalg.norm(b - against * n))
        pushes = against > 0.0 and math.isfinite(mu) and along > mu * against
        if pushes and parallel.any_rank(walls.mesh.comm, bool(touched[wall.dofs].any())):
            sliding.append(f"{wall.spec.name!r} (along/against {along / against:.3g} > μ = {mu:g})")
    if not sliding:
        return ""
    return (
        "The body force pushes along RigidWall " + ", ".join(sliding) + " harder than its "
        "friction can hold: unless something else holds the body there, it slides, and a "
        "static run has no solution; dynamic=True follows the slide."
    )


#: Above this many separate bodies a static model's supports are not checked body by body.
MOST_BODIES_CHECKED = 50

#: What a stop message adds for a cohesionless soil that failed its first static step.
COHESIONLESS_ADVICE = (
    "The law is cohesionless (c = 0) and its points start unstressed: near zero stress "
    "they return to the apex, where they carry nothing and stiffen nothing, so the first "
    "step may have no solution however short. Start them from their weight "
    "(initial_stress=fe_mpm.geostatic_stress(...)), or give the soil a small cohesion "
    "(100 Pa let a silo of sand between frictional walls run)."
)


def failure_advice(
    point_domains: bool,
    ghost_factor: float,
    domains_would_do: bool = False,
    static_plastic: bool = False,
    sliding: str = "",
    lost_loads: dict[str, float] | None = None,
    cohesionless_from_rest: bool = False,
    staged: bool = False,
    later_stage: bool = False,
) -> str:
    """What a run's stop message adds about its options (empty if nothing).

    Point domains without a ghost penalty leave a cell that holds only a sliver of
    a domain with its nodes weakly held, and Newton may then find no solution
    however short the step: the strip footing (h = 0.2, 32 base points per cell)
    stops so at s/B = 0.64 with ``ghost_penalty=0`` and runs to s/B = 2 with 0.001.
    A static run of standard MPM (``domains_would_do``: no domains, but a set-up that
    takes them) may stop because its points cross cells with their whole volume: the
    squeezed J2 block of :func:`fe_mpm.scenes.platen_compression` in u-p stops at 23 %
    shortening (of 50) on n = 40, and with domains runs to the end on n = 10 and 20.
    A static run of a law that yields (``static_plastic``) may have passed its limit
    load (:data:`LIMIT_LOAD_ADVICE`): a J2 block standing free under rising gravity
    stops so once its base yields, and the advice about domains alone misled there.
    ``sliding`` (:func:`sliding_on_walls`) comes first where given, then the grid
    loads that the last step lost (``lost_loads``, label -> share): a thick sphere
    pressurised by a grid ``Pressure`` on cells of 0.125 had lost 14 % of its load by
    step 8, where Newton stopped, and the message spoke only of cell crossing.
    ``cohesionless_from_rest``: a static run of a cohesionless law (c = 0) whose
    unstressed points failed their first step: a helper's Janssen silo (sand between
    frictional walls, gravity ramped) stopped there with the step cut 4096-fold, where
    a geostatic start or c = 100 Pa ran.
    ``staged``: points were added or removed before the step (a lift of an
    embankment, an excavation), whose load comes whole at any step length.
    ``later_stage``: the first step of a static run whose points an earlier
    Simulation stepped: what the stage changes comes whole in that step, and Newton
    may fail short of any limit (a helper's staged strength reduction of Griffiths
    and Lane's slope, 2026-12-07: from the same state at F = 1, F = 1.05 failed and
    1.15 to 1.3 converged; the message spoke of the limit load alone).
    """
    advice = [sliding] if sliding else []
    if later_stage:
        advice.append(
            "This is the first step of a later stage (its points come from an earlier "
            "Simulation): what the stage changes, a weaker law or another load, comes "
            "whole in this step however short it is cut, and Newton may fail here short "
            "of any limit load (a staged strength reduction of a slope failed at F = 1.05 "
            "and converged at 1.3 from the same state). A failure here says nothing of "
            "the body's strength: ramp the change over steps instead (fresh points and "
            "gravity ramped, docs/user_scenes.md, strength reduction)."
        )
    if staged:
        advice.append(
            "Points were added or removed just before this step (add_points, "
            "remove_points): their weight, or the support they gave, comes whole in this "
            "step however short it is cut, so a stage the body cannot carry stops here."
        )
    if cohesionless_from_rest:
        advice.append(COHESIONLESS_ADVICE)
    for label, share in (lost_loads or {}).items():
        advice.append(
            f"{label} had lost {100 * share:.1f} % of its load in the last step (its grid "
            f"nodes carry no material, StepReport.lost_load). {follow_the_body(label)}"
        )
    if point_domains and ghost_factor == 0.0:
        advice.append(
            "This run has point domains without a ghost penalty (ghost_penalty=0): a "
            "cell holding only a sliver of a domain ties its nodes weakly, and that can "
            "leave Newton without a solution; a penalty ties them (ghost_penalty=γ, the "
            "default of static runs; on the strip footing 0.001 was enough)."
        )
    elif domains_would_do:
        advice.append(
            "Its points cross cells with their whole volume (standard MPM), so the "
            "cells they enter and leave fill and empty at once, which can leave Newton "
            "without a solution; point_domains=True spreads each point over the cells "
            "its domain covers (see docs/cell_crossing.md)."
        )
    if static_plastic:
        advice.append(LIMIT_LOAD_ADVICE)
    return " ".join(advice)


def warn_static_fluid(material, keeps_shape: bool, dynamic: bool) -> None:
    """Warn where a static run has a law that keeps no shape (a fluid).

    ``keeps_shape`` is the law's: False only for a fluid, which zones of several laws
    refuse.

    A static step gives a fluid no shear stiffness but its viscosity over a pseudo-time
    step: water at rest in a tank held its level for two static steps, then its
    surface fell from 0.094 to 0.063 m as the steps were cut, and the run ended with
    points through the base (a helper's tank, 2026-12-06).
    """
    if not (dynamic or keeps_shape):
        warn(
            f"Simulation: a static run of {type(material).__name__}, which keeps no shape: "
            "a static step gives it no shear stiffness, and water at rest in a tank left "
            "its level within steps and ended with points through its base. Run fluids "
            "with dynamic=True."
        )


#: PPP resists a pressure's variation across a cell in proportion to 1/G: a body whose
#: weight changes its pressure by more than this share of its shear modulus from one
#: side of a cell to the other (``ρ |b| h / G``) is warned.
PPP_WEIGHT_RATIO = 0.03


def warn_ppp_against_weight(
    comm, sizes: np.ndarray, points, material, spec: FormulationSpec, ppp_alpha: float, body_force
) -> None:
    """Warn where PPP would resist a body's hydrostatic gradient; collective.

    ``sizes`` are this rank's cells' longest edges (m, ``Tracker.sizes``); the largest
    over every rank is the h of the ratio ``ρ |b| h / G``.

    PPP penalises the pressure's variation inside each cell, a linear pressure too,
    with weight α/G. Measured on a soft Neo-Hookean "water" (K = 2 MPa) in a tank 1 m
    deep on cells of 0.1 m, gravity ramped in 4 static steps (a helper's scene,
    2026-12-06): ρ g h / G = 0.01 left the side thrust 1 % off ρ g H²/2, 0.33 put it
    12 % off and 1 put it 60 % off with σ_yy 65 % too large, each step converged
    and nothing said so; with ``ppp_alpha=0`` or ``"u-nbva"`` it was right.
    """
    if not (spec.ppp and ppp_alpha > 0.0) or body_force is None:
        return
    g = float(np.linalg.norm(body_force))
    if g == 0.0:
        return
    h = parallel.largest(comm, float(np.max(sizes, initial=0.0)))
    # Zone by zone: the densest zone's ρ over the softest zone's G, a pair no zone
    # had, warned of a gel (ratio 0.018) on a steel base as 0.142 (a helper, 2026-12-08).
    laws = laws_of(material)
    labels = np.zeros(len(points), dtype=int) if len(laws) == 1 else np.asarray(points.material)
    ratio, rho, mu = 0.0, 0.0, 1.0
    for k, law in enumerate(laws):
        rho_k = float(np.max(points.density[labels == k], initial=0.0))
        rho_k = parallel.largest(comm, rho_k)
        if rho_k * g * h / float(law.mu) > ratio:
            ratio, rho, mu = rho_k * g * h / float(law.mu), rho_k, float(law.mu)
    if ratio > PPP_WEIGHT_RATIO:
        warn(
            f"Simulation: the weight changes the pressure across a cell by ρ |b| h / G = "
            f"{ratio:.3g} of the shear modulus (ρ = {rho:.4g} kg/m³, h = {h:.3g} m, "
            f"G = {mu:.4g} Pa), and PPP (ppp_alpha = {ppp_alpha:g}) resists that "
            "gradient in proportion to 1/G: a soft body under its weight then comes out "
            "wrong (0.33 put a tank's thrust 12 % off, 1 put it 60 % off, every step "
            "converged). Pass ppp_alpha=0 or take formulation 'u-nbva'."
        )


#: A penalty above this many times E / h (h the grid's largest cell) is warned about:
#: 10⁴ times the advised 10³ E/h, whose gap under a pressure p, p h / (10³ E), is
#: already negligible. Measured 2026-12-07 (a helper's probe: a block pressed 1 cm by
#: a PointDirichlet on triangles of 0.25 m sides, h = 0.35 m, E = 1 MPa): the force
#: within 2e-6 of its converged value up to 1.4e10 E/h, then 0.86 % off at 1.4e11 E/h
#: and 28 % at 3.5e14, each step accepted at the round-off floor of the penalty's own
#: forces (ε h β), which had swallowed the load. The floor grows with β, so a stiffer
#: penalty buys nothing but that.
STIFF_PENALTY = 1e7

#: A penalty below this many times E / h is warned about: its gap under a pressure p,
#: p/β, is then at least p h / E, the squeeze of a whole cell of the body, and the
#: support is as soft as the body it holds. Measured 2026-12-08 (a
#: helper's footing, a penalty of 1e-3 E/h as a slip of units by 1e6 gives): q/c_u
#: 0.149 at s/B = 0.1 against 6.03, 2 Newton iterations a step, nothing said.
SOFT_PENALTY = 1.0


def warn_stiff_penalties(comm, material, supports: Sequence, walls: Sequence, sizes) -> None:
    """Warn of a PointDirichlet's or RigidWall's penalty far from 10³ E/h; collective.

    ``sizes`` are this rank's cells' longest edges (m, ``Tracker.sizes``). A fluid
    without its ``shear_scale`` sets no E, and nothing is checked.
    """
    given = [(f"PointDirichlet {s.name!r}", s.penalty) for s in supports]
    given += [(f"RigidWall {w.name!r}", w.penalty) for w in walls if w.penalty is not None]
    if not given:
        return
    try:
        E = young_modulus(material)  # the stiffest law's, for a penalty too stiff
        softest = min(young_modulus(law) for law in laws_of(material))  # for one too soft
    except (AttributeError, ValueError):  # a fluid without its shear_scale
        return
    h = parallel.largest(comm, float(np.max(sizes, initial=0.0)))
    for owner, penalty in given:
        ratio = penalty * h / E
        if ratio > STIFF_PENALTY:
            warn(
                f"{owner}: penalty = {penalty:.3g} Pa/m is {ratio:.3g} E/h (E = {E:.4g} Pa, "
                f"h = {h:.3g} m), where about 1e3 E/h already keeps the gap negligible: the "
                "round-off of so stiff a penalty's forces grows with it and may swallow the "
                "load, and Newton then accepts a step whose force is off (1.4e11 E/h put a "
                "platen's force 0.86 % off, 3.5e14 E/h 28 %). Take 1e3 E/h."
            )
        elif penalty * h / softest < SOFT_PENALTY:
            # Against the softest law: clay's 1e3 E/h beside a steel zone was told it
            # was 0.05 E/h of the steel (a reviewer, 2026-12-08).
            ratio = penalty * h / softest
            warn(
                f"{owner}: penalty = {penalty:.3g} Pa/m is {ratio:.3g} E/h (E = {softest:.4g} "
                f"Pa, the softest law's; h = {h:.3g} m): a support that soft gives way as "
                "much as a cell of the body it holds, and a footing rides on its springs "
                "instead of pressing in (1e-3 "
                "E/h read a fortieth of the load a footing carries, every step converged). "
                "Take about 1e3 E/h; in another unit system give the penalty in its units "
                "(stress per length)."
            )


def _dilates(law) -> bool:
    """Whether ``law`` may dilate as it yields.

    A dilatancy angle above 0; Mast's evolving-angle cones whose friction rises above
    the critical state's (a₁ > 0, so tan ψ = tan φ_F − tan φ_cs > 0); a smooth cap's
    cone flowing with some associativity.
    """
    return (
        getattr(law, "dilatancy_angle", 0.0) > 0.0
        or getattr(law, "a1", 0.0) > 0.0
        or getattr(law, "associativity", 0.0) > 0.0
    )


def warn_dilatant_averaging(material, spec: FormulationSpec, dynamic: bool) -> None:
    """Warn where a static ``u-nbva`` run has a law that dilates as it yields.

    A helper's footing (Drucker–Prager, ψ = 30°) stopped at a fifth of its collapse
    load in ``u-nbva`` and ran to it in u-p; with ψ = 0 both run (docs/limitations.md).
    """
    if dynamic or not spec.volume_average:
        return
    dilating = [law for law in laws_of(material) if _dilates(law)]
    if dilating:
        law = dilating[0]
        warn(
            f"Simulation: 'u-nbva' with {type(law).__name__}, which dilates as it yields: "
            "a static run of a dilatant soil in u-nbva "
            "stopped far below its collapse load (a strip footing at 0.18 c N_c, where "
            "u-p reached 1.02); take 'up' for a dilatant soil (docs/limitations.md)"
        )


def _never_yields(law) -> bool:
    """Whether ``law``'s strength (cohesion or yield stress) is at least its Young's modulus.

    Then it yields at no strain below one: an elastic law in effect (a helper's
    tunnel took Mohr–Coulomb with c = 1e15 Pa for an elastic law that keeps the
    initial stress, 2026-12-07).
    """
    strength = max(getattr(law, "cohesion", 0.0), getattr(law, "yield_stress", 0.0))
    return strength >= getattr(law, "E", math.inf)


def warn_plastic_locking(material, spec: FormulationSpec) -> None:
    """Warn where the plain ``u`` form has a law whose plastic flow keeps the volume.

    P1 cells of the u form have one volume change each, which isochoric flow cannot
    follow: a helper's thick sphere in J2 under internal pressure (h = 0.15 a,
    2026-12-07) moved 11 % less than Hill's solution at 0.9 times his limit
    pressure, where u-p was within 0.7 %, and carried 1.2 times it without a word.
    """
    if spec.pressure or spec.volume_average or spec.u_degree != 1:
        return
    locking = [
        law
        for law in laws_of(material)
        if law.history
        # fe_mpm's own plastic laws: a user's law with a history (a damage law) may have
        # no plastic flow at all (a helper's, 2026-12-07, was told of one)
        and is_builtin(law)
        and getattr(law, "keeps_shape", True)
        and not _dilates(law)
        and not isinstance(law, SmoothCapDruckerPrager)  # its cap's flow is associated
        and not _never_yields(law)
    ]
    if locking:
        warn(
            f"Simulation: 'u' with {type(locking[0]).__name__}, whose plastic flow keeps "
            "the volume: the u form locks under such flow (a thick J2 sphere under "
            "internal pressure moved 11 % too little at 0.9 times its limit pressure, "
            "where 'up' was within 1 %); take 'up', or 'u-nbva' (volumetric "
            "averaging, which also unlocks it) (docs/materials.md)"
        )


def check_law(material, spec: FormulationSpec, formulation: str) -> None:
    """Refuse a law that lacks what the law protocol or the formulation asks for.

    Every law is a :class:`~fe_mpm.materials.protocol.Law`; the mixed forms need a
    deviatoric response (:class:`~fe_mpm.materials.protocol.MixedLaw`).
    """
    missing = missing_members(material, Law)
    if missing:
        raise TypeError(
            f"Simulation: material {type(material).__name__} is not a law: it lacks "
            f"{', '.join(missing)} (fe_mpm.materials.protocol.Law says what a law provides)"
        )
    if spec.pressure and not isinstance(material, MixedLaw):
        raise ValueError(
            f"Simulation: formulation {formulation!r} needs a material with a "
            "deviatoric response (kirchhoff_deviatoric, see "
            "fe_mpm.materials.protocol.MixedLaw)"
        )
    check_formulation = getattr(material, "check_formulation", None)
    if check_formulation is not None:
        check_formulation(spec.pressure)


def laws_of_zones(material, points: MaterialPoints, comm) -> object:
    """The simulation's law: ``material`` itself, or the zones of a list of laws.

    Every point's ``material`` label must name one of the laws: 0 where one law is
    given, an index into the list where several are
    (:mod:`fe_mpm.materials.zones`). Collective: every rank refuses alike.
    """
    # A list, tuple or array of laws; a law itself is not iterable.
    several = not hasattr(material, "kirchhoff") and isinstance(material, Iterable)
    laws = list(material) if several else [material]
    for law in laws:
        if isinstance(law, type):
            raise TypeError(
                f"Simulation: material must be a law object, e.g. {law.__name__}(E, nu, ...), "
                f"got the class {law.__name__} itself"
            )
    if several and len(laws) == 0:
        raise ValueError("Simulation: material is an empty list; give a law or a list of laws")
    error = None
    try:  # set after seeding too (points.material = ...): checked again here
        points.material = points._checked_material(len(points))
    except (TypeError, ValueError) as err:
        error = err
    parallel.raise_together(comm, error)
    highest = parallel.largest(comm, int(points.material.max(initial=0)))
    if highest >= len(laws):
        given = f"{len(laws)} laws" if several else f"one law ({type(material).__name__})"
        raise ValueError(
            f"Simulation: points are seeded with material={highest} (seed(..., material=k)), "
            f"but Simulation was given {given}; material k names the k-th of a list of "
            "laws, 0 to len(laws) - 1"
        )
    if len(laws) == 1:
        return laws[0]
    return material_zones(laws)


def take_density(material, points: MaterialPoints) -> None:
    """Give the points their law's density, or check that theirs agrees with it.

    The mass of a point is what body forces and inertia use; the law's
    ``density`` only fills it in when :func:`~fe_mpm.seed` was given none. With
    several laws (:mod:`fe_mpm.materials.zones`) each law does so at its own points.
    """
    densities = getattr(material, "densities", None)
    if densities is None:
        zones = [(material.density, np.ones(len(points), dtype=bool), "the material's")]
    else:
        zones = [
            (rho, points.material == k, f"material {k}'s") for k, rho in enumerate(densities())
        ]
    reference_volume = points.volume / np.linalg.det(points.F)
    if not points.density_given:
        for rho, zone, _ in zones:
            if rho is not None:
                points.mass[zone] = rho * reference_volume[zone]
        # A zone whose law has no density keeps ρ₀ = 1 kg/m³ (seed's placeholder).
        points.density_given = all(rho is not None for rho, _, _ in zones)
        return
    rho_points = points.mass / reference_volume
    for rho, zone, whose in zones:
        if rho is None:
            continue
        off = zone & (np.abs(rho_points - rho) > DENSITY_RTOL * rho)
        if np.any(off):
            first = np.flatnonzero(off)[0]
            raise ValueError(
                f"Simulation: {whose} density {rho:g} kg/m³ differs from the points' "
                f"{rho_points[first]:g} kg/m³ (point {first}; from seed(..., density=...) or "
                "their masses). Give the density in one place: seed(..., density=...) for "
                "zones of different densities, or the law's density alone."
            )


def check_weight_of_initial_stress(
    comm, points: MaterialPoints, stressed: bool, body_force
) -> None:
    """Refuse an initial stress under a body force on points that weigh nothing real.

    Points seeded without a density, whose law gives none either, carry seed's
    placeholder ρ₀ = 1 kg/m³. A stress at rest built for a real density (say
    ``geostatic_stress(..., density=2000.0)``) then pushes a layer that weighs a
    two-thousandth of what it holds up, and the layer springs up in its first
    step without a word (a helper following the docs' example, 2026-12-06).
    """
    weighs = body_force is not None and np.any(np.asarray(body_force, dtype=float) != 0.0)
    placeholder = (
        stressed
        and weighs
        and not points.density_given
        # masses a script set by hand after seeding are its own (relative only: numpy's
        # atol of 1e-8 took every body of points under 1e-8 kg for the placeholder)
        and np.allclose(points.mass, points.volume / np.linalg.det(points.F), 1e-12, 0.0)
    )
    if parallel.any_rank(comm, bool(placeholder)):  # one rank may hold no points
        raise ValueError(
            "Simulation: initial_stress under a body force needs the points' density, "
            "but they have none (seed's placeholder, 1 kg/m³), so they would not weigh "
            "what the stress holds up. Give it with seed(..., density=...) or the law's "
            "density=... (or set points.mass); geostatic_stress(..., density=...) only "
            "builds the stress."
        )


def warn_placeholder_density(comm, points: MaterialPoints, body_force, dynamic: bool) -> None:
    """Warn where points that weigh or move carry seed's placeholder density, 1 kg/m³.

    Given neither to :func:`~fe_mpm.seed` nor to the law, the density is 1 kg/m³. Under
    a body force or in dynamics that is rarely meant: a new user's debris flow of
    2000 kg/m³ pushed its bed with 24 N/m instead of about 100 kN/m, and nothing said
    so (2026-12-07). A script that means 1 kg/m³ says so with ``density=1.0``.
    """
    weighs = body_force is not None and (
        callable(body_force) or np.any(np.asarray(body_force, dtype=float) != 0.0)
    )
    # Point by point: in zones of several laws those whose law gives a density have it,
    # the others keep the placeholder; masses a script set by hand are its own.
    light = 0
    if (weighs or dynamic) and not points.density_given:
        reference_volume = points.volume / np.linalg.det(points.F)
        light = int(
            np.count_nonzero(np.isclose(points.mass, reference_volume, rtol=1e-12, atol=0.0))
        )
    light = parallel.total(comm, light)
    if light:
        moves = "a body force is given" if weighs else "the run is dynamic"
        warn(
            f"Simulation: {moves}, but {light} point(s) have no density (neither "
            "seed(..., density=...) nor their law's density= was given), so they carry "
            "seed's placeholder, 1 kg/m³: a soil of 2000 kg/m³ would weigh, push its walls "
            "and resist acceleration 2000 times less. Give the density, or density=1.0 if "
            "1 kg/m³ is meant."
        )


#: An initial stress is out of balance with the body force where the weight it holds up
#: (−div σ, fitted linearly over the points) and the body's weight ρ̄ b differ by more
#: than this share of the larger...
UNBALANCED_SHARE = 0.5
#: ... and that difference over the body's extent exceeds this share of its largest
#: stress: gravity on a small sample under a large confining stress is no mistake.
UNBALANCED_STRESS_SHARE = 0.1


def warn_elastic_tensors_started(
    comm: MPI.Comm, points: MaterialPoints, material, started: Mapping[str, str | None]
) -> None:
    """Warn (collective) where a new law's elastic tensors start on deformed points.

    ``started``: each convected elastic tensor of the law that the points lacked, and
    the other one it was converted from (None: from F,
    :meth:`~fe_mpm.materials.HistoryField.elastic_values`). Until 2026-12-07 they
    started at I, so the new law's stress restarted from zero at F ≠ I: a block that
    had sagged 4.34 mm under its weight in a Neo-Hookean stage sagged 4.29 mm more in
    one step of an elastic HenckyJ2 stage (a helper's scene), without a word. Taken
    from F where a J2Plasticity stage had left b̄ᵉ, its plastic strain became elastic
    strain: 10 times the stress (a reviewer); b̄ᵉ is now converted.
    """
    if not started:
        return
    g = points.F.shape[-1]
    strain = np.abs(points.F - np.eye(g)).max() if len(points) else 0.0
    strain = parallel.largest(comm, float(strain))
    if strain == 0.0:
        return
    laws = ", ".join(sorted({type(law).__name__ for law in laws_of(material)}))
    told = []
    for name, other in started.items():
        if other is None:
            told.append(
                f"{name!r} starts as their whole deformation taken as elastic (F Fᵀ): any "
                "plastic deformation of an earlier stage becomes elastic strain, and "
                "stress, in this one"
            )
        else:
            told.append(f"{name!r} starts from the {other!r} they carry, converted")
    warn(
        f"Simulation: the points start deformed (largest |F - I| = {strain:.3g}) and "
        f"lack the law's ({laws}) elastic tensor: {'; '.join(told)}. Its other internal "
        "variables start at their initial values."
    )


#: A point whose elastic state the law's return at rest moves by more than this
#: (in b_e, about the strain) starts outside its yield surface.
OUTSIDE_YIELD = 1e-9


def warn_initial_stress_outside_yield(comm, points: MaterialPoints, material) -> None:
    """Warn where an initial stress lies outside the law's yield surface; collective.

    The law's own return at rest (ΔF = I) from the started state: a point whose
    elastic state it moves was outside, and the first step yields it before anything
    is loaded. Found 2026-12-07 by a helper: a Tresca layer (c_u = 10 kPa, 5 m deep)
    started with K0 = 0.5, whose deviator reached 2.4 c_u at the base, settled
    0.86 mm in its first step at rest and its base σ_xx moved by 58 %, without a
    word. Laws that return in UFL are not checked.
    """
    if not hasattr(material, "return_map") or "be" not in points.history:
        return
    n, g = len(points), points.gdim
    moved, change = np.zeros(0, dtype=bool), 0.0
    if n:
        history = {name: value.copy() for name, value in points.history.items()}
        result = material.return_map(np.tile(np.eye(g), (n, 1, 1)), history)
        be = points.history["be"]
        moved = np.abs(result.history["be"] - be).max(axis=(1, 2)) > OUTSIDE_YIELD
        if moved.any():
            J = np.linalg.det(points.F)[moved]
            sigma = points.stress[moved]
            returned = result.tau[moved] / J[:, None, None]
            size = np.maximum(np.linalg.norm(sigma, axis=(1, 2)), np.finfo(float).tiny)
            change = float((np.linalg.norm(returned - sigma, axis=(1, 2)) / size).max())
    count = parallel.total(comm, int(moved.sum()))
    if count:
        change = parallel.largest(comm, change)
        warn(
            f"Simulation: {count} of the {parallel.total(comm, n)} points start with an "
            "initial_stress outside the law's yield surface; the law returns each to it "
            f"in the first step (the largest change {100 * change:.3g} % of the stress), so "
            "the body yields and moves at rest, before any load. Choose K0 (or the stress) "
            "inside the surface, e.g. K0 nearer 1 for a Tresca soil, or start the body "
            "unstressed and ramp the gravity."
        )


def warn_unbalanced_initial_stress(
    comm, points: MaterialPoints, stress: np.ndarray, body_force
) -> None:
    """Warn where an initial stress does not hold up the body force's weight.

    At rest div σ + ρ b = 0. The stress's gradient is fitted as a linear field over
    the points (least squares, weighted by volume, over all ranks), and the weight it
    holds up, −div σ (N/m³), is compared with the mean ρ̄ b. A 3D user who built
    ``geostatic_stress`` (vertical z) and gave gravity as ``(0, -9.81, 0)``, the
    habit of 2D, had a layer whose base carried none of its weight, every step
    converged (a helper, 2026-12-07); gravity upward, or a stress of the wrong
    sign, doubles the weight instead.

    Args:
        comm: The grid's communicator.
        points: This rank's points, at their start.
        stress: Their Cauchy stresses (n, 3, 3), Pa.
        body_force: Body force per unit mass (g,), m/s², or None.
    """
    g = points.gdim
    b = np.zeros(g) if body_force is None else np.asarray(body_force, dtype=float)[:g]
    x, v = points.x[:, :g], points.volume
    mass, volume = parallel.total(comm, np.array([points.mass.sum(), v.sum()]))
    lo = parallel.smallest(comm, x.min(axis=0, initial=np.inf))
    hi = parallel.largest(comm, x.max(axis=0, initial=-np.inf))
    sigma = np.asarray(stress, dtype=float)[:, :g, :g].reshape(-1, g * g)
    largest = parallel.largest(comm, float(np.abs(sigma).max(initial=0.0)))
    if volume <= 0.0:
        return
    extent = float(np.max(hi - lo))
    length = max(extent, np.finfo(float).tiny)  # a single point has no extent
    # About the centre and over the extent: raw coordinates of a georeferenced grid
    # (x near 5e5 m) left the normal matrix so ill-conditioned that the fit lost the
    # vertical gradient and a layer at rest was warned (the review, 2026-12-07).
    centre = parallel.total(comm, v @ x) / volume
    scaled = (x - centre) / length
    design = np.concatenate([np.ones((x.shape[0], 1)), scaled], axis=1)  # (n, g+1)
    normal = parallel.total(comm, np.einsum("n,na,nb->ab", v, design, design))
    moments = parallel.total(comm, np.einsum("n,na,ns->as", v, design, sigma))
    # lstsq: a layer of points in a plane leaves a gradient across it undetermined (0).
    fit = np.linalg.lstsq(normal, moments, rcond=1e-12)[0]
    gradient = fit[1:].T.reshape(g, g, g) / length  # [i, j, k] = ∂σ_ij/∂x_k
    held = -np.einsum("ijj->i", gradient)
    weight = mass / volume * b
    gap = float(np.linalg.norm(held - weight))
    scale = max(float(np.linalg.norm(held)), float(np.linalg.norm(weight)))
    if gap > UNBALANCED_SHARE * scale and gap * extent > UNBALANCED_STRESS_SHARE * largest > 0:

        def vector(v: np.ndarray) -> str:
            return "(" + ", ".join(f"{c:.4g}" for c in np.where(abs(v) > 1e-9 * scale, v, 0)) + ")"

        warn(
            "Simulation: initial_stress is out of balance with body_force: the stress "
            f"holds up a weight of {vector(held)} N/m³ (its fitted −div σ), the body "
            f"weighs {vector(weight)} N/m³ (ρ̄ b). Check that "
            "the body force points along the stress's vertical (geostatic_stress takes "
            "the last coordinate as vertical: z in 3D, y in 2D), downwards, and that the "
            "stress is compressive; a stress from an earlier stage in equilibrium "
            "under other loads may be fine."
        )


#: A rigid mode whose stiffness from the supports is below this share of the largest
#: is free. The rows are O(1) (unit directions, rotations scaled by the material's
#: size), so the largest is about the number of rows N and round-off leaves a free
#: mode near 1e-16 N; two pins a thousandth of the body apart hold a rotation with
#: about 1e-6, a share of 1e-12 even with N = 1e6 rows.
FREE_MODE_RTOL = 1e-13


def _acting_point_conditions(conditions, boundary, walls) -> list | None:
    """The boundary points' conditions, or None where nothing acts on the model.

    A model with no loads and no conditions at all stays at rest: it needs no check
    of its supports, as a whole or body by body.
    """
    point_conditions = [] if boundary is None else boundary.points.conditions
    if not (conditions.loads_or_supports or point_conditions or walls):
        return None
    return point_conditions


def check_supports(conditions, boundary, occupied: np.ndarray, walls=None) -> None:
    """Refuse a static model whose supports leave a rigid translation or rotation free.

    Without inertia, a body that nothing holds in some direction has a singular
    tangent (a rigid-body mode): Newton would fail with no hint. Supports count
    only where they reach material: nodes outside the occupied cells are pinned.
    (A model with no loads and no conditions at all stays at rest: it needs no check.)
    Each support is a row ``d · m_k(x)`` over the rigid modes m_k (translations, and
    rotations about the material's centre scaled by its size) at the place x it holds
    in direction d; the modes that no row reaches are free. Rotations were added
    2026-12-06, found by a helper: a cube on a frictionless base, held across it at one
    node only, failed Newton in its second step with advice about cell crossing.

    Args:
        conditions: The grid's :class:`~fe_mpm.grid_conditions.GridConditions`.
        boundary: The :class:`~fe_mpm.boundary_points.BoundaryPointStep`, or None
            (``PointDirichlet`` hold their components too).
        occupied: The cells that hold material.
        walls: The grid's :class:`~fe_mpm.walls.RigidWalls`, or None: a wall holds
            the body along its normal, and with friction along its plane too.
    """
    point_conditions = _acting_point_conditions(conditions, boundary, walls)
    if point_conditions is None:
        return
    gram = _support_gram(conditions, point_conditions, occupied, walls)
    g = conditions.mesh.geometry.dim
    free = _free_modes(gram[:g, :g])
    if free.shape[1]:
        names = _directions(free)
        raise ValueError(
            f"Simulation: a static model needs supports that stop every rigid "
            f"translation, but nothing holds the material in {names}: no Dirichlet "
            "condition (or PointDirichlet, or RigidWall) on that direction touches a node "
            "of an occupied cell. The tangent would be singular (a rigid-body mode). Add a "
            "support, or pass dynamic=True."
        )
    free = _free_modes(gram)
    if free.shape[1] == 0:
        return
    about = _rotation_axis(free, g)
    raise ValueError(
        f"Simulation: a static model needs supports that stop every rigid rotation, but "
        f"nothing stops the material turning about {about}: the supports that touch "
        "occupied cells (Dirichlet, PointDirichlet, RigidWall) hold it at too few places "
        "(e.g. one node, or one line through the axis). The tangent would be singular "
        "(a rigid-body mode). Hold a second place across that axis, or pass dynamic=True."
    )


def check_each_body(conditions, boundary, occupied: np.ndarray, walls=None) -> None:
    """Refuse a static model with a body that nothing holds, once the whole is held.

    Called by a step, after :func:`check_supports` (which :meth:`Simulation.prepare_step`
    calls, and the Taylor tests' scattered points pass).

    Material in cells that share no node forms separate bodies, and each needs its
    own supports: a block in the air beside one on its base, or one body on a gmsh
    model whose surfaces were not fragmented (two nodes at each place along their
    common edge), stopped Newton with a diverged line search and no hint (a helper's
    scenes, 2026-12-06). Every ``PointDirichlet`` point counts for every body, so a
    body held by none is always found, one held elsewhere may not be. Above
    :data:`MOST_BODIES_CHECKED` bodies (a granular packing) each is not checked.
    """
    mesh = conditions.mesh
    point_conditions = _acting_point_conditions(conditions, boundary, walls)
    if point_conditions is None:
        return
    body, count = bodies_of_cells(mesh, occupied)  # occupied: sorted, each cell once
    if not 1 < count <= MOST_BODIES_CHECKED:
        return
    g = mesh.geometry.dim
    for b in range(count):
        cells = occupied[body == b]
        gram = _support_gram(conditions, point_conditions, cells, walls)
        free = _free_modes(gram)
        if free.shape[1]:
            corners = mesh.geometry.x[mesh.geometry.dofmaps[0][cells], :g].reshape(-1, g)
            lo = parallel.smallest(mesh.comm, corners.min(axis=0, initial=np.inf))
            hi = parallel.largest(mesh.comm, corners.max(axis=0, initial=-np.inf))
            # Name the free motion, as check_supports does (a helper's floating slab,
            # held sideways by rollers, was told only "every rigid motion").
            moving = _free_modes(gram[:g, :g])
            if moving.shape[1]:
                motion = f"moving along {_directions(moving)}"
            else:
                motion = f"turning about {_rotation_axis(free, g)}"
            raise ValueError(
                f"Simulation: the material forms {count} separate bodies (groups of "
                "occupied cells that share no node), and a static model needs supports "
                f"for each: nothing stops the one in the box from {lo.round(6).tolist()} "
                f"to {hi.round(6).tolist()} {motion}, so the tangent would "
                "be singular. Support it, join it to another, or pass dynamic=True. A gmsh "
                "model whose surfaces were not fragmented (gmsh.model.occ.fragment) has "
                "two nodes at each place along their common edges, which cuts one body "
                "in two."
            )


def _support_gram(conditions, point_conditions, occupied: np.ndarray, walls) -> np.ndarray:
    """Σ rowᵀ row over every support's :func:`support_rows`, over all ranks (g + r, g + r)."""
    mesh = conditions.mesh
    g = mesh.geometry.dim
    x = mesh.geometry.x[:, :g]
    occupied_nodes = np.zeros(x.shape[0], dtype=bool)
    occupied_nodes[mesh.geometry.dofmaps[0][occupied]] = True
    places, ways = [], []  # where each support holds, and in which direction
    for (spec, _, _), nodes in zip(conditions.dirichlet, conditions.dirichlet_nodes, strict=True):
        nodes = nodes[occupied_nodes[nodes]]
        comps = range(g) if spec.component is None else [spec.component]
        for c in comps:
            places.append(x[nodes])
            ways.append(np.tile(np.eye(g)[c], (nodes.size, 1)))
    for condition in point_conditions:
        if isinstance(condition, PointDirichlet):
            at = np.asarray(condition.x, dtype=np.float64).reshape(-1, g)
            for c in range(g) if condition.components is None else condition.components:
                places.append(at)
                ways.append(np.tile(np.eye(g)[int(c)], (at.shape[0], 1)))
    if walls is not None:
        for at, direction in walls.held_places(occupied):
            places.append(at)
            ways.append(np.tile(direction, (at.shape[0], 1)))
    comm = mesh.comm
    material = x[occupied_nodes]
    lo = parallel.smallest(comm, material.min(axis=0, initial=np.inf))
    hi = parallel.largest(comm, material.max(axis=0, initial=-np.inf))
    centre, size = (lo + hi) / 2, max(float(np.max(hi - lo)), np.finfo(float).tiny)
    at = np.vstack(places or [np.zeros((0, g))])
    way = np.vstack(ways or [np.zeros((0, g))])
    rows = support_rows(at, way, centre, size)
    return parallel.total(comm, rows.T @ rows)


def _free_modes(gram: np.ndarray) -> np.ndarray:
    """The modes (columns) that ``gram`` holds with less than :data:`FREE_MODE_RTOL` of its most."""
    stiffness, modes = np.linalg.eigh(gram)
    return modes[:, stiffness <= FREE_MODE_RTOL * max(stiffness.max(), 1.0)]


def support_rows(at: np.ndarray, way: np.ndarray, centre: np.ndarray, size: float) -> np.ndarray:
    """How much each support resists each rigid mode, ``d · m_k(x)`` (n, g + r).

    Args:
        at: Where each support holds (n, g), m.
        way: The direction it holds in (n, g), unit.
        centre: The centre of the rotations (g,), m.
        size: The length that scales a rotation to a displacement (m).

    Returns:
        Columns: the g translations, then the rotations (r = 1 in 2D, about z;
        r = 3 in 3D, about x, y, z), each moving a place at ``size`` from the centre by 1.
    """
    arm = (at - centre) / size
    if at.shape[1] == 2:  # the rotation about z moves x by (−y, x)
        turn = way[:, 1] * arm[:, 0] - way[:, 0] * arm[:, 1]
        return np.column_stack([way, turn])
    # about axis e_k, x moves by e_k × arm, and d · (e_k × arm) = (arm × d)_k
    return np.column_stack([way, np.cross(arm, way)])


def _directions(free: np.ndarray) -> str:
    """The free translations (columns of ``free``, (g, k)) in words: ``x``, or a vector."""
    return ", ".join(
        "xyz"[int(np.argmax(np.abs(d)))] if np.isclose(np.abs(d).max(), 1.0) else str(d.round(3))
        for d in free.T
    )


def _rotation_axis(free: np.ndarray, g: int) -> str:
    """The axis of the first free mode's rotation (``free``'s columns; translations held).

    ``z`` in 2D, else :func:`_axis_name`'s.
    """
    axis = free[g:, 0]
    return "z" if g == 2 else _axis_name(axis / np.linalg.norm(axis))


def _axis_name(axis: np.ndarray) -> str:
    """``x``, ``y`` or ``z`` for a coordinate axis, the rounded vector otherwise."""
    k = int(np.argmax(np.abs(axis)))
    if np.isclose(abs(axis[k]), 1.0, atol=1e-6):
        return "the " + "xyz"[k] + " axis"
    return f"the axis {axis.round(3)}"


def domains_would_be_taken(
    points: MaterialPoints,
    spec: FormulationSpec,
    pressure_by_parts_given: bool | None,
    keeps_shape: bool,
) -> bool:
    """Whether these options would take ``point_domains=True``: no check refuses them.

    Asks the checks themselves (:func:`check_domains`, :func:`pressure_by_parts`), so
    that advice to turn domains on follows their refusals as they change.
    """
    try:
        check_domains(True, None, points, spec)
        pressure_by_parts(pressure_by_parts_given, keeps_shape, True, spec)
    except (ValueError, NotImplementedError):
        return False
    return True


def check_column_name(owner: str, name) -> None:
    """Refuse a name that cannot head a CSV column.

    A comma split a marker "tip,left" into two columns of ``steps.csv`` and shifted
    every value after it (a helper's post-processing, 2026-12-06).
    """
    if not isinstance(name, str) or not name or any(c in name for c in ',"\n\r'):
        raise ValueError(
            f"{owner} name {name!r} must be a non-empty string without commas, quotes or "
            "line breaks: it heads columns of steps.csv and walls.csv"
        )


def check_force_names(reactions: dict | None, walls: Sequence, boundary: Sequence) -> set[str]:
    """The names under which forces are reported, refused if two conditions share one.

    Reactions, rigid walls and boundary-point conditions all report their force in
    ``StepReport.reactions`` by name (and ``steps.csv`` by column), so a name shared
    by two would keep only one of the forces: a reaction and a wall both named
    "base" reported the wall's force alone, without a word (until 2026-12-05).

    Returns:
        The names, which markers may not take either.
    """
    if reactions is not None and not isinstance(reactions, dict):
        raise TypeError(
            "Simulation: reactions must be a dict, name -> facet tag or marker function of "
            f"the boundary whose reaction is summed, got {type(reactions).__name__}"
        )
    owners: dict[str, list[str]] = {}
    for kind, names in (
        ("reaction", list(reactions or {})),
        ("RigidWall", [wall.name for wall in walls]),
        ("boundary-point condition", [condition.name for condition in boundary]),
    ):
        for name in names:
            check_column_name(f"Simulation: the {kind}", name)
            owners.setdefault(name, []).append(kind)
    for name, kinds in owners.items():
        if len(kinds) > 1:
            what = (
                f"{len(kinds)} {kinds[0]}s"
                if len(set(kinds)) == 1
                else f"a {' and a '.join(kinds)}"
            )
            raise ValueError(
                f"Simulation: {name!r} names {what}; reactions, rigid "
                "walls and boundary-point conditions report their forces by name "
                "(StepReport.reactions), so each needs its own"
            )
    return set(owners)


def check_flags(**flags) -> None:
    """Refuse a yes/no option given as anything but a bool (``dynamic="no"`` ran dynamics)."""
    for name, value in flags.items():
        if not isinstance(value, bool | np.bool_):
            raise TypeError(f"Simulation: {name} must be True or False, got {value!r}")


def check_body_force_scale(body_force, body_force_scale) -> None:
    """``body_force_scale`` is a function of time that scales a given ``body_force``.

    Raises:
        TypeError: It is not callable (a number failed only in the first step).
        ValueError: It is given without a body force (it was ignored).
    """
    if body_force_scale is None:
        return
    if not callable(body_force_scale):
        raise TypeError(
            "Simulation: body_force_scale must be a function of time t -> factor, got "
            f"{body_force_scale!r}; a constant factor belongs in body_force itself"
        )
    if body_force is None:
        raise ValueError("Simulation: body_force_scale scales body_force, which is not given")


def check_petsc_options(petsc_options) -> None:
    """A mapping of PETSc option names to values, with a Newton fe-mpm can drive.

    Raises:
        TypeError: Not a mapping.
        ValueError: ``snes_type`` other than ``newtonls``: fe-mpm's Newton drives
            the line searches and tests convergence by its forces, and
            ``ksponly`` ended the process from inside PETSc (a helper's probes).
    """
    if petsc_options is None:
        return
    if not isinstance(petsc_options, Mapping):
        raise TypeError(
            "Simulation: petsc_options must be a dict of PETSc option names to values, "
            f"got {type(petsc_options).__name__}"
        )
    snes_type = petsc_options.get("snes_type", "newtonls")
    if snes_type != "newtonls":
        raise ValueError(
            f"Simulation: petsc_options['snes_type'] must be 'newtonls' (Newton with the "
            f"line searches of line_search=), got {snes_type!r}"
        )


#: Each list option of Simulation and what its entries may be.
CONDITION_LISTS = {
    "dirichlet": (Dirichlet,),
    "tractions": (Traction, Pressure),
    "point_dirichlet": (PointDirichlet,),
    "point_tractions": (PointTraction, PointPressure),
    "walls": (RigidWall,),
}


def condition_lists(**given) -> dict[str, tuple]:
    """Each of Simulation's list options as a tuple, its entries checked.

    None is an empty list. A single condition instead of a list, or an entry of
    another kind (a bare function, a PointDirichlet among the grid's), is refused
    naming the option and what it takes (a helper's probes, 2026-12-07, met
    AttributeErrors from deep inside).

    Raises:
        TypeError: An option is neither a list nor None, or an entry is of a kind
            the option does not take.
    """
    lists = {}
    for name, value in given.items():
        kinds = CONDITION_LISTS[name]
        wanted = " or ".join(kind.__name__ for kind in kinds)
        if value is None:
            value = ()
        if isinstance(value, kinds) or callable(value) or not isinstance(value, Iterable):
            raise TypeError(
                f"Simulation: {name} must be a list of {wanted}, got a "
                f"{type(value).__name__}; write {name}=[...] even for one"
            )
        value = tuple(value)
        for k, entry in enumerate(value):
            if not isinstance(entry, kinds):
                hint = (
                    f" (wrap a marker function as {kinds[0].__name__}(where, ...))"
                    if callable(entry) and not isinstance(entry, type)
                    else ""
                )
                one = " or a ".join(kind.__name__ for kind in kinds)
                raise TypeError(
                    f"Simulation: {name}[{k}] must be a {one}, got {type(entry).__name__}{hint}"
                )
        lists[name] = value
    return lists


def check_walls(walls: tuple, spec, formulation: str) -> tuple:
    """The rigid walls (each one checked by :func:`condition_lists`), or raise.

    Raises:
        NotImplementedError: P2 displacements (the walls' springs sit on the
            vertices only).
    """
    if walls and spec.u_degree != 1:
        raise NotImplementedError(
            f"Simulation: walls with formulation={formulation!r}: a wall's springs sit on "
            "the grid's vertices, so they need P1 displacements "
            "('u', 'u-nbva', 'up' or 'up-nostab')"
        )
    return walls
