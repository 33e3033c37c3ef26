"""Boundary conditions and loads on the background grid.

Both act on grid facets, chosen by a facet tag (an integer from the mesh's facet
tags, e.g. a gmsh physical group) or by a marker ``x -> bool`` on the facet
vertices' coordinates (shape ``(3, n)``), as in ``dolfinx.mesh.locate_entities_boundary``.
"""

from __future__ import annotations

import math
import numbers
import reprlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from fe_mpm._dolfinx import dolfinx
from fe_mpm.checks import check_finite, check_int, check_range
from fe_mpm.parallel import any_rank, total

#: A boundary point in an empty cell reads an occupied neighbour's field up to this
#: far outside it (the least barycentric coordinate there, and in distance this many
#: of its largest heights, :meth:`~fe_mpm.tracker.Tracker.within_reach`): half a cell. The default
#: of ``PointDirichlet(reach=)``, and the reach of every ``PointTraction`` point.
SNAP_REACH = 0.5

Where = int | Callable[[np.ndarray], np.ndarray]
Value = float | Sequence[float] | Callable[[float], float | Sequence[float]]
Profile = Callable[[np.ndarray, float], np.ndarray]


def _check_where(owner: str, where: object) -> None:
    """Raise ``TypeError`` unless ``where`` is a facet tag (an int) or a marker."""
    if callable(where):
        return
    # int(1.5) would select tag 1 without a word.
    if isinstance(where, bool | np.bool_) or not isinstance(where, numbers.Integral):
        raise TypeError(
            f"{owner}: where must be a facet tag (an int) or a marker x -> bool, "
            f"got {reprlib.repr(where)}"
        )


def _checked_marker(owner: str, where: Callable) -> Callable:
    """``where`` for DOLFINx's entity search, with a clear error for a wrong result.

    DOLFINx takes a marker's result as a boolean array of one entry per point; a
    marker returning anything else (``lambda x: True``, floats) stopped with C++'s
    bare "std::bad_cast". A sequence of booleans is taken as their array.
    """

    def marker(x: np.ndarray) -> np.ndarray:
        value = where(x)
        array = np.asarray(value)
        if x.shape[1] == 0 and array.size == 0:
            # A rank with no entities of the kind asked: an empty list is no error there
            # (np.asarray([]) is float), or that rank alone would stop.
            return np.zeros(0, dtype=bool)
        if array.shape != (x.shape[1],) or array.dtype != np.bool_:
            got = (
                f"an array of shape {array.shape} and dtype {array.dtype}"
                if isinstance(value, np.ndarray)
                else reprlib.repr(value)
            )
            raise ValueError(
                f"{owner}: its marker must return a boolean array with one entry per "
                f"point, shape ({x.shape[1]},) for x of shape {x.shape}, as "
                f"np.isclose(x[1], 0.0) does; got {got}"
            )
        return array

    return marker


def _check_callable(owner: str, field: str, value: object, kind: str) -> None:
    """Raise ``TypeError`` unless ``value`` is None or callable (``kind`` describes it)."""
    if value is not None and not callable(value):
        raise TypeError(f"{owner}: {field} must be {kind} or None, got {reprlib.repr(value)}")


def _vector(owner: str, field: str, value: object) -> tuple[float, ...]:
    """A non-empty 1-D sequence of finite numbers as a tuple of floats, or raise."""
    a = check_finite(owner, field, value, what="component")
    if a.ndim != 1 or a.size == 0:
        raise TypeError(
            f"{owner}: {field} must be a sequence of numbers, one per component, "
            f"got {reprlib.repr(value)}"
        )
    return tuple(a.tolist())


def _value_at(owner: str, field: str, f: Callable, t: float) -> np.ndarray:
    """``f(t)`` as a float array; raise ``ValueError`` unless it holds finite numbers.

    Args:
        owner: The condition, for the message.
        field: The name of the callable, e.g. ``"value"`` or ``"scale"``.
        f: The callable, ``t -> number or vector``.
        t: Time (s, or the pseudo-time of a static run).
    """
    v = f(t)
    try:
        a = np.asarray(v)
    except ValueError:  # ragged
        a = np.asarray(np.nan)
    # A nan here would reach the grid as a boundary value and Newton would fail far from the cause.
    if a.dtype.kind not in "iuf" or not np.all(np.isfinite(a)):
        raise ValueError(
            f"{owner}: {field}(t) must return finite numbers, got "
            f"{reprlib.repr(v)} at t = {float(t):g}"
        )
    return a.astype(np.float64)


def _scale_at(owner: str, scale: Callable[[float], float] | None, t: float) -> float:
    """The load factor ``scale(t)`` (1 if None), a finite number, or raise ``ValueError``."""
    if scale is None:
        return 1.0
    factor = _value_at(owner, "scale", scale, t)
    if factor.size != 1:
        raise ValueError(
            f"{owner}: scale(t) must return one number, got shape {factor.shape} "
            f"at t = {float(t):g}"
        )
    return float(factor.reshape(-1)[0])


def _points(owner: str, x: object, weight: object) -> tuple[np.ndarray, np.ndarray]:
    """Positions (n, g) and weights (n,) of boundary points, checked.

    Raises:
        TypeError: ``x`` or ``weight`` holds something other than numbers.
        ValueError: ``x`` is not (n, 2) or (n, 3) with n ≥ 1 or not finite, or a
            weight is not finite and > 0 (the message names the first bad point).
    """
    x = check_finite(owner, "x", x, what="point")
    if x.ndim != 2 or x.shape[1] not in (2, 3) or x.shape[0] == 0:
        raise ValueError(f"{owner}: x must have shape (n, 2) or (n, 3) with n ≥ 1, got {x.shape}")
    w = check_finite(owner, "weight", weight, what="point")
    if w.ndim > 1 or w.size not in (1, x.shape[0]):
        raise ValueError(
            f"{owner}: weight must be one number or one per point, shape "
            f"({x.shape[0]},), got shape {w.shape}"
        )
    w = np.broadcast_to(w, (x.shape[0],)).copy()
    bad = np.flatnonzero(w <= 0)
    if bad.size:
        raise ValueError(
            f"{owner}: every weight must be > 0 (m in 2D, m² in 3D); point "
            f"{bad[0]} has {w[bad[0]]:g}"
        )
    return x, w


@dataclass(frozen=True)
class Dirichlet:
    """Prescribed displacement on grid nodes.

    Args:
        where: Facet tag or marker. A marker that holds no whole exterior facet
            holds the whole facets (in 3D, else edges) it is true at inside the grid,
            else the boundary edges or vertices (a corner pinned against rigid
            motion; see :func:`dirichlet_entities`); never a lone node inside.
        value: Total prescribed displacement (m) as a function of time ``t``, or
            a constant. The grid is reset every step, so the step from ``t_n`` to
            ``t_{n+1}`` imposes ``value(t_{n+1}) − value(t_n)`` on the grid nodes
            (so a constant must be 0, which fixes the nodes; another constant is
            refused). A vector for all components, a scalar with ``component``.
            The nodes move, not the body's face: a face pushed away from them (a
            platen pressed into a block whose top then lies below the held nodes)
            is no longer held, and the load falls short without a word; a face
            that moves with the body is held by a :class:`PointDirichlet`.
        component: Constrain only this component (0, 1 or 2), e.g. a roller.
        profile: Space- and time-dependent prescribed displacement ``(x, t) ->
            u`` with ``x`` of shape ``(3, n)`` and ``u`` of shape ``(g, n)`` (or
            ``(n,)`` with ``component``). Replaces ``value`` when given; the step
            again imposes ``profile(x, t_{n+1}) − profile(x, t_n)``.
    """

    where: Where
    value: Value = 0.0
    component: int | None = None
    profile: Profile | None = None

    def __post_init__(self) -> None:
        _check_where("Dirichlet", self.where)
        if self.component is not None:
            check_int("Dirichlet", "component", self.component, lo=0, hi=2)
        _check_callable("Dirichlet", "profile", self.profile, "a function (x, t) -> u")
        if not callable(self.value):
            value = check_finite("Dirichlet", "value", self.value, what="component")
            if value.ndim > 1:
                raise ValueError(
                    f"Dirichlet: value must be a number or a vector, got shape {value.shape}"
                )
            if np.any(value != 0.0):
                # value is the total displacement at t: a constant one has moved by
                # nothing between any two times, so the nodes would just be held.
                raise ValueError(
                    f"Dirichlet: value={self.value!r} is a constant, so it would hold the "
                    "nodes where they are: value is the total displacement as a function "
                    "of time, and each step imposes value(t_new) - value(t_old) on the "
                    "grid, which is reset. To move the nodes by d over the run, give "
                    "value=lambda t: d * t / t_end (a constant value must be 0)"
                )
            # object.__setattr__: the dataclass is frozen; keep floats, not what was given.
            object.__setattr__(
                self, "value", float(value) if value.ndim == 0 else tuple(value.tolist())
            )

    def at(self, t: float) -> np.ndarray:
        """Prescribed displacement at time ``t`` (m) as an array.

        Raises:
            ValueError: A callable ``value`` returned a non-finite value at ``t``.
        """
        if callable(self.value):
            return _value_at("Dirichlet", "value", self.value, t)
        return np.asarray(self.value, dtype=np.float64)


@dataclass(frozen=True)
class Traction:
    """Surface traction on grid facets, per unit area of the grid (Pa).

    Args:
        where: Facet tag or boundary marker.
        value: Traction vector (Pa), length g.
        scale: Load factor as a function of time, ``t -> float``; constant 1 if None.
            For static load stepping use e.g. ``scale=lambda t: t`` with ``t_end=1``.
    """

    where: Where
    value: Sequence[float]
    scale: Callable[[float], float] | None = None

    def __post_init__(self) -> None:
        _check_where("Traction", self.where)
        object.__setattr__(self, "value", _vector("Traction", "value", self.value))
        _check_callable("Traction", "scale", self.scale, "a function t -> float")

    def at(self, t: float) -> np.ndarray:
        """Traction vector at time ``t`` (Pa).

        Raises:
            ValueError: ``scale`` returned a non-finite value at ``t``.
        """
        return _scale_at("Traction", self.scale, t) * np.asarray(self.value, dtype=np.float64)


@dataclass(frozen=True)
class Pressure:
    """Normal pressure on grid facets (Pa): the traction −p n, n the grid's outward normal.

    A positive pressure pushes into the grid on every facet, whatever its
    orientation: the inner face of a pressurised ring or a borehole, a curved face
    that a :class:`Traction` (one vector for all facets) cannot load. Like a
    :class:`Traction` it stays on its grid facets (the normal is theirs, not the
    body's, and does not follow the body), and its share on nodes that no material
    reaches is lost (``StepReport.lost_load``).

    Args:
        where: Facet tag or boundary marker of exterior grid facets.
        value: Pressure p (Pa), finite; negative pulls (a suction).
        scale: Load factor as a function of time, ``t -> float``; constant 1 if None.
    """

    where: Where
    value: float
    scale: Callable[[float], float] | None = None

    def __post_init__(self) -> None:
        _check_where("Pressure", self.where)
        object.__setattr__(self, "value", check_range("Pressure", "value", self.value))
        _check_callable("Pressure", "scale", self.scale, "a function t -> float")

    def at(self, t: float) -> float:
        """Pressure at time ``t`` (Pa).

        Raises:
            ValueError: ``scale`` returned a non-finite value at ``t``.
        """
        return _scale_at("Pressure", self.scale, t) * self.value


def refuse_tags_of_other_entities(mesh: dolfinx.mesh.Mesh, facet_tags, owner: str = "") -> None:
    """Refuse ``facet_tags`` whose entities are not the grid's facets (e.g. cell tags).

    Their ``find()`` would give cell indices, taken for facet indices without a word.
    ``owner`` begins the message (``"Simulation: "``).
    """
    tdim = mesh.topology.dim
    if facet_tags.dim != tdim - 1:
        raise ValueError(
            f"{owner}facet_tags has entities of dimension {facet_tags.dim} but the facets "
            f"of this {tdim}D mesh have dimension {tdim - 1}; cell tags cannot select "
            "boundary facets (pass the facet tags of model_to_mesh, data.facet_tags)"
        )


def boundary_facets(
    mesh: dolfinx.mesh.Mesh,
    where: Where,
    facet_tags: dolfinx.mesh.MeshTags | None,
    owner: str = "a boundary condition",
    hint: str = "",
) -> np.ndarray:
    """Local indices of the exterior facets selected by ``where``.

    ``owner`` names the condition in the messages (``"Dirichlet 1"``); ``hint`` ends the
    message of a marker that selects nothing.

    Raises:
        ValueError: ``facet_tags`` does not tag facets (e.g. cell tags), a tag
            is given without facet tags, or nothing is selected.
    """
    fdim = mesh.topology.dim - 1
    if facet_tags is not None:
        refuse_tags_of_other_entities(mesh, facet_tags)
    if callable(where):
        facets = dolfinx.mesh.locate_entities_boundary(mesh, fdim, _checked_marker(owner, where))
    else:
        if facet_tags is None:
            raise ValueError(
                f"{owner}: boundary tag {where} given but Simulation's facet_tags is None. "
                "dolfinx.io.gmsh.model_to_mesh gives facet_tags=None when the gmsh model "
                "has no physical group of the facets' dimension (1 in 2D, 2 in 3D): add "
                "one per boundary, e.g. gmsh.model.addPhysicalGroup(1, curves, tag=11)"
            )
        facets = facet_tags.find(int(where))
        # On a distributed mesh a rank may hold none of them: only none anywhere is wrong.
        if not any_rank(mesh.comm, facets.size > 0):
            present = set(facet_tags.values.tolist())
            present = set().union(*mesh.comm.allgather(present))
            raise ValueError(
                f"{owner}: boundary tag {where} selects no facets; tags present: {sorted(present)}"
            )
    if not any_rank(mesh.comm, facets.size > 0):
        raise ValueError(
            f"{owner}: its boundary marker selects no facet on the grid's boundary (a marker "
            "is called with the facet vertices' coordinates x, shape (3, n), and must be true "
            f"at every vertex of a facet on the grid's outer boundary{hint})"
        )
    return np.asarray(facets, dtype=np.int32)


def check_exterior(mesh: dolfinx.mesh.Mesh, facets: np.ndarray, owner: str, why: str) -> None:
    """Refuse facets inside the grid, for a condition that needs a facet's one outward normal.

    Args:
        mesh: The grid.
        facets: The condition's facets this rank owns (local indices).
        owner: The condition's name in the message (``"Pressure 0"``).
        why: The rest of the message: why it needs them outside, and what to do.

    Raises:
        ValueError: On every rank, when some rank owns a facet that is not exterior.
    """
    exterior = dolfinx.mesh.exterior_facet_indices(mesh.topology)  # owned ones only
    inside = np.setdiff1d(facets, exterior)
    if any_rank(mesh.comm, inside.size > 0):
        count = total(mesh.comm, int(inside.size))
        raise ValueError(f"{owner}: {count} of its facets lie inside the grid, {why}")


def dirichlet_entities(
    mesh: dolfinx.mesh.Mesh,
    where: Where,
    facet_tags: dolfinx.mesh.MeshTags | None,
    owner: str = "Dirichlet",
) -> tuple[int, np.ndarray]:
    """The boundary entities a :class:`Dirichlet` (or a reaction) holds: ``(dim, indices)``.

    The exterior facets selected by ``where`` (dimension tdim − 1). A marker that
    holds no whole facet takes the boundary entities of the highest lower dimension
    it holds whole: in 3D the edges of a line support (so that P2's mid-edge nodes
    are held too), else vertices, as ``dolfinx.fem.locate_dofs_geometrical`` finds
    the nodes of a point or a line: a corner pinned against rigid motion is
    ``lambda x: np.isclose(x[0], 0) & np.isclose(x[1], 0)``. As with facets, a marker
    is called with entity vertices' coordinates; one that holds some whole boundary
    facets holds those only. A marker that holds no boundary entity of a dimension but
    some inside the grid holds those (a face inside the grid, as a facet tag of its
    facets does; in 3D also edges inside), before trying lower dimensions on the
    boundary: otherwise the line y = 1 inside a taller grid would hold only its two
    ends on the grid's sides. A marker true only at nodes inside the grid is refused.

    Raises:
        ValueError: As :func:`boundary_facets`, when nothing is selected.
    """
    tdim = mesh.topology.dim
    if callable(where):
        marker = _checked_marker(owner, where)
        for dim in range(tdim - 1, -1, -1):
            entities = dolfinx.mesh.locate_entities_boundary(mesh, dim, marker)
            if dim > 0 and not any_rank(mesh.comm, entities.size > 0):
                # A face inside the grid (the top of a body seeded below the grid's
                # top) holds no boundary facet but touches the boundary at its ends:
                # its ends alone would hold two nodes where a whole face was meant.
                # Hold the face, as a facet tag of it would; not a lone node inside
                # the grid (dim 0), more likely a pin that missed the boundary.
                entities = dolfinx.mesh.locate_entities(mesh, dim, marker)
            if any_rank(mesh.comm, entities.size > 0):
                mesh.topology.create_connectivity(dim, tdim)
                return dim, np.asarray(entities, dtype=np.int32)
    hint = (
        "; a Dirichlet or reaction marker may also hold whole facets (3D: edges) inside "
        "the grid, which a grid has only where its cells are aligned with them, or "
        "boundary edges or vertices"
    )
    return tdim - 1, boundary_facets(mesh, where, facet_tags, owner, hint)


@dataclass(frozen=True)
class PointDirichlet:
    """Prescribed displacement at boundary points, imposed by a penalty (non-conforming).

    The grid does not follow a moving boundary such as a rigid footing, so no
    grid node lies on it. Kratos MPM imposes such conditions through boundary
    material points with a penalty; so does this. Each boundary point is convected
    with the grid solution like a material point, and the penalty pulls it onto its
    target ``x₀ + value(t)``: the step adds ``Σ_b β w_b (x_b + Δu(x_b) − x_b^target)·δu(x_b)``
    (constrained components only) to the residual. The gap left is about
    ``load / β``; it does not accumulate over steps.

    Args:
        name: Name of the condition; its force on the body is reported in
            ``StepReport.reactions[name]`` (N, per unit thickness in 2D).
        x: Initial positions of the boundary points (n, g), m. Under MPI every
            rank gives all of them; each point then acts on one rank. A face that
            grows is held only where points are: lay them over all the face will
            reach (a point beyond the material waits at its target until material
            reaches it: until a cell that holds points lies within ``reach`` of it,
            which may be half a cell before the body's face; from then on it holds
            the body both ways, so it is a support, not a contact: a block thrown
            onto a row of them was caught three quarters of a cell short and stayed
            glued, pulled back as hard as it had pushed; for an impact or a body that
            may lift off take a :class:`RigidWall`). A block squeezed to half its
            length by a platen laid over its initial face only flows around the
            platen's last point, and the force falls 10 % short in the last 5 % of
            the stroke
            (:func:`fe_mpm.scenes.platen_compression` covers the grid's side).
        weight: Boundary measure each point represents (n,): length (m) in 2D,
            area (m²) in 3D, > 0. Points may also fill a rigid body to tie the grid
            nodes inside it (see ``meshes.footing_points``); each then carries the
            stiffness β·w of a boundary point of the same spacing.
        value: Total prescribed displacement of the boundary at time ``t`` (m), a
            vector of length g (a rigid motion: the same for every point).
        components: Constrained components, e.g. ``(1,)`` for a smooth footing;
            None constrains all (a rough footing).
        penalty: Penalty stiffness β (Pa/m), > 0. About 10³ E/h (E Young's modulus,
            h cell size) keeps the gap negligible and the tangent well conditioned.
        reach: How far outside the material's cells a point still acts, in
            barycentric units of the nearest occupied cell and, as a distance, in
            that cell's largest heights, ≥ 0: one number or one per point. A
            body's surface lies between its points, often in a cell
            whose points have moved on, so a point up to half a cell out (0.5, the
            default) reads that cell's field extrapolated. Points inside a rigid
            body need 0: one read half a cell out holds the cell's gradient too,
            which stiffens the soil under a footing (its elastic slope by 13 %).
    """

    name: str
    x: np.ndarray
    weight: np.ndarray
    value: Callable[[float], Sequence[float]]
    penalty: float
    components: tuple[int, ...] | None = None
    reach: float | np.ndarray = SNAP_REACH

    def __post_init__(self) -> None:
        owner = f"PointDirichlet {self.name!r}"
        x, weight = _points(owner, self.x, self.weight)
        if not callable(self.value):
            raise TypeError(
                f"{owner}: value must be a function t -> displacement (m), "
                f"got {reprlib.repr(self.value)}"
            )
        penalty = check_range(owner, "penalty", self.penalty, lo=0.0, lo_open=True)
        components = self.components
        if components is not None:
            if isinstance(components, str) or not isinstance(components, Sequence | np.ndarray):
                raise TypeError(
                    f"{owner}: components must be a tuple of component indices "
                    f"such as (1,), got {reprlib.repr(components)}"
                )
            components = tuple(check_int(owner, "components", c, lo=0, hi=2) for c in components)
            if not components or len(set(components)) != len(components):
                # (none held nothing; (1, 1) doubled the penalty: a helper's probes)
                raise ValueError(
                    f"{owner}: components must name each held component once, e.g. (1,) "
                    f"or (0, 1), got {components}; None holds every component"
                )
        reach = check_finite(owner, "reach", self.reach, what="point")
        if reach.ndim > 1 or reach.size not in (1, x.shape[0]) or np.any(reach < 0):
            raise ValueError(
                f"{owner}: reach must be one number ≥ 0 or one per point (shape "
                f"({x.shape[0]},)), got {reprlib.repr(self.reach)}"
            )
        # object.__setattr__: the dataclass is frozen; keep the checked arrays and floats.
        for name, value in (
            ("x", x),
            ("weight", weight),
            ("penalty", penalty),
            ("components", components),
            ("reach", np.broadcast_to(reach, (x.shape[0],)).copy()),
        ):
            object.__setattr__(self, name, value)

    def at(self, t: float) -> np.ndarray:
        """Prescribed displacement at time ``t`` (m), shape (g,).

        Raises:
            ValueError: ``value`` returned a non-finite value at ``t``.
        """
        return _value_at(f"PointDirichlet {self.name!r}", "value", self.value, t)


@dataclass(frozen=True)
class PointTraction:
    """Surface traction carried by boundary points that move with the body.

    A :class:`Traction` stays on its grid facets; once the body moves off them its
    load acts on nothing. These points are convected with the grid solution like
    material points (Kratos MPM's particle line loads), so the load follows the
    body. The step adds ``−Σ_b w_b t(t)·δu(x_b)`` to the residual: with the points
    at the midpoints of boundary facets and ``w_b`` their lengths, this is exactly
    the grid traction's integral for a P1 displacement while the body still lies on
    those facets (``meshes.facet_points`` places them so); a P2 displacement needs
    ``facet_points(..., degree=2)``, and points one to a cell there are warned about.

    Args:
        name: Name of the load; the force it applies is reported in
            ``StepReport.reactions[name]`` (N, per unit thickness in 2D).
        x: Initial positions of the points (n, g), m, on the body's boundary. Under
            MPI every rank gives all of them (:func:`~fe_mpm.meshes.facet_points`
            gathers them); each point then acts on one rank.
        weight: Boundary measure each point represents (n,): length (m) in 2D, area in 3D.
        value: Traction vector (Pa), length g, a dead load (fixed direction).
        scale: Load factor as a function of time, ``t -> float``; constant 1 if None.
    """

    name: str
    x: np.ndarray
    weight: np.ndarray
    value: Sequence[float]
    scale: Callable[[float], float] | None = None

    def __post_init__(self) -> None:
        owner = f"PointTraction {self.name!r}"
        x, weight = _points(owner, self.x, self.weight)
        _check_callable(owner, "scale", self.scale, "a function t -> float")
        # object.__setattr__: the dataclass is frozen; keep the checked arrays and floats.
        for name, value in (
            ("x", x),
            ("weight", weight),
            ("value", _vector(owner, "value", self.value)),
        ):
            object.__setattr__(self, name, value)

    def at(self, t: float) -> np.ndarray:
        """Traction vector at time ``t`` (Pa).

        Raises:
            ValueError: ``scale`` returned a non-finite value at ``t``.
        """
        factor = _scale_at(f"PointTraction {self.name!r}", self.scale, t)
        return factor * np.asarray(self.value, dtype=np.float64)


@dataclass(frozen=True)
class PointPressure:
    """A normal pressure carried by boundary points that move with the body (a follower load).

    A :class:`Pressure` stays on its grid facets, along their normals; once the body
    moves off them, or its face turns or stretches, it loads the wrong place or
    nothing. These points are convected with the grid solution like a
    :class:`PointTraction`'s, and each also carries its piece of the body's face as
    an area vector ``a = weight · normal``, which deforms with the body by Nanson's
    rule, ``a ← cof(ΔF) a`` (ΔF the grid's increment at the point). The step adds
    ``Σ_b p cof(ΔF_b) a_b · δu(x_b)`` to the residual, with ΔF_b the unknown's, so the
    load follows the face within the step too and Newton sees its tangent: a
    pressurised cavity that expands to 1.5 times its radius is pushed along its
    current normals over its current length (``demos/cavity_expansion.py``).

    Nanson's rule with the ΔF of the point's cell is first order where the face's
    stretch varies across that cell, and the error adds up step by step: a thick
    Neo-Hookean cylinder (A = 1, B = 2, ν = 0.499, cells of 0.1, point domains)
    inflated to twice its bore in 10 steps got 4.8 % less area than its face had, and
    its bore stopped at 1.85 instead of 2 (a helper's scene, 2026-12-06). Given the
    ``corners`` of the facet piece each point stands for
    (``meshes.facet_points(..., corners=True)``), the corners move with the grid's
    displacement where they are, and after every step each point's area vector is
    its share of the moved piece: the face's own stretch, with no error carried from
    step to step. Within the step Nanson's rule still gives the load's tangent.

    Args:
        name: Name of the load; the force it applies is reported in
            ``StepReport.reactions[name]`` (N, per unit thickness in 2D).
        x: Initial positions of the points (n, g), m, on the body's boundary; under
            MPI every rank gives all of them (:func:`~fe_mpm.meshes.facet_points`,
            with ``degree=2`` for P2 displacements: two points per facet).
        weight: Boundary measure each point represents (n,): length (m) in 2D, area in 3D.
        normal: The body's outward normal at each point (n, g), or one for all; made
            unit here.
        value: Pressure p (Pa), finite: positive pushes into the body, negative pulls.
        scale: Load factor as a function of time, ``t -> float``; constant 1 if None.
        corners: The corners of the facet piece each point stands for (n, g, g), m:
            a segment's two ends in 2D, a triangle's three corners in 3D, across
            ``normal``; None: the area follows Nanson's rule alone.
    """

    name: str
    x: np.ndarray
    weight: np.ndarray
    normal: np.ndarray
    value: float
    scale: Callable[[float], float] | None = None
    corners: np.ndarray | None = None

    def __post_init__(self) -> None:
        owner = f"PointPressure {self.name!r}"
        x, weight = _points(owner, self.x, self.weight)
        normal = check_finite(owner, "normal", self.normal, what="point")
        if normal.shape == (x.shape[1],):
            normal = np.tile(normal, (x.shape[0], 1))
        if normal.shape != x.shape:
            raise ValueError(
                f"{owner}: normal must have shape {x.shape} (one per point) or "
                f"({x.shape[1]},), got {normal.shape}"
            )
        length = np.linalg.norm(normal, axis=1)
        if np.any(length <= 0.0):
            first = int(np.flatnonzero(length <= 0.0)[0])
            raise ValueError(f"{owner}: normal of point {first} is zero; give the outward normal")
        _check_callable(owner, "scale", self.scale, "a function t -> float")
        normal = normal / length[:, None]
        if self.corners is not None:
            object.__setattr__(self, "corners", _face_corners(owner, self.corners, normal))
        for name, value in (
            ("x", x),
            ("weight", weight),
            ("normal", normal),
            ("value", check_range(owner, "value", self.value)),
        ):
            object.__setattr__(self, name, value)

    def at(self, t: float) -> float:
        """Pressure at time ``t`` (Pa).

        Raises:
            ValueError: ``scale`` returned a non-finite value at ``t``.
        """
        return _scale_at(f"PointPressure {self.name!r}", self.scale, t) * self.value


def face_vectors(corners: np.ndarray) -> np.ndarray:
    """The area vectors of facet pieces (n, g) from their corners (n, g, g), m or m².

    A segment's length along its edge turned by −90° in 2D, half the cross product of
    a triangle's edges in 3D: the sign follows the corners' order.
    """
    edges = corners[:, 1:] - corners[:, :1]
    if corners.shape[1] == 2:
        return np.stack([edges[:, 0, 1], -edges[:, 0, 0]], axis=1)
    return 0.5 * np.cross(edges[:, 0], edges[:, 1])


#: A piece's corners must lie across the given normal to within this angle's cosine.
FACE_NORMAL_COS = 0.99


def _face_corners(owner: str, corners, normal: np.ndarray) -> np.ndarray:
    """``corners`` checked: (n, g, g), finite, each piece spanning a face across its normal."""
    n, g = normal.shape
    corners = check_finite(owner, "corners", corners, what="point")
    if corners.shape != (n, g, g):
        raise ValueError(f"{owner}: corners must have shape ({n}, {g}, {g}), got {corners.shape}")
    vectors = face_vectors(corners)
    size = np.linalg.norm(vectors, axis=1)
    if np.any(size <= 0.0):
        first = int(np.flatnonzero(size <= 0.0)[0])
        raise ValueError(f"{owner}: the corners of point {first} span no face")
    cos = np.abs(np.einsum("ni,ni->n", vectors, normal)) / size
    if np.any(cos < FACE_NORMAL_COS):
        first = int(np.argmin(cos))
        raise ValueError(
            f"{owner}: the corners of point {first} do not lie across its normal "
            f"(cos = {cos[first]:.3f}); give each point its own facet piece"
        )
    return corners


#: ``RigidWall(friction=STICKING)``: the wall does not let the body slip while they touch.
STICKING = math.inf


@dataclass(frozen=True)
class RigidWall:
    """A fixed rigid face on the grid's boundary: unilateral contact with Coulomb friction.

    The face is a plane of exterior grid facets (a channel bed, a wall, the face of
    a column the grid is meshed around). The body may press on it, slide along it
    and leave it; it cannot pass through. The wall acts on its grid nodes through a
    penalty spring per node (:mod:`fe_mpm.forms.contact`): a body pressing with
    pressure p enters it by p / ``penalty``, and that entry does not grow over
    steps (the springs keep their extension from step to step). Its force on the
    body is reported in ``StepReport.reactions[name]`` and, split into normal and
    tangential parts and node by node, in ``StepReport.walls[name]``.

    Args:
        name: Name of the wall in the reports.
        where: Facet tag or boundary marker of its facets, all on one plane.
        friction: Coulomb's friction coefficient μ ≥ 0 (μ = tan θ_fr): 0 is a
            smooth wall; :data:`STICKING` (∞) lets no slip happen while in contact.
        penalty: Spring stiffness per unit area β (Pa/m), > 0 (along the wall too
            when sticking); None: 10³ E / h, with E the law's Young's modulus and h
            the mean size of the wall's facets.
        slip_scale: The slip s over which friction rises to μ p (m), > 0: it
            reaches 76 % at s, 99.5 % at 3 s (see :mod:`fe_mpm.forms.contact`).
            None: 10⁻³ h. Below s the wall holds like a spring of stiffness μ p / s,
            so a body that should slide but whose elastic slip is below about 3 s
            (a stiff fill in a small hopper: ρ g H² / E) carries too little
            friction: give a slip scale well below the slip you expect
            (docs/limitations.md).
    """

    name: str
    where: Where
    friction: float = 0.0
    penalty: float | None = None
    slip_scale: float | None = None

    def __post_init__(self) -> None:
        owner = f"RigidWall {self.name!r}"
        if not isinstance(self.name, str) or not self.name:
            raise TypeError(f"RigidWall: name must be a non-empty string, got {self.name!r}")
        _check_where(owner, self.where)
        friction = self.friction
        if not (isinstance(friction, numbers.Real) and friction == math.inf):
            friction = check_range(owner, "friction", friction, lo=0.0)
        object.__setattr__(self, "friction", float(friction))
        for field in ("penalty", "slip_scale"):
            if getattr(self, field) is not None:
                value = check_range(owner, field, getattr(self, field), lo=0.0, lo_open=True)
                object.__setattr__(self, field, value)
