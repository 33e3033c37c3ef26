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


def embedded_3d(F: np.ndarray) -> np.ndarray:
    """Deformation gradients (n, g, g) as (n, 3, 3): in plane strain F₃₃ = 1."""
    n, g = F.shape[0], F.shape[1]
    F3 = np.tile(np.eye(3), (n, 1, 1))
    F3[:, :g, :g] = F
    return F3


def spectral_decomposition(b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues in descending order (n, 3) and eigenvectors as columns (n, 3, 3)."""
    if not (b[:, 2, :2].any() or b[:, :2, 2].any()):
        return _plane_decomposition(b)
    finite = np.isfinite(b).all(axis=(1, 2))
    if not finite.all():
        # A diverging Newton iterate: NaN where it is not finite (LAPACK would raise),
        # so that the residual is not finite and Newton stops as it should.
        x, Q = np.full((b.shape[0], 3), np.nan), np.full(b.shape, np.nan)
        x[finite], Q[finite] = spectral_decomposition(b[finite])
        return x, Q
    x, Q = np.linalg.eigh(b)
    return x[:, ::-1], Q[:, :, ::-1]


def _plane_decomposition(b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`spectral_decomposition` of tensors whose 3rd axis is principal (plane strain).

    The in-plane 2x2 block ``m I + r [[cos 2θ, sin 2θ], [sin 2θ, −cos 2θ]]`` has the
    eigenvalues m ± r along (cos θ, sin θ) and (−sin θ, cos θ): in closed form about
    three times faster than LAPACK called point by point. Like ``eigh`` it reads the
    lower triangle.
    """
    n = b.shape[0]
    half_gap, shear = 0.5 * (b[:, 0, 0] - b[:, 1, 1]), b[:, 1, 0]
    mean, radius = 0.5 * (b[:, 0, 0] + b[:, 1, 1]), np.hypot(half_gap, shear)
    angle = 0.5 * np.arctan2(shear, half_gap)
    cos, sin = np.cos(angle), np.sin(angle)
    x = np.stack([mean + radius, mean - radius, b[:, 2, 2]], axis=1)
    Q = np.zeros((n, 3, 3))
    Q[:, 0, 0], Q[:, 1, 0], Q[:, 0, 1], Q[:, 1, 1], Q[:, 2, 2] = cos, sin, -sin, cos, 1.0
    order = np.argsort(-x, axis=1, kind="stable")
    return np.take_along_axis(x, order, axis=1), np.take_along_axis(Q, order[:, None, :], axis=2)


def deviator(A: np.ndarray) -> np.ndarray:
    """The deviator A − ⅓ tr A 1 of tensors (n, 3, 3)."""
    return A - np.trace(A, axis1=1, axis2=2)[:, None, None] / 3.0 * np.eye(3)


def norm(A: np.ndarray) -> np.ndarray:
    """The Frobenius norm ‖A‖ of tensors (n, 3, 3), (n,)."""
    return np.sqrt(np.einsum("nij,nij->n", A, A))


def from_principal(values: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Σ_A v_A n_A⊗n_A (n, 3, 3) from principal values (n, 3) and eigenvectors (n, 3, 3)."""
    # (Q diag(v)) Qᵀ as a batched matmul: three times faster than the three-operand einsum.
    return (Q * values[:, None, :]) @ np.swapaxes(Q, 1, 2)


def derivative_wrt_dF(
    x: np.ndarray,
    Q: np.ndarray,
    y: np.ndarray,
    dy_dx: np.ndarray,
    dF: np.ndarray,
    b_n: np.ndarray,
    g: int = 3,
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
    # db'_AB/dΔF_kl = Q_kA M_lB + M_lA Q_kB with M = b_n ΔFᵀ Q, laid out (n, kl, A, B).
    M = (b_n @ np.swapaxes(dF, 1, 2) @ Q)[:, :g]
    Qg = Q[:, :g]
    db = (Qg[:, :, None, :, None] * M[:, None, :, None, :]).reshape(n, g * g, 3, 3)
    db = db + np.swapaxes(db, 2, 3)
    idx = np.arange(3)
    dtau = theta[:, None] * db
    dtau[:, :, idx, idx] = db[:, :, idx, idx] @ np.swapaxes(dy_dx, 1, 2)
    # τ_ij = Σ_AB Q_iA Q_jB τ'_AB as one (kl, AB) x (AB, ij) product per point: about
    # twice as fast as rotating each of the g² matrices τ'(kl) by Q on its own.
    QQ = (Q[:, :, None, :, None] * Q[:, None, :, None, :]).reshape(n, 9, 9)
    rotated = dtau.reshape(n, g * g, 9) @ np.swapaxes(QQ, 1, 2)
    return np.moveaxis(rotated.reshape(n, g, g, 3, 3), (1, 2), (3, 4))
