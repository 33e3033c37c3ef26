"""Hypothesis strategies for small user scenes that nobody designed (tests/test_user_scenes.py).

A :class:`Scene` is plain, printable data: when a property fails, Hypothesis prints the
shrunk scene as ``Scene(...)``, and ``build(scene)`` rebuilds it exactly. Nothing here
asserts anything; the invariants live in the test file.

The scenes:

- a 2D or 3D block on ``create_rectangle``/``create_box`` (MPI.COMM_SELF, triangles or
  tetrahedra), 2–6 cells a side in 2D and 2–4 in 3D (time), sides 0.5–3 m;
- seeded fully, or only up to a body height (a margin of empty cells above it), or, in 2D,
  under a sloping line (a slope);
- a Neo-Hookean, J2 or Mohr-Coulomb law, E 1e6–1e8 Pa, ν 0–0.45, ρ 500–3000 kg/m³ (given
  to ``seed`` only; the body force acts through the points' mass);
- formulation ``u``, ``u-nbva`` (any law), ``up`` (the laws with ``kirchhoff_deviatoric``;
  Mohr-Coulomb only as Tresca there) or ``up-p2p1`` (Neo-Hookean with ≥ 3 points per cell);
- gravity along −y (y is "up" in 2D and 3D), constant or ramped, and on a fully seeded
  block optionally a grid traction on the top facets (same load factor as gravity);
- the base (y = 0) fixed, optionally rollers on the sides (normal component fixed);
- static (1–8 load steps to t = 1) or dynamic (Newmark, P1 only, t_end 0.01–0.05 s,
  optional damping).

The plastic strength is drawn relative to the largest vertical stress the loads can put in
the body, ``demand = ρ g H_body + |traction|``: ``strength="strong"`` draws 3–10 times it
(an equilibrium exists at every load step, so a static run must finish), ``"any"`` draws
0.1–10 times it (a weak body may collapse, and a ConvergenceError is then a fair answer).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from hypothesis import strategies as st

import fe_mpm
from fe_mpm._dolfinx import dolfinx  # the PyPI wheel needs its bootstrap before dolfinx

G = 9.81
#: Points per cell drawn, by dimension: the smallest of the Gauss rules ``seed`` accepts
#: (triangles 1, 3, 6, 7, 12, ...; tetrahedra 1, 4, 24, ...). Each count is a slot layout
#: and so a set of forms to compile; with a cold compile cache the larger counts cost the
#: suite more time than they add scenes.
PER_CELL = {2: (1, 3, 6), 3: (1, 4)}
DIAGONALS = {
    "right": dolfinx.mesh.DiagonalType.right,
    "left": dolfinx.mesh.DiagonalType.left,
    "crossed": dolfinx.mesh.DiagonalType.crossed,
}


def _sig(x: float, digits: int = 3) -> float:
    """Round to a few significant digits, so a printed scene reads (and rebuilds) exactly."""
    return float(f"{x:.{digits}g}")


def decades(lo: float, hi: float) -> st.SearchStrategy[float]:
    """10^(k/10) for lo ≤ 10^(k/10) ≤ hi, 3 significant digits; shrinks towards lo.

    Integers underneath, so a shrunk scene has round values (no 5e-324).
    """
    k_lo, k_hi = math.ceil(10 * math.log10(lo) - 1e-9), math.floor(10 * math.log10(hi) + 1e-9)
    return st.integers(k_lo, k_hi).map(lambda k: _sig(10.0 ** (k / 10)))


def grid(lo: float, hi: float, step: float) -> st.SearchStrategy[float]:
    """lo, lo + step, ..., hi (exactly representable as printed); shrinks towards lo."""
    n = round((hi - lo) / step)
    return st.integers(0, n).map(lambda k: _sig(lo + k * step, 6))


# -- the data of a scene -------------------------------------------------------------------------


@dataclass(frozen=True)
class Law:
    """A constitutive law by name and parameters (Pa, -, Pa, degrees)."""

    name: str  # "NeoHookean" | "J2Plasticity" | "MohrCoulomb"
    E: float
    nu: float
    strength: float = 0.0  # σ_Y for J2, c for Mohr-Coulomb
    friction_angle: float = 0.0

    def build(self):
        if self.name == "NeoHookean":
            return fe_mpm.NeoHookean(self.E, self.nu)
        if self.name == "J2Plasticity":
            return fe_mpm.J2Plasticity(self.E, self.nu, yield_stress=self.strength)
        return fe_mpm.MohrCoulomb(
            self.E, self.nu, cohesion=self.strength, friction_angle=self.friction_angle
        )


@dataclass(frozen=True)
class Scene:
    """One small scene. Lengths in m, density in kg/m³, traction in Pa, times in s.

    ``body_rows``: rows of cells seeded from the base (== cells[1]: no margin).
    ``slope``: (left, right) heights of the line under which a 2D slope is seeded, or None.
    """

    dim: int
    size: tuple[float, ...]
    cells: tuple[int, ...]
    diagonal: str
    per_cell: int
    body_rows: int
    slope: tuple[float, float] | None
    law: Law
    density: float
    formulation: str
    ramp: bool
    traction: tuple[float, ...] | None
    rollers: bool
    n_steps: int
    dynamic: bool = False
    t_end: float = 1.0
    damping: float = 0.0

    @property
    def h(self) -> float:
        """The smallest side of a cell's box (m): the unit of "a few cells"."""
        return min(s / n for s, n in zip(self.size, self.cells, strict=True))

    @property
    def body_height(self) -> float:
        if self.slope is not None:
            return max(self.slope)
        return self.size[1] * self.body_rows / self.cells[1]

    @property
    def demand(self) -> float:
        """The largest vertical stress the loads can cause, ρ g H_body + |traction| (Pa)."""
        traction = float(np.linalg.norm(self.traction)) if self.traction is not None else 0.0
        return self.density * G * self.body_height + traction

    @property
    def strength_ratio(self) -> float:
        """Uniaxial compressive strength over :attr:`demand` (inf for an elastic law)."""
        law = self.law
        if law.name == "NeoHookean":
            return math.inf
        if law.name == "J2Plasticity":
            return law.strength / self.demand
        phi = math.radians(law.friction_angle)
        return 2.0 * law.strength * math.cos(phi) / (1.0 - math.sin(phi)) / self.demand

    def load_factor(self, t: float) -> float:
        return t / self.t_end if self.ramp else 1.0


class _Ramp:
    """Load factor t / t_end (a class, not a lambda, so a scene's loads print plainly)."""

    def __init__(self, t_end: float):
        self.t_end = t_end

    def __call__(self, t: float) -> float:
        return t / self.t_end


@dataclass
class Built:
    """A scene set up: the simulation and what the invariants need."""

    scene: Scene
    mesh: dolfinx.mesh.Mesh
    points: fe_mpm.MaterialPoints
    sim: fe_mpm.Simulation
    gravity: np.ndarray  # (g,)
    top_area: float  # m (2D, per unit thickness) or m² (3D)

    def applied_load(self, t: float) -> np.ndarray:
        """Total external force on the body at time t (N, or N/m in 2D): weight + traction."""
        s = self.scene
        f = self.points.mass.sum() * self.gravity
        if s.traction is not None:
            f = f + self.top_area * np.asarray(s.traction)
        return s.load_factor(t) * f


def _close(a, b):
    return np.isclose(a, b, rtol=0.0, atol=1e-9)


def build(scene: Scene, min_step_fraction: float | None = None) -> Built:
    """Mesh, points and Simulation of a scene (reactions "base" and "supports" requested).

    ``min_step_fraction``: the smallest step ``run`` may cut to, as a fraction of the nominal
    step (None: fe-mpm's default, 1/1024). A failing step costs every halving down to it.
    """
    from mpi4py import MPI  # here: after fe_mpm, whose wheel bootstrap must come first

    s = scene
    g = s.dim
    L = s.size
    if g == 2:
        mesh = dolfinx.mesh.create_rectangle(
            MPI.COMM_SELF,
            [[0.0, 0.0], list(L)],
            list(s.cells),
            dolfinx.mesh.CellType.triangle,
            diagonal=DIAGONALS[s.diagonal],
        )
    else:
        mesh = dolfinx.mesh.create_box(
            MPI.COMM_SELF,
            [[0.0, 0.0, 0.0], list(L)],
            list(s.cells),
            dolfinx.mesh.CellType.tetrahedron,
        )
    tdim = mesh.topology.dim
    num_cells = mesh.topology.index_map(tdim).size_local
    centroids = dolfinx.mesh.compute_midpoints(mesh, tdim, np.arange(num_cells, dtype=np.int32))
    if s.slope is not None:
        left, right = s.slope
        below = centroids[:, 1] < left + (right - left) * centroids[:, 0] / L[0]
    else:
        below = centroids[:, 1] < s.body_height - 1e-9
    cells = np.flatnonzero(below).astype(np.int32)
    points = fe_mpm.seed(
        mesh, s.per_cell, density=s.density, cells=None if cells.size == num_cells else cells
    )

    def base(x):
        return _close(x[1], 0.0)

    sides = [c for c in range(g) if c != 1]
    dirichlet = [fe_mpm.Dirichlet(base)]
    if s.rollers:
        for c in sides:
            dirichlet.append(
                fe_mpm.Dirichlet(lambda x, c=c: _close(x[c], 0.0) | _close(x[c], L[c]), component=c)
            )

    def supports(x):
        held = base(x)
        if s.rollers:
            for c in sides:
                held = held | _close(x[c], 0.0) | _close(x[c], L[c])
        return held

    gravity = np.zeros(g)
    gravity[1] = -G
    scale = _Ramp(s.t_end) if s.ramp else None
    tractions = []
    if s.traction is not None:
        tractions.append(fe_mpm.Traction(lambda x: _close(x[1], L[1]), s.traction, scale=scale))
    kwargs = dict(dynamic=True, damping=s.damping) if s.dynamic else {}
    if min_step_fraction is not None:
        kwargs["min_step"] = min_step_fraction * s.t_end / s.n_steps
    sim = fe_mpm.Simulation(
        mesh,
        points,
        s.law.build(),
        s.formulation,
        dirichlet=dirichlet,
        tractions=tractions,
        body_force=tuple(gravity),
        body_force_scale=scale,
        reactions={"base": base, "supports": supports},
        **kwargs,
    )
    top_area = float(np.prod([L[c] for c in sides]))
    return Built(s, mesh, points, sim, gravity, top_area)


# -- strategies ----------------------------------------------------------------------------------


@st.composite
def laws(draw, demand: float, strength: str = "any", names=None, E=(1e6, 1e8)) -> Law:
    """A law whose plastic strength is ``factor × demand`` (see the module docstring)."""
    name = draw(st.sampled_from(names or ("NeoHookean", "J2Plasticity", "MohrCoulomb")))
    youngs = draw(decades(*E))
    nu = draw(grid(0.0, 0.45, 0.01))
    if name == "NeoHookean":
        return Law(name, youngs, nu)
    factor = draw(decades(3.0, 10.0) if strength == "strong" else decades(0.1, 10.0))
    if name == "J2Plasticity":
        return Law(name, youngs, nu, _sig(factor * demand))
    phi = draw(st.sampled_from((0.0, 0.0, 10.0, 20.0, 30.0, 40.0)))
    # Uniaxial compressive strength 2c cos φ / (1 − sin φ) = factor × demand.
    s = math.sin(math.radians(phi))
    cohesion = factor * demand * (1.0 - s) / (2.0 * math.cos(math.radians(phi)))
    return Law(name, youngs, nu, _sig(cohesion), phi)


@st.composite
def scenes(
    draw,
    *,
    dims=(2, 3),
    strength: str = "any",
    names=None,
    E=(1e6, 1e8),
    static: bool | None = None,
    rollers: bool | None = None,
    margins: bool = True,
    slopes: bool = True,
    tractions: bool = True,
    n_steps=(1, 8),
) -> Scene:
    """A random scene. ``static``/``rollers`` None: drawn; else fixed."""
    dim = draw(st.sampled_from(dims))
    n_max = 6 if dim == 2 else 4
    size = tuple(draw(grid(0.5, 3.0, 0.1)) for _ in range(dim))
    cells = tuple(draw(st.integers(2, n_max)) for _ in range(dim))
    diagonal = draw(st.sampled_from(tuple(DIAGONALS))) if dim == 2 else "right"
    per_cell = draw(st.sampled_from(PER_CELL[dim]))
    hy = size[1] / cells[1]

    shape = "block"
    if dim == 2 and slopes and draw(st.booleans()):
        shape = "slope"
    elif margins and draw(st.booleans()):
        shape = "margin"
    body_rows, slope = cells[1], None
    if shape == "margin":
        body_rows = draw(st.integers(1, cells[1] - 1))
    elif shape == "slope":
        left = _sig(draw(grid(0.5, 1.0, 0.05)) * size[1])
        right = _sig(hy + draw(grid(0.0, 0.9, 0.1)) * (left - hy))
        slope = (left, max(right, _sig(hy * 1.001)))

    density = draw(grid(500.0, 3000.0, 100.0))
    ramp = draw(st.booleans())
    traction = None
    body_h = max(slope) if slope else size[1] * body_rows / cells[1]
    weight_stress = density * G * body_h
    if tractions and shape == "block" and draw(st.booleans()):
        q = draw(grid(0.0, 1.0, 0.1)) * weight_stress
        shear = [
            draw(st.sampled_from((0.0, 0.1, -0.1, 0.2, -0.2))) * weight_stress
            for _ in range(dim - 1)
        ]
        traction = (shear[0], -q) if dim == 2 else (shear[0], -q, shear[1])
        traction = tuple(_sig(v) for v in traction)
    demand = weight_stress + (float(np.linalg.norm(traction)) if traction else 0.0)

    is_static = draw(st.booleans()) if static is None else static
    law = draw(laws(demand, strength, names, E))
    forms = ["u", "u-nbva"]
    if law.name != "MohrCoulomb" or law.friction_angle == 0.0:
        forms.append("up")
    if law.name == "NeoHookean" and per_cell >= 3 and is_static:
        forms.append("up-p2p1")
    formulation = draw(st.sampled_from(forms))
    has_rollers = draw(st.booleans()) if rollers is None else rollers
    steps = draw(st.integers(*n_steps))
    fields = (dim, size, cells, diagonal, per_cell, body_rows, slope, law, density)
    fields += (formulation, ramp, traction, has_rollers, steps)
    if is_static:
        return Scene(*fields)
    t_end = draw(grid(0.01, 0.05, 0.01))
    damping = draw(st.sampled_from((0.0, 0.0, 0.5, 1.5)))
    return Scene(*fields, dynamic=True, t_end=t_end, damping=damping)
