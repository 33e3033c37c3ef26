"""Boundary points with a prescribed displacement (penalty), the footing's boundary condition.

A smooth rigid platen pushes a Neo-Hookean block down by 10 % in plane strain,
with rollers below and on the left and the right side free. The deformation is
homogeneous, F = diag(λ_x, 0.9), with λ_x from σ_xx = 0:
τ_xx = λ ln J + μ(λ_x² − 1) = 0, J = 0.9 λ_x. The platen force per unit
thickness is σ_yy times the current width.

The platen's points sit inside the grid's top cells after the first step, so
their force reaches the nodes below them too (through N_I(x_b)): the
non-conforming boundary error of MPM. The stress field is then homogeneous only
to a few per cent, and the test allows for that; the stroke itself is exact to
the penalty gap.
"""

import warnings

import numpy as np
import pytest

import fe_mpm
from fe_mpm import meshes
from fe_mpm.meshes import rectangle_mesh

E, NU, STRETCH = 10.0, 0.3, 0.9


def _platen_run(components=(1,), penalty=1e5, formulation="u", steps=4, above=None):
    """The platen; ``above``: the reach of a second row of its points 0.1 above it."""
    mesh = rectangle_mesh((0.0, 0.0), (1.4, 1.2), (7, 6))
    points = fe_mpm.seed(mesh, per_cell=3)
    points.keep((points.x[:, 0] < 1.0) & (points.x[:, 1] < 1.0))
    n = 20
    xb = np.column_stack([(np.arange(n) + 0.5) / n, np.ones(n)])
    reach = 0.5
    if above is not None:  # half a cell above the body's top
        xb = np.vstack([xb, xb + [0.0, 0.1]])
        reach = np.r_[np.full(n, 0.5), np.full(n, above)]
    platen = fe_mpm.PointDirichlet(
        "platen",
        xb,
        np.full(len(xb), 1.0 / n),
        lambda t: np.array([0.0, (STRETCH - 1) * t]),
        penalty=penalty,
        components=components,
        reach=reach,
    )
    sim = fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.NeoHookean(E, NU),
        formulation,
        dirichlet=[
            fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0), component=1),
            fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0), component=0),
        ],
        point_dirichlet=[platen],
    )
    reports = sim.run(1.0, steps, progress=False)
    return sim, points, reports


def test_smooth_platen_gives_the_homogeneous_compression():
    sim, points, reports = _platen_run()
    mat = sim.material
    lam, mu = mat.lmbda, mat.mu

    def tau_xx(lx):
        return lam * np.log(STRETCH * lx) + mu * (lx**2 - 1)

    lo, hi = 1.0, 1.5  # τ_xx(1) < 0 < τ_xx(1.5)
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if tau_xx(mid) < 0 else (lo, mid)
    lx = 0.5 * (lo + hi)
    J = STRETCH * lx
    sigma_yy = (lam * np.log(J) + mu * (STRETCH**2 - 1)) / J
    # Mean vertical stretch: the stroke, less the part the top cells absorb (measured 0.3 %).
    assert np.average(points.F[:, 1, 1], weights=points.volume) == pytest.approx(STRETCH, abs=5e-3)
    assert np.abs(points.F[:, 1, 1] - STRETCH).max() < 0.04  # non-conforming boundary error
    force = reports[-1].reactions["platen"][1]
    # Pushes down on the body; the top cells absorb part of the stroke (measured −2.8 %).
    assert force == pytest.approx(sigma_yy * lx, rel=0.04)
    assert max(r.newton_iterations for r in reports) <= 6


def test_platen_gap_falls_like_one_over_the_penalty_and_does_not_accumulate():
    """The gap is re-measured from the convected points every step, so it is load/β."""
    gaps = {}
    for beta in (1e3, 1e5):
        sim, _, reports = _platen_run(penalty=beta)
        pp = sim._boundary.points
        gap = pp.x[:, 1] - pp.targets(sim.t)[:, 1]
        gaps[beta] = np.average(gap, weights=pp.weight)
        load = abs(reports[-1].reactions["platen"][1])
        # force = Σ β w_b gap_b exactly: the mean gap is load/(β × platen width 1)
        assert gaps[beta] == pytest.approx(load / beta, rel=1e-6)
    assert gaps[1e5] < gaps[1e3] / 50


def test_points_inside_a_rigid_body_act_only_where_material_is():
    """A footing's body points: read half a cell out of the body, they would hold
    its cells' gradient too.

    A second row of platen points half a cell above the body's top, in the empty
    cells there: with ``reach=0`` it takes no part, and the run is the platen's
    own to round-off; with the surface's ``reach=0.5`` it reads the top cells'
    field extrapolated and stiffens them (measured: the force +18 %; the same
    to every digit with reach 0).
    """
    alone = _platen_run()[2][-1].reactions["platen"][1]
    inert = _platen_run(above=0.0)[2][-1].reactions["platen"][1]
    reaching = _platen_run(above=0.5)[2][-1].reactions["platen"][1]
    assert inert == pytest.approx(alone, rel=1e-9)
    assert abs(reaching / alone - 1) > 0.01, (reaching, alone)


@pytest.mark.parametrize(
    "bad, match",
    [
        (dict(penalty=0.0), "penalty must lie in"),
        (dict(weight=np.zeros(2)), "every weight must be > 0"),
        (dict(x=np.zeros((2, 3))), "x must have shape"),
        (dict(components=(2,)), "components must lie in"),
        (dict(reach=-0.1), "reach must be one number ≥ 0 or one per point"),
        (dict(reach=[0.5, 0.5, 0.5]), "reach must be one number ≥ 0 or one per point"),
    ],
)
def test_bad_point_conditions_are_named(bad, match):
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    spec = dict(
        name="p",
        x=np.array([[0.2, 0.5], [0.6, 0.5]]),
        weight=np.ones(2),
        value=lambda t: (0.0, 0.0),
        penalty=1.0,
    )
    spec.update(bad)
    with pytest.raises(ValueError, match=match):
        fe_mpm.Simulation(
            mesh,
            fe_mpm.seed(mesh),
            fe_mpm.NeoHookean(1.0, 0.3),
            point_dirichlet=[fe_mpm.PointDirichlet(**spec)],
        )


def _split_law_platen() -> tuple[float, float]:
    """The mixed forms' law (τ = −J p I + μ dev b̄, p = −K (J − 1)) under the platen:
    σ_xx = 0 fixes λ_x; the platen force per unit thickness is σ_yy λ_x."""
    mat = fe_mpm.NeoHookean(E, NU)

    def tau(lx):
        J = STRETCH * lx
        b_bar = J ** (-2 / 3) * np.array([lx**2, STRETCH**2, 1.0])
        return J * mat.bulk_modulus * (J - 1) + mat.mu * (b_bar - b_bar.sum() / 3), J

    lo, hi = 1.0, 1.5  # τ_xx(1) < 0 < τ_xx(1.5)
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if tau(mid)[0][0] < 0 else (lo, mid)
    lx = 0.5 * (lo + hi)
    t, J = tau(lx)
    return t[1] / J * lx, lx


def test_taylor_hood_platen_is_the_homogeneous_compression_in_its_first_step():
    """P2/P1 with boundary points: in the first step (points at their Gauss positions) the
    homogeneous compression is exact up to the penalty gap. Measured: force 1.4e-4 and
    mean stretch 1.2e-5 from the closed form (u-p on P1 gives the same to 1e-6). Reading
    the P2 displacement at the platen points as if it were P1 moves the force by 10 %
    (convection) or 360-fold (penalty)."""
    _, points, reports = _platen_run(formulation="up-p2p1", steps=1)
    force, _ = _split_law_platen()
    assert reports[-1].reactions["platen"][1] == pytest.approx(force, rel=1e-3)
    stretch = np.average(points.F[:, 1, 1], weights=points.volume)
    assert stretch == pytest.approx(STRETCH, abs=1e-4)


def _cantilever_with_a_tip_load(min_fill: float):
    """A 3D cantilever seeded by level set in a gmsh box, its tip load a PointTraction.

    2 m × 0.2 m × 0.2 m (E = 1 MPa), clamped at x = 0, held at its sides in z, a
    1 N shear on its end face as 16 points; the box reaches past the beam, so the
    level set cuts cells at the end face, some of them to slivers (1e-7 of a cell).
    """
    import gmsh

    from fe_mpm import boundary_points
    from fe_mpm.meshes.gmsh_session import gmsh_session, to_dolfinx

    length, side = 2.0, 0.2
    with gmsh_session("cantilever") as model:
        model.occ.addBox(0.0, -0.4, 0.0, length + 0.3, 0.8, side)
        model.occ.synchronize()
        model.addPhysicalGroup(3, [1], tag=1)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", 0.1)
        model.mesh.generate(3)
        mesh = to_dolfinx(model, 3).mesh
    inside = lambda x: np.minimum.reduce([length - x[0], side - x[1], x[1]])  # noqa: E731
    points = fe_mpm.seed(mesh, per_cell=4, level_set=inside)
    y, z = np.meshgrid((np.arange(4) + 0.5) / 4 * side, (np.arange(4) + 0.5) / 4 * side)
    end = np.column_stack([np.full(16, length - 1e-9), y.ravel(), z.ravel()])
    load = fe_mpm.PointTraction(
        "tip", end, np.full(16, side**2 / 16), (0.0, -1.0 / side**2, 0.0), lambda t: t
    )
    sides = lambda x: np.isclose(x[2], 0.0) | np.isclose(x[2], side)  # noqa: E731
    kept, boundary_points.LOAD_MIN_FILL = boundary_points.LOAD_MIN_FILL, min_fill
    try:
        sim = fe_mpm.Simulation(
            mesh,
            points,
            fe_mpm.NeoHookean(1.0e6, 0.3),
            dirichlet=[
                fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0)),
                fe_mpm.Dirichlet(sides, component=2),
            ],
            point_tractions=[load],
            min_step=0.1,
        )
        sim.add_marker("end", (length - 0.01, side / 2, side / 2))
        reports = sim.run(1.0, 2, progress=False)
    finally:
        boundary_points.LOAD_MIN_FILL = kept
    return reports, side


def test_a_tip_load_on_a_level_set_body_does_not_throw_the_nodes_of_a_sliver():
    """Found 2026-12-05 trying a new user's scene: a load point in a cut cell that
    the material fills to 1e-7 loaded nodes held by that sliver alone; Newton failed
    at a fifth of the load, and the step cut to 1/640 of it threw the point 1.6 m.
    Such a point now loads a better-filled neighbour (``LOAD_MIN_FILL``): two steps
    of 3 Newton iterations (bound 6), none failed, and the tip deflects 0.617 times
    the linear Timoshenko beam's P L³/(3EI) + P L/(κ G A): P1 tetrahedra two cells
    deep lock in bending (0.82 on another gmsh grid of the same beam), so the band
    is wide (0.5–1.0); a thrown node shows in the iterations and the failures. With
    the old rule (``LOAD_MIN_FILL`` = 0) Newton stalls in the first step and the
    step is cut below ``min_step``."""
    reports, side = _cantilever_with_a_tip_load(0.1)
    assert [r.failed_iterations for r in reports] == [0, 0]
    assert max(r.newton_iterations for r in reports) <= 6
    E, nu, P, L = 1.0e6, 0.3, 1.0, 2.0
    inertia, shear = side**4 / 12.0, E / (2.0 * (1.0 + nu))
    timoshenko = P * L**3 / (3.0 * E * inertia) + P * L / (5.0 / 6.0 * shear * side**2)
    ratio = -(reports[-1].markers["end"][1] - side / 2) / timoshenko
    assert 0.5 < ratio < 1.0
    np.testing.assert_allclose(reports[-1].reactions["tip"], [0.0, -1.0, 0.0], atol=1e-12)
    with pytest.raises(fe_mpm.ConvergenceError):
        _cantilever_with_a_tip_load(0.0)


@pytest.mark.parametrize("fitted", [False, True])
def test_p2_platen_points_read_far_outside_the_body_are_warned_about(fitted):
    """A block 1 m square held by point platens on its top and bottom edges. On a grid
    whose lines cut those edges mid-cell, half the base's points read the P2/P1 field
    of a seeded cell from more than a fifth of a cell outside it (measured: 5 of 10),
    where a quadratic field bends away (a user's sheared J2 block on such a grid held
    1.5 N where P1 held 22.4 N): warned, naming the condition. On a grid fitted to the
    edges, and in P1, nothing is said."""
    offset = 0.1 if fitted else 0.0
    mesh = meshes.rectangle_mesh(
        (-0.3 - offset, -0.3 - offset), (1.3 - offset, 1.3 - offset), (8, 8)
    )
    centre = meshes.cell_centroids(mesh)
    inside = (centre > 0.0) & (centre < 1.0)
    x = np.linspace(0.05, 0.95, 10)
    platens = [
        fe_mpm.PointDirichlet(
            name, np.column_stack([x, np.full(10, y)]), np.full(10, 0.1), value, penalty=1e6
        )
        for name, y, value in (
            ("base", 0.0, lambda t: np.zeros(2)),
            ("top", 1.0, lambda t: np.array([0.1 * t, 0.0])),
        )
    ]
    for formulation in ("up-p2p1", "up"):
        points = fe_mpm.seed(mesh, per_cell=3, cells=np.flatnonzero(inside.all(axis=1)))
        sim = fe_mpm.Simulation(
            mesh, points, fe_mpm.NeoHookean(1000.0, 0.3), formulation, point_dirichlet=platens
        )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sim.run(1.0, 1, progress=False)
        far = [str(w.message) for w in caught if "bends away from the body" in str(w.message)]
        if formulation == "up-p2p1" and not fitted:
            assert len(far) == 1 and "of PointDirichlet 'base'" in far[0], far
            assert "Fit the grid's lines" in far[0]
        else:
            assert far == [], far


def _footing_force_across_a_gap(gap: float) -> float:
    """The vertical force (N) of a rough 0.5 m square footing whose 16 points start
    ``gap`` above a 3D soil box's top (gmsh tetrahedra of 0.25 m, 4 points each, a
    fixed base) and move down 0.02 m in one step."""
    import gmsh

    from fe_mpm.meshes.gmsh_session import gmsh_session, to_dolfinx

    with gmsh_session("box") as model:
        soil = model.occ.addBox(0, 0, 0, 2.0, 1.0, 1.0)
        whole = model.occ.addBox(0, 0, 0, 2.0, 1.0, 1.5)
        model.occ.fragment([(3, whole)], [(3, soil)])
        model.occ.synchronize()
        volumes = [v for _, v in model.getEntities(3)]
        below = [v for v in volumes if model.occ.getCenterOfMass(3, v)[2] < 1.0]
        model.addPhysicalGroup(3, below, tag=1)
        model.addPhysicalGroup(3, [v for v in volumes if v not in below], tag=2)
        gmsh.option.setNumber("Mesh.MeshSizeMin", 0.25)
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.25)
        model.mesh.generate(3)
        data = to_dolfinx(model, 3)
    points = fe_mpm.seed(data.mesh, 4, cells=data.cell_tags.find(1), density=1800.0)
    side = (np.arange(4) + 0.5) * 0.125 - 0.25
    X, Y = np.meshgrid(1.0 + side, 0.5 + side, indexing="ij")
    base = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, 1.0 + gap)])
    footing = fe_mpm.PointDirichlet(
        "footing", base, np.full(16, 0.125**2), lambda t: (0.0, 0.0, -0.02 * t), penalty=8e10
    )
    sim = fe_mpm.Simulation(
        data.mesh,
        points,
        fe_mpm.NeoHookean(20e6, 0.3, 1800.0),
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[2], 0.0))],
        point_dirichlet=[footing],
    )
    return float(sim.run(1.0, 1, progress=False)[-1].reactions["footing"][2])


def test_a_footing_a_cell_above_the_soil_does_not_grip_it():
    """A point reads an occupied cell's field up to half a cell out (``reach``), but the
    least barycentric coordinate of a tetrahedron that only shares a vertex with the
    point's cell can be mild far off: a footing 0.2 m above a soil box of 0.25 m cells
    (4/5 of a cell), lowered 0.02 m, pushed it down with 42 % of the force it takes in
    contact, without a word (a helper's 3D footing, 2026-12-07). The distance is now
    bounded too, by half the largest height of the cell read."""
    touching = _footing_force_across_a_gap(0.0)
    assert touching < -1e5
    assert _footing_force_across_a_gap(0.2) == 0.0


def _pin_run(pin_y, pin_value, held, formulation="u"):
    """A block on a fixed base, its top pulled up 1 cm by penalty points.

    ``held``: name -> marker of the grid lines held fixed, each also a reaction;
    ``pin_y``: a row of penalty points at that height moving by ``pin_value`` (None:
    no pin). The reactions of the step, by name."""
    E, h = 1e6, 0.125
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.5), (8, 12))
    xs = (np.arange(16) + 0.5) / 16

    def platen(name, y, value, **options):
        x = np.column_stack([xs, np.full(16, y)])
        return fe_mpm.PointDirichlet(name, x, 1 / 16, value, 1e3 * E / h, **options)

    supports = [platen("top", 1.0, lambda t: (0.0, 0.01 * t))]
    if pin_y is not None:
        supports.append(platen("pin", pin_y, pin_value, reach=0.0))
    sim = fe_mpm.Simulation(
        mesh, fe_mpm.seed(mesh, 3, level_set=lambda x: 1.0 - x[1]), fe_mpm.NeoHookean(E, 0.3),
        formulation, dirichlet=[fe_mpm.Dirichlet(m) for m in held.values()],
        point_dirichlet=supports, reactions=held,
    )  # fmt: skip
    return sim.run(1.0, 1, progress=False)[-1].reactions


@pytest.mark.parametrize("formulation", ["u", "up"])
def test_a_penalty_points_share_on_held_nodes_goes_to_the_support_not_the_body(formulation):
    """A helper's pin (2026-12-07): fixed penalty points in the bottom cells of a
    block on a fixed base, its top pulled up 1 cm. The pin reported −49.4 kN/m and
    the base +36.3 kN/m, pushing up, where the pull was 13.2 kN/m: the penalty's
    share N_I f_b on the base's nodes went straight into the base, and both counted
    it. That share is now the base's alone.

    Exact check: a pin in cells whose nodes the grid holds all of, its target moved
    off them, pulls on nothing that can move. It reports 0, and the base's reaction
    is that of the run without it, to round-off (the penalty's share, 2e4 N/m, is
    what both reported before)."""
    base = lambda x: np.isclose(x[1], 0.0)  # noqa: E731
    line = lambda x: np.isclose(x[1], 0.125)  # noqa: E731  (held inside: facets inside the grid)
    bottom_rows = {"base": base, "line": line}  # all nodes of the bottom row of cells
    alone = _pin_run(None, None, bottom_rows, formulation)
    moved = lambda t: (0.0, -0.001 * t)  # noqa: E731
    pinned = _pin_run(0.125 / 4, moved, bottom_rows, formulation)
    np.testing.assert_allclose(pinned["pin"], 0.0, atol=1e-6)
    for name in ("base", "line"):
        np.testing.assert_allclose(pinned[name], alone[name], rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(pinned["top"], alone["top"], rtol=1e-9, atol=1e-6)

    # The helper's scene: the pin and the base both hold the block down.
    forces = _pin_run(0.125 / 4, lambda t: (0.0, 0.0), {"base": base}, formulation)
    np.testing.assert_allclose(sum(forces.values()), 0.0, atol=1e-6)
    assert forces["base"][1] < 0.0 and forces["pin"][1] < 0.0 < forces["top"][1]
