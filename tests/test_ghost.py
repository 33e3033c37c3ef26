"""Ghost stabilisation (``Simulation(ghost_penalty=γ)``): which facets, and what it resists."""

from petsc4py import PETSc

import numpy as np
import pytest

import fe_mpm
from fe_mpm import meshes, scenes
from fe_mpm.formulations import FORMULATIONS, GridFields
from fe_mpm.ghost import (
    POORLY_FILLED,
    WITH_DOMAINS,
    WITH_DOMAINS_DYNAMIC,
    GhostStabilisation,
    connected_groups,
)
from fe_mpm.tracker import Tracker


def _ghost(formulation="u", gamma=0.5, mu=3.0, n=4):
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (n, n))
    fields = GridFields(mesh, FORMULATIONS[formulation])
    return mesh, fields, GhostStabilisation(fields, gamma, mu)


def _all_facets(mesh, ghost):
    """Assemble G on every interior facet: fill every cell at 0.25."""
    tracker = Tracker(mesh)
    cells = np.arange(tracker.num_cells, dtype=np.int32)
    ghost.update(cells, 0.25 * tracker.volumes, tracker.volumes, [])
    return ghost


@pytest.mark.parametrize("formulation", ["u", "up", "up-p2p1"])
def test_the_penalty_vanishes_for_affine_increments_and_resists_the_rest(formulation):
    """G Δu = 0 for Δu = a + B x (rigid motions and homogeneous strains pass freely;
    with P2 every quadratic too, whose second derivatives do not jump either), the
    pressure of the u-p unknown has no part in it, and Δuᵀ G Δu > 0 for a
    displacement that bends (P1) or one of higher degree (P2)."""
    mesh, fields, ghost = _ghost(formulation)
    G = _all_facets(mesh, ghost).full
    assert ghost.facets.size == 3 * 4 * 4 - 2 * 4  # every interior facet of the 4 x 4 grid
    w = fields.w

    def interpolate(f):
        w.x.array[:] = 0.0
        if fields.spec.pressure:
            sub = w.sub(0)
            sub.interpolate(f)
            w.x.array[:] = sub.x.array  # sub shares w's array
        else:
            w.interpolate(f)
        return w.x.petsc_vec.copy()

    free = [lambda x: np.stack([0.3 + 2.0 * x[0] - x[1], -0.1 + 0.5 * x[0]])]
    bent = lambda x: np.stack([x[1] ** 2, x[0] * x[1]])  # noqa: E731
    if fields.spec.u_degree == 2:
        free.append(bent)
        bent = lambda x: np.stack([np.abs(x[0] - 0.4), 0.0 * x[0]])  # noqa: E731 (a kink)
    for f in free:
        v = interpolate(f)
        y = v.duplicate()
        G.mult(v, y)
        assert y.norm() < 1e-12 * G.norm() * v.norm()
    v = interpolate(bent)
    G.mult(v, y)
    assert v.dot(y) > 1e-5 * G.norm() * v.norm() ** 2  # measured 3.9e-4 (P1), 1.3e-4 (P2)
    if fields.spec.pressure:
        pressure = v.duplicate()
        pressure.array[:] = 0.0
        pressure.array[fields.Q[1]] = np.random.default_rng(1).uniform(size=fields.Q[1].size)
        G.mult(pressure, y)
        assert y.norm() == 0.0


def test_the_penalty_scales_with_gamma_and_mu():
    norms = []
    for gamma, mu in ((0.5, 3.0), (1.0, 3.0), (0.5, 6.0)):
        mesh, _, ghost = _ghost("u", gamma, mu)
        norms.append(_all_facets(mesh, ghost).full.norm(PETSc.NormType.FROBENIUS))
    assert norms[1] == pytest.approx(2 * norms[0], rel=1e-13)
    assert norms[2] == pytest.approx(2 * norms[0], rel=1e-13)


def test_ghost_facets_are_those_of_poorly_filled_occupied_cells():
    """On a 4 x 4 grid: cells of the bottom row full, of the second row a third full,
    the rest empty. The ghost facets are the interior facets with both cells
    occupied and one of them poorly filled: inside the second row, and between the
    two rows; not inside the full row, nor next to an empty cell."""
    mesh, _, ghost = _ghost("u")
    tracker = Tracker(mesh)
    centroid_y = tracker.centroids[:, 1]
    fill = np.where(centroid_y < 0.25, 1.0, np.where(centroid_y < 0.5, 1 / 3, 0.0))
    cells = np.flatnonzero(fill > 0).astype(np.int32)  # one point in each occupied cell
    ghost.update(cells, (fill * tracker.volumes)[cells], tracker.volumes, [])
    a, b = (fill[ghost._cells[:, i]] for i in (0, 1))
    expected = (a > 0) & (b > 0) & (np.minimum(a, b) < POORLY_FILLED)
    assert np.array_equal(np.sort(ghost.facets), np.sort(ghost._interior[expected]))
    # 8 cells of the second row: 7 facets inside it, and 4 facets with the bottom row.
    assert ghost.facets.size == 7 + 4
    mesh.topology.create_connectivity(1, 0)
    facet_vertices = mesh.topology.connectivity(1, 0)
    y = mesh.geometry.x[:, 1]
    for f in ghost.facets:
        ends = y[facet_vertices.links(f)]
        assert 0.25 - 1e-12 <= ends.min() and ends.max() <= 0.5 + 1e-12


@pytest.mark.parametrize("wobble", [-4e-16, 0.0, 4e-16])
def test_a_cell_filled_by_half_is_filled_whatever_the_round_off(wobble):
    """Two of four equal points fill a cell by one half, give or take the round-off of
    their volumes. Without a margin the facets flipped with it from one run (or rank
    count) to the next: a 3D block falling under gravity picked 265 facets in
    serial and 268 on 2 ranks. Half-filled cells beside full ones give no facets."""
    mesh, _, ghost = _ghost("u")
    tracker = Tracker(mesh)
    fill = np.where(tracker.centroids[:, 1] < 0.25, 1.0, POORLY_FILLED * (1 + wobble))
    cells = np.arange(tracker.num_cells, dtype=np.int32)
    ghost.update(cells, fill * tracker.volumes, tracker.volumes, [])
    assert ghost.facets.size == 0
    ghost.update(cells, np.where(fill < 1, 0.499, 1.0) * tracker.volumes, tracker.volumes, [])
    assert ghost.facets.size > 0  # just below one half is poorly filled


def test_a_full_body_has_no_ghost_facets_and_the_same_answer():
    """Cook's membrane in one step fills every occupied cell: no facet is stabilised,
    and the answer is the same with and without the penalty."""
    tips = []
    for gamma in (0.0, 1.0):
        sim = scenes.cook_membrane(8, 0.33, "up", ghost_penalty=gamma)
        sim.run(1.0, 1, progress=False)
        tips.append(scenes.tip_deflection(sim))
    assert sim.ghost.facets.size == 0
    assert tips[1] == tips[0]


def test_the_penalty_acts_on_partly_filled_cells_and_costs_little_accuracy():
    """Cook's membrane at 5 N with point domains, n = 16, 20 steps: the penalty acts
    on the facets of the cells the body fills in part (measured: about 40 facets),
    moves the tip by less than 1 % at γ = 0.1 (measured 1.3503 → 1.3427), and
    Newton still converges in 3 iterations a step (the tangent holds the penalty).
    The step's matrix gains the couplings of those facets only, the two opposite
    vertices' 3 × 3 blocks (u and p) each way a facet: until 2026-12-07 it held every interior
    facet's, as explicit zeros that MUMPS factorised (its solves took three times
    as long)."""
    tips, facets, newton, entries = [], [], [], []
    for gamma in (0.0, 0.1):
        sim = scenes.cook_membrane(
            16,
            0.499,
            "up",
            traction=5.0 / 16,
            load="points",
            margin=8,
            point_domains=True,
            ghost_penalty=gamma,
        )
        sim.run(1.0, 20, progress=False)
        tips.append(scenes.tip_deflection(sim))
        facets.append(0 if sim.ghost is None else sim.ghost.facets.size)
        newton.append(max(r.newton_iterations for r in sim.history))
        entries.append(sim._newton.A.getInfo()["nz_used"])
    assert facets[0] == 0 and facets[1] > 20
    assert 0 < entries[1] - entries[0] <= 18 * facets[1]
    assert 0.0 < abs(tips[1] / tips[0] - 1) < 0.01
    assert abs(tips[1] / 1.3542 - 1) < 0.015  # the converged FEM answer
    assert newton == [3, 3]


@pytest.mark.parametrize(
    ("value", "error", "match"),
    [
        (-0.1, ValueError, "ghost_penalty"),
        (np.nan, ValueError, "ghost_penalty"),
    ],
)
def test_ghost_penalty_must_be_non_negative(value, error, match):
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    with pytest.raises(error, match=match):
        fe_mpm.Simulation(mesh, fe_mpm.seed(mesh), fe_mpm.NeoHookean(1.0, 0.3), ghost_penalty=value)


def test_a_p2_cell_left_with_too_few_points_is_tied_by_the_penalty():
    """A Taylor–Hood cell left with 2 of its 3 points has a strain mode no point sees
    (``test_bad_input`` shows that step refused); with the ghost penalty the cell is
    poorly filled, its facets are ghost facets, and the step is taken and converges.
    With no neighbour to tie it to, the same cell is still refused."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    law = fe_mpm.NeoHookean(1.0, 0.3)
    base = [fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0))]
    for gamma in (0.1, 0.0):
        points = fe_mpm.seed(mesh, per_cell=3)
        sim = fe_mpm.Simulation(
            mesh, points, law, "up-p2p1", dirichlet=base, ghost_penalty=gamma, body_force=(0, -0.1)
        )
        sim.step(1.0)
        first = np.flatnonzero(points.cell == points.cell[0])[0]
        other = np.flatnonzero(points.cell != points.cell[0])[0]
        points.x[first] = points.x[other]  # one cell now holds 2 points
        if gamma == 0.0:
            with pytest.raises(fe_mpm.ConvergenceError, match="needs at least 3 .* ghost_penalty"):
                sim.step(2.0)
        else:
            report = sim.step(2.0)
            assert report.newton_iterations <= 5
            assert sim.ghost.facets.size > 0
    # Cells tied only to each other share one quadratic that their points must see:
    # one cell with 2 points, or the two cells of a square with one point each
    # (together 2, and the penalty makes them one quadratic) are still refused.
    tracker = Tracker(mesh)
    square = np.flatnonzero(np.all(tracker.centroids < 0.5, axis=1))
    assert square.size == 2
    for cells, per_cell in (([0], 2), (square, 1)):
        few = fe_mpm.seed(mesh, per_cell=3 if per_cell == 2 else 1, cells=np.asarray(cells))
        few.keep(np.arange(len(few)) < per_cell * len(cells))
        sim = fe_mpm.Simulation(mesh, few, law, "up-p2p1", dirichlet=base, ghost_penalty=0.1)
        with pytest.raises(ValueError, match="needs at least 3"):
            sim.step(1.0)


def test_cells_joined_by_ghost_facets_form_groups():
    """connected_groups labels every node with the lowest node of its group, the
    same partition as a plain union–find, on random graphs."""
    rng = np.random.default_rng(5)
    for _ in range(20):
        n = int(rng.integers(2, 300))
        edges = rng.integers(0, n, (int(rng.integers(0, 400)), 2))
        parent = list(range(n))

        def root(x):
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        for a, b in edges:
            parent[root(a)] = root(b)
        roots = np.array([root(i) for i in range(n)])
        lowest = np.array([np.flatnonzero(roots == roots[i]).min() for i in range(n)])
        assert np.array_equal(connected_groups(edges, n), lowest)


def test_the_p2_penalty_sees_the_jump_of_the_second_derivative():
    """A C¹ displacement, (max(x − ½, 0)², 0), has no gradient jump on the 4 × 4
    grid, only a jump of ∂ₓₓ = 2 across the four vertical facets at x = ½: the P2
    penalty gives Δuᵀ G Δu = γ 2μ h³ 2² |F| · 4 exactly (h the facets' cells'
    diameter √2/4, |F| = ¼), and the P1 part alone would give 0."""
    mesh, fields, ghost = _ghost("up-p2p1", gamma=0.5, mu=3.0)
    G = _all_facets(mesh, ghost).full
    sub = fields.w.sub(0)
    sub.interpolate(lambda x: np.stack([np.maximum(x[0] - 0.5, 0.0) ** 2, 0.0 * x[0]]))
    fields.w.x.array[:] = sub.x.array
    v = fields.w.x.petsc_vec.copy()
    y = v.duplicate()
    G.mult(v, y)
    h = np.sqrt(2.0) / 4.0
    assert v.dot(y) == pytest.approx(2 * 0.5 * 3.0 * h**3 * 4.0 * 0.25 * 4, rel=1e-12)


def test_point_domains_bring_the_ghost_penalty_unless_told_otherwise():
    """In static runs; in dynamic ones a weak one (it damps like a dashpot), enough to
    tie a sliver's nodes (``fe_mpm.ghost.WITH_DOMAINS_DYNAMIC``)."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (2, 2))
    law = fe_mpm.NeoHookean(3.0, 0.25)

    def ghost(**options):
        return fe_mpm.Simulation(mesh, fe_mpm.seed(mesh), law, **options).ghost

    assert ghost() is None
    assert ghost(point_domains=True).scale.value == pytest.approx(2 * WITH_DOMAINS[1] * law.mu)
    assert ghost(point_domains=True, ghost_penalty=0.0) is None
    assert ghost(ghost_penalty=0.3).scale.value == pytest.approx(0.6 * law.mu)
    weak = ghost(point_domains=True, dynamic=True)
    assert weak.scale.value == pytest.approx(2 * WITH_DOMAINS_DYNAMIC * law.mu)
    assert ghost(point_domains=True, dynamic=True, ghost_penalty=0.0) is None
    dynamic = ghost(point_domains=True, dynamic=True, ghost_penalty=0.1)
    assert dynamic.scale.value == pytest.approx(0.2 * law.mu)


@pytest.mark.parametrize("gamma", [0.0, 1.0])
def test_the_base_reaction_carries_the_weight_with_the_penalty(gamma):
    """A block on a fixed base under gravity, its upper row of cells a third full
    (one of three points kept): the penalty acts on the facets next to that row,
    which reach the base's nodes, and the base's reaction still equals the weight
    (it includes the penalty's force)."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (4, 4))
    points = fe_mpm.seed(mesh, per_cell=3, density=2.0)
    y = points.x[:, 1]
    upper = (y > 0.25) & (y < 0.5)
    first_of_cell = np.r_[True, points.cell[1:] != points.cell[:-1]]
    points.keep((y < 0.25) | (upper & first_of_cell))
    base = lambda x: np.isclose(x[1], 0.0)  # noqa: E731
    sim = fe_mpm.Simulation(
        mesh,
        points,
        fe_mpm.NeoHookean(1e3, 0.3, density=2.0),
        dirichlet=[fe_mpm.Dirichlet(base)],
        body_force=(0.0, -10.0),
        reactions={"base": base},
        ghost_penalty=gamma,
    )
    report = sim.run(1.0, 1, progress=False)[-1]
    weight = 10.0 * points.mass.sum()
    if gamma:
        assert sim.ghost.facets.size > 0
    assert report.reactions["base"][1] == pytest.approx(weight, rel=1e-9)


def test_a_prescribed_shift_next_to_ghost_facets_takes_one_newton_iteration():
    """The base of a block is shifted rigidly; its lowest row of cells is a third full,
    so ghost facets reach the shifted nodes. The answer is a rigid translation, which
    the penalty does not resist, and Newton's first update (the Dirichlet lifting,
    which must hold the penalty's part G (g − x) too) lands on it: one iteration
    (measured: 4 when the lifting leaves the penalty out)."""
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (4, 4))
    points = fe_mpm.seed(mesh, per_cell=3, density=2.0)
    y = points.x[:, 1]
    first_of_cell = np.r_[True, points.cell[1:] != points.cell[:-1]]
    points.keep(((y > 0.25) & (y < 0.75)) | ((y < 0.25) & first_of_cell))
    base = fe_mpm.Dirichlet(lambda x: np.isclose(x[1], 0.0), lambda t: (0.02 * t, 0.01 * t))
    x0 = points.x.copy()
    sim = fe_mpm.Simulation(
        mesh, points, fe_mpm.NeoHookean(1e3, 0.3, density=2.0), dirichlet=[base], ghost_penalty=1.0
    )
    report = sim.run(1.0, 1, progress=False)[-1]
    assert sim.ghost.facets.size > 0
    assert report.newton_iterations == 1
    assert np.allclose(points.x - x0, (0.02, 0.01), rtol=0, atol=1e-12)
