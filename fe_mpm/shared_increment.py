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
matrix pattern, which PETSc is allowed to add.

P1 displacements only (a P2 gradient varies within a cell), in 2D and 3D, serial
like the domains themselves.
"""

from __future__ import annotations

from petsc4py import PETSc

import numpy as np


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
        mean = np.zeros((self.n_points, local.shape[1]))
        np.add.at(mean, self.owner, local * self.share[:, None])
        shift = (mean[self.owner] - local).reshape(-1, g, g)
        forms.q.pack(forms.dF_shift, self.layout, shift)
        self._at = self.w.x.array.copy()

    def hold(self, bcs) -> None:
        """The Dirichlet conditions of the solve: their rows and columns get nothing.

        Also lays out, once per solve, where each coupling goes in the matrix.
        """
        self.held[:] = False
        for bc in bcs:
            self.held[bc.dof_indices()[0]] = True
        k, l_, _ = self.pairs
        # The rows and columns of the values correct() computes, in its order.
        rows = [np.broadcast_to(self.u_dofs[k][:, :, :, None, None], (k.size, *self._u_block))]
        cols = [np.broadcast_to(self.u_dofs[l_][:, None, None, :, :], (k.size, *self._u_block))]
        if self.p_dofs is not None:
            rows.append(np.broadcast_to(self.p_dofs[k][:, :, None, None], (k.size, *self._p_block)))
            cols.append(np.broadcast_to(self.u_dofs[l_][:, None, :, :], (k.size, *self._p_block)))
        rows = np.concatenate([r.ravel() for r in rows])
        cols = np.concatenate([c.ravel() for c in cols])
        self._layout = _csr_layout(rows, cols, self.held, self.size)

    def correct(self, A: PETSc.Mat) -> None:
        """Add Σ_k G_k (B̄_p − B_k) to the assembled Jacobian ``A`` at the current iterate."""
        if self.pairs[0].size == 0:
            return
        if not self._allowed:
            A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
            A.setOption(PETSc.Mat.Option.NEW_NONZERO_LOCATION_ERR, False)
            self._allowed = True
        self.refresh()
        g, (k, l_, c) = self.g, self.pairs
        n, nodes = k.size, g + 1
        values = self.forms.increment_tangent.evaluate(self.layout)
        tangent = values[:, : g**4].reshape(-1, g, g, g * g)  # ∂(stress)_mn/∂ΔF_ij
        # What each piece puts against its cell's test functions per unit ΔF, G_k:
        # (b, m) rows, (i, j) increment; the weight and s_l − δ_kl come in per pair.
        G_u = np.einsum("kbn,kmnq->kbmq", self.grads, tangent, optimize=True)
        G_u *= self.weight[:, None, None, None]
        # ΔF_ij of piece l moves with u_(a, i) by grads_l[a, j]: contract j by matmul.
        left = (G_u[k] * c[:, None, None, None]).reshape(n, nodes * g * g, g)
        blocks = [np.matmul(left, np.swapaxes(self.grads[l_], 1, 2))]  # (n, b m i, a)
        blocks[0] = np.swapaxes(blocks[0].reshape(n, nodes, g, g, nodes), 3, 4)  # b m a i
        if self.p_dofs is not None:  # −Σ V q(x_k) ∂(det ΔF e)/∂ΔF
            volume = values[:, g**4 :].reshape(-1, g, g)
            G_p = -(self.weight[:, None] * self.bary)[:, :, None, None] * volume[:, None]
            left = (G_p[k] * c[:, None, None, None]).reshape(n, nodes * g, g)
            block = np.matmul(left, np.swapaxes(self.grads[l_], 1, 2))  # (n, b i, a)
            blocks.append(np.swapaxes(block.reshape(n, nodes, g, nodes), 2, 3))  # b a i
        data = np.concatenate([b.ravel() for b in blocks])
        indptr, indices, taken, starts = self._layout
        summed = np.add.reduceat(data[taken], starts)
        A.setValuesLocalCSR(indptr, indices, summed, addv=PETSc.InsertMode.ADD_VALUES)
        A.assemble()

    @property
    def _u_block(self) -> tuple[int, ...]:
        """The shape of one pair's displacement couplings: (b, m) rows, (a, i) columns."""
        return (self.g + 1, self.g, self.g + 1, self.g)

    @property
    def _p_block(self) -> tuple[int, ...]:
        """The shape of one pair's pressure couplings: b rows, (a, i) columns."""
        return (self.g + 1, self.g + 1, self.g)


def _csr_layout(rows: np.ndarray, cols: np.ndarray, held: np.ndarray, size: int):
    """Where (row, col) entries go in compressed rows, repeated entries summed.

    Returns the compressed rows (indptr, indices), the entries to take, in order (those
    off the held rows and columns, sorted), and where each summed run starts.
    """
    keep = ~(held[rows] | held[cols])
    key = rows[keep].astype(np.int64) * size + cols[keep]
    order = np.argsort(key, kind="stable")
    key = key[order]
    first = np.ones(key.size, dtype=bool)
    first[1:] = key[1:] != key[:-1]
    starts = np.flatnonzero(first)
    r, c = np.divmod(key[starts], size)
    indptr = np.concatenate([[0], np.cumsum(np.bincount(r, minlength=size))])
    taken = np.flatnonzero(keep)[order]
    return indptr.astype(PETSc.IntType), c.astype(PETSc.IntType), taken, starts


def _pairs(owner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every pair (k, l) of sub-points of one point that has more than one (pairs,) each."""
    counts = np.bincount(owner)
    starts = np.cumsum(counts) - counts
    n = counts[owner]
    many = np.flatnonzero(n > 1)
    k = np.repeat(many, n[many])
    within = np.arange(k.size) - np.repeat(np.cumsum(n[many]) - n[many], n[many])
    return k, starts[owner[k]] + within
