r"""Mast's cone-shaped yield surfaces, returned in principal space, compiled.

Three returns share one loop over the points (:func:`_cone_loop`): the
Drucker–Prager cone with a tension cutoff (:func:`_cone_return`, below), the cone
with Mast's smooth cap (:func:`_cap_return`, §3.6.2) and Matsuoka–Nakai's cone
(:func:`_matsuoka_nakai_return`, §3.7). Each writes the principal stresses and
∂τ_A/∂ε^tr_B of one point; the loop turns them into τ, bᵉ and, for the spectral
formula, the eigen-pairs.

**The cone and its cutoff.**

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
    _dot,
    _matvec,
    _vecmat,
    clear_point,
    elastic_state_point,
    from_principal_point,
    jit,
    plane_strain,
    point_arrays,
    store_point,
    trial_point,
)

#: Region codes of the returns: the cone, the cutoff, both (the corner: the apex, or
#: the smooth cap's rim), the smooth cap.
ELASTIC, CONE, CUTOFF, CORNER, CAP = 0, 1, 2, 3, 4
#: Which surface a loop returns to.
DRUCKER_PRAGER, MATSUOKA_NAKAI, SMOOTH_CAP = 0, 1, 2

_SQRT_2_3 = math.sqrt(2.0 / 3.0)


@jit
def _elastic(K, G, ev, e, y, D):
    """The elastic stress K ε_v + 2G e into ``y`` and its stiffness into ``D``."""
    for A in range(3):
        y[A] = K * ev + 2.0 * G * e[A]
        for B in range(3):
            D[A, B] = K + 2.0 * G * ((1.0 if A == B else 0.0) - 1.0 / 3.0)


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
        _elastic(K, G, ev, e, y, D)
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
def _return_tangent(A, g, f, D):
    """∂τ/∂ε^tr of a return to one surface, into ``D`` (3, 3).

    The return's equations a⁻¹(τ − τ^tr) + Δγ g(τ) = 0 and F(τ) = 0, differentiated
    at their solution, with A = a⁻¹ + Δγ ∂g/∂τ and f = ∂F/∂τ:
    D = A⁻¹ − (A⁻¹g)(fᵀA⁻¹)/(fᵀA⁻¹g).
    """
    Ainv = np.empty((3, 3))
    _inverse3(A, Ainv)
    Ag = _matvec(Ainv, g)
    fA = _vecmat(f, Ainv)
    denominator = _dot(f, Ag)
    for i in range(3):
        for j in range(3):
            D[i, j] = Ainv[i, j] - Ag[i] * fA[j] / denominator


@jit
def _mn_value(s0, s1, s2, kappa):
    """Matsuoka–Nakai's F = 6κ Ī₃ + 3Ī₁‖s‖² − 2Ī₁³ = 6κ Π σ̄ + 3Ī₁ Σσ̄² − 3Ī₁³ (Eq. 3.120)."""
    I1 = s0 + s1 + s2
    return 6.0 * kappa * s0 * s1 * s2 + 3.0 * I1 * (s0 * s0 + s1 * s1 + s2 * s2) - 3.0 * I1**3


@jit
def _mn_gradient(s0, s1, s2, kappa):
    """∂F/∂σ̄ of :func:`_mn_value`, principal (3-tuple)."""
    I1 = s0 + s1 + s2
    S2 = s0 * s0 + s1 * s1 + s2 * s2
    common = 3.0 * S2 - 9.0 * I1 * I1
    return (
        6.0 * kappa * s1 * s2 + common + 6.0 * I1 * s0,
        6.0 * kappa * s0 * s2 + common + 6.0 * I1 * s1,
        6.0 * kappa * s0 * s1 + common + 6.0 * I1 * s2,
    )


@jit
def _mn_hessian(s0, s1, s2, kappa, out):
    """∂²F/∂σ̄² of :func:`_mn_value` (Mast Eq. 3.127 with the shift), into ``out`` (3, 3)."""
    I1 = s0 + s1 + s2
    s = (s0, s1, s2)
    for i in range(3):
        for j in range(3):
            other = 0.0
            if i != j:
                other = 6.0 * kappa * s[3 - i - j]
            out[i, j] = other + 6.0 * (s[i] + s[j]) - 18.0 * I1 + (6.0 * I1 if i == j else 0.0)


@jit
def _mn_outside(gamma, base, n, radius_tr, G, drop, kappa, scale3, tolerance):
    """Whether the stress σ̄(Δγ) of the radial path lies outside the Matsuoka–Nakai cone.

    σ̄(Δγ) = (base − drop Δγ) 1 + (‖s^tr‖ − 2GΔγ) n: the cone is the part of F ≤ 0
    in the closed negative octant of σ̄.
    """
    r = radius_tr - 2.0 * G * gamma
    m = base - drop * gamma
    s0, s1, s2 = m + r * n[0], m + r * n[1], m + r * n[2]
    if max(s0, s1, s2) > tolerance * scale3 ** (1.0 / 3.0):
        return True
    return _mn_value(s0, s1, s2, kappa) > tolerance * scale3


@jit
def _inverse3(A, out):
    """The inverse of a (3, 3) array into ``out``."""
    c00 = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
    c01 = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
    c02 = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
    det = A[0, 0] * c00 + A[0, 1] * c01 + A[0, 2] * c02
    out[0, 0] = c00 / det
    out[1, 0] = c01 / det
    out[2, 0] = c02 / det
    out[0, 1] = (A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]) / det
    out[1, 1] = (A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]) / det
    out[2, 1] = (A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]) / det
    out[0, 2] = (A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]) / det
    out[1, 2] = (A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]) / det
    out[2, 2] = (A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]) / det


@jit
def _mn_generator(theta, kappa, m):
    """The Matsuoka–Nakai cone's generator at Lode angle θ through mean stress −1: ``m``.

    m = −1 + r d(θ), d(θ) = cos θ (1, −1, 0)/√2 + sin θ (1, 1, −2)/√6 (a unit
    deviator), and r the smallest positive root of F(m) = 0, a cubic in r:
    −(6κ − 54) + (3κ − 9) r² + 6κ det(d) r³ (bisection, then Newton).
    """
    c, s = math.cos(theta), math.sin(theta)
    d = (
        c / math.sqrt(2.0) + s / math.sqrt(6.0),
        -c / math.sqrt(2.0) + s / math.sqrt(6.0),
        -2.0 * s / math.sqrt(6.0),
    )
    a0, a2, a3 = -(6.0 * kappa - 54.0), 3.0 * kappa - 9.0, 6.0 * kappa * d[0] * d[1] * d[2]
    # The cubic rises from a₀ < 0 at r = 0; its first root is bracketed, and Newton
    # from the root of its quadratic part, kept inside the bracket, finds it.
    hi = math.sqrt(-a0 / a2)
    while a0 + a2 * hi * hi + a3 * hi**3 <= 0.0:
        hi *= 2.0
    lo = 0.0
    r = min(math.sqrt(-a0 / a2), hi)
    for _ in range(100):
        value = a0 + a2 * r * r + a3 * r**3
        if value > 0.0:
            hi = r
        else:
            lo = r
        if value == 0.0 or hi - lo <= 1e-15 * hi:
            break
        step = r - value / (2.0 * a2 * r + 3.0 * a3 * r * r)
        r = step if lo < step < hi else 0.5 * (lo + hi)
    for A in range(3):
        m[A] = -1.0 + r * d[A]


@jit
def _lode_directions(theta):
    """The unit deviator d(θ) = cos θ (1, −1, 0)/√2 + sin θ (1, 1, −2)/√6 and dd/dθ."""
    c, s = math.cos(theta), math.sin(theta)
    a, b = 1.0 / math.sqrt(2.0), 1.0 / math.sqrt(6.0)
    d = (c * a + s * b, -c * a + s * b, -2.0 * s * b)
    dd = (-s * a + c * b, s * a + c * b, -2.0 * c * b)
    return d, dd


@jit
def _mn_flow(theta, kappa_G, sign, g, dg):
    """The flow of the Matsuoka–Nakai potential attached at a stress of Lode angle θ.

    The potential is the κ_G cone through the stress (its apex where that puts it,
    Mast §3.7), so its normal there is ∂G/∂σ at the cone's generator m_G(θ) =
    −1 + r_G d(θ), the same at any distance from the apex. Scaled to a unit
    deviatoric part (so Δγ is Δλ), with the volumetric part's sign that of ψ_G
    (``sign``: κ_G holds only sin²ψ_G). At ψ_G = 0 (κ_G = 9) the cone is the axis and
    the normal's limit is d(θ): no volume change. Writes ĝ into ``g`` and dĝ/dθ into
    ``dg``.
    """
    d, dd = _lode_directions(theta)
    if kappa_G - 9.0 <= 1e-12 * kappa_G:
        for i in range(3):
            g[i] = d[i]
            dg[i] = dd[i]
        return
    m = np.empty(3)
    _mn_generator(theta, kappa_G, m)
    r = math.sqrt((m[0] + 1.0) ** 2 + (m[1] + 1.0) ** 2 + (m[2] + 1.0) ** 2)
    a2 = 3.0 * kappa_G - 9.0
    a3 = 6.0 * kappa_G * d[0] * d[1] * d[2]
    da3 = 6.0 * kappa_G * (dd[0] * d[1] * d[2] + d[0] * dd[1] * d[2] + d[0] * d[1] * dd[2])
    dr = -da3 * r**3 / (2.0 * a2 * r + 3.0 * a3 * r * r)
    dm = (dr * d[0] + r * dd[0], dr * d[1] + r * dd[1], dr * d[2] + r * dd[2])
    grad = _mn_gradient(m[0], m[1], m[2], kappa_G)
    H = np.empty((3, 3))
    _mn_hessian(m[0], m[1], m[2], kappa_G, H)
    dgrad = _matvec(H, dm)
    mean = (grad[0] + grad[1] + grad[2]) / 3.0
    dmean = (dgrad[0] + dgrad[1] + dgrad[2]) / 3.0
    dev = (grad[0] - mean, grad[1] - mean, grad[2] - mean)
    ddev = (dgrad[0] - dmean, dgrad[1] - dmean, dgrad[2] - dmean)
    N = math.sqrt(_dot(dev, dev))
    dN = _dot(dev, ddev) / N
    for i in range(3):
        g[i] = dev[i] / N + sign * mean / N
        dg[i] = ddev[i] / N - dev[i] * dN / N**2 + sign * (dmean / N - mean * dN / N**2)


@jit
def _mn_plane_gap(theta, kappa, kappa_G, sign, K, G, v, m, g, dg):
    """det[m(θ), w(θ), v] with w = a ĝ(θ).

    Zero where v lies in the plane of the yield cone's generator m(θ) and the flow
    there. ``m``, ``g`` and ``dg`` are written.
    """
    _mn_generator(theta, kappa, m)
    _mn_flow(theta, kappa_G, sign, g, dg)
    mean = (K - 2.0 * G / 3.0) * (g[0] + g[1] + g[2])
    w = (mean + 2.0 * G * g[0], mean + 2.0 * G * g[1], mean + 2.0 * G * g[2])
    return (
        m[0] * (w[1] * v[2] - w[2] * v[1])
        - m[1] * (w[0] * v[2] - w[2] * v[0])
        + m[2] * (w[0] * v[1] - w[1] * v[0])
    )


@jit
def _matsuoka_nakai_return(eps, K, G, kappa, rho_G, kappa_G, T, tolerance, y, D):
    """Matsuoka–Nakai yield with Drucker–Prager's flow or with its own potential's.

    Drucker–Prager's (Mast's "MN with DP G") for ``kappa_G`` < 0, else the
    Matsuoka–Nakai potential with κ_G ≥ 9.

    The apex and the cutoff are at τ = (T/3) 1. With Drucker–Prager's flow
    n + ϱ_G 1 the deviator keeps its direction (and the Lode angle), so the return
    follows the line σ̄(Δγ) of :func:`_mn_outside` to where it enters the cone:
    bisection on that line (the cone is convex and the line ends inside it, on the
    axis), then Newton on F. Past the apex the point returns to it.

    With the Matsuoka–Nakai potential attached at the stress (:func:`_mn_flow`) the
    flow ĝ(θ) turns the deviator but depends on the Lode angle θ alone, so the
    trials that return to the yield cone's generator m(θ) fill the wedge
    {t m + Δγ a ĝ(θ): t, Δγ ≥ 0}: the return finds the θ whose wedge's plane holds
    the trial (a root of :func:`_mn_plane_gap` near the trial's θ), then t and Δγ;
    a trial in no wedge returns to the apex.

    The tangent is D = A⁻¹ − (A⁻¹g)(∂Fᵀ A⁻¹)/(∂Fᵀ A⁻¹ g), A = a⁻¹ + Δγ ∂g/∂τ
    (Drucker–Prager: ∂g/∂τ = (P − n nᵀ)/‖s‖; Matsuoka–Nakai: dĝ/dθ ⊗ d'(θ)/‖s‖), the
    derivative of the return's equations at the solution. Both flows have a unit
    deviatoric part: returns the region and Δλ = Δγ.
    """
    if kappa - 9.0 <= 1e-12 * kappa:
        # φ_F = 0: the cone has no width, the hydrostatic axis (as Drucker–Prager's).
        return _cone_return(eps, K, G, 0.0, rho_G, 0.0, T, 0.0, tolerance, y, D)
    ev = eps[0] + eps[1] + eps[2]
    e = (eps[0] - ev / 3.0, eps[1] - ev / 3.0, eps[2] - ev / 3.0)
    norm_e = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    I1 = 3.0 * K * ev
    shift = T / 3.0
    n = (0.0, 0.0, 0.0)
    if norm_e > 0.0:
        n = (e[0] / norm_e, e[1] / norm_e, e[2] / norm_e)
    radius_tr = 2.0 * G * norm_e
    base = I1 / 3.0 - shift  # the shifted mean stress of the trial
    drop = 3.0 * K * rho_G  # how fast the mean stress falls with Δγ (Drucker–Prager flow)
    scale = abs(base) + radius_tr
    scale3 = scale * scale * scale
    if not _mn_outside(0.0, base, n, radius_tr, G, drop, kappa, scale3, tolerance):
        _elastic(K, G, ev, e, y, D)
        return ELASTIC, 0.0
    compliance_mean = 1.0 / (9.0 * K) - 1.0 / (6.0 * G)
    A = np.empty((3, 3))
    apex = False
    if kappa_G < 0.0:
        # At Δγ = ‖e‖ the line meets the axis: inside the cone if the shifted mean
        # stress is compressive there, else the point returns to the apex.
        if base - drop * norm_e >= -tolerance * scale:
            apex = True
        else:
            # Bracket the entry on the line by the sign of F alone (a tolerance scaled
            # by the trial would stop far from a surface point near the apex), then
            # Newton on F kept in the bracket, to the returned stress's own size.
            lo, hi = 0.0, norm_e
            for _ in range(30):
                mid = 0.5 * (lo + hi)
                if _mn_outside(mid, base, n, radius_tr, G, drop, kappa, scale3, 0.0):
                    lo = mid
                else:
                    hi = mid
            gamma = hi
            direction = (drop + 2.0 * G * n[0], drop + 2.0 * G * n[1], drop + 2.0 * G * n[2])
            for _ in range(100):
                r = radius_tr - 2.0 * G * gamma
                m = base - drop * gamma
                s = (m + r * n[0], m + r * n[1], m + r * n[2])
                value = _mn_value(s[0], s[1], s[2], kappa)
                size = abs(m) + r
                if abs(value) <= 1e-15 * size * size * size or hi - lo <= 1e-16 * norm_e:
                    break
                if value > 0.0:
                    lo = gamma
                else:
                    hi = gamma
                grad = _mn_gradient(s[0], s[1], s[2], kappa)
                slope = -(grad[0] * direction[0] + grad[1] * direction[1] + grad[2] * direction[2])
                step = gamma - value / slope if slope != 0.0 else lo
                gamma = step if lo < step < hi else 0.5 * (lo + hi)
            radius = radius_tr - 2.0 * G * gamma
            m = base - drop * gamma
            for i in range(3):
                y[i] = m + shift + radius * n[i]
            s = (m + radius * n[0], m + radius * n[1], m + radius * n[2])
            f_grad = _mn_gradient(s[0], s[1], s[2], kappa)
            for i in range(3):
                for j in range(3):
                    P = (1.0 if i == j else 0.0) - 1.0 / 3.0
                    A[i, j] = compliance_mean + (1.0 / (2.0 * G) if i == j else 0.0)
                    A[i, j] += gamma * (P - n[i] * n[j]) / radius
            g = (n[0] + rho_G, n[1] + rho_G, n[2] + rho_G)
            dlambda = gamma
    else:
        v = (base + radius_tr * n[0], base + radius_tr * n[1], base + radius_tr * n[2])
        theta_tr = math.atan2(
            (n[0] + n[1] - 2.0 * n[2]) / math.sqrt(6.0), (n[0] - n[1]) / math.sqrt(2.0)
        )
        sign = 1.0 if rho_G >= 0.0 else -1.0
        m_work, g_work, dg_work = np.empty(3), np.empty(3), np.empty(3)
        # The nearest sign change of the gap on either side of the trial's θ.
        samples = 24
        width = math.pi / 3.0
        found = False
        lo = hi = theta = theta_tr
        gap_tr = _mn_plane_gap(theta_tr, kappa, kappa_G, sign, K, G, v, m_work, g_work, dg_work)
        gap_lo = gap_hi = gap_tr
        if gap_tr == 0.0:
            found = True
        last_plus = last_minus = gap_tr  # the gap at the last sample on each side
        for k in range(1, samples + 1):
            if found:
                break
            for direction in (1.0, -1.0):
                a = theta_tr + direction * width * (k - 1) / samples
                b = theta_tr + direction * width * k / samples
                gap_a = last_plus if direction > 0.0 else last_minus
                gap_b = _mn_plane_gap(b, kappa, kappa_G, sign, K, G, v, m_work, g_work, dg_work)
                if direction > 0.0:
                    last_plus = gap_b
                else:
                    last_minus = gap_b
                if gap_a * gap_b <= 0.0:
                    lo, hi, gap_lo, gap_hi, found = a, b, gap_a, gap_b, True
                    break
        if not found:
            apex = True
        else:
            # Regula falsi with the Illinois halving (the gap is smooth in θ).
            theta = hi
            side = 0
            for _ in range(100):
                if gap_hi == gap_lo or gap_hi == 0.0 or abs(hi - lo) <= 1e-15 * abs(hi):
                    break
                theta = hi - gap_hi * (hi - lo) / (gap_hi - gap_lo)
                gap = _mn_plane_gap(theta, kappa, kappa_G, sign, K, G, v, m_work, g_work, dg_work)
                if gap * gap_hi < 0.0:
                    lo, gap_lo = hi, gap_hi
                    side = 0
                else:
                    if side == 1:
                        gap_lo *= 0.5
                    side = 1
                hi, gap_hi = theta, gap
                if abs(gap) <= 1e-15 * (abs(gap_lo) + abs(gap_tr)):
                    break
            _mn_plane_gap(theta, kappa, kappa_G, sign, K, G, v, m_work, g_work, dg_work)
            m = (m_work[0], m_work[1], m_work[2])
            g = (g_work[0], g_work[1], g_work[2])
            mean = (K - 2.0 * G / 3.0) * (g[0] + g[1] + g[2])
            w = (mean + 2.0 * G * g[0], mean + 2.0 * G * g[1], mean + 2.0 * G * g[2])
            # v = t m + Δγ w, in the least-squares sense (v lies in their plane).
            mm, mw, ww = _dot(m, m), _dot(m, w), _dot(w, w)
            mv, wv = _dot(m, v), _dot(w, v)
            det = mm * ww - mw * mw
            t = (ww * mv - mw * wv) / det
            gamma = (mm * wv - mw * mv) / det
            if t <= 0.0 or gamma < 0.0:
                apex = True
            else:
                s = (t * m[0], t * m[1], t * m[2])
                for i in range(3):
                    y[i] = shift + s[i]
                f_grad = _mn_gradient(s[0], s[1], s[2], kappa)
                # ĝ depends on σ through θ only: ∂θ/∂σ = d'(θ)/‖s‖.
                _, dd = _lode_directions(theta)
                radius = t * math.sqrt((m[0] + 1.0) ** 2 + (m[1] + 1.0) ** 2 + (m[2] + 1.0) ** 2)
                for i in range(3):
                    for j in range(3):
                        A[i, j] = compliance_mean + (1.0 / (2.0 * G) if i == j else 0.0)
                        A[i, j] += gamma * dg_work[i] * dd[j] / radius
                dlambda = gamma
    if apex:
        for i in range(3):
            y[i] = shift
            for j in range(3):
                D[i, j] = 0.0
        return CORNER, norm_e
    _return_tangent(A, g, f_grad, D)
    return CONE, dlambda


@jit
def _cap_return(eps, K, G, rho_F, rho_G, mu, tolerance, y, D):
    """The cone with Mast's smooth cap (§3.6.2): one point; τ into ``y``, ∂τ/∂ε into ``D``.

    In the (I₁, ‖s‖) plane the cone ‖s‖ = μ − ϱ_F I₁ holds for I₁ ≤ I_t and the
    circle √(I₁² + ‖s‖²) = R_t, R_t = μ/√(1 + ϱ_F²), beyond it, tangent to the cone at
    I_t = μϱ_F/(1 + ϱ_F²), ‖s‖_t = μ/(1 + ϱ_F²). The cone's return (flow n + ϱ_G 1)
    is kept if it lands on the cone; else the cap's (associated, toward the origin
    of the plane: I₁ and ‖s‖ shrink by 1 + 9KΔγ/R_t and 1 + 2GΔγ/R_t, Newton on
    Δγ); a trial between the two (non-associated flow leaves a gap) goes to the rim
    I_t, ‖s‖_t with its deviator's direction. Returns the region and ‖dev Δεᵖ‖.
    """
    ev = eps[0] + eps[1] + eps[2]
    e = (eps[0] - ev / 3.0, eps[1] - ev / 3.0, eps[2] - ev / 3.0)
    norm_e = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    I1 = 3.0 * K * ev
    s_norm = 2.0 * G * norm_e
    R = mu / math.sqrt(1.0 + rho_F * rho_F)
    I_t = mu * rho_F / (1.0 + rho_F * rho_F)
    s_t = mu / (1.0 + rho_F * rho_F)
    scale = abs(I1) + s_norm + mu
    if I1 <= I_t:
        inside = s_norm + rho_F * I1 - mu <= tolerance * scale
    else:
        inside = math.sqrt(I1 * I1 + s_norm * s_norm) - R <= tolerance * scale
    if inside:
        _elastic(K, G, ev, e, y, D)
        return ELASTIC, 0.0
    n = (0.0, 0.0, 0.0)
    if norm_e > 0.0:
        n = (e[0] / norm_e, e[1] / norm_e, e[2] / norm_e)
    # The cone: a valid return leaves the deviator (the apex is beyond the cap).
    F1 = s_norm + rho_F * I1 - mu
    if F1 > 0.0:
        gamma = F1 / (2.0 * G + 9.0 * K * rho_F * rho_G)
        if gamma <= norm_e and I1 - 9.0 * K * rho_G * gamma <= I_t * (1.0 + tolerance):
            return _cone_return(eps, K, G, rho_F, rho_G, mu, math.inf, 0.0, tolerance, y, D)
    # The cap: φ(Δγ) = I₁(Δγ)² + ‖s‖(Δγ)² − R² is convex and falls, so Newton from 0
    # climbs to its root from below.
    a, b = 9.0 * K / R, 2.0 * G / R
    gamma = 0.0
    for _ in range(100):
        i1 = I1 / (1.0 + a * gamma)
        sn = s_norm / (1.0 + b * gamma)
        phi = i1 * i1 + sn * sn - R * R
        if phi <= 1e-15 * R * R:
            break
        slope = -2.0 * (i1 * i1 * a / (1.0 + a * gamma) + sn * sn * b / (1.0 + b * gamma))
        gamma -= phi / slope
    i1 = I1 / (1.0 + a * gamma)
    sn = s_norm / (1.0 + b * gamma)
    if i1 >= I_t * (1.0 - tolerance):
        for A in range(3):
            y[A] = i1 / 3.0 + sn * n[A]
        compliance_mean = 1.0 / (9.0 * K) - 1.0 / (6.0 * G)
        rho = math.sqrt(i1 * i1 + sn * sn)
        grad = (
            (y[0] + 2.0 / 3.0 * i1) / rho,
            (y[1] + 2.0 / 3.0 * i1) / rho,
            (y[2] + 2.0 / 3.0 * i1) / rho,
        )
        A_ = np.empty((3, 3))
        for i in range(3):
            for j in range(3):
                hessian = ((1.0 if i == j else 0.0) + 2.0 / 3.0 - grad[i] * grad[j]) / rho
                A_[i, j] = compliance_mean + (1.0 / (2.0 * G) if i == j else 0.0)
                A_[i, j] += gamma * hessian
        _return_tangent(A_, grad, grad, D)
        return CAP, norm_e - sn / (2.0 * G)
    # The rim: the stress is fixed but for its deviator's direction.
    coefficient = s_t / norm_e if norm_e > 0.0 else 0.0
    for A in range(3):
        y[A] = I_t / 3.0 + s_t * n[A]
        for B in range(3):
            P = (1.0 if A == B else 0.0) - 1.0 / 3.0
            D[A, B] = coefficient * (P - n[A] * n[B])
    return CORNER, norm_e - s_t / (2.0 * G)


@jit
def _cone_loop(
    dF,
    b_n,
    plane,
    K,
    G,
    rho_F,
    rho_G,
    kappa,
    T,
    k,
    kappa_MN,
    kappa_G,
    tolerance,
    surface,
):
    n = dF.shape[0]
    tau, be, dgamma, region, x, Q, F3, y, D, work, b, y_p, D_p = point_arrays(n)
    C = np.empty((3, 3))  # the compliance a⁻¹, for bᵉ
    for i in range(3):
        for j in range(3):
            C[i, j] = 1.0 / (9.0 * K) - 1.0 / (6.0 * G) + (1.0 / (2.0 * G) if i == j else 0.0)
    for p in range(n):
        trial_point(p, dF, b_n, plane, F3, x, Q, b, work)
        eps = (0.5 * math.log(x[p, 0]), 0.5 * math.log(x[p, 1]), 0.5 * math.log(x[p, 2]))
        clear_point(y_p, D_p)
        if surface == DRUCKER_PRAGER:
            region[p], dgamma[p] = _cone_return(
                eps, K, G, rho_F[p], rho_G[p], kappa[p], T[p], k, tolerance, y_p, D_p
            )
        elif surface == SMOOTH_CAP:
            region[p], dgamma[p] = _cap_return(
                eps, K, G, rho_F[p], rho_G[p], kappa[p], tolerance, y_p, D_p
            )
        else:
            potential = -1.0 if kappa_G.shape[0] == 0 else kappa_G[p]
            region[p], dgamma[p] = _matsuoka_nakai_return(
                eps, K, G, kappa_MN[p], rho_G[p], potential, T[p], tolerance, y_p, D_p
            )
        store_point(y, D, p, y_p, D_p)
        from_principal_point(Q, p, y_p, tau)
        if region[p] == ELASTIC:
            for i in range(3):
                for j in range(3):
                    be[p, i, j] = b[i, j]
        else:
            elastic_state_point(Q, p, y_p, C, be)
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
    kappa_MN: np.ndarray | None = None,
    kappa_G: np.ndarray | None = None,
    cap: bool = False,
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
        kappa_MN: Matsuoka–Nakai's κ_F per point (n,): the yield surface is then
            :func:`_matsuoka_nakai_return`'s, with its apex at I₁ = T (``rho_F``,
            ``kappa`` and ``k`` unused); None for the cone.
        kappa_G: The Matsuoka–Nakai potential's κ_G per point (n,), or None for
            Drucker–Prager's flow (``rho_G``).
        cap: Mast's smooth cap in place of the cutoff (:func:`_cap_return`;
            ``kappa`` is its μ; ``T`` and ``k`` unused).

    Returns:
        ``tau`` (n, 3, 3) Pa, ``be`` (n, 3, 3), ``dgamma`` = Δγ₁ (n,), ``region``
        (n,) int8, and for :func:`~fe_mpm.materials.compiled.spectral_derivative` the
        eigenvalues ``x``, eigenvectors ``Q``, ``F3``, principal stresses ``y`` and
        ``dy_deps`` = ∂y/∂ε^tr (n, 3, 3).
    """
    dF = np.ascontiguousarray(dF, dtype=float)
    b_n = np.ascontiguousarray(b_n, dtype=float)
    plane = plane_strain(dF, b_n)
    n = dF.shape[0]
    per_point = [
        np.ascontiguousarray(np.broadcast_to(v, (n,)), dtype=float)
        for v in (rho_F, rho_G, kappa, T)
    ]
    kappa_MN, kappa_G = (
        np.zeros(0) if v is None else np.ascontiguousarray(np.broadcast_to(v, (n,)), dtype=float)
        for v in (kappa_MN, kappa_G)
    )
    out = _cone_loop(
        dF,
        b_n,
        plane,
        float(K),
        float(G),
        *per_point,
        float(k),
        kappa_MN,
        kappa_G,
        float(tolerance),
        SMOOTH_CAP if cap else (DRUCKER_PRAGER if kappa_MN.shape[0] == 0 else MATSUOKA_NAKAI),
    )
    names = ("tau", "be", "dgamma", "region", "x", "Q", "F3", "y", "dy_deps")
    return dict(zip(names, out, strict=True))
