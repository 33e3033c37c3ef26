r"""Isotropic functions of the trial left Cauchy–Green tensor and their exact derivative.

A law integrated in principal space (Hencky elasticity with a principal return)
gives the Kirchhoff stress as an isotropic function of
:math:`b^{tr} = \Delta F\, b^e_n\, \Delta F^T`:
:math:`\tau = \sum_A y_A(x)\, n_A \otimes n_A`, with :math:`x_A` the eigenvalues of
:math:`b^{tr}` and :math:`n_A` its eigenvectors. In the eigenbasis the derivative
is (e.g. de Souza Neto et al. 2008, App. A; thesis Eq. 3.145)

.. math::

    d\tau'_{AA} = \sum_B \frac{\partial y_A}{\partial x_B}\, db'_{BB}, \qquad
    d\tau'_{AB} = \theta_{AB}\, db'_{AB}\ (A \ne B), \qquad
    \theta_{AB} = \frac{y_A - y_B}{x_A - x_B},

where :math:`db' = Q^T db\, Q`. For (nearly) equal eigenvalues θ takes its limit
:math:`\partial y_A/\partial x_A - \partial y_A/\partial x_B`, which is what makes
the formula exact at repeated eigenvalues, where the thesis's Eq. 3.147 divides
by zero (a virgin point has :math:`b^{tr} = I` with all three equal).
"""

from __future__ import annotations

import numpy as np

#: Relative gap below which two eigenvalues are treated as equal.
REPEATED = 1e-10


def spectral_decomposition(b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues in descending order (n, 3) and eigenvectors as columns (n, 3, 3)."""
    x, Q = np.linalg.eigh(b)
    return x[:, ::-1], Q[:, :, ::-1]


def from_principal(values: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Σ_A v_A n_A⊗n_A (n, 3, 3) from principal values (n, 3) and eigenvectors (n, 3, 3)."""
    # (Q diag(v)) Qᵀ as a batched matmul: three times faster than the three-operand einsum.
    return (Q * values[:, None, :]) @ np.swapaxes(Q, 1, 2)


def derivative_wrt_dF(
    x: np.ndarray, Q: np.ndarray, y: np.ndarray, dy_dx: np.ndarray,
    dF: np.ndarray, b_n: np.ndarray, g: int = 3,
) -> np.ndarray:
    """∂τ_ij/∂ΔF_kl (n, 3, 3, g, g) of τ = Σ y_A(x) n_A⊗n_A with b^tr = ΔF b_n ΔFᵀ.

    Args:
        x: Eigenvalues of b^tr (n, 3).
        Q: Its eigenvectors as columns (n, 3, 3).
        y: Principal values of τ (n, 3).
        dy_dx: ∂y_A/∂x_B (n, 3, 3).
        dF: ΔF embedded in 3D (n, 3, 3).
        b_n: b^e at t_n (n, 3, 3), symmetric.
        g: How many leading components of ΔF vary (2 in plane strain, where
            ΔF_33 = 1); the derivative is returned for those only.
    """
    n = x.shape[0]
    theta = np.zeros((n, 3, 3))
    scale = np.max(np.abs(x), axis=1)
    for A, B in ((0, 1), (0, 2), (1, 2)):
        gap = x[:, A] - x[:, B]
        close = np.abs(gap) <= REPEATED * scale
        limit = 0.5 * (dy_dx[:, A, A] - dy_dx[:, A, B] + dy_dx[:, B, B] - dy_dx[:, B, A])
        quotient = (y[:, A] - y[:, B]) / np.where(close, 1.0, gap)
        theta[:, A, B] = theta[:, B, A] = np.where(close, limit, quotient)
    # db'_AB/dΔF_kl = Q_kA M_lB + M_lA Q_kB with M = b_n ΔFᵀ Q.
    M = (b_n @ np.swapaxes(dF, 1, 2) @ Q)[:, :g]
    Qg = Q[:, :g]
    # Work with (n, k, l, a, b) so that the rotations are batched 3x3 matmuls.
    db = Qg[:, :, None, :, None] * M[:, None, :, None, :]
    db = db + np.swapaxes(db, 3, 4)
    idx = np.arange(3)
    dtau = theta[:, None, None] * db
    dtau[..., idx, idx] = np.einsum("nab,nklb->nkla", dy_dx, db[..., idx, idx])
    rotated = Q[:, None, None] @ dtau @ np.swapaxes(Q, 1, 2)[:, None, None]
    return np.moveaxis(rotated, (1, 2), (3, 4))
