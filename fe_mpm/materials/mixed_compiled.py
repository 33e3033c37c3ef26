"""The tangent blocks of the return at the field's pressure, compiled (numba).

The same formulas as the numpy route of :mod:`~fe_mpm.materials.mixed_return` (which
stays as the reference and as the route without numba), in one pass per point: the
numpy route makes several (n, 9, 9) temporaries, and was the larger part of a
Newton iteration's return on a plastic footing.
"""

from __future__ import annotations

import numpy as np

from fe_mpm.materials.compiled import jit


@jit
def _blocks_loop(D9, Fs, lam, spring, cols, out_s, out_sm, out_v, out_vm):
    n, nc = D9.shape[0], cols.shape[0]
    m = np.empty(9)
    devD_F = np.empty(9)
    dd = np.empty(nc)
    for p in range(n):
        for c in range(9):
            m[c] = (D9[p, 0, c] + D9[p, 4, c] + D9[p, 8, c]) / 3.0
        h = 0.0
        for c in range(9):
            h += m[c] * Fs[p, c]
        h /= 3.0
        for r in range(9):
            on_diagonal = r == 0 or r == 4 or r == 8
            acc = 0.0
            for c in range(9):
                dev = D9[p, r, c] - m[c] if on_diagonal else D9[p, r, c]
                acc += dev * Fs[p, c]
            devD_F[r] = acc / 3.0
        # On the spring s is the apex's, whatever τ̄_m; δ follows τ̄_m at its stiffness.
        on_spring = spring[p] > 0.0
        for j in range(nc):
            # A trial so far out that the return is the apex's with no stiffness at
            # all (D9 = 0, h = 0): δ gets no slope in ΔF there, not 0/0.
            dd[j] = 0.0 if on_spring and h == 0.0 else -lam[p] * m[cols[j]] / h
        dd_tau = 1.0 / spring[p] if on_spring else 1.0 / h
        ds_tau = 0.0 if on_spring else 1.0 / h
        for r in range(9):
            on_diagonal = r == 0 or r == 4 or r == 8
            for j in range(nc):
                c = cols[j]
                dev = D9[p, r, c] - m[c] if on_diagonal else D9[p, r, c]
                out_s[p, r, j] = dev * lam[p] + devD_F[r] * dd[j]
            out_sm[p, r] = devD_F[r] * ds_tau
        for j in range(nc):
            out_v[p, j] = -dd[j]
        out_vm[p] = -dd_tau


def blocks(D9, Fs, lam, spring, cols):
    """∂s/∂ΔF (n, 9, g²), ∂s/∂τ̄_m (n, 9), ∂v/∂ΔF (n, g²), ∂v/∂τ̄_m (n,).

    Args:
        D9: ∂τ/∂ΔF* at the shifted trials the returns were taken at (n, 9, 9), Pa.
        Fs: Those ΔF* = e^{δ/3} ΔF (n, 9).
        lam: e^{δ/3} (n,).
        spring: ∂τ̄_m/∂δ (Pa) where a spring holds the point (its return is the
            apex's, taken where the trial first reaches it), 0 elsewhere (n,).
        cols: The columns kl that ΔF varies (g²,).
    """
    n, nc = D9.shape[0], cols.shape[0]
    out_s, out_sm = np.empty((n, 9, nc)), np.empty((n, 9))
    out_v, out_vm = np.empty((n, nc)), np.empty(n)
    _blocks_loop(
        np.ascontiguousarray(D9, dtype=float),
        np.ascontiguousarray(Fs, dtype=float),
        np.ascontiguousarray(lam, dtype=float),
        np.ascontiguousarray(spring, dtype=float),
        np.ascontiguousarray(cols, dtype=np.int64),
        out_s,
        out_sm,
        out_v,
        out_vm,
    )
    return out_s, out_sm, out_v, out_vm
