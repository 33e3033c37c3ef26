"""A pressure that follows the body's face (fe_mpm.PointPressure).

References:
- On a face that barely moves it is the grid's traction on that face, on the face
  as it has stretched: one step of a block pressed on its top gives the grid
  Traction's corner displacement times the top's stretch 1 + u_x (measured to 2e-8
  relative; they differ by 3.9e-4 at p / E = 1e-3), and pushes with p times the
  top's length.
- Its residual and Jacobian are consistent (Taylor test): the tangent includes the
  load's stiffness p ∂cof(ΔF)/∂ΔF.
- Each point's face deforms by Nanson's rule, so a face that turns with the body
  carries the pressure along its new normal. Given its facet's corners, each point's
  face is after every step its share of the moved facet: the face's area is then the
  polyline's through the moved corners, where Nanson's rule with one cell's ΔF loses
  area step by step (a thick cylinder inflated to twice its bore, below). (The
  cavity expanded to 1.5 times its radius, ``demos/cavity_expansion.py``, checks a
  stretching face against Gibson and Anderson's curve.)
"""

import warnings

import numpy as np
import pytest
from test_taylor import assert_first_step_is_consistent

import fe_mpm
from fe_mpm import meshes
from fe_mpm._dolfinx import dolfinx
from fe_mpm.boundary_points import BoundaryPoints, BoundaryPointStep
from fe_mpm.meshes import cell_centroids, rectangle_mesh
from fe_mpm.tracker import Tracker

E, P = 1e6, 1e3


def _block(load: str, pressure: float = P, steps: int = 1, restart: bool = False, **options):
    """A unit block on rollers, pressed on its top (y = 1), in a grid that ends there:
    the corner (1, 1)'s displacement, Newton's iterations and the load's force."""
    mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.0), (4, 4))
    points = fe_mpm.seed(mesh, 3)
    top = np.column_stack([(np.arange(8) + 0.5) / 8, np.ones(8)])
    loads = {
        "grid": dict(
            tractions=[
                fe_mpm.Traction(lambda x: np.isclose(x[1], 1.0), (0, -pressure), lambda t: t)
            ]
        ),
        "points": dict(
            point_tractions=[
                fe_mpm.PointPressure("top", top, 1 / 8, (0.0, 1.0), pressure, lambda t: t)
            ]
        ),
    }[load]
    sim = fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.NeoHookean(E, 0.3),
        dirichlet=[
            fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0), component=1),
            fe_mpm.Dirichlet(lambda x: np.isclose(x[0], 0.0), component=0),
        ],
        **loads,
        **options,
    )
    sim.add_marker("corner", (1.0, 1.0 - 1e-9))
    reports = sim.history if restart else sim.run(1.0, steps, progress=False)
    return sim, reports and reports[-1].markers["corner"] - (1.0, 1.0), reports


def test_on_a_face_that_barely_moves_it_is_the_grids_traction():
    _, grid, _ = _block("grid")
    _, points, reports = _block("points")
    stretched = 1.0 + points[0]  # the top's length at the end of the step
    # The grid's traction acts on the top as it was, the follower on the top stretched.
    np.testing.assert_allclose(points, grid * stretched, rtol=1e-6)
    assert abs(points[0] / grid[0] - 1.0) > 1e-4  # the two differ by that stretch
    np.testing.assert_allclose(reports[-1].reactions["top"], [0.0, -P * stretched], atol=1e-9)


def test_its_residual_and_jacobian_are_consistent():
    """About a random grid unknown (up to 0.02 of the unit block per node) in u and u-p."""
    for formulation in ("u", "up"):
        mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.5), (4, 6))
        inside = np.flatnonzero(cell_centroids(mesh)[:, 1] < 1.0)
        points = fe_mpm.seed(mesh, 3, cells=inside)
        top = np.column_stack([(np.arange(8) + 0.5) / 8, np.ones(8)])
        sim = fe_mpm.Simulation(
            mesh,
            points,
            fe_mpm.NeoHookean(10.0, 0.3),
            formulation,
            dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))],
            point_tractions=[fe_mpm.PointPressure("top", top, 1 / 8, (0.3, 1.0), 2.0)],
        )
        assert_first_step_is_consistent(np.random.default_rng(5), sim)


@pytest.mark.parametrize("dim", [2, 3])
def test_each_face_deforms_by_nansons_rule(dim):
    """After a step each point's face is cof(ΔF) a = det ΔF ΔF⁻ᵀ a for the grid's ΔF
    at the point: a face turned by a rotation keeps its size and turns with it (the
    pressure then pushes along the new normal), one stretched along itself grows. Checked
    on random ΔF, a quarter turn and a stretch, against numpy's inverse."""
    mesh = rectangle_mesh((0.0,) * dim, (1.0,) * dim, (2,) * dim)
    rng = np.random.default_rng(1)
    x = rng.uniform(0.2, 0.8, (5, dim))
    normal = rng.normal(size=(5, dim))
    condition = fe_mpm.PointPressure("face", x, rng.uniform(0.1, 1.0, 5), normal, P)
    step = BoundaryPointStep.of([condition], Tracker(mesh))
    faces = step.points.area.copy()
    turn = np.eye(dim)
    turn[:2, :2] = [[0.0, -1.0], [1.0, 0.0]]
    stretch = np.diag([1.5] + [1.0] * (dim - 1))
    dF = np.stack(
        [np.eye(dim) + 0.2 * rng.normal(size=(dim, dim)) for _ in range(3)] + [turn, stretch]
    )
    step._active = np.ones(5, dtype=bool)
    step._deform_faces(_Forms(dF))
    expected = np.einsum("n,nji,nj->ni", np.linalg.det(dF), np.linalg.inv(dF), faces)
    np.testing.assert_allclose(step.points.area, expected, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(step.points.area[3], turn @ faces[3], atol=1e-14)


class _Forms:
    """The step's forms as the faces' update reads them: ΔF at the points."""

    def __init__(self, dF):
        self.dF_at_boundary = self
        self._dF = dF

    def evaluate(self, layout):
        return self._dF.reshape(len(self._dF), -1)


def test_bad_point_pressures_are_refused_with_the_field_named():
    x = np.array([[0.5, 1.0], [0.6, 1.0]])
    with pytest.raises(ValueError, match=r"PointPressure 'top': normal of point 1 is zero"):
        fe_mpm.PointPressure("top", x, 0.1, [[0.0, 1.0], [0.0, 0.0]], P)
    with pytest.raises(ValueError, match=r"normal must have shape \(2, 2\)"):
        fe_mpm.PointPressure("top", x, 0.1, [[0.0, 1.0, 0.0]] * 2, P)
    with pytest.raises(
        ValueError, match=r"PointPressure 'top': value must lie in \(-inf, inf\), got inf"
    ):
        fe_mpm.PointPressure("top", x, 0.1, (0.0, 1.0), np.inf)
    with pytest.raises(ValueError, match="every weight must be > 0"):
        fe_mpm.PointPressure("top", x, 0.0, (0.0, 1.0), P)
    pieces = np.array([[[0.45, 1.0], [0.55, 1.0]], [[0.55, 1.0], [0.65, 1.0]]])
    fe_mpm.PointPressure("top", x, 0.1, (0.0, 1.0), P, corners=pieces)
    with pytest.raises(ValueError, match=r"'top': corners must have shape \(2, 2, 2\)"):
        fe_mpm.PointPressure("top", x, 0.1, (0.0, 1.0), P, corners=pieces[:, :, :1])
    with pytest.raises(ValueError, match="corners of point 1 span no face"):
        fe_mpm.PointPressure(
            "top", x, 0.1, (0.0, 1.0), P, corners=np.array([pieces[0], [[0.6, 1.0], [0.6, 1.0]]])
        )
    with pytest.raises(ValueError, match="corners of point 0 do not lie across its normal"):
        fe_mpm.PointPressure("top", x, 0.1, (1.0, 0.0), P, corners=pieces)


#: The thick cylinder of these tests: bore A, outside B, a Neo-Hookean law near
#: incompressibility.
A, B, BORE_LAW = 1.0, 2.0, fe_mpm.NeoHookean(1000.0, 0.499)


def _bore(h: float, margin: float, pressure: float, corners: bool, **options):
    """A quarter of the cylinder on rollers, on cells of h with ``margin`` of grid
    around it, pressed on its bore by a PointPressure rising to ``pressure``."""
    scene = meshes.quarter_ring(A, B, h, margin)
    points = fe_mpm.seed(scene.mesh, 3, cells=scene.cell_tags.find(meshes.RING_BODY))
    bore = scene.facet_tags.find(meshes.RING_INNER)
    x, w, pieces = meshes.facet_points(scene.mesh, bore, corners=True)
    normal = -x / np.linalg.norm(x, axis=1)[:, None]
    load = fe_mpm.PointPressure(
        "bore", x, w, normal, pressure, scale=lambda t: t, corners=pieces if corners else None
    )
    return fe_mpm.Simulation(
        scene.mesh,
        points,
        BORE_LAW,
        "up",
        facet_tags=scene.facet_tags,
        dirichlet=[
            fe_mpm.Dirichlet(meshes.RING_X_AXIS, component=1),
            fe_mpm.Dirichlet(meshes.RING_Y_AXIS, component=0),
        ],
        point_tractions=[load],
        point_domains=True,
        **options,
    )


def _inflated_cylinder(corners: bool) -> tuple[float, float]:
    """The cylinder (cells of 0.1, point domains) inflated in 10 steps to the pressure
    that takes an incompressible one to a bore of 2: the load points' area over the
    polyline through them at the end, and the pressure of the bore reached over the
    pressure applied (closed form)."""

    def pressure(a: float) -> float:  # Rivlin's, for the incompressible law
        c = a * a - A * A
        b = np.sqrt(B * B + c)
        return BORE_LAW.mu * (np.log(B / A) - np.log(b / a) + 0.5 * c * (1 / a**2 - 1 / b**2))

    sim = _bore(0.1, np.sqrt(B * B + 3.0) - B + 0.3, pressure(2.0), corners)
    sim.add_marker("middle", (A / np.sqrt(2.0), A / np.sqrt(2.0)))
    report = sim.run(1.0, 10, progress=False)[-1]
    at = sim._boundary.points.x
    at = at[np.argsort(np.arctan2(at[:, 1], at[:, 0]))]
    ends = np.vstack([[np.linalg.norm(at[0]), 0.0], at, [0.0, np.linalg.norm(at[-1])]])
    polyline = np.linalg.norm(np.diff(ends, axis=0), axis=1).sum()
    area = np.linalg.norm(sim._boundary.points.area, axis=1).sum()
    return area / polyline, pressure(np.linalg.norm(report.markers["middle"])) / pressure(2.0)


def test_a_face_stretched_twofold_keeps_its_area_with_its_facets_corners():
    """Measured (2026-12-06): with the corners the area is 0.9965 of the polyline's
    (the rest is the last step's Nanson increment) and the bore holds 0.975 of the
    pressure; by Nanson's rule alone 0.952 and 0.947 (a helper's scene: the cell at
    the bore, filled in part, stretches less than the bore does, and each step's
    shortfall stays)."""
    area, held = _inflated_cylinder(corners=True)
    assert area > 0.99 and held > 0.965
    area, held = _inflated_cylinder(corners=False)
    assert area < 0.97 and held < 0.96


def test_a_restored_run_keeps_the_faces_as_they_had_deformed(tmp_path):
    """The faces are state: a run pressed hard (p / E = 0.05, the top stretching by
    2 %) and restored from its checkpoint after 2 of 4 steps repeats the
    uninterrupted run; with the faces of the start instead it would push on a top 2 %
    shorter."""
    _, _, expected = _block("points", 5e-2 * E, 4, checkpoint_dir=tmp_path, checkpoint_every=2)
    sim, _, _ = _block("points", 5e-2 * E, restart=True)  # built alike, not run
    sim.restore(tmp_path / "step_000002")
    reports = sim.run(1.0, 2, progress=False)
    for got, want in zip(reports, expected[2:], strict=True):
        np.testing.assert_array_equal(got.reactions["top"], want.reactions["top"])


def _small_bore(corners: bool, **options) -> fe_mpm.Simulation:
    """The cylinder on cells of 0.2, its bore pressed to 60 Pa."""
    return _bore(0.2, 1.0, 60.0, corners, **options)


def test_the_faces_corners_are_restored_and_a_checkpoint_without_them_is_refused(tmp_path):
    """A run with corners restored after 2 of 4 steps repeats the uninterrupted one to
    every digit; a checkpoint written without corners, restored into a simulation whose
    PointPressure has them, would read NaN corners (every area NaN a step later, a
    review found) and is refused."""
    expected = _small_bore(True, checkpoint_dir=tmp_path / "with", checkpoint_every=2).run(
        1.0, 4, progress=False
    )
    sim = _small_bore(True)
    sim.restore(tmp_path / "with" / "step_000002")
    for got, want in zip(sim.run(1.0, 2, progress=False), expected[2:], strict=True):
        np.testing.assert_array_equal(got.reactions["bore"], want.reactions["bore"])
    _small_bore(False, checkpoint_dir=tmp_path / "without", checkpoint_every=2).run(
        0.5, 2, progress=False
    )
    with pytest.raises(ValueError, match="holds no facet corners for the PointPressure"):
        _small_bore(True).restore(tmp_path / "without" / "step_000002")


def test_a_corner_no_occupied_cell_reaches_moves_with_its_point():
    """A corner in the grid but past every occupied cell's reach has no field to read:
    it moves with its load point. It stayed where it was (a review, 2026-12-06): the
    fallback took corners outside the grid only."""
    mesh = rectangle_mesh((0.0, 0.0), (4.0, 1.0), (4, 1))
    top = dolfinx.mesh.locate_entities_boundary(
        mesh, 1, lambda x: np.isclose(x[1], 1.0) & (x[0] < 1.01)
    )
    x, w, corners = meshes.facet_points(mesh, top, corners=True)
    load = fe_mpm.PointPressure("top", x, w, (0.0, 1.0), 1.0, corners=corners)
    step = BoundaryPointStep(BoundaryPoints([load], 2), Tracker(mesh), 1)
    step._occupied = step.tracker.centroids[:, 0] < 1.0  # the body: the first cells
    step.points.corners[:] += (2.5, -0.5)  # corners moved far past them
    before = step.points.corners.copy()
    moved = np.full((len(w), 2), 0.01)  # what the points moved by
    step._move_corners(lambda cells, bary: np.full((len(cells), 2), 0.02), moved, w > 0)
    np.testing.assert_allclose(step.points.corners - before, 0.01, rtol=0, atol=1e-15)


@pytest.mark.parametrize("curved", [False, True])
def test_a_normal_that_points_into_the_body_is_warned(curved):
    """A positive pressure pushes along −normal: given the inward normal it pulls.

    A block on a grid that goes on above it, pressed on its top (a helper's probe,
    2026-12-07: the normal (0, −1) pulled the block up by p times its top, said
    nothing). Curved: the bore of a hole in a plate, pressed from the hole, whose outward
    normal points to the centre.
    """
    if curved:
        mesh = rectangle_mesh((-2.0, -2.0), (2.0, 2.0), (16, 16))
        r = np.linalg.norm(cell_centroids(mesh), axis=1)
        points = fe_mpm.seed(mesh, 3, cells=np.flatnonzero(r > 1.0))
        angle = np.linspace(0.0, 2.0 * np.pi, 32, endpoint=False)
        x = np.column_stack([np.cos(angle), np.sin(angle)])
        outward, weight = -x, 2.0 * np.pi / 32
        held = lambda x: np.isclose(np.abs(x).max(axis=0), 2.0)  # noqa: E731
    else:
        mesh = rectangle_mesh((0.0, 0.0), (1.0, 1.5), (4, 6))
        points = fe_mpm.seed(mesh, 3, cells=np.flatnonzero(cell_centroids(mesh)[:, 1] < 1.0))
        x = np.column_stack([(np.arange(8) + 0.5) / 8, np.ones(8)])
        outward, weight = np.array([0.0, 1.0]), 1 / 8
        held = lambda x: np.isclose(x[1], 0.0)  # noqa: E731
    said = {}
    for sign in (1.0, -1.0):
        sim = fe_mpm.Simulation(
            mesh,
            points,
            fe_mpm.NeoHookean(E, 0.3),
            dirichlet=[fe_mpm.Dirichlet(held)],
            point_tractions=[fe_mpm.PointPressure("p", x, weight, sign * outward, P)],
        )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sim.step(0.1)
        said[sign] = [str(w.message) for w in caught if "into the body" in str(w.message)]
    assert not said[1.0]
    assert len(said[-1.0]) == 1 and "PointPressure 'p'" in said[-1.0][0]
