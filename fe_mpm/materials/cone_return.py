r"""The Drucker–Prager cone with a tension cutoff, returned in principal space, compiled.

Mast (2013) §3.6.1, Eqs. 3.84–3.100, on principal Hencky strains (Kirchhoff
stresses, tension positive; compression is negative, as in Mast). With the
elasticity :math:`\tau = K\,\varepsilon_v \mathbf 1 + 2G\,e` (:math:`e` the
deviatoric strain, :math:`\varepsilon_v` the volumetric one),
:math:`s = \operatorname{dev}\tau`, :math:`I_1 = \operatorname{tr}\tau` and
:math:`n = e/\lVert e\rVert`:

.. math::

    F_1 = \lVert s\rVert + \varrho_F I_1 - \kappa - \sqrt{2/3}\,k\,\alpha, \qquad
    F_2 = I_1 - T,

with the plastic potentials :math:`G_1 = \lVert s\rVert + \varrho_G I_1` (flow
:math:`n + \varrho_G \mathbf 1`) and :math:`G_2 = I_1` (flow :math:`\mathbf 1`).
Both returns are linear in the multipliers (Eqs. 3.94–3.100):

.. math::

    \tau = \bigl(\lVert s^{tr}\rVert - 2G\Delta\gamma_1\bigr) n
      + \tfrac13\bigl(I_1^{tr} - 9K\varrho_G\Delta\gamma_1 - 9K\Delta\gamma_2\bigr)\mathbf 1,
    \qquad
    \begin{bmatrix} F_1^{tr} \\ F_2^{tr} \end{bmatrix}
    = \begin{bmatrix} 2G + 9K\varrho_F\varrho_G + \tfrac23 k & 9K\varrho_F \\
      9K\varrho_G & 9K \end{bmatrix}
      \begin{bmatrix} \Delta\gamma_1 \\ \Delta\gamma_2 \end{bmatrix},

and :math:`\alpha_{n+1} = \alpha_n + \sqrt{2/3}\,\Delta\gamma_1`. The active set is
the first of cone alone, cutoff alone, both (the corner) whose result satisfies
the other surface: for ``k = 0`` and ``T`` at the cone's apex, the corner is the
apex. The cutoff sits at the initial apex, so a hardening cone (``k ≥ 0``) keeps the
corner on the plane :math:`I_1 = T`.

The tangent :math:`\partial\tau_A/\partial\varepsilon^{tr}_B` differentiates that
closed form, with :math:`\partial n/\partial\varepsilon = (P - n n^T)/\lVert e\rVert`,
:math:`P = I - \tfrac13 \mathbf 1\mathbf 1^T`, and the multipliers' derivatives from
the same 2×2 matrix; the spectral formula of
:func:`~fe_mpm.materials.compiled.spectral_derivative` takes it to
:math:`\partial\tau/\partial\Delta F`. Mast's code is explicit and has no tangent;
this one is exact in every region (``tests/test_drucker_prager.py``).

The parameters may differ from point to point (Mast's evolving angles, frozen over
a step), so they come as arrays.
"""

from __future__ import annotations

import math

import numpy as np

from fe_mpm.materials.compiled import (
    from_principal_point,
    jit,
    trial_decomposition,
    trial_point,
)

#: Region codes of the cone return.
ELASTIC, CONE, CUTOFF, CORNER = 0, 1, 2, 3

_SQRT_2_3 = math.sqrt(2.0 / 3.0)


@jit
def _cone_return(eps, K, G, rho_F, rho_G, kappa, T, k, tolerance, y, D):
    """Return one point's trial strains ``eps`` (3-tuple); write τ into ``y``, ∂τ/∂ε into ``D``.

    ``kappa`` includes the hardening of α_n. Returns the region and Δγ₁.
    """
    ev = eps[0] + eps[1] + eps[2]
    e = (eps[0] - ev / 3.0, eps[1] - ev / 3.0, eps[2] - ev / 3.0)
    norm_e = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    I1 = 3.0 * K * ev
    F1 = 2.0 * G * norm_e + rho_F * I1 - kappa
    F2 = I1 - T
    scale_1 = 2.0 * G * norm_e + abs(rho_F * I1) + abs(kappa)
    scale_2 = abs(I1) + abs(T)
    # A point that ended the last step on a surface starts this one with F = 0 up to
    # round-off: call it elastic, as the Mohr-Coulomb return does.
    plastic_1 = F1 > tolerance * scale_1
    plastic_2 = F2 > tolerance * scale_2
    if not (plastic_1 or plastic_2):
        for A in range(3):
            y[A] = K * ev + 2.0 * G * e[A]
            for B in range(3):
                D[A, B] = K + 2.0 * G * ((1.0 if A == B else 0.0) - 1.0 / 3.0)
        return ELASTIC, 0.0
    n = (0.0, 0.0, 0.0)
    if norm_e > 0.0:
        n = (e[0] / norm_e, e[1] / norm_e, e[2] / norm_e)
    J11 = 2.0 * G + 9.0 * K * rho_F * rho_G + 2.0 / 3.0 * k
    J12 = 9.0 * K * rho_F
    J21 = 9.0 * K * rho_G
    J22 = 9.0 * K
    region = ELASTIC
    g1 = g2 = 0.0
    if plastic_1:
        g1 = F1 / J11
        # Valid while the returned stress stays on this side of the cutoff and of the
        # apex; a cone of no width (φ_F = 0, κ = 0) returns to its axis, ‖e‖ − Δγ₁ = 0
        # up to round-off.
        inside = I1 - 9.0 * K * rho_G * g1 - T <= tolerance * scale_2
        if inside and norm_e - g1 >= -tolerance * norm_e:
            region = CONE
        else:
            g1 = 0.0
    if region == ELASTIC and plastic_2:
        g2 = F2 / J22
        # Strictly inside the cone after it; on its edge the corner takes over (at the
        # apex a deviatoric perturbation leaves the cutoff alone for the corner).
        if F1 - J12 * g2 < -tolerance * scale_1:
            region = CUTOFF
        else:
            g2 = 0.0
    if region == ELASTIC:
        det = J11 * J22 - J12 * J21
        g1 = (J22 * F1 - J12 * F2) / det
        g2 = (J11 * F2 - J21 * F1) / det
        region = CORNER
    # ∂F₁/∂ε = 2G n + 3Kϱ_F 1 and ∂F₂/∂ε = 3K 1 give the multipliers' derivatives,
    # and ‖s‖ with its derivative d‖s‖ follows in each region.
    v = 3.0 * K * rho_F
    dF1 = (2.0 * G * n[0] + v, 2.0 * G * n[1] + v, 2.0 * G * n[2] + v)
    dg1 = (0.0, 0.0, 0.0)
    dg2 = (0.0, 0.0, 0.0)
    if region == CONE:
        dg1 = (dF1[0] / J11, dF1[1] / J11, dF1[2] / J11)
        radius = 2.0 * G * max(norm_e - g1, 0.0)
        ds = (2.0 * G * (n[0] - dg1[0]), 2.0 * G * (n[1] - dg1[1]), 2.0 * G * (n[2] - dg1[2]))
    elif region == CUTOFF:
        dg2 = (1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0)
        radius = 2.0 * G * norm_e
        ds = (2.0 * G * n[0], 2.0 * G * n[1], 2.0 * G * n[2])
    else:
        det = J11 * J22 - J12 * J21
        dg1 = (
            (J22 * dF1[0] - J12 * 3.0 * K) / det,
            (J22 * dF1[1] - J12 * 3.0 * K) / det,
            (J22 * dF1[2] - J12 * 3.0 * K) / det,
        )
        dg2 = (
            (J11 * 3.0 * K - J21 * dF1[0]) / det,
            (J11 * 3.0 * K - J21 * dF1[1]) / det,
            (J11 * 3.0 * K - J21 * dF1[2]) / det,
        )
        # On both surfaces ‖s‖ = κ + ⅔kΔγ₁ − ϱ_F T: zero at the apex without the
        # cancellation of 2G(‖e‖ − Δγ₁), which round-off could make negative.
        radius = max(kappa + 2.0 / 3.0 * k * g1 - rho_F * T, 0.0)
        ds = (2.0 / 3.0 * k * dg1[0], 2.0 / 3.0 * k * dg1[1], 2.0 / 3.0 * k * dg1[2])
    # The deviatoric stiffness across n, ‖s‖/‖e‖; where e = 0 the trial is hydrostatic:
    # elastic on the cutoff alone, none at the apex.
    coefficient = 0.0
    if norm_e > 0.0:
        coefficient = radius / norm_e
    elif region == CUTOFF:
        coefficient = 2.0 * G
    mean = (I1 - 9.0 * K * rho_G * g1 - 9.0 * K * g2) / 3.0
    for A in range(3):
        y[A] = radius * n[A] + mean
        for B in range(3):
            P = (1.0 if A == B else 0.0) - 1.0 / 3.0
            D[A, B] = (
                n[A] * ds[B]
                + coefficient * (P - n[A] * n[B])
                + K
                - 3.0 * K * rho_G * dg1[B]
                - 3.0 * K * dg2[B]
            )
    return region, g1


@jit
def _cone_loop(dF, b_n, x_given, Q_given, plane, K, G, rho_F, rho_G, kappa, T, k, tolerance):
    n = dF.shape[0]
    tau = np.zeros((n, 3, 3))
    be = np.zeros((n, 3, 3))
    dgamma = np.zeros(n)
    region = np.zeros(n, dtype=np.int8)
    x = np.zeros((n, 3))
    Q = np.zeros((n, 3, 3))
    F3 = np.zeros((n, 3, 3))
    y = np.zeros((n, 3))
    D = np.zeros((n, 3, 3))
    work, b = np.zeros((3, 3)), np.zeros((3, 3))
    for p in range(n):
        trial_point(p, dF, b_n, x_given, Q_given, plane, F3, x, Q, b, work)
        eps = (0.5 * math.log(x[p, 0]), 0.5 * math.log(x[p, 1]), 0.5 * math.log(x[p, 2]))
        region[p], dgamma[p] = _cone_return(
            eps, K, G, rho_F[p], rho_G[p], kappa[p], T[p], k, tolerance, y[p], D[p]
        )
        from_principal_point(Q[p], y[p], tau[p])
        if region[p] == ELASTIC:
            for i in range(3):
                for j in range(3):
                    be[p, i, j] = b[i, j]
        else:
            # b^e_{n+1} = exp(2 ε^e), ε^e = a⁻¹ τ.
            mean = (y[p, 0] + y[p, 1] + y[p, 2]) / 3.0
            stretch = (
                math.exp(2.0 * (mean / (3.0 * K) + (y[p, 0] - mean) / (2.0 * G))),
                math.exp(2.0 * (mean / (3.0 * K) + (y[p, 1] - mean) / (2.0 * G))),
                math.exp(2.0 * (mean / (3.0 * K) + (y[p, 2] - mean) / (2.0 * G))),
            )
            from_principal_point(Q[p], stretch, be[p])
    return tau, be, dgamma, region, x, Q, F3, y, D


def cone_points(
    dF: np.ndarray,
    b_n: np.ndarray,
    K: float,
    G: float,
    rho_F: np.ndarray,
    rho_G: np.ndarray,
    kappa: np.ndarray,
    T: np.ndarray,
    k: float,
    tolerance: float,
) -> dict[str, np.ndarray]:
    """The cone-and-cutoff step of every point, compiled.

    Args:
        dF: Deformation gradient increments (n, g, g).
        b_n: b^e at t_n (n, 3, 3).
        K: Bulk modulus (Pa).
        G: Shear modulus (Pa).
        rho_F: Friction slope ϱ_F per point (n,).
        rho_G: Dilatancy slope ϱ_G per point (n,).
        kappa: The cone's ‖s‖ at I₁ = 0 at t_n, hardening included (n,), Pa.
        T: The cutoff's I₁ per point (n,), Pa; ``inf`` for none.
        k: Linear isotropic hardening modulus (Pa), ≥ 0.
        tolerance: Relative yield tolerance.

    Returns:
        ``tau`` (n, 3, 3) Pa, ``be`` (n, 3, 3), ``dgamma`` = Δγ₁ (n,), ``region``
        (n,) int8, and for :func:`~fe_mpm.materials.compiled.spectral_derivative` the
        eigenvalues ``x``, eigenvectors ``Q``, ``F3``, principal stresses ``y`` and
        ``dy_deps`` = ∂y/∂ε^tr (n, 3, 3).
    """
    dF = np.ascontiguousarray(dF, dtype=float)
    b_n = np.ascontiguousarray(b_n, dtype=float)
    plane, x_given, Q_given = trial_decomposition(dF, b_n)
    n = dF.shape[0]
    per_point = [
        np.ascontiguousarray(np.broadcast_to(v, (n,)), dtype=float)
        for v in (rho_F, rho_G, kappa, T)
    ]
    out = _cone_loop(
        dF,
        b_n,
        x_given,
        Q_given,
        plane,
        float(K),
        float(G),
        *per_point,
        float(k),
        float(tolerance),
    )
    names = ("tau", "be", "dgamma", "region", "x", "Q", "F3", "y", "dy_deps")
    return dict(zip(names, out, strict=True))
