"""Material points: the carriers of mass, volume, deformation and history.

A :class:`MaterialPoints` set holds one row per point. Shapes use ``n`` for the
number of points and ``g`` for the geometric dimension (2 or 3).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import basix
import numpy as np
import numpy.typing as npt

from fe_mpm._dolfinx import dolfinx
from fe_mpm.checks import check_choice, check_range

#: The per-point arrays of :class:`MaterialPoints` (all indexed by point first).
PER_POINT_FIELDS = ("x", "volume", "mass", "F", "stress", "cell", "x0", "velocity", "acceleration")


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
        history: The material's internal variables by name, each ``(n, *shape)``
            (e.g. ``plastic_strain`` for J2); filled in by the simulation.
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
    history: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.x = np.ascontiguousarray(self.x, dtype=np.float64)
        if self.x.ndim != 2 or self.x.shape[1] not in (2, 3):
            raise ValueError(
                f"MaterialPoints: x must have shape (n, 2) or (n, 3), got {self.x.shape}"
            )
        n, g = self.x.shape
        self.volume = np.asarray(self.volume, dtype=np.float64).reshape(n)
        self.mass = np.asarray(self.mass, dtype=np.float64).reshape(n)
        if np.any(self.volume <= 0) or not np.all(np.isfinite(self.volume)):
            raise ValueError("MaterialPoints: volume must be > 0 and finite at every point")
        if np.any(self.mass < 0):
            raise ValueError("MaterialPoints: mass must be >= 0 at every point")
        if self.F is None:
            self.F = np.tile(np.eye(g), (n, 1, 1))
        if self.stress is None:
            self.stress = np.zeros((n, 3, 3))
        if self.cell is None:
            self.cell = np.full(n, -1, dtype=np.int32)
        if self.x0 is None:
            self.x0 = self.x.copy()
        for name in ("velocity", "acceleration"):
            value = getattr(self, name)
            value = np.zeros((n, g)) if value is None else np.array(value, dtype=np.float64)
            if value.shape != (n, g):
                raise ValueError(
                    f"MaterialPoints: {name} must have shape {(n, g)}, got {value.shape}"
                )
            setattr(self, name, value)

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

    def keep(self, mask: np.ndarray) -> None:
        """Keep only the points where ``mask`` is true (used when dropping points)."""
        for name in PER_POINT_FIELDS:
            setattr(self, name, getattr(self, name)[mask])
        self.history = {name: values[mask] for name, values in self.history.items()}


def _rule_with_count(cell: basix.CellType, per_cell: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the lowest-degree basix Gauss rule with exactly ``per_cell`` points."""
    counts = {}
    for degree in range(0, 13):
        pts, wts = basix.make_quadrature(cell, degree)
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
    density: float = 1.0,
    cells: npt.ArrayLike | None = None,
    volumes: str = "gauss",
) -> MaterialPoints:
    """Place material points at the Gauss points of the cells of ``mesh``.

    This is the thesis's initialisation (Iaconeta 2019, §2.4): the points sit at
    the Gauss points of a finite-element mesh of the body and share the cell's
    volume and mass.

    Args:
        mesh: An affine simplex mesh (triangles or tetrahedra) covering the body.
        per_cell: Points per cell; any size of a basix Gauss rule (triangles:
            1, 3, 6, 7, 12, ...; tetrahedra: 1, 4, 6, 11, ...).
        density: Mass density ρ₀ (kg/m³), > 0.
        cells: Cells to seed (local indices); all cells by default.
        volumes: ``"gauss"`` gives each point the Gauss weight times the cell
            volume (exact quadrature of the initial body); ``"equal"`` splits the
            cell volume equally, as in the thesis.

    Returns:
        The material points, undeformed (``F = I``).
    """
    check_range("seed", "density", density, lo=0.0, lo_open=True)
    check_choice("seed", "volumes", volumes, ("gauss", "equal"))
    if per_cell < 1:
        raise ValueError(f"seed: per_cell must be >= 1, got {per_cell}")
    tdim = mesh.topology.dim
    num_cells = mesh.topology.index_map(tdim).size_local
    if num_cells == 0:
        raise ValueError("seed: the mesh has no cells")
    cell_type = simplex_cell_type(mesh)
    ref_pts, ref_wts = _rule_with_count(cell_type, per_cell)
    cells = np.arange(num_cells, dtype=np.int32) if cells is None else np.asarray(cells, np.int32)
    if cells.size == 0:
        raise ValueError("seed: no cells to seed")

    X = mesh.geometry.x[:, : mesh.geometry.dim]
    nodes = X[mesh.geometry.dofmaps[0][cells]]  # (nc, tdim+1, g)
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
        mass=density * vol.reshape(-1),
        cell=np.repeat(cells, per_cell),
    )


def merge(*sets: MaterialPoints) -> MaterialPoints:
    """One set of undeformed points from several seeds (e.g. zones seeded at other densities)."""
    if not sets:
        raise ValueError("merge: no point sets given")
    return MaterialPoints(
        x=np.vstack([s.x for s in sets]),
        volume=np.concatenate([s.volume for s in sets]),
        mass=np.concatenate([s.mass for s in sets]),
        cell=np.concatenate([s.cell for s in sets]),
    )


def simplex_cell_type(mesh: dolfinx.mesh.Mesh) -> basix.CellType:
    """The basix cell type of an affine simplex mesh; a clear error for anything else."""
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
    return basix.CellType[name]
