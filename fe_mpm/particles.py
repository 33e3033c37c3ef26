"""Material points: the carriers of mass, volume, deformation and history.

A :class:`MaterialPoints` set holds one row per point. Shapes use ``n`` for the
number of points and ``g`` for the geometric dimension (2 or 3).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import basix
import numpy as np
import numpy.typing as npt

from fe_mpm import parallel
from fe_mpm._dolfinx import dolfinx
from fe_mpm.checks import check_choice, check_finite, check_indices, check_int, check_range
from fe_mpm.cut_cells import inside_simplices

#: A cell whose size (d! times its area or volume) is below this share of its longest
#: edge to the power d is flat.
FLAT_CELL = 1e-10

#: A level set's value within this share of its largest magnitude is on its zero.
LEVEL_SET_ROUND_OFF = 1e-12

#: The per-point arrays of :class:`MaterialPoints` (all indexed by point first).
PER_POINT_FIELDS = (
    "x",
    "volume",
    "mass",
    "F",
    "stress",
    "cell",
    "x0",
    "velocity",
    "acceleration",
    "material",
)


def _one_per_point(name: str, values, n: int) -> np.ndarray:
    """``values`` (n,) checked finite: a number for each point, not one for all."""
    a = check_finite("MaterialPoints", name, values, what="point")
    if a.shape != (n,):
        raise ValueError(
            f"MaterialPoints: {name} must have one entry per point, shape ({n},), got "
            f"shape {a.shape} (np.full({n}, value) gives every point the same)"
        )
    return a.copy()


def _shaped(name: str, values, shape: tuple, described: str) -> np.ndarray:
    """``values`` as a float array of ``shape``, or a ValueError naming the field."""
    a = np.array(check_finite("MaterialPoints", name, values, what="point"), dtype=np.float64)
    if a.shape != shape:
        raise ValueError(
            f"MaterialPoints: {name} must have shape {described}, {shape} here, got {a.shape}"
        )
    return a


@dataclass
class MaterialPoints:
    """State carried by the material points between steps.

    Attributes:
        x: Positions, shape ``(n, g)`` (m).
        volume: Current volumes ``V_p``, shape ``(n,)`` (m³ per unit thickness in 2D).
        mass: Masses ``m_p``, shape ``(n,)`` (kg); constant in time.
        F: Deformation gradients, shape ``(n, g, g)``.
        stress: Cauchy stress, shape ``(n, 3, 3)`` (Pa; in 2D plane strain it
            includes σ_33), written after each step.
        cell: Background cell holding each point, shape ``(n,)``; ``-1`` before tracking.
        x0: Initial positions, shape ``(n, g)`` (m), for displacement output.
        velocity: Velocities ``v_p``, shape ``(n, g)`` (m/s); used by dynamic runs.
        acceleration: Accelerations ``a_p``, shape ``(n, g)`` (m/s²); used by dynamic runs.
        material: Each point's law, shape ``(n,)``: its index in the list of laws
            given to :class:`~fe_mpm.Simulation` (0, the only one, when it is given
            one law); set by ``seed(..., material=k)``.
        history: The material's internal variables by name, each ``(n, *shape)``
            (e.g. ``plastic_strain`` for J2); filled in by the simulation.
        density_given: False when ``mass`` is a placeholder (ρ₀ = 1 kg/m³) that the
            law's ``density`` replaces when the simulation starts (``seed`` without
            a density).
        simulated_to: The time (s) a :class:`~fe_mpm.Simulation` last stepped these
            points to; None while none has. A second simulation given them starts
            from their deformed state, and warns.

    Raises:
        TypeError: An array holds something other than real numbers.
        ValueError: A shape is wrong, a value is not finite, a volume is not > 0,
            a mass is < 0 or a given ``F`` has ``det F ≤ 0``; the message names the
            first bad point.
    """

    x: np.ndarray
    volume: np.ndarray
    mass: np.ndarray
    F: np.ndarray = field(default=None)  # type: ignore[assignment]
    stress: np.ndarray = field(default=None)  # type: ignore[assignment]
    cell: np.ndarray = field(default=None)  # type: ignore[assignment]
    x0: np.ndarray = field(default=None)  # type: ignore[assignment]
    velocity: np.ndarray = field(default=None)  # type: ignore[assignment]
    acceleration: np.ndarray = field(default=None)  # type: ignore[assignment]
    material: np.ndarray = field(default=None)  # type: ignore[assignment]
    history: dict[str, np.ndarray] = field(default_factory=dict)
    density_given: bool = True
    simulated_to: float | None = None

    def __post_init__(self) -> None:
        # Copies throughout: the points move and change in place, the caller's arrays must not.
        self.x = np.array(check_finite("MaterialPoints", "x", self.x, what="point"), order="C")
        if self.x.ndim != 2 or self.x.shape[1] not in (2, 3):
            raise ValueError(
                f"MaterialPoints: x must have shape (n, 2) or (n, 3), got {self.x.shape}"
            )
        n, g = self.x.shape
        self.volume = _one_per_point("volume", self.volume, n)
        self.mass = _one_per_point("mass", self.mass, n)
        if self.F is None:
            self.F = np.tile(np.eye(g), (n, 1, 1))
        else:
            self.F = self._checked_F(n, g).copy()
        self._refuse_bad_values()
        if self.stress is None:
            self.stress = np.zeros((n, 3, 3))
        else:
            self.stress = _shaped("stress", self.stress, (n, 3, 3), "(n, 3, 3), 3 x 3 in 2D too")
        if self.cell is None:
            self.cell = np.full(n, -1, dtype=np.int32)
        else:
            self.cell = _shaped("cell", self.cell, (n,), "(n,)").astype(np.int32)
        self.x0 = self.x.copy() if self.x0 is None else _shaped("x0", self.x0, (n, g), "(n, g)")
        for name in ("velocity", "acceleration"):
            if getattr(self, name) is None:
                setattr(self, name, np.zeros((n, g)))
        self.check_motion()
        self.material = self._checked_material(n)

    def check_motion(self, owner: str = "MaterialPoints", prefix: str = "") -> None:
        """Check the velocity and acceleration, which scripts often set after seeding.

        Each becomes a float array of shape (n, g), checked finite.

        Args:
            owner: Who asks, for the message.
            prefix: Put before the field's name in the message (``"points."``).

        Raises:
            ValueError: A value is not finite or the shape is not (n, g); the message
                names the field.
        """
        n, g = self.x.shape
        for name in ("velocity", "acceleration"):
            value = getattr(self, name)
            if np.shape(value) != (n, g):
                raise ValueError(
                    f"{owner}: {prefix}{name} must have shape {(n, g)} (one row per point), "
                    f"got {np.shape(value)}"
                )
            value = check_finite(owner, prefix + name, value, what="point")
            setattr(self, name, np.array(value, dtype=np.float64))

    def check_state(self, owner: str = "MaterialPoints", prefix: str = "") -> None:
        """Check again what a script may have set after seeding: x, volume, mass, F, stress.

        ``MaterialPoints`` checks them when built, but a script may change them in place
        (a point given det F < 0 ran to a stress of the wrong sign, a NaN position
        stopped Newton with "force scale nan"; a helper's scenes, 2026-12-06).

        Raises:
            ValueError: A value is not finite, a volume is ≤ 0, a mass < 0, det F ≤ 0, or
                a shape is wrong; the message names the field and the first point.
        """
        n, g = self.x.shape
        for name, shape in (
            ("x", (n, g)),
            ("volume", (n,)),
            ("mass", (n,)),
            ("F", (n, g, g)),
            ("stress", (n, 3, 3)),
        ):
            value = getattr(self, name)
            if np.shape(value) != shape:
                raise ValueError(
                    f"{owner}: {prefix}{name} must have shape {shape}, got {np.shape(value)}"
                )
            check_finite(owner, prefix + name, value, what="point")
        for name, value in self.history.items():
            # A script's own per-point field (a tag set to None crashed deep inside the
            # domains' tiling; a helper's excavation, 2026-12-07).
            if not isinstance(value, np.ndarray) or value.shape[:1] != (n,):
                raise ValueError(
                    f"{owner}: {prefix}history[{name!r}] must be a numpy array with one row "
                    f"per point, shape ({n}, ...), got {type(value).__name__} of shape "
                    f"{np.shape(value)}"
                )
        self._refuse_bad_values(owner, prefix)

    def _refuse_bad_values(self, owner: str = "MaterialPoints", prefix: str = "") -> None:
        """Refuse a volume ≤ 0, a mass < 0 or det F ≤ 0, naming the first such point.

        det F ≤ 0 is an inverted or flattened point: its volume V = J V₀ would be ≤ 0.
        """
        _refuse_points(prefix + "volume", self.volume <= 0, "> 0", self.volume, owner)
        _refuse_points(prefix + "mass", self.mass < 0, ">= 0", self.mass, owner)
        J = np.linalg.det(self.F)
        _refuse_points(f"det {prefix}F", J <= 0, "> 0", J, owner)

    def _checked_material(self, n: int) -> np.ndarray:
        """The laws' indices as a (n,) int array, each ≥ 0."""
        if self.material is None:
            return np.zeros(n, dtype=np.int32)
        labels = np.asarray(self.material)
        whole = labels.dtype.kind in "iu" or (
            labels.dtype.kind == "f" and np.all(np.isfinite(labels) & (labels == np.rint(labels)))
        )
        if not whole:  # bools, objects and fractions alike
            raise TypeError(
                "MaterialPoints: material must hold whole numbers (each point's law: its "
                f"index in Simulation's list of laws), got {labels.dtype}"
            )
        labels = np.broadcast_to(labels, (n,)) if labels.ndim == 0 else labels.reshape(-1)
        if labels.shape != (n,):
            raise ValueError(f"MaterialPoints: material must have shape ({n},), got {labels.shape}")
        _refuse_points("material", labels < 0, ">= 0", labels)
        _refuse_points("material", labels > np.iinfo(np.int32).max, "< 2**31", labels)
        return labels.astype(np.int32)

    def _checked_F(self, n: int, g: int) -> np.ndarray:
        """The given deformation gradients as a finite (n, g, g) float array."""
        F = check_finite("MaterialPoints", "F", self.F, what="point")
        if F.shape != (n, g, g):
            raise ValueError(f"MaterialPoints: F must have shape {(n, g, g)}, got {F.shape}")
        return F

    def __len__(self) -> int:
        return self.x.shape[0]

    @property
    def gdim(self) -> int:
        """Geometric dimension g."""
        return self.x.shape[1]

    @property
    def density(self) -> np.ndarray:
        """Current mass density ``m_p / V_p`` (kg/m³), shape ``(n,)``."""
        return self.mass / self.volume

    def momentum(self) -> np.ndarray:
        """Total linear momentum ``Σ m_p v_p`` (kg m/s), shape ``(g,)``."""
        return self.mass @ self.velocity

    def kinetic_energy(self) -> float:
        """Total kinetic energy ``Σ ½ m_p |v_p|²`` (J per unit thickness in 2D)."""
        return 0.5 * float(self.mass @ np.sum(self.velocity**2, axis=1))

    def extend(self, new: MaterialPoints) -> None:
        """Append the points ``new`` to these, in place, as :func:`merge` joins sets."""
        joined = merge(self, new)
        for name in PER_POINT_FIELDS:
            setattr(self, name, getattr(joined, name))
        self.history = joined.history

    def keep(self, mask: np.ndarray) -> None:
        """Keep only the points where ``mask`` is true (used when dropping points)."""
        for name in PER_POINT_FIELDS:
            setattr(self, name, getattr(self, name)[mask])
        self.history = {name: values[mask] for name, values in self.history.items()}


def coincident(x: np.ndarray) -> np.ndarray:
    """Which rows of ``x`` (n, k) equal another row, shape (n,).

    Sorted by a lexsort and compared with their neighbours: ``np.unique(axis=0)`` took
    8 times as long on 768 000 points (a helper's profile, 2026-12-06).
    """
    order = np.lexsort(x.T[::-1])
    in_order = x[order]
    same = np.all(in_order[1:] == in_order[:-1], axis=1)
    twice = np.zeros(len(x), dtype=bool)
    twice[order[1:][same]] = True
    twice[order[:-1][same]] = True
    return twice


def _refuse_points(
    field: str, bad: np.ndarray, valid: str, values: np.ndarray, owner: str = "MaterialPoints"
) -> None:
    """Raise ``ValueError`` naming the first point where ``bad`` holds, if any."""
    where = np.flatnonzero(bad)
    if where.size:
        i = int(where[0])
        raise ValueError(
            f"{owner}: {field} must be {valid} at every point; point {i} "
            f"has {values[i]:g} ({where.size} of {bad.size} points)"
        )


def _rule_with_count(cell: basix.CellType, per_cell: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the lowest-degree basix Gauss rule with exactly ``per_cell`` points.

    Only rules with positive weights and every point inside the cell qualify: a
    negative weight would give a point a negative volume, and a point on a face
    lies on the grid's boundary where the body touches it (on tetrahedra basix's
    rules of 5 and 31 points have a negative weight, and those of 14 and 15 points
    on the faces).
    """
    counts = {}
    for degree in range(0, 13):
        pts, wts = basix.make_quadrature(cell, degree)
        inside = np.all(pts > 0) and np.all(pts.sum(axis=1) < 1)
        if np.all(wts > 0) and inside:
            counts.setdefault(len(wts), (pts, wts))
    if per_cell not in counts:
        raise ValueError(
            f"seed: per_cell must be one of {sorted(counts)} on {cell.name} cells, got {per_cell}"
        )
    return counts[per_cell]


def seed(
    mesh: dolfinx.mesh.Mesh,
    per_cell: int = 1,
    *,
    density: float | None = None,
    cells: npt.ArrayLike | None = None,
    volumes: str = "gauss",
    level_set: Callable[[np.ndarray], np.ndarray]
    | Sequence[Callable[[np.ndarray], np.ndarray]]
    | None = None,
    material: int = 0,
) -> MaterialPoints:
    """Place material points at the Gauss points of the cells of ``mesh``.

    This is the thesis's initialisation (Iaconeta 2019, §2.4): the points sit at
    the Gauss points of a finite-element mesh of the body and share the cell's
    volume and mass.

    Args:
        mesh: An affine simplex mesh (triangles or tetrahedra) covering the body.
        per_cell: Points per cell; any size of a basix Gauss rule (triangles:
            1, 3, 6, 7, 12, ...; tetrahedra: 1, 4, 24, 57, ...). On triangles 1, 3
            and 12 sit where Kratos MPM's ``MATERIAL_POINTS_PER_ELEMENT`` puts them; 6
            is another rule than Kratos's.
        density: Mass density ρ₀ (kg/m³), > 0. None takes the law's ``density``
            when the simulation starts (1 if the law has none either); give it
            here to seed zones of different densities (see :func:`merge`).
        cells: Cells to seed: a 1-D array of local cell indices, each once; all
            cells by default. Under MPI every rank calls ``seed`` with its own
            selection, which may be empty on some ranks but not on all; ghost
            cells in it (``c >= size_local``, as ``cell_tags.find`` returns them)
            are left to the rank that owns them, which seeds them from its own
            selection. A boolean mask is refused: pass ``np.flatnonzero(mask)``.
        volumes: ``"gauss"`` gives each point the Gauss weight times the cell
            volume (exact quadrature of the initial body); ``"equal"`` splits the
            cell volume equally, as in the thesis.
        level_set: The body as the region where ``level_set(x) >= 0``, for a body
            whose surface crosses cells (a water level, a slope drawn on a plain
            grid). ``x`` has shape ``(3, n)``, as in
            ``dolfinx.mesh.locate_entities``; the result, shape ``(n,)``, is
            positive inside (a signed distance, e.g. ``lambda x: depth - x[1]``).
            Cells wholly inside get ``per_cell`` points; a cell the surface cuts
            gets ``per_cell`` points on each triangle (tetrahedron) of its inside
            part, where the level set's linear interpolant is ≥ 0 (exact for a
            planar surface), so the points integrate the body to the rule's degree
            and a fluid at rest stands in equilibrium; cells wholly outside get
            none. A node where ``|level_set|`` is within 1e-12 of its largest value
            lies on the surface, and a cell with every vertex there is inside or not
            as the level set at its centroid says (round-off no longer decides).
            A list of level sets gives the body where all are ≥ 0, each cutting
            the pieces the ones before it left: a polygon (polyhedron) given by its
            faces' planes is then exact in every cell, at its corners and across a
            layer thinner than a cell, where one level set written as their
            ``np.minimum`` is not (its linear interpolant misses the corner; a layer
            1.2 cells thick lost 12.5 % of its area, one 0.5 cells thick all of it).
            Combines with ``cells``, which then names the cells to consider.
        material: The points' law, ≥ 0: its index in the list of laws given to
            :class:`~fe_mpm.Simulation`, for a body of several materials (seed each
            zone with its index and :func:`merge` them). 0 for a body of one law.

    Returns:
        The material points, undeformed (``F = I``).

    Raises:
        TypeError: ``per_cell`` is not an int, or ``cells`` is a boolean mask or
            not integer indices.
        ValueError: A value lies outside its range, ``cells`` is not 1-D, is
            empty, holds duplicates or indices of no cell on this rank, or
            ``level_set`` gives values of the wrong shape, non-finite values, or
            leaves no cell inside on any rank.
    """
    if density is not None:
        check_range("seed", "density", density, lo=0.0, lo_open=True)
    check_choice("seed", "volumes", volumes, ("gauss", "equal"))
    per_cell = check_int("seed", "per_cell", per_cell, lo=1)
    material = check_int("seed", "material", material, lo=0)
    cell_type = simplex_cell_type(mesh)
    tdim = mesh.topology.dim
    cell_map = mesh.topology.index_map(tdim)
    num_cells = cell_map.size_local
    # A rank may own no cells, or none of the selection: it seeds nothing. Only a
    # selection that is empty on every rank is an error.
    if parallel.total(mesh.comm, num_cells) == 0:
        raise ValueError("seed: the mesh has no cells")
    ref_pts, ref_wts = _rule_with_count(cell_type, per_cell)
    chosen = cells is not None
    if cells is None:
        cells = np.arange(num_cells, dtype=np.int32)
    else:
        cells = _cells(cells, num_cells, cell_map.num_ghosts)
    if parallel.total(mesh.comm, cells.size) == 0:
        raise ValueError(
            "seed: cells is empty on every rank: no cells to seed (is the tag in "
            "cell_tags.find(tag) one the grid has? np.unique(cell_tags.values) lists them)"
            if chosen
            else "seed: the grid has no cells to seed"
        )

    X = mesh.geometry.x[:, : mesh.geometry.dim]
    nodes = X[mesh.geometry.dofmaps[0][cells]]  # (nc, tdim+1, g)
    if level_set is not None:
        # Each level set cuts the pieces the ones before it left: their intersection.
        sets = list(level_set) if isinstance(level_set, list | tuple) else [level_set]
        if not sets:
            raise ValueError("seed: level_set is an empty list; give one level set or more")
        for one in sets:
            nodes, piece_cell = inside_simplices(nodes, _values_at_vertices(one, mesh, nodes))
            cells = cells[piece_cell]
        if parallel.total(mesh.comm, cells.size) == 0:
            raise ValueError(
                "seed: level_set is nowhere positive in the cells to seed (at none of their "
                "vertices: a body narrower than a cell that falls between the grid's nodes "
                "is missed; give its faces as a list of level sets, or refine the grid)"
            )
    x0 = nodes[:, 0, :]
    jac = nodes[:, 1:, :] - x0[:, None, :]  # rows are edge vectors: x = x0 + ξ @ jac
    x = x0[:, None, :] + np.einsum("qk,ckg->cqg", ref_pts, jac)
    detJ = np.abs(np.linalg.det(jac))
    if volumes == "gauss":
        vol = detJ[:, None] * ref_wts[None, :]
    else:
        ref_vol = ref_wts.sum()
        vol = np.repeat((detJ * ref_vol / per_cell)[:, None], per_cell, axis=1)
    gdim = mesh.geometry.dim
    return MaterialPoints(
        x=x.reshape(-1, gdim),
        volume=vol.reshape(-1),
        mass=(1.0 if density is None else float(density)) * vol.reshape(-1),
        cell=np.repeat(cells, per_cell),
        material=np.full(x.shape[0] * per_cell, material, dtype=np.int32),
        density_given=density is not None,
    )


def _values_at_vertices(
    level_set: Callable, mesh: dolfinx.mesh.Mesh, corners: np.ndarray
) -> np.ndarray:
    """The level set at ``corners`` (nc, d + 1, g), shape (nc, d + 1), 0 where round-off decides.

    A node on the body's surface evaluates to ±1e-16 or so: a box given as the
    ``np.minimum`` of its faces, its corners typed as decimals that fall on grid nodes,
    lost a whole cell at a corner whose vertices all lay on the surface, as the signs
    fell (1.85 % of a 0.3 × 0.2 box; 192 of 342 such boxes lost area, a helper's scan,
    2026-12-06). Values within :data:`LEVEL_SET_ROUND_OFF` of the level set's largest
    magnitude on the grid's nodes count as 0, on the surface, and a simplex whose
    vertices all lie on it is inside or outside as the level set at its centroid says.
    Collective.

    Args:
        level_set: One of ``seed``'s level sets.
        mesh: The grid.
        corners: The vertices of the cells (or of the pieces of them) to cut.
    """
    on_nodes = _level_set_values(level_set, mesh.geometry.x)
    scale = parallel.largest(mesh.comm, float(np.max(np.abs(on_nodes), initial=0.0)))
    tolerance = LEVEL_SET_ROUND_OFF * scale
    n, vertices, g = corners.shape
    at = np.zeros((3, n * vertices))
    at[:g] = corners.reshape(-1, g).T
    values = _level_set_values(level_set, at.T).reshape(n, vertices).copy()
    values[np.abs(values) <= tolerance] = 0.0
    on_surface = np.flatnonzero(np.all(values == 0.0, axis=1))
    if on_surface.size:
        centroids = np.zeros((3, on_surface.size))
        centroids[:g] = corners[on_surface].mean(axis=1).T
        at_centroids = _level_set_values(level_set, centroids.T)
        values[on_surface[at_centroids < -tolerance]] = -1.0  # outside
    return values


def _level_set_values(level_set: Callable, x: np.ndarray) -> np.ndarray:
    """``level_set`` at the grid's nodes ``x`` (n, 3), checked: shape (n,), finite."""
    if not callable(level_set):
        raise TypeError(f"seed: level_set must be a function of x (3, n), got {level_set!r}")
    values = check_finite("seed", "level_set", level_set(x.T), what="grid node")
    if values.shape != (len(x),):
        raise ValueError(
            f"seed: level_set must return one value per point, shape ({len(x)},) for "
            f"x of shape (3, {len(x)}), got shape {values.shape}"
        )
    return values


def _cells(cells: npt.ArrayLike, num_cells: int, num_ghosts: int = 0) -> np.ndarray:
    """The cells to seed as int32 local indices, or raise saying what is wrong with them.

    Args:
        cells: The ``cells`` given to :func:`seed`.
        num_cells: Number of cells this rank owns (``size_local``).
        num_ghosts: Number of ghost cells after them, which belong to another rank
            that seeds them: dropped here.

    Returns:
        The owned cells among ``cells``, int32, in the order given.
    """
    a = check_indices(
        "seed",
        "cells",
        cells,
        num_cells + num_ghosts,
        what="cell indices",
        counted=f" (this rank's {num_cells} owned and {num_ghosts} ghost cells)",
    )
    values, counts = np.unique(a, return_counts=True)
    repeated = np.flatnonzero(counts > 1)
    if repeated.size:
        cell, k = int(values[repeated[0]]), int(counts[repeated[0]])
        times = "twice" if k == 2 else f"{k} times"
        raise ValueError(
            f"seed: cells holds duplicates, e.g. cell {cell} {times}; each cell "
            "would get its points again"
        )
    return a[a < num_cells]


def merge(*sets: MaterialPoints) -> MaterialPoints:
    """One set of points from several (zones seeded with other laws or densities).

    Every per-point field comes along, in the order of ``sets``: the velocities set on
    each zone (two bodies thrown at each other), deformation gradients, stresses and
    internal variables. Until 2026-12-05 only positions, volumes, masses and cells
    did, and a zone's velocity was dropped without a word.

    Raises:
        ValueError: No sets, sets of different dimensions, some seeded with a density
            and some without, sets holding different internal variables, or a field of
            a set with the wrong shape or a non-finite value (named: ``sets[1].velocity``;
            until 2026-12-07 a velocity set as one vector failed in numpy's concatenate).
    """
    if not sets:
        raise ValueError("merge: no point sets given")
    for k, s in enumerate(sets):
        if not isinstance(s, MaterialPoints):
            raise TypeError(
                f"merge: sets[{k}] must be MaterialPoints, got {type(s).__name__}; pass the "
                "sets as separate arguments, merge(a, b), or unpack a list, merge(*sets)"
            )
    given = {s.density_given for s in sets}
    if len(given) > 1:
        raise ValueError(
            "merge: some sets were seeded with a density and some without; "
            "give every zone its density (seed(..., density=...))"
        )
    if len({s.gdim for s in sets}) > 1:
        raise ValueError(
            f"merge: the sets have points of {sorted({s.gdim for s in sets})} dimensions"
        )
    if len({tuple(sorted(s.history)) for s in sets}) > 1:
        raise ValueError(
            "merge: the sets hold different internal variables "
            f"({[sorted(s.history) for s in sets]}); merge them before a simulation fills them "
            "in, or add new points to a running one with Simulation.add_points, which starts "
            "theirs at the law's initial values"
        )
    for i, s in enumerate(sets):  # a script may have set these after seeding
        s.check_state("merge", f"sets[{i}].")
        s.check_motion("merge", f"sets[{i}].")
    history = {name: np.concatenate([s.history[name] for s in sets]) for name in sets[0].history}
    fields = {name: np.concatenate([getattr(s, name) for s in sets]) for name in PER_POINT_FIELDS}
    stepped = [s.simulated_to for s in sets if s.simulated_to is not None]
    return MaterialPoints(
        **fields,
        history=history,
        density_given=given.pop(),
        simulated_to=max(stepped) if stepped else None,
    )


def simplex_cell_type(mesh: dolfinx.mesh.Mesh) -> basix.CellType:
    """The basix cell type of an affine simplex mesh; a clear error for anything else.

    Also refused: a grid of several cell types (a gmsh surface recombined into
    quadrilaterals beside triangles ended in DOLFINx's "Multiple index maps of this
    dimension"), and cells of no area or volume (a 2D gmsh model drawn in the x–z
    plane and read with ``gdim=2`` is flat: seeding it gave a body of 1e-16 m², and
    the first step spoke of a free rotation; a helper's scenes, 2026-12-06).
    Collective.
    """
    types = mesh.topology.entity_types[-1]
    if len(types) > 1:
        raise ValueError(
            "fe-mpm needs a grid of one simplex cell type, got a grid mixing "
            f"{' and '.join(t.name for t in types)} cells (a gmsh surface recombined "
            "into quadrilaterals? leave recombination off)"
        )
    name = mesh.topology.cell_name()
    if name not in ("triangle", "tetrahedron"):
        raise ValueError(f"fe-mpm needs a triangle or tetrahedron mesh, got {name} cells")
    if mesh.geometry.dim != mesh.topology.dim:
        raise ValueError(
            f"fe-mpm needs geometric dimension = topological dimension, got "
            f"gdim={mesh.geometry.dim}, tdim={mesh.topology.dim}"
        )
    if mesh.geometry.cmaps[0].degree != 1:
        raise ValueError("fe-mpm needs an affine (degree-1) mesh geometry")
    _refuse_flat_cells(mesh)
    return basix.CellType[name]


def _refuse_flat_cells(mesh: dolfinx.mesh.Mesh) -> None:
    """Refuse (collective) cells whose size is round-off against their longest edge.

    A cell's size over its longest edge to the power d is about 0.1 to 1 for a fair
    simplex; :data:`FLAT_CELL` is far below any cell a mesher makes.
    """
    tdim = mesh.topology.dim
    cells = mesh.topology.index_map(tdim).size_local
    corners = mesh.geometry.x[mesh.geometry.dofmaps[0][:cells], :tdim]
    edges = corners[:, 1:, :] - corners[:, :1, :]
    size = np.abs(np.linalg.det(edges)) if cells else np.zeros(0)
    longest = np.zeros(cells)
    for i in range(tdim + 1):
        for j in range(i):
            longest = np.maximum(longest, np.linalg.norm(corners[:, i] - corners[:, j], axis=1))
    flat = np.flatnonzero(size <= FLAT_CELL * longest**tdim)
    error = None
    if flat.size:
        k = int(flat[0])
        error = ValueError(
            f"fe-mpm needs cells with {'an area' if tdim == 2 else 'a volume'}: {flat.size} "
            f"of the grid's cells are flat (first: cell {k} at {corners[k].tolist()}). Was "
            "a 2D gmsh model drawn outside the x-y plane? Draw it in x-y."
        )
    parallel.raise_together(mesh.comm, error)
