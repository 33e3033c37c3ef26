"""The separate bodies the occupied cells form (fe_mpm/bodies.py)."""

import warnings

from mpi4py import MPI

import dolfinx
import numpy as np
import pytest

import fe_mpm
from fe_mpm.bodies import body_labels, count_bodies
from fe_mpm.meshes import cell_centroids, rectangle_mesh


def _labels_by_search(cell_nodes: np.ndarray) -> np.ndarray:
    """The same labels by a plain search from each unlabelled cell, for comparison."""
    labels = np.full(cell_nodes.shape[0], -1)
    body = 0
    for start in range(cell_nodes.shape[0]):
        if labels[start] >= 0:
            continue
        labels[start], frontier = body, [start]
        while frontier:
            cell = frontier.pop()
            joined = np.flatnonzero(np.isin(cell_nodes, cell_nodes[cell]).any(axis=1))
            for other in joined[labels[joined] < 0]:
                labels[other] = body
                frontier.append(other)
        body += 1
    return labels


@pytest.mark.parametrize("seed", range(20))
def test_body_labels_match_a_search_on_random_cells(seed):
    rng = np.random.default_rng(seed)
    nodes = int(rng.integers(5, 200))
    cells = rng.integers(0, nodes, size=(int(rng.integers(1, 120)), 3))
    assert np.array_equal(body_labels(cells), _labels_by_search(cells))


def test_a_long_chain_is_one_body_and_empty_is_none():
    chain = np.column_stack([np.arange(500), np.arange(1, 501), np.arange(2, 502)])[::-1]
    assert np.all(body_labels(chain) == 0)
    assert body_labels(np.zeros((0, 3), dtype=np.int64)).size == 0


E, NU, LENGTH, WIDTH, H = 1.0e6, 0.3, 1.0, 0.2, 0.05


def _uniaxial_force(stretch: float) -> float:
    """The "u" Neo-Hookean strip's force per unit depth (N/m) at ``stretch`` in plane strain.

    τ = λ ln J I + μ (b − I), with the lateral stretch from τ₂₂ = 0 (bisection).
    """
    mu, lam = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
    lo, hi = 1e-3, 1.0
    for _ in range(100):  # τ₂₂ rises with the lateral stretch
        mid = (lo + hi) / 2
        if lam * np.log(stretch * mid) + mu * (mid**2 - 1) > 0:
            hi = mid
        else:
            lo = mid
    tau_11 = lam * np.log(stretch * lo) + mu * (stretch**2 - 1)
    return tau_11 / stretch * WIDTH


def _strip_pulled_to_twice_its_length(point_domains: bool, t_end: float = 0.5, steps: int = 10):
    """A strip on rollers pulled by boundary points to λ = 2 in 10 steps (one point per
    cell), or to λ = 1 + 2 ``t_end`` in ``steps``."""
    mesh = dolfinx.mesh.create_rectangle(
        MPI.COMM_SELF, [[0.0, 0.0], [63 * H, 6 * H]], [63, 6], dolfinx.mesh.CellType.triangle
    )
    points = fe_mpm.seed(mesh, per_cell=1, density=1000.0)
    points.keep((points.x[:, 0] < LENGTH) & (points.x[:, 1] < WIDTH))
    across = (np.arange(16) + 0.5) * WIDTH / 16
    pull = fe_mpm.PointDirichlet(
        "pull",
        np.column_stack([np.full(16, LENGTH), across]),
        np.full(16, WIDTH / 16),
        lambda t: np.array([2.0 * LENGTH * t, 0.0]),
        penalty=1e3 * E / H,
        components=(0,),
    )
    rollers = [fe_mpm.Dirichlet(lambda x, i=i: np.isclose(x[i], 0.0), component=i) for i in (0, 1)]
    sim = fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.NeoHookean(E=E, nu=NU),
        "u",
        dirichlet=rollers,
        point_dirichlet=[pull],
        point_domains=point_domains,
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        reports = sim.run(t_end=t_end, n_steps=steps, progress=False)
    tears = [str(w.message) for w in caught if "had come apart" in str(w.message)]
    return [(r.t, r.reactions["pull"][0]) for r in reports], tears


def test_a_strip_torn_in_standard_mpm_is_told_once_and_domains_keep_it_whole():
    # Standard MPM: the force is lost once points lie more than a cell apart, while
    # every step converges (a new user's strip, 2026-12-07); the run now says so once.
    forces, tears = _strip_pulled_to_twice_its_length(point_domains=False)
    assert len(tears) == 1, tears
    assert "where there were 1 at the start" in tears[0], tears[0]
    torn_at = float(tears[0].split("By t = ")[1].split(" ")[0])
    after = [f for t, f in forces if t > torn_at + 1e-12]
    assert after and max(abs(f) for f in after) < 1e-6 * _uniaxial_force(2.0), forces
    # Torn in the run's last step: told at its end (a helper's strip was not).
    steps = round(torn_at / 0.05)  # the same steps as above, to the tear's
    _, tears = _strip_pulled_to_twice_its_length(False, t_end=steps * 0.05, steps=steps)
    assert len(tears) == 1 and tears[0].startswith(f"By t = {torn_at:g} "), tears
    # With domains it stays whole: every step's force within 0.05 % of the closed
    # form (measured 0.003 %), and nothing is said.
    forces, tears = _strip_pulled_to_twice_its_length(point_domains=True)
    assert tears == []
    for t, force in forces:
        assert force == pytest.approx(_uniaxial_force(1.0 + 2.0 * t), rel=5e-4), (t, force)


@pytest.mark.parametrize("point_domains", [False, True])
def test_an_elastic_strip_flung_apart_in_dynamics_is_told_once_unless_domains_hold_it(
    point_domains,
):
    """Elastic solids are watched in dynamic runs too (a plastic or fluid flow may throw
    off a grain or a splash; no law here fractures). A soft strip held at one end and
    thrown outwards, v = 2 x / L, coasts to λ ≈ 1.8 in 0.5 s: standard MPM tears it
    by t = 0.25 and says so once; point domains keep it whole, silently."""
    mesh = dolfinx.mesh.create_rectangle(
        MPI.COMM_SELF, [[0.0, 0.0], [63 * H, 6 * H]], [63, 6], dolfinx.mesh.CellType.triangle
    )
    points = fe_mpm.seed(mesh, per_cell=1, density=1000.0)
    points.keep((points.x[:, 0] < LENGTH) & (points.x[:, 1] < WIDTH))
    points.velocity[:, 0] = 2.0 * points.x[:, 0] / LENGTH
    rollers = [fe_mpm.Dirichlet(lambda x, i=i: np.isclose(x[i], 0.0), component=i) for i in (0, 1)]
    sim = fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.NeoHookean(E=1e3, nu=NU),
        "u",
        dirichlet=rollers,
        dynamic=True,
        point_domains=point_domains,
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sim.run(t_end=0.5, n_steps=20, progress=False)
    tears = [str(w.message) for w in caught if "had come apart" in str(w.message)]
    assert points.x[:, 0].max() > 1.7  # stretched far past a cell between points
    assert len(tears) == int(not point_domains), tears


def test_a_body_cut_in_two_by_removing_points_is_counted_anew_and_not_told():
    """An excavation may leave two bodies: ``remove_points`` counts the bodies anew,
    so a block clamped on its base and cut through by a trench, then loaded, is not
    told that it came apart (nor after a second step)."""
    mesh = dolfinx.mesh.create_rectangle(
        MPI.COMM_SELF, [[0.0, 0.0], [1.0, 0.5]], [20, 10], dolfinx.mesh.CellType.triangle
    )
    points = fe_mpm.seed(mesh, per_cell=1, density=1000.0)
    points.keep(points.x[:, 1] < 0.3)
    sim = fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.NeoHookean(E=E, nu=NU),
        "u",
        dirichlet=[fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))],
        body_force=(0.0, -9.81),
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sim.run(t_end=1.0, n_steps=1, progress=False)
        sim.remove_points(np.abs(points.x[:, 0] - 0.5) < 0.15)
        sim.run(t_end=3.0, n_steps=2, progress=False)
    assert not [w for w in caught if "had come apart" in str(w.message)]
    assert count_bodies(sim.mesh, sim.tracker.locate(sim.points.x)) == 2  # the cut is real


@pytest.mark.parametrize(
    "domains, two, warned",
    [(True, True, "creates energy"), (True, False, None), (False, True, "pulls as well")],
)
def test_two_bodies_that_meet_in_dynamics_are_warned(domains, two, warned):
    """A helper's two elastic bars closing from two cells apart (2026-12-07): with point
    domains they pushed on each other from the first steps and the impact created
    energy (they left at 1.074 times their speed); standard MPM kept it to 0.5 %. A
    dynamic run with domains now says so when two of its bodies meet; a bar alone is
    not told. Standard MPM is told too, of the grid's joint that pulls as well as
    pushes: a second helper's bar striking one at rest parted with a restitution of
    0.60, where seen from their centre of mass it was 0.98."""
    n, h = 10, 0.1
    v = 0.1 if domains else 2.0  # (standard MPM's bars meet when their cells share a node)
    gap = 2 if domains else 1
    grid = rectangle_mesh((0.0, 0.0), (2.0 + 10 * h, 2 * h), (2 * n + 10, 2))
    x = cell_centroids(grid)[:, 0]
    left = fe_mpm.seed(grid, 3, density=1000.0, cells=np.flatnonzero((x > 4 * h) & (x < 4 * h + 1)))
    left.velocity[:, 0] = v
    points = left
    if two:
        far = (4 + gap) * h + 1
        right = fe_mpm.seed(
            grid, 3, density=1000.0, cells=np.flatnonzero((x > far) & (x < far + 1))
        )
        right.velocity[:, 0] = -v
        points = fe_mpm.merge(left, right)
    law = fe_mpm.NeoHookean(1e6, 0.0, 1000.0)
    sim = fe_mpm.Simulation(grid, points, law, dynamic=True, point_domains=domains)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sim.run(0.02, 12, progress=False)
    said = [
        str(w.message) for w in caught if "two bodies of the material had met" in str(w.message)
    ]
    assert len(said) == (warned is not None), said
    assert warned is None or warned in said[0]
