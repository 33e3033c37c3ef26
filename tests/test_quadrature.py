"""Material points as quadrature: assembled forms equal a brute-force particle loop.

Points at random positions, random volumes, 0 to 5 points per cell (so some
cells are empty), and a nonlinear integrand. The slot rule (design note) must
reproduce Σ_p V_p f(x_p) to round-off, both with one entity per cell and with
two slots per entity (so cells with up to 5 points appear up to 3 times, each
copy with its own points).
"""

import sys

import basix.ufl
import dolfinx.fem.petsc  # noqa: F401
import numpy as np
import pytest
import ufl
from layouts import embed_3d, random_points

from fe_mpm._dolfinx import dolfinx
from fe_mpm.assembly import StepForm
from fe_mpm.forms import displacement, inertia, mixed_up, penalty
from fe_mpm.formulations import collapse
from fe_mpm.materials import NeoHookean
from fe_mpm.meshes import rectangle_mesh
from fe_mpm.quadrature import (
    OCCUPIED,
    SLOT_BUCKETS,
    MaterialPointQuadrature,
    SlotLayout,
    bucket,
    slot_count,
)
from fe_mpm.tracker import Tracker

RTOL = 1e-12


def _mesh(dim):
    if dim == 2:
        return rectangle_mesh((0.0, 0.0), (2.0, 1.0), (6, 4))
    return rectangle_mesh((0.0, 0.0, 0.0), (1.0, 1.0, 2.0), (2, 2, 3))


def _setup(dim, seed=1, F_spread=0.0, nslot=None):
    rng = np.random.default_rng(seed)
    mesh = _mesh(dim)
    ncells = mesh.topology.index_map(dim).size_local
    counts = rng.integers(0, 6, size=ncells)
    pts, cells = random_points(mesh, rng, counts, fill=False, F_spread=F_spread)
    layout = SlotLayout.from_cells(cells, nslot)
    q = MaterialPointQuadrature(mesh, layout.nslot)
    tracker = Tracker(mesh)
    q.pack_geometry(pts.x, pts.volume, layout, tracker.centroids, tracker.volumes)
    return rng, mesh, pts, layout, q


def _p1_basis(V, cell, x):
    """Values (v,) and gradients (v, g) of the P1 basis of ``cell`` at ``x`` (from dof coords)."""
    gdim = x.size
    dofs = V.dofmap.list[cell]
    X = V.tabulate_dof_coordinates()[dofs, :gdim]
    M = np.vstack([np.ones(len(dofs)), X.T])  # sum_i N_i [1, X_i] = [1, x]
    Minv = np.linalg.inv(M)
    return dofs, Minv @ np.concatenate([[1.0], x]), Minv[:, 1:]


def _assemble(form, mesh, layout, q):
    f = StepForm(form, mesh, quadratures={OCCUPIED: q}).bind(layout)
    if form.arguments().__len__() == 1:
        return f.assemble_vector().copy()
    A = dolfinx.fem.assemble_matrix(f.form, coeffs=f.coefficients())
    A.scatter_reverse()
    return A.to_dense()


@pytest.mark.parametrize("nslot", [None, 2])
@pytest.mark.parametrize("dim", [2, 3])
def test_scalar_nonlinear_form_equals_particle_sum(dim, nslot):
    rng, mesh, pts, layout, q = _setup(dim, nslot=nslot)
    if nslot is not None:
        assert layout.num_entities > layout.occupied.size, "want cells split into entities"
    assert layout.occupied.size < mesh.topology.index_map(dim).size_local, "want empty cells"
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1))
    u = dolfinx.fem.Function(V)
    u.x.array[:] = rng.uniform(-1.0, 1.0, u.x.array.size)
    w = ufl.TestFunction(V)
    up, gu = q.at_points(u), q.grad_at_points(u)
    R = q.sum((1 + up**2) * ufl.dot(gu, q.grad_at_points(w)) + up**3 * q.at_points(w))
    J = ufl.derivative(R, u, ufl.TrialFunction(V))
    R_mp, J_mp = _assemble(R, mesh, layout, q), _assemble(J, mesh, layout, q)

    R_bf = np.zeros_like(R_mp)
    J_bf = np.zeros_like(J_mp)
    uvals = u.x.array
    for p in range(len(pts)):
        dofs, N, dN = _p1_basis(V, layout.cell[p], pts.x[p])
        V_p = pts.volume[p]
        u_p, g_p = N @ uvals[dofs], dN.T @ uvals[dofs]
        R_bf[dofs] += V_p * ((1 + u_p**2) * dN @ g_p + u_p**3 * N)
        J_bf[np.ix_(dofs, dofs)] += V_p * (
            2 * u_p * np.outer(dN @ g_p, N) + (1 + u_p**2) * dN @ dN.T + 3 * u_p**2 * np.outer(N, N)
        )
    assert np.linalg.norm(R_mp - R_bf) <= RTOL * np.linalg.norm(R_bf)
    assert np.linalg.norm(J_mp - J_bf) <= RTOL * np.linalg.norm(J_bf)


@pytest.mark.parametrize("nslot", [None, 2])
@pytest.mark.parametrize("dim", [2, 3])
def test_neo_hookean_residual_equals_particle_sum(dim, nslot):
    rng, mesh, pts, layout, q = _setup(dim, seed=2, F_spread=0.1, nslot=nslot)
    mat = NeoHookean(E=10.0, nu=0.3)
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (dim,)))
    du = dolfinx.fem.Function(V)
    du.x.array[:] = rng.uniform(-0.05, 0.05, du.x.array.size)
    F_n = q.function((dim, dim), "F_n")
    rho = q.function((), "density")
    q.pack(F_n, layout, pts.F, empty=np.eye(dim))
    q.pack(rho, layout, pts.density)
    b = np.arange(1.0, dim + 1.0)
    R = displacement.residual(
        du, ufl.TestFunction(V), q, F_n, rho, mat.kirchhoff, body_force=ufl.as_vector(b)
    )
    R_mp = _assemble(R, mesh, layout, q)

    R_bf = np.zeros_like(R_mp).reshape(-1, dim)
    U = du.x.array.reshape(-1, dim)
    for p in range(len(pts)):
        dofs, N, dN = _p1_basis(V, layout.cell[p], pts.x[p])
        dF = np.eye(dim) + U[dofs].T @ dN
        F = dF @ pts.F[p]
        J = np.linalg.det(F)
        tau = mat.lmbda * np.log(J) * np.eye(dim) + mat.mu * (F @ F.T - np.eye(dim))
        P = tau @ np.linalg.inv(dF).T / np.linalg.det(pts.F[p])
        R_bf[dofs] += pts.volume[p] * (dN @ P.T - pts.density[p] * np.outer(N, b))
    R_bf = R_bf.ravel()
    assert np.linalg.norm(R_mp - R_bf) <= RTOL * np.linalg.norm(R_bf)


def test_fields_of_degree_other_than_1_or_2_are_refused_by_name():
    _, mesh, _, _, q = _setup(2)
    u = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("Lagrange", 3)))
    for method in (q.at_points, q.grad_at_points):
        with pytest.raises(ValueError, match=rf"{method.__name__}: degree must be 1 or 2, got 3"):
            method(u, 3)


def test_a_layout_for_another_slot_count_is_refused_naming_both():
    _, mesh, pts, layout, q = _setup(2)
    other = SlotLayout.from_cells(layout.cell, layout.nslot + 1)
    tracker = Tracker(mesh)
    with pytest.raises(
        ValueError,
        match=rf"layout has {other.nslot} slots per entity, "
        rf"the rule {q.nslot}",
    ):
        q.pack_geometry(pts.x, pts.volume, other, tracker.centroids, tracker.volumes)


def test_slot_layout_numbers_points_within_cells():
    cells = np.array([3, 1, 3, 3, 0, 1], dtype=np.int32)
    layout = SlotLayout.from_cells(cells)
    assert layout.slot.tolist() == [0, 0, 1, 2, 0, 1]
    assert layout.occupied.tolist() == [0, 1, 3]
    assert layout.entities.tolist() == [0, 1, 3]
    assert layout.max_count == 3 and layout.nslot == 3
    assert bucket(3) == 3 and bucket(5) == 6 and bucket(13) == 16
    # one point per cell: one slot, one entity per cell
    single = SlotLayout.from_cells(np.array([4, 2, 7], dtype=np.int32))
    assert single.nslot == 1 and single.slot.tolist() == [0, 0, 0]
    assert single.entities.tolist() == [2, 4, 7]


def test_no_points_give_an_empty_layout():
    layout = SlotLayout.from_cells(np.zeros(0, dtype=np.int32), nslot=2)
    assert layout.num_entities == 0 and layout.occupied.size == 0 and layout.max_count == 0


def test_a_full_cell_is_split_into_entities_of_nslot_points():
    cells = np.array([3, 1, 3, 3, 0, 1], dtype=np.int32)
    layout = SlotLayout.from_cells(cells, nslot=2)
    assert layout.entities.tolist() == [0, 1, 3, 3]
    assert layout.entity.tolist() == [2, 1, 2, 3, 0, 1]
    assert layout.slot.tolist() == [0, 0, 1, 0, 0, 1]


def test_slot_count_balances_empty_slots_against_entities():
    """The footing's seeding (12 points per cell near it, 3 elsewhere) gets 3 slots,
    not 12; an even seeding gets its count; a current count is kept unless another
    saves a fifth of the cost (no recompiling for small gains)."""
    mixed = np.r_[np.full(100, 12), np.full(450, 3)]
    assert slot_count(mixed) == 3
    assert slot_count(np.full(50, 1)) == 1 and slot_count(np.full(50, 6)) == 6
    assert slot_count(np.r_[np.full(99, 1), 2]) == 1  # one cell crossed into: no recompile
    assert slot_count(mixed, current=4) == 4
    assert slot_count(mixed, current=12) == 3
    # two points a cell: 2 slots cost 4 a cell, 3 slots 5, exactly a fifth more: switch
    assert slot_count(np.full(4, 2), current=3) == 2
    # one cell of 5: one entity of 6 slots (8 in cost) beats 2 of 3 (10), 5 of 1 (15)
    assert slot_count(np.array([5])) == 6 and slot_count(np.array([0, 5, 0])) == 6
    # no point anywhere: keep the current count, or 1
    assert slot_count(np.zeros(3, dtype=int)) == 1 and slot_count(np.array([], dtype=int)) == 1
    assert slot_count(np.zeros(3, dtype=int), current=4) == 4
    # more points in a cell than the largest bucket: refused, naming the limit
    too_many = SLOT_BUCKETS[-1] + 1
    with pytest.raises(
        ValueError,
        match=f"{too_many} material points in one cell exceeds the "
        f"supported {SLOT_BUCKETS[-1]}; refine the background grid, or seed fewer points "
        r"per cell \(seed\(level_set=...\) puts",  # a helper's cube cut by six faces
    ):
        bucket(too_many)


def _p2_basis(V, cell, x):
    """Values (n,) and gradients (n, g) of the P2 basis of ``cell`` at ``x``.

    From the node coordinates: the basis is the inverse of the Vandermonde matrix
    of the monomials of degree ≤ 2, independent of how the form compiler tabulates it.
    """
    g = x.size
    nodes = V.dofmap.list[cell]
    X = V.tabulate_dof_coordinates()[nodes, :g]
    pairs = [(i, j) for i in range(g) for j in range(i, g)]

    def monomials(y):
        return np.concatenate([[1.0], y, [y[i] * y[j] for i, j in pairs]])

    def monomial_gradients(y):
        d = np.zeros((1 + g + len(pairs), g))
        d[1 : 1 + g] = np.eye(g)
        for k, (i, j) in enumerate(pairs):
            d[1 + g + k, i] += y[j]
            d[1 + g + k, j] += y[i]
        return d

    C = np.linalg.inv(np.array([monomials(X_i) for X_i in X]))
    return nodes, monomials(x) @ C, C.T @ monomial_gradients(x)


@pytest.mark.parametrize("dim", [2, 3])
def test_taylor_hood_up_residual_and_stress_equal_particle_sums(dim):
    """P2/P1 u-p: the residual under a body force, and the output Cauchy stress of a
    compressible state (J far from 1), against a loop over the points with the P2
    basis built by hand. Guards the degree of the load evaluation (a P2 test function
    read as P1 misses ½ d·H·d) and the 1/J of the deviatoric Cauchy stress."""
    rng, mesh, pts, layout, q = _setup(dim, seed=3, F_spread=0.15)
    mat = NeoHookean(E=10.0, nu=0.3)
    cell = mesh.topology.cell_name()
    u_el = basix.ufl.element("Lagrange", cell, 2, shape=(dim,))
    p_el = basix.ufl.element("Lagrange", cell, 1)
    W = dolfinx.fem.functionspace(mesh, basix.ufl.mixed_element([u_el, p_el]))
    V2, to_u = collapse(W.sub(0))
    Q1, to_p = collapse(W.sub(1))
    sol = dolfinx.fem.Function(W)
    sol.x.array[to_u] = rng.uniform(-0.01, 0.01, len(to_u))
    sol.x.array[to_p] = rng.uniform(-1.0, 1.0, len(to_p))
    du, p = ufl.split(sol)
    w, q_test = ufl.TestFunctions(W)
    F_n = q.function((dim, dim), "F_n")
    rho = q.function((), "density")
    q.pack(F_n, layout, pts.F, empty=np.eye(dim))
    q.pack(rho, layout, pts.density)
    b = np.arange(1.0, dim + 1.0)
    R = mixed_up.residual(
        du, p, w, q_test, q, F_n, rho, mat, None, body_force=ufl.as_vector(b), u_degree=2
    )
    R_mp = _assemble(R, mesh, layout, q)
    dF_p = ufl.Identity(dim) + q.grad_at_points(du, 2)
    A = rng.uniform(-1.0, 1.0, (3, 3))
    v = ufl.TestFunction(Q1)
    sigma = mixed_up.cauchy_stress_3d(mat, dF_p * F_n, q.at_points(p))
    S_mp = _assemble(q.sum(ufl.inner(sigma, ufl.as_matrix(A)) * q.at_points(v)), mesh, layout, q)

    R_bf, S_bf = np.zeros_like(R_mp), np.zeros_like(S_mp)
    U = sol.x.array[to_u].reshape(-1, dim)
    P = sol.x.array[to_p]
    J_all = []
    for k in range(len(pts)):
        nodes, N2, dN2 = _p2_basis(V2, layout.cell[k], pts.x[k])
        pdofs, N1, _ = _p1_basis(Q1, layout.cell[k], pts.x[k])
        dF = np.eye(dim) + U[nodes].T @ dN2
        F3 = embed_3d(dF @ pts.F[k])
        J = np.linalg.det(F3)
        J_all.append(J)
        p_k = N1 @ P[pdofs]
        b_bar = J ** (-2.0 / 3.0) * F3 @ F3.T
        dev_tau = mat.mu * (b_bar - np.trace(b_bar) / 3.0 * np.eye(3))
        tau = -J * p_k * np.eye(dim) + dev_tau[:dim, :dim]
        Piola = tau @ np.linalg.inv(dF).T / np.linalg.det(pts.F[k])
        V_k = pts.volume[k]
        r_u = V_k * (dN2 @ Piola.T - pts.density[k] * np.outer(N2, b))
        R_bf[to_u.reshape(-1, dim)[nodes]] += r_u
        R_bf[to_p[pdofs]] -= V_k * np.linalg.det(dF) * N1 * ((J - 1.0) + p_k / mat.bulk_modulus)
        sigma_k = -p_k * np.eye(3) + dev_tau / J
        S_bf[pdofs] += V_k * np.sum(sigma_k * A) * N1
    assert max(abs(np.array(J_all) - 1.0)) > 0.2, "want a compressible state"
    assert np.linalg.norm(R_mp - R_bf) <= RTOL * np.linalg.norm(R_bf)
    assert np.linalg.norm(S_mp - S_bf) <= RTOL * np.linalg.norm(S_bf)


@pytest.mark.parametrize("lumped", [False, True])
@pytest.mark.parametrize("dim", [2, 3])
def test_inertia_equals_particle_sum(dim, lumped):
    """The Newmark–Bossak inertia and damping term against a loop over the points: the
    consistent mass Σ_p m_p N_I N_J, or the row-sum lumped mass Σ_p m_p N_I on the
    diagonal, reached through the second moments C_p = Σ_I N_I r_I ⊗ r_I."""
    rng, mesh, pts, layout, q = _setup(dim, seed=4)
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (dim,)))
    du, v_n, a_n = (dolfinx.fem.Function(V) for _ in range(3))
    for f in (du, v_n, a_n):
        f.x.array[:] = rng.uniform(-1.0, 1.0, f.x.array.size)
    # Bossak's α_B = −0.2 (β = 0.36, γ = 0.7) exercises every coefficient of the rule.
    dt, bossak, alpha = 0.05, -0.2, 0.3
    beta, gamma = (1 - bossak) ** 2 / 4, 0.5 - bossak
    constants = {name: dolfinx.fem.Constant(mesh, 0.0) for name in inertia.COEFFICIENTS}
    nm = inertia.NewmarkData(
        v_n,
        a_n,
        **constants,
        bossak=dolfinx.fem.Constant(mesh, bossak),
        damping=dolfinx.fem.Constant(mesh, alpha),
    )
    nm.set_step(dt)
    rho = q.function((), "density")
    q.pack(rho, layout, pts.density)
    X = V.tabulate_dof_coordinates()[:, :dim]
    bases = [_p1_basis(V, c, x) for c, x in zip(layout.cell, pts.x)]
    lumping = None
    if lumped:
        lumping = q.function((dim, dim), "second_moment")
        r = [X[nodes] - x for (nodes, _, _), x in zip(bases, pts.x)]
        C = np.array([np.einsum("v,vi,vj->ij", N, r_k, r_k) for (_, N, _), r_k in zip(bases, r)])
        q.pack(lumping, layout, C)
    R_mp = _assemble(inertia.inertia(du, ufl.TestFunction(V), q, rho, nm, lumping), mesh, layout, q)

    # Newmark's a_{n+1} and v_{n+1} written out from β and γ, then Bossak's weighting.
    du_, v_, a_ = du.x.array, v_n.x.array, a_n.x.array
    a_new = (du_ - dt * v_ - dt**2 * (0.5 - beta) * a_) / (beta * dt**2)
    v_new = v_ + dt * ((1 - gamma) * a_ + gamma * a_new)
    a_nodes = ((1 - bossak) * a_new + bossak * a_ + alpha * v_new).reshape(-1, dim)
    R_bf = np.zeros_like(R_mp).reshape(-1, dim)
    for (nodes, N, _), m in zip(bases, pts.mass):
        if lumped:
            R_bf[nodes] += m * N[:, None] * a_nodes[nodes]
        else:
            R_bf[nodes] += m * np.outer(N, N @ a_nodes[nodes])
    R_bf = R_bf.ravel()
    assert np.linalg.norm(R_mp - R_bf) <= RTOL * np.linalg.norm(R_bf)


@pytest.mark.parametrize("degree", [1, 2])
def test_boundary_point_penalty_equals_particle_sum(degree):
    """The penalty and traction of boundary points, Σ_b w_b (β∘(g_b + Δu(x_b)) − t_b)·δu(x_b),
    against a loop over the points, on P1 and on Taylor–Hood's P2 displacement (read
    at the points with its curvature, not as if it were linear)."""
    dim = 2
    rng, mesh, pts, layout, q = _setup(dim, seed=5)
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", degree, (dim,)))
    du = dolfinx.fem.Function(V)
    du.x.array[:] = rng.uniform(-0.1, 0.1, du.x.array.size)
    gap, beta, t = (rng.uniform(-1.0, 1.0, (len(pts), dim)) for _ in range(3))
    fields = []
    for name, values in (("gap", gap), ("penalty", beta), ("traction", t)):
        fields.append(q.function((dim,), name))
        q.pack(fields[-1], layout, values)
    R = penalty.penalty(du, ufl.TestFunction(V), q, *fields, u_degree=degree)
    R_mp = _assemble(R, mesh, layout, q)

    basis = _p2_basis if degree == 2 else _p1_basis
    U = du.x.array.reshape(-1, dim)
    R_bf = np.zeros_like(R_mp).reshape(-1, dim)
    for k in range(len(pts)):
        nodes, N, _ = basis(V, layout.cell[k], pts.x[k])
        force = beta[k] * (gap[k] + N @ U[nodes]) - t[k]
        R_bf[nodes] += pts.volume[k] * np.outer(N, force)
    R_bf = R_bf.ravel()
    assert np.linalg.norm(R_mp - R_bf) <= RTOL * np.linalg.norm(R_bf)


def test_a_bound_form_repacks_what_changed_between_assemblies_and_only_that():
    """Per-iterate slot data and changed finite element fields reach the next assembly.

    A bound form writes a field into its coefficients again only when its slot data
    are new or its dofs differ (:mod:`fe_mpm.packing`); per-iterate fields go in
    point by point, over the vacant slots' values of the first pack. Each assembly
    must equal a form bound afresh to eagerly packed data: the particle sum.
    """
    dim = 2
    rng, mesh, pts, layout, q = _setup(dim, seed=3, F_spread=0.1, nslot=2)
    assert layout.num_entities * layout.nslot > len(pts), "want vacant slots"
    mat = NeoHookean(E=10.0, nu=0.3)
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (dim,)))
    du = dolfinx.fem.Function(V)
    F_n = q.function((dim, dim), "F_n")
    rho = q.function((), "density")
    q.pack(rho, layout, pts.density)
    R = displacement.residual(du, ufl.TestFunction(V), q, F_n, rho, mat.kirchhoff)
    form = StepForm(R, mesh, quadratures={OCCUPIED: q}, dynamic={F_n})
    bound = form.bind(layout)

    def fresh(F):
        q.pack(F_n, layout, F, empty=np.eye(dim))
        vector = form.bind(layout).assemble_vector().copy()
        q.pack(F_n, layout, F, empty=np.eye(dim), per_iterate=True)
        return vector

    for trial in range(3):
        F = pts.F + 0.05 * rng.standard_normal(pts.F.shape)
        du.x.array[:] = rng.uniform(-0.05, 0.05, du.x.array.size)  # in place
        expected = fresh(F)
        got = bound.assemble_vector()
        assert np.linalg.norm(got - expected) <= RTOL * np.linalg.norm(expected), trial
        assert np.array_equal(bound.assemble_vector(), got)  # nothing new: the same


def test_per_iterate_fields_pack_where_a_rank_holds_no_points():
    """Under MPI a rank may hold no points; its per-iterate packs must not fail (a
    rank that raised alone left the others waiting in the next collective)."""
    mesh = _mesh(2)
    layout = SlotLayout.from_cells(np.zeros(0, dtype=np.int32), 1)
    q = MaterialPointQuadrature(mesh, layout.nslot)
    tau = q.function((3, 3), "tau_k")
    q.pack(tau, layout, np.zeros((0, 3, 3)), per_iterate=True)
    assert q.values[tau].slots.shape == (0, 9)
    array = np.zeros((0, 9))
    q.values[tau].scatter(array, slice(0, 9))


def test_per_iterate_rows_are_scattered_the_same_without_numba(monkeypatch):
    """numba writes a per-iterate field's rows into a kernel's array; without numba
    (which fe-mpm's numpy route allows) numpy writes the same, and a row count that
    does not match the layout is refused rather than written out of bounds."""
    rng, mesh, pts, layout, q = _setup(2, seed=4, nslot=2)
    tau = q.function((3, 3), "tau_k")
    values = rng.standard_normal((len(pts), 3, 3))
    q.pack(tau, layout, values, per_iterate=True)
    width, columns = 40, slice(7, 7 + 2 * 9)
    with_numba = rng.standard_normal((layout.num_entities, width))
    without = with_numba.copy()
    q.values[tau].scatter(with_numba, columns)
    monkeypatch.setitem(sys.modules, "fe_mpm.slot_scatter", None)  # its import fails
    q.values[tau].scatter(without, columns)
    assert np.array_equal(with_numba, without)
    block = with_numba[:, columns].reshape(layout.num_entities, 2, 9)
    assert np.array_equal(block[layout.entity, layout.slot], values.reshape(-1, 9))
    with pytest.raises(ValueError, match="rows for"):
        q.pack(tau, layout, values[1:], per_iterate=True)
