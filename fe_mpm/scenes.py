"""Ready-made simulations of the benchmark scenes (geometry from :mod:`fe_mpm.meshes`).

The demos spell these set-ups out step by step; tests and benchmarks call them.
"""

from __future__ import annotations

from collections.abc import Sequence

from mpi4py import MPI

import numpy as np

from fe_mpm import meshes
from fe_mpm._dolfinx import dolfinx
from fe_mpm.boundary import SNAP_REACH, Dirichlet, PointDirichlet, PointTraction, Traction
from fe_mpm.checks import check_int, check_range
from fe_mpm.formulations import FORMULATIONS
from fe_mpm.materials import J2Plasticity, MohrCoulomb, NeoHookean
from fe_mpm.particles import merge, seed
from fe_mpm.report import StepReport
from fe_mpm.simulation import Simulation


def _ramp_then_hold(t: float) -> float:
    """The load factor of :func:`cook_membrane`: ``t`` up to 1, then 1."""
    return min(t, 1.0)


def cook_membrane(
    n: int = 16,
    nu: float = 0.33,
    formulation: str = "u",
    *,
    E: float = 70.0,
    per_cell: int = 1,
    structured: bool = True,
    h: float | None = None,
    margin: int = 0,
    material=None,
    traction: float = 1.0 / 16.0,
    load: str = "grid",
    thickness: float | None = None,
    layers: int = 1,
    **options,
) -> Simulation:
    """Cook's membrane as in Iaconeta (2019) Table 5.1, with marker ``"A"`` at (48, 60).

    Clamped left edge, vertical traction 1/16 on the right edge ramped with the
    pseudo-time ``t`` (full load at ``t = 1``, held after), Neo-Hookean material
    unless another law is given.

    Args:
        n: Elements per side of the structured grid.
        nu: Poisson's ratio.
        formulation: See :mod:`fe_mpm.formulations`.
        E: Young's modulus.
        per_cell: Material points per triangle.
        structured: Structured (lower-left to upper-right cut) or unstructured grid.
        h: Element size of the unstructured grid.
        margin: Rows of empty cells above and below the body (for several steps).
        material: The law; default ``NeoHookean(E, nu)``.
        traction: Vertical traction on the right edge at full load.
        load: ``"grid"``: a :class:`Traction` on the right grid edge (the thesis's
            set-up; it stays there, so it suits one step or small motion);
            ``"points"``: a :class:`PointTraction` on points at the edge's facet
            midpoints (two Gauss points per facet for P2), which follow the body
            (for large motion over many steps; in one step it equals the grid load).
        thickness: None: the 2D membrane. A length > 0: the membrane extruded by it
            on a grid of tetrahedra, with rollers on its front and back faces
            (plane strain, so its answer converges to the 2D one) and marker ``"A"``
            at mid-thickness.
        layers: Layers of cells across the thickness (3D only).
        options: Passed on to :class:`~fe_mpm.simulation.Simulation`.
    """
    scene = meshes.cook_membrane(
        n=n, structured=structured, h=h, margin=margin, thickness=thickness, layers=layers
    )
    points = seed(scene.mesh, per_cell=per_cell, cells=meshes.body_cells(scene))
    shear = (0.0, traction) if thickness is None else (0.0, traction, 0.0)
    supports = [Dirichlet(meshes.COOK_CLAMPED)]
    if thickness is not None:
        supports.append(Dirichlet(meshes.COOK_FACES, 0.0, component=2))
    loads = {}
    if load == "grid":
        loads["tractions"] = [Traction(meshes.COOK_LOADED, shear, scale=_ramp_then_hold)]
    elif load == "points":
        loaded = scene.facet_tags.find(meshes.COOK_LOADED)
        spec = FORMULATIONS.get(formulation)  # an unknown one is Simulation's to refuse
        x, weight = meshes.facet_points(scene.mesh, loaded, spec.u_degree if spec else 1)
        loads["point_tractions"] = [PointTraction("load", x, weight, shear, scale=_ramp_then_hold)]
    else:
        raise ValueError(f"cook_membrane: load must be 'grid' or 'points', got {load!r}")
    sim = Simulation(
        scene.mesh,
        points,
        material or NeoHookean(E=E, nu=nu),
        formulation,
        facet_tags=scene.facet_tags,
        dirichlet=supports,
        **loads,
        **options,
    )
    sim.add_marker("A", meshes.COOK_POINT_A if thickness is None else (48.0, 60.0, thickness / 2))
    return sim


def tip_deflection(sim: Simulation) -> float:
    """Vertical displacement of Cook's point A (m)."""
    return float(sim.marker("A")[1] - meshes.COOK_POINT_A[1])


def footing_pressure(report: StepReport, B: float = 1.0) -> float:
    """The mean pressure q = −F_y / (B/2) (Pa) under the half footing of :func:`strip_footing`.

    Args:
        report: A step's report (its ``reactions["footing"]``, N per metre of strip).
        B: The footing's full width (m); the model is its half.
    """
    return float(-report.reactions["footing"][1] / (B / 2))


def strip_footing(
    formulation: str = "up",
    *,
    B: float = 1.0,
    cu: float = 100.0,
    E: float = 1.0e4,
    nu: float = 0.495,
    h: float | None = None,
    h_far: float | None = None,
    near_width: float | None = None,
    near_depth: float | None = None,
    points_near: int = 12,
    points_far: int = 3,
    settlement: float | None = None,
    smooth: bool = False,
    footing_thickness: float | None = None,
    penalty: float | None = None,
    base_points_per_cell: int = 2,
    edge_size: float | None = None,
    edge_radius: float | None = None,
    edge_line: bool = True,
    material=None,
    **options,
) -> Simulation:
    """The rigid strip footing of Iaconeta (2019) §6.2 on weightless soil, Tresca by default.

    The scene of ``demos/strip_footing.py`` (which explains it): a half model with
    rollers on the sides and a fixed base; the footing is a :class:`PointDirichlet`
    of base and body points pulled down by ``settlement · t``, whose force is
    ``reactions["footing"]``.

    Args:
        formulation: ``"u"``, ``"u-nbva"`` or ``"up"``.
        B: Footing width (m).
        cu: Undrained strength c_u (Pa); the default, 100 Pa, is in SI units (with
            ``E``): give both in another system.
        E: Young's modulus (Pa).
        nu: Poisson's ratio.
        h: Cell size near the footing (m); 0.05 B by default.
        h_far: Cell size far away (m); see :func:`fe_mpm.meshes.strip_footing`.
        near_width: Width of the refined, densely seeded zone (m).
        near_depth: Its depth (m).
        points_near: Material points per cell in the refined zone.
        points_far: Material points per cell elsewhere.
        settlement: Settlement at ``t = 1`` (m); 2 B by default.
        smooth: Smooth footing (vertical constraint only) instead of rough.
        footing_thickness: Height of the footing's body points (m); default 2h.
            They hold the upper nodes of the cells its base crosses, which the
            soil under the base holds only weakly once plastic (without them u-p
            stops at s/B = 0.5 on h = 0.2); they act only in cells that soil has
            reached (``PointDirichlet(reach=0)``).
        penalty: Penalty stiffness of the footing points (Pa/m); default 1e3 E/h
            (E/``edge_size`` with a finer edge). With 32 base points per cell and
            ``footing_thickness=0``, 50 E/h cuts the step-to-step jitter of q from
            0.196 to 0.136 (h = 0.2, 100 steps, ``benchmarks/footing_jitter.py``);
            its gap is then 2 % of a 20 mm step.
        base_points_per_cell: Penalty points on the footing's base per cell width h
            (``edge_size`` with a finer edge; ≥ 1). Each carries its share of the
            base; a point that crosses into the next cell moves that share at once,
            part of the step-to-step jitter of q (``benchmarks/footing_jitter.py``).
        edge_size: Cell size around the footing's edge and its path down to the
            settlement (m), ≤ h; None: h (see :func:`fe_mpm.meshes.strip_footing`).
            On stiff soil (E/c_u = 3000, rough) the collapse load on h = 0.1 comes
            out 1.125 × (2 + π) with none and 1.003 × with h/4 (1.038 × with
            E/c_u = 10 000, where the points barely move).
        edge_radius: Half-width of that zone (m); 0.4 B by default.
        edge_line: The edge's path x = B/2 as a grid line (default), so that the
            footing ends on grid nodes (see :func:`fe_mpm.meshes.strip_footing`).
        material: The soil's law; default ``MohrCoulomb.tresca(E, nu, cu)``. Given,
            ``nu`` and ``cu`` are not used, and ``E`` still sets the default
            penalty: pass the law's own.
        options: Passed on to :class:`~fe_mpm.simulation.Simulation`.
    """
    per_cell = check_int("strip_footing", "base_points_per_cell", base_points_per_cell, lo=1)
    # (0 ran a whole analysis of a footing that never moved)
    settlement = 2.0 * B if settlement is None else settlement
    check_range("strip_footing", "settlement", settlement, lo=0.0, lo_open=True)
    h = 0.05 * B if h is None else h
    scene = meshes.strip_footing(
        B,
        h=h,
        h_far=h_far,
        near_width=near_width,
        near_depth=near_depth,
        edge_size=edge_size,
        edge_radius=edge_radius,
        edge_line=edge_line,
        edge_depth=0.0 if edge_size is None else settlement,
    )
    near = scene.cell_tags.find(meshes.FOOTING_SOIL_NEAR)
    far = scene.cell_tags.find(meshes.FOOTING_SOIL)
    points = merge(
        seed(scene.mesh, points_near, cells=near), seed(scene.mesh, points_far, cells=far)
    )
    thickness = 2 * h if footing_thickness is None else footing_thickness
    n = max(4, int(round(B / h)))  # the body's lattice: two points per cell width
    x_body, w_body = meshes.footing_points(B, n, thickness)
    body = x_body[:, 1] > 0.0
    finest = h if edge_size is None else edge_size
    x_b, w_b = meshes.footing_points(B, max(4, int(round(B / finest))) * per_cell // 2)
    x_f, w_f = np.concatenate([x_b, x_body[body]]), np.concatenate([w_b, w_body[body]])
    footing = PointDirichlet(
        "footing",
        x_f,
        w_f,
        lambda t: np.array([0.0, -settlement * t]),
        penalty=penalty or 1e3 * E / finest,
        components=(1,) if smooth else None,
        # The body's points act only in cells that soil has reached: read through
        # the surface from half a cell above, they held the soil under the base
        # rigid (+13 % on the elastic slope, +30 % once the base was h/2 down).
        reach=np.r_[np.full(len(x_b), SNAP_REACH), np.zeros(int(body.sum()))],
    )
    return Simulation(
        scene.mesh,
        points,
        material or MohrCoulomb.tresca(E, nu, cu),
        formulation,
        facet_tags=scene.facet_tags,
        dirichlet=[
            Dirichlet(meshes.FOOTING_SYMMETRY, component=0),
            Dirichlet(meshes.FOOTING_FAR_SIDE, component=0),
            Dirichlet(meshes.FOOTING_BASE),
        ],
        point_dirichlet=[footing],
        **options,
    )


#: AMPLE's elastic column: height (m), Young's modulus (Pa), density (kg/m³), gravity (m/s²).
COLUMN = {"L": 50.0, "E": 4e5, "density": 80.0, "g": 10.0}


def elastic_column(ny: int, per_cell: int = 1, *, dim: int = 2, **options) -> Simulation:
    """AMPLE's column (1 m wide, ``ny`` cells high) under ramped self-weight.

    Neo-Hookean with ν = 0, rollers on the base and sides, gravity scaled by ``t``
    (10 % strain at the base at ``t = 1``). ``dim`` 2: plane strain on a grid of
    triangles; 3: a 1 m × 1 m prism of tetrahedra (six per cube of
    :func:`dolfinx.mesh.create_box`), one cell across, gravity along z.
    ``options`` go to :class:`Simulation`.
    """
    L, E, rho, g = COLUMN["L"], COLUMN["E"], COLUMN["density"], COLUMN["g"]
    dim = check_int("elastic_column", "dim", dim, lo=2, hi=3)
    if dim == 2:
        scene = meshes.column(1.0, L, 1, ny, margin=0)
        mesh, tags = scene.mesh, scene.facet_tags
        rollers = [
            Dirichlet(meshes.COLUMN_BASE, component=1),
            Dirichlet(meshes.COLUMN_SIDES, component=0),
        ]
    else:
        ny = check_int("elastic_column", "ny", ny, lo=1)
        mesh = dolfinx.mesh.create_box(
            MPI.COMM_WORLD,
            [[0.0, 0.0, 0.0], [1.0, 1.0, L]],
            [1, 1, ny],
            dolfinx.mesh.CellType.tetrahedron,
        )
        tags = None
        rollers = [
            Dirichlet(lambda x: np.isclose(x[2], 0.0), component=2),
            Dirichlet(lambda x: np.isclose(x[0], 0.0) | np.isclose(x[0], 1.0), component=0),
            Dirichlet(lambda x: np.isclose(x[1], 0.0) | np.isclose(x[1], 1.0), component=1),
        ]
    return Simulation(
        mesh,
        seed(mesh, per_cell=per_cell, density=rho),
        NeoHookean(E, 0.0, rho),
        facet_tags=tags,
        dirichlet=rollers,
        body_force=(0.0,) * (dim - 1) + (-g,),
        body_force_scale=lambda t: t,
        **options,
    )


def column_stress_error(sim: Simulation) -> float:
    """AMPLE's error of :func:`elastic_column` at full load (dimensionless).

    ``Σ_p abs(σ_yy,p + ρ₀ g (L − Y_p)) V_p / (ρ₀ g L Σ_p V_p)``, Y_p the initial height
    (along z in 3D): equilibrium gives σ_yy = −ρ₀ g (L − Y) exactly, for any law.
    """
    L, rho, g = COLUMN["L"], COLUMN["density"], COLUMN["g"]
    pts = sim.points
    up = pts.gdim - 1
    exact = -rho * g * (L - pts.x0[:, up])
    error = np.sum(np.abs(pts.stress[:, up, up] - exact) * pts.volume)
    return float(error / (rho * g * L * pts.volume.sum()))


#: The squeezed block of :func:`platen_compression`: Young's modulus (Pa), Poisson's
#: ratio, and the flow stress of its von Mises law (Pa).
PLATEN = {"E": 1000.0, "nu": 0.3, "yield_stress": 1.0}
PLATEN_LAWS = ("neo-hookean", "j2")


def _platen_law(law: str):
    """The block's law by name: ``"neo-hookean"`` or perfectly plastic ``"j2"``."""
    if law not in PLATEN_LAWS:
        raise ValueError(f"platen_compression: law must be one of {PLATEN_LAWS}, got {law!r}")
    E, nu = PLATEN["E"], PLATEN["nu"]
    if law == "j2":
        return J2Plasticity(E, nu, PLATEN["yield_stress"])
    return NeoHookean(E, nu)


def platen_compression(
    n: int,
    per_cell: int = 3,
    *,
    law: str = "neo-hookean",
    dim: int = 2,
    formulation: str = "u",
    compression: float = 0.5,
    platen_points_per_cell: int = 6,
    layers: Sequence | None = None,
    **options,
) -> Simulation:
    """A unit block squeezed between smooth platens to ``1 − compression`` of its length.

    The deformation is homogeneous, so the platen's force has a closed form
    (:func:`platen_force_exact`) at every stretch, for any grid and any number of
    steps: what a run adds to it is the method's own error, mostly cell crossing
    as the block widens through the empty cells beside it. A quarter (an eighth in
    3D) of the block, [0, 1]^dim, with rollers on the planes x = 0, y = 0 (and z = 0),
    on a grid of ``n`` cells per metre (triangles, or six tetrahedra per cube) wide
    enough for the block's widening; the platen is a :class:`PointDirichlet` named
    ``"platen"`` on x = 1 that constrains x only and moves by ``−compression · t``.
    Its points cover the whole grid beside the block: the block's side face widens,
    and a point above it takes part once material reaches it.

    Args:
        n: Cells per metre (the block is ``n`` cells long), ≥ 2.
        per_cell: Material points per cell.
        law: ``"neo-hookean"`` or ``"j2"`` (von Mises, perfectly plastic), with
            :data:`PLATEN`'s constants.
        dim: 2 (plane strain) or 3.
        formulation: Passed to :class:`Simulation`.
        compression: Shortening at ``t = 1`` over the initial length, in (0, 0.8].
        platen_points_per_cell: The platen's points per cell width (per cell side in
            3D) at the start, ≥ 1. The face they hold widens, up to twice at half the
            length, and P2 needs two per facet: with two per cell P2/P1 Neo-Hookean
            with domains was 4.3 % low at half the length and the J2 block stopped
            at 42 %; with six both are within 0.05 % (P1 moves by 0.02 %).
        layers: Laws in place of ``law``, for a block of several materials: equal
            bands across the platen (side by side along y, the first at y = 0), each
            squeezed alike, so the platen carries the sum of their forces where
            their laws keep the bands' widening alike (the same ν, or all plastic).
        options: Passed on to :class:`~fe_mpm.simulation.Simulation`.
    """
    n = check_int("platen_compression", "n", n, lo=2)
    dim = check_int("platen_compression", "dim", dim, lo=2, hi=3)
    compression = check_range(
        "platen_compression", "compression", compression, lo=0.0, hi=0.8, lo_open=True
    )
    platen_points_per_cell = check_int(
        "platen_compression", "platen_points_per_cell", platen_points_per_cell, lo=1
    )
    material = _platen_law(law) if layers is None else list(layers)
    # The widest the block gets: incompressible, its side grows by λ^(−1/(dim − 1)).
    side = (1.0 - compression) ** (-1.0 / (dim - 1)) + 2.0 / n
    extent = [1.0 + 2.0 / n] + [side] * (dim - 1)
    cells = [int(np.ceil(e * n)) for e in extent]
    top = [c / n for c in cells]
    kind = dolfinx.mesh.CellType.triangle if dim == 2 else dolfinx.mesh.CellType.tetrahedron
    create = dolfinx.mesh.create_rectangle if dim == 2 else dolfinx.mesh.create_box
    mesh = create(MPI.COMM_WORLD, [[0.0] * dim, top], cells, kind)
    points = seed(mesh, per_cell=per_cell, density=1.0)
    points.keep(np.all(points.x < 1.0, axis=1))
    if layers is not None:
        band = np.floor(points.x[:, 1] * len(material)).astype(np.int32)
        points.material = np.minimum(band, len(material) - 1)
    # The platen's points over the grid's side, less a margin of a cell.
    m = platen_points_per_cell * (cells[1] - 1)
    spacing = (top[1] - 1.0 / n) / m
    lateral = (np.arange(m) + 0.5) * spacing
    grids = np.meshgrid(*[lateral] * (dim - 1), indexing="ij")
    x_platen = np.column_stack([np.ones(m ** (dim - 1))] + [g.ravel() for g in grids])
    platen = PointDirichlet(
        "platen",
        x_platen,
        np.full(len(x_platen), spacing ** (dim - 1)),
        lambda t: np.r_[-compression * t, np.zeros(dim - 1)],
        penalty=1e3 * PLATEN["E"] * n,
        components=(0,),
    )
    rollers = [Dirichlet(lambda x, i=i: np.isclose(x[i], 0.0), component=i) for i in range(dim)]
    return Simulation(
        mesh, points, material, formulation, dirichlet=rollers, point_dirichlet=[platen], **options
    )


def _platen_state(
    owner: str, law: str, stretch: float, dim: int, formulation: str
) -> tuple[float, float]:
    """Kirchhoff's τ_xx (Pa) and J of the block of :func:`platen_compression` at ``stretch``.

    - Neo-Hookean: F = diag(λ, μ_t, μ_t) (plane strain: μ_t in y only), the
      transverse stretch μ_t from τ_yy = 0 (bisection). In the u forms the law is
      the full one, τ = λ_L ln J I + μ (b − I); the mixed forms split it,
      τ = K J (J − 1) I + μ dev(b̄) (``docs/formulations.md``), another material
      away from J = 1, whose volumetric stress is weakest at J = 1/2: past that
      (near λ = 0.47 in plane strain) a squeezed block has no stable state, and
      below λ ≈ 0.4 none free across.
    - Perfectly plastic J2: the rigid-plastic limit, τ_xx = −(2/√3) σ_Y in plane
      strain (s_zz = 0 once the flow is plastic) and −σ_Y in 3D, exact once
      1 − λ ≫ σ_Y / E (10⁻³ here). J = 1 leaves out the elastic volume change,
      σ_Y / (√3 K) = 7e-4 in plane strain here.

    Raises:
        ValueError: ``stretch`` is not in (0, 1], or the split law has no stable
            state there (the message says so, with ``owner``'s name).
    """
    material = _platen_law(law)
    dim = check_int(owner, "dim", dim, lo=2, hi=3)
    stretch = check_range(owner, "stretch", stretch, lo=0.0, hi=1.0, lo_open=True)
    if formulation not in FORMULATIONS:
        raise ValueError(
            f"{owner}: formulation must be one of {tuple(FORMULATIONS)}, got {formulation!r}"
        )
    if law == "j2":
        return -(2.0 / np.sqrt(3.0) if dim == 2 else 1.0) * material.yield_stress, 1.0
    mu, lam, K = material.mu, material.lmbda, material.bulk_modulus
    split = FORMULATIONS[formulation].pressure

    def kirchhoff(t: float) -> tuple[float, float, float]:
        """τ_xx, τ_yy and J at the transverse stretch t."""
        stretches = np.array([stretch, t, t if dim == 3 else 1.0])
        J = float(np.prod(stretches))
        if split:
            b_bar = J ** (-2.0 / 3.0) * stretches**2
            dev = b_bar - b_bar.mean()
            return K * J * (J - 1.0) + mu * dev[0], K * J * (J - 1.0) + mu * dev[1], J
        return lam * np.log(J) + mu * (stretch**2 - 1.0), lam * np.log(J) + mu * (t * t - 1.0), J

    lo, hi = 1.0, 1.0 / stretch  # τ_yy(1) < 0 (λ ≤ 1) and τ_yy(1/λ) > 0, but see the split law
    if stretch < 1.0 and kirchhoff(lo)[1] >= 0.0:
        lo = hi  # no root in the bracket: refused below
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if kirchhoff(mid)[1] < 0.0 else (lo, mid)
    tau_xx, tau_yy, J = kirchhoff(lo)
    if split and (J <= 0.5 or abs(tau_yy) > 1e-9 * abs(tau_xx)):
        raise ValueError(
            f"{owner}: the mixed forms' split Neo-Hookean has no stable state free "
            f"across at stretch {stretch:g} (J ≤ 1/2, where its volumetric stress "
            f"K J (J − 1) turns over): squeeze it less"
        )
    return tau_xx, J


def platen_force_exact(law: str, stretch: float, dim: int = 2, formulation: str = "u") -> float:
    """The force (N; N/m in 2D) on the platen of :func:`platen_compression` at ``stretch``.

    ``stretch`` λ, in (0, 1], is the block's length over its initial length. The block
    is homogeneous and free across, so the platen carries ``−τ_xx / λ`` on the unit
    face: Kirchhoff's τ_xx (its Cauchy stress times J) over λ, since the face's area
    grows by J / λ. τ_xx is :func:`_platen_state`'s; ``formulation`` matters for the
    Neo-Hookean law, which the mixed forms split.
    """
    return -_platen_state("platen_force_exact", law, stretch, dim, formulation)[0] / stretch


def platen_stress_exact(law: str, stretch: float, dim: int = 2, formulation: str = "u") -> float:
    """The Cauchy stress σ_xx (Pa) of every point of :func:`platen_compression` at ``stretch``."""
    tau, J = _platen_state("platen_stress_exact", law, stretch, dim, formulation)
    return tau / J


def platen_force(report: StepReport) -> float:
    """The platen's push on the block of :func:`platen_compression` (N; N/m in 2D), > 0."""
    return -float(report.reactions["platen"][0])
