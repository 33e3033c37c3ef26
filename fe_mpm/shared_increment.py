r"""Point domains whose pieces share their point's increment, with the exact Jacobian.

With ``Simulation(point_domains=True, shared_increment=True)`` every piece of a
domain takes its point's increment, the share-weighted mean of the grid increments
at the pieces, :math:`\Delta F_p = \sum_l s_l \Delta F(x_l)` (the domain's mean
gradient, as GIMP and CPDI take it), instead of the grid increment of its own cell.
All pieces of a point then carry one stress and one return, and the point keeps
the increment that was in equilibrium (without it each piece reaches equilibrium
with its own cell's gradient and the point keeps its corners' affine map:
``docs/cell_crossing.md`` measures what that does over many steps).

The forms integrate cell by cell, so the mean enters them through a slot field,
the shift :math:`S_k = \Delta F_p - \Delta F(x_k)`, set before every residual
(:meth:`SharedIncrement.refresh`). The Jacobian the forms assemble holds the shift
fixed: :math:`\sum_k G_k B_k`, where :math:`B_k` maps the grid unknown to
:math:`\Delta F(x_k)` (the P1 gradients of the piece's cell) and
:math:`G_k = \partial R_k / \partial \Delta F` is what the piece puts against the
test functions of its cell, differentiated with respect to the increment
(``StepForms.increment_tangent``: the displacement rows, and u-p's volumetric
rows). The exact Jacobian is :math:`\sum_k G_k \bar B_p` with
:math:`\bar B_p = \sum_l s_l B_l`, so :meth:`SharedIncrement.correct` adds
:math:`\sum_k G_k (\bar B_p - B_k)`. It couples the cell of each piece to the cells of
its point's other pieces, which may share only a vertex: entries outside the grid's
matrix pattern, which PETSc is allowed to add. The sum is the product of three sparse
matrices, G (M B), which PETSc forms: B and M are fixed for a step, G changes with
each Jacobian (:meth:`SharedIncrement.hold`). On Cook (n = 32, three points per
cell) a run costs about twice one whose pieces keep their own increments.

P1 displacements only (a P2 gradient varies within a cell), in 2D and 3D, serial
like the domains themselves.
"""

from __future__ import annotations

from petsc4py import PETSc

import numpy as np

from fe_mpm.domains import share_weighted_mean


class SharedIncrement:
    """The shift to each point's mean increment, and the Jacobian's couplings it brings.

    One per step; its pieces are those of the step.

    Args:
        forms: The step's forms, built with ``shared_increment=True``.
        layout: The sub-points' slot layout.
        owner: Each sub-point's point (k,), sorted.
        share: Each sub-point's share of its point (k,); each point's add up to 1.
        weight: Each sub-point's volume, its weight in the forms' sums (k,), m³ (m² in 2D).
        cells: Each sub-point's cell (k,).
        bary: Its barycentric coordinates there (k, d + 1).
        fields: The grid unknowns.
        gradients: The gradients of every cell's P1 basis functions (cells, d + 1, d),
            1/m (:attr:`~fe_mpm.tracker.Tracker.p1_gradients`).
    """

    def __init__(
        self, forms, layout, owner, share, weight, cells, bary, fields, gradients: np.ndarray
    ):
        self.forms, self.layout, self.w = forms, layout, fields.w
        self.owner, self.share, self.weight = owner, share, weight
        self.bary = bary
        self.g = gradients.shape[2]
        self.n_points = int(owner.max()) + 1 if owner.size else 0
        self.grads = gradients[cells]  # (k, d + 1, d)
        self.u_dofs = fields.displacement_dofs_of(cells)  # (k, d + 1, d)
        self.p_dofs = fields.scalar_dofs_of(cells) if fields.spec.pressure else None
        k, l_ = _pairs(owner)
        self.pairs = (k, l_, share[l_] - (k == l_))  # and the coefficient s_l − δ_kl
        self._at: np.ndarray | None = None
        self._allowed = False
        # The rows and columns of the unknown (ghosts included), and which the
        # Dirichlet conditions hold (set per solve).
        self.size = fields.w.x.array.size
        self.held = np.zeros(self.size, dtype=bool)

    def refresh(self) -> None:
        """Set the shift at the current iterate unless it is set there already."""
        if self._at is not None and np.array_equal(self._at, self.w.x.array):
            return
        forms, g = self.forms, self.g
        local = forms.dF_at_points.evaluate(self.layout)  # (k, g * g)
        mean = share_weighted_mean(local, self.owner, self.share, self.n_points)
        shift = (mean[self.owner] - local).reshape(-1, g, g)
        forms.q.pack(forms.dF_shift, self.layout, shift, per_iterate=True)
        self._at = self.w.x.array.copy()

    def hold(self, bcs) -> None:
        """The Dirichlet conditions of the solve: their rows and columns get nothing.

        Also builds, once per solve, the sparse factors of the couplings,
        Σ_k G_k (B̄_p − B_k) = G (M B): B maps the unknown to every piece's ΔF (its
        cell's P1 gradients, the held columns left out), M takes each piece's ΔF to its
        point's mean minus its own (Σ_l s_l ΔF_l − ΔF_k), and G (set per Jacobian) holds
        what each piece puts against its cell's test functions per unit ΔF.
        """
        self.destroy()
        self.held[:] = False
        for bc in bcs:
            self.held[bc.dof_indices()[0]] = True
        g, n_sub = self.g, self.owner.size
        q = g * g
        nodes = g + 1
        # B: row (k, i, j), entries at u(a, i) of k's cell, values ∂λ_a/∂x_j.
        cols = np.broadcast_to(self.u_dofs[:, None, :, :], (n_sub, g, nodes, g))  # k j a i
        cols = np.swapaxes(cols, 1, 3)  # k i a j -> rows (k, i, j) hold a
        cols = np.swapaxes(cols, 2, 3)  # k i j a
        vals = np.broadcast_to(self.grads[:, None, :, :], (n_sub, g, nodes, g))  # k i a j
        vals = np.swapaxes(vals, 2, 3) * ~self.held[cols]  # k i j a
        self._B = _aij(n_sub * q, self.size, cols.reshape(-1, nodes), vals.reshape(-1, nodes))
        # M: row (k, ij), entries (l, ij) for the pieces l of k's point, s_l − δ_kl.
        k, l_, c = self.pairs
        row = (k[:, None] * q + np.arange(q)).ravel()
        col = (l_[:, None] * q + np.arange(q)).ravel()
        self._M = _aij_coo(n_sub * q, n_sub * q, row, col, np.repeat(c, q))
        self._MB = self._M.matMult(self._B)
        # G's rows: u(b, m) (and p(b)) of each piece's cell; columns (k, ij).
        rows = [self.u_dofs.reshape(n_sub, nodes * g)]
        if self.p_dofs is not None:
            rows.append(self.p_dofs)
        rows = np.concatenate(rows, axis=1)  # (k, r)
        row = np.broadcast_to(rows[:, :, None], (*rows.shape, q)).ravel()
        col = np.broadcast_to(
            (np.arange(n_sub)[:, None] * q + np.arange(q))[:, None, :], (*rows.shape, q)
        ).ravel()
        keep = np.flatnonzero(~self.held[row])
        order, indptr = _compressed_rows(row[keep], col[keep], self.size)
        self._G_take = keep[order]
        self._G_csr = (indptr, col[self._G_take])

    def correct(self, A: PETSc.Mat) -> None:
        """Add Σ_k G_k (B̄_p − B_k) to the assembled Jacobian ``A`` at the current iterate."""
        if self.pairs[0].size == 0:
            return
        if not self._allowed:
            A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
            A.setOption(PETSc.Mat.Option.NEW_NONZERO_LOCATION_ERR, False)
            self._allowed = True
        self.refresh()
        g, n_sub = self.g, self.owner.size
        values = self.forms.increment_tangent.evaluate(self.layout)
        tangent = values[:, : g**4].reshape(-1, g, g, g * g)  # ∂(stress)_mn/∂ΔF_ij
        # What each piece puts against its cell's test functions per unit ΔF: rows
        # u(b, m) and p(b), columns ΔF_ij, times the piece's weight.
        G = [np.einsum("kbn,kmnq->kbmq", self.grads, tangent, optimize=True).reshape(n_sub, -1)]
        if self.p_dofs is not None:  # −Σ V q(x_k) ∂(det ΔF e)/∂ΔF
            volume = values[:, g**4 :].reshape(n_sub, 1, g * g)
            G.append((-self.bary[:, :, None] * volume).reshape(n_sub, -1))
        G = np.concatenate(G, axis=1) * self.weight[:, None]
        indptr, indices = self._G_csr
        Gmat = _csr_matrix((self.size, n_sub * g * g), indptr, indices, G.ravel()[self._G_take])
        C = Gmat.matMult(self._MB)
        ai, aj, av = C.getValuesCSR()
        A.setValuesLocalCSR(ai, aj, av, addv=PETSc.InsertMode.ADD_VALUES)
        A.assemble()
        C.destroy()
        Gmat.destroy()

    def destroy(self) -> None:
        """Free the PETSc objects of the last solve."""
        for name in ("_B", "_M", "_MB"):
            matrix = getattr(self, name, None)
            if matrix is not None:
                matrix.destroy()
                setattr(self, name, None)


def _aij(nrows: int, ncols: int, cols: np.ndarray, vals: np.ndarray) -> PETSc.Mat:
    """A serial AIJ matrix with the same number of entries in every row (nrows, width)."""
    order = np.argsort(cols, axis=1)
    cols = np.take_along_axis(cols, order, axis=1).ravel()
    vals = np.take_along_axis(vals, order, axis=1).ravel()
    indptr = np.arange(nrows + 1) * order.shape[1]
    return _csr_matrix((nrows, ncols), indptr, cols, vals)


def _aij_coo(nrows: int, ncols: int, row: np.ndarray, col: np.ndarray, val: np.ndarray):
    """A serial AIJ matrix of (row, col, value) triplets, each (row, col) once."""
    order, indptr = _compressed_rows(row, col, nrows)
    return _csr_matrix((nrows, ncols), indptr, col[order], val[order])


def _compressed_rows(row: np.ndarray, col: np.ndarray, nrows: int):
    """The order that sorts (row, col) triplets by row then column, and the row pointer."""
    order = np.lexsort((col, row))
    indptr = np.concatenate([[0], np.cumsum(np.bincount(row, minlength=nrows))])
    return order, indptr


def _csr_matrix(shape, indptr, indices, values) -> PETSc.Mat:
    """A serial AIJ matrix that owns copies of its compressed rows."""
    matrix = PETSc.Mat().createAIJ(
        shape, nnz=np.diff(indptr).astype(PETSc.IntType), comm=PETSc.COMM_SELF
    )
    matrix.setValuesCSR(
        np.ascontiguousarray(indptr, dtype=PETSc.IntType),
        np.ascontiguousarray(indices, dtype=PETSc.IntType),
        np.ascontiguousarray(values, dtype=PETSc.ScalarType),
    )
    matrix.assemble()
    return matrix


def _pairs(owner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every pair (k, l) of sub-points of one point that has more than one (pairs,) each."""
    counts = np.bincount(owner)
    starts = np.cumsum(counts) - counts
    n = counts[owner]
    many = np.flatnonzero(n > 1)
    k = np.repeat(many, n[many])
    within = np.arange(k.size) - np.repeat(np.cumsum(n[many]) - n[many], n[many])
    return k, starts[owner[k]] + within
