r"""The principal-space laws compiled point by point (numba), one fused pass each.

The numpy route (:mod:`~fe_mpm.materials.spectral`,
:mod:`~fe_mpm.materials.principal_return`) works on whole arrays, one operation at
a time: clear, but each of its steps writes arrays of every point, and the
tangent's (n, 9, g²) products dominate a plastic step. Here the same arithmetic runs
per point in compiled loops:

- :func:`mohr_coulomb_points`: b^tr, its eigen-decomposition (closed form in plane
  strain; otherwise Jacobi rotations, where the numpy route calls LAPACK), the
  Mohr-Coulomb return, τ, b^e_{n+1} and the plastic strain increment;
- :func:`spectral_derivative`: ∂τ/∂ΔF of any isotropic function of b^tr, the
  formula of :func:`~fe_mpm.materials.spectral.derivative_wrt_dF`.

The numpy functions stay the reference: the suite checks that these agree with them
to round-off (``tests/test_compiled_laws.py``). numba compiles on first use and
caches the machine code on disk (``cache=True``, in ``__pycache__``), so only a
machine's first run pays for it. It is imported here only, and this module only when
a law first runs, so that scenes without such a law start without it.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fe_mpm.materials.principal_return import (
    APEX,
    ELASTIC,
    LINE_1,
    LINE_2,
    PLANE,
    YIELD_TOLERANCE,
    MohrCoulombSurface,
)
from fe_mpm.materials.spectral import REPEATED

_SQRT_2_3 = math.sqrt(2.0 / 3.0)

# error_model="numpy": a division by zero gives inf or nan, as on the numpy route
# (and no branch per division to raise ZeroDivisionError).
jit = numba.njit(cache=True, nogil=True, error_model="numpy")


# numba's matrix products call BLAS through SciPy, which fe-mpm does not need, and
# an array per point would cost more than its arithmetic: 3-vectors are tuples here,
# and 3x3 products go into work arrays allocated once per call. The loops index the
# per-point arrays (``Q[p, i, A]``) rather than slicing them (``Q[p]``): each slice is
# a new array whose reference count numba updates atomically, and with a dozen per
# point that was half the return map's time (8 352 plane-strain points: 3.8 ms per
# call sliced, 2.6 ms indexed).
@jit
def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


@jit
def _matvec(a, v):
    """The product a v of a (3, 3) array and a 3-tuple."""
    return (
        a[0, 0] * v[0] + a[0, 1] * v[1] + a[0, 2] * v[2],
        a[1, 0] * v[0] + a[1, 1] * v[1] + a[1, 2] * v[2],
        a[2, 0] * v[0] + a[2, 1] * v[1] + a[2, 2] * v[2],
    )


@jit
def _vecmat(v, a):
    """The product vᵀ a of a 3-tuple and a (3, 3) array."""
    return (
        v[0] * a[0, 0] + v[1] * a[1, 0] + v[2] * a[2, 0],
        v[0] * a[0, 1] + v[1] * a[1, 1] + v[2] * a[2, 1],
        v[0] * a[0, 2] + v[1] * a[1, 2] + v[2] * a[2, 2],
    )


@jit
def _plane_eigen(b, x, Q, p):
    """Eigenvalues (descending) into ``x[p]`` and eigenvectors into ``Q[p]`` (columns) of b.

    b's 3rd axis is principal.

    The arithmetic of :func:`~fe_mpm.materials.spectral._plane_decomposition`,
    including its stable ordering of equal values.
    """
    half_gap = 0.5 * (b[0, 0] - b[1, 1])
    shear = b[1, 0]
    mean = 0.5 * (b[0, 0] + b[1, 1])
    radius = math.hypot(half_gap, shear)
    angle = 0.5 * math.atan2(shear, half_gap)
    c, s = math.cos(angle), math.sin(angle)
    values = (mean + radius, mean - radius, b[2, 2])
    vectors = ((c, s, 0.0), (-s, c, 0.0), (0.0, 0.0, 1.0))
    # The order np.argsort(-x, kind="stable") gives: ties keep their index order.
    o0, o1, o2 = 0, 1, 2
    if values[o0] < values[o1]:
        o0, o1 = o1, o0
    if values[o1] < values[o2]:
        o1, o2 = o2, o1
        if values[o0] < values[o1]:
            o0, o1 = o1, o0
    order = (o0, o1, o2)
    for A in range(3):
        x[p, A] = values[order[A]]
        for i in range(3):
            Q[p, i, A] = vectors[order[A]][i]


#: Sweeps after which the Jacobi iteration gives up (a 3x3 matrix needs about five).
JACOBI_SWEEPS = 50


@jit
def _jacobi_eigen(b, x, Q, p, a):
    """Eigenvalues (descending) into ``x[p]`` and eigenvectors into ``Q[p]`` (columns) of b.

    Cyclic Jacobi rotations of the symmetric (3, 3) ``b`` (its lower triangle, as LAPACK's
    ``eigh`` reads it; Golub and Van Loan §8.5, with the rotation and the test for a
    negligible entry of Numerical Recipes' ``jacobi``), in ``a``, a (3, 3) work array.
    Per point in a compiled loop it replaces LAPACK called through numpy, which cost
    2.4 ms a call for 3 072 points (15 of the 75 s of Newton of a short 3D soil–column
    impact). A non-finite
    ``b`` gives NaN eigenvalues, for Newton to report.
    """
    for i in range(3):
        for j in range(3):
            a[i, j] = b[i, j] if i >= j else b[j, i]
            Q[p, i, j] = 1.0 if i == j else 0.0
    for sweep in range(JACOBI_SWEEPS):
        if not abs(a[1, 0]) + abs(a[2, 0]) + abs(a[2, 1]) > 0.0:  # diagonal, or NaN
            break
        for i, j, k in ((0, 1, 2), (0, 2, 1), (1, 2, 0)):
            aij = a[j, i]
            g = 100.0 * abs(aij)
            if sweep > 3 and abs(a[i, i]) + g == abs(a[i, i]) and abs(a[j, j]) + g == abs(a[j, j]):
                a[i, j] = a[j, i] = 0.0
                continue
            if aij == 0.0:
                continue
            h = a[j, j] - a[i, i]
            if abs(h) + g == abs(h):
                t = aij / h
            else:
                theta = 0.5 * h / aij
                t = 1.0 / (abs(theta) + math.sqrt(1.0 + theta * theta))
                if theta < 0.0:
                    t = -t
            c = 1.0 / math.sqrt(1.0 + t * t)
            s = t * c
            a[i, i] -= t * aij
            a[j, j] += t * aij
            a[i, j] = a[j, i] = 0.0
            aki, akj = a[k, i], a[k, j]
            a[k, i] = a[i, k] = c * aki - s * akj
            a[k, j] = a[j, k] = s * aki + c * akj
            for r in range(3):
                qi, qj = Q[p, r, i], Q[p, r, j]
                Q[p, r, i] = c * qi - s * qj
                Q[p, r, j] = s * qi + c * qj
    # Descending, each vector with its value (three compare-and-swaps).
    for A in range(3):
        x[p, A] = a[A, A]
    for A, B in ((0, 1), (1, 2), (0, 1)):
        if x[p, A] < x[p, B]:
            x[p, A], x[p, B] = x[p, B], x[p, A]
            for r in range(3):
                Q[p, r, A], Q[p, r, B] = Q[p, r, B], Q[p, r, A]


@jit
def _return(eps, a, C, k, m, two_c_sqrt_k, p1, p2, apex, has_apex, tolerance, y, D):
    """The Mohr-Coulomb return of one point (:func:`mohr_coulomb_return`); its region.

    ``eps``, ``p1`` and ``p2`` are 3-tuples; ``y`` (3,) and ``D`` (3, 3) are written.
    """
    trial = _vecmat(eps, a)
    f = k * trial[0] - trial[2] - two_c_sqrt_k
    if not f > tolerance * (abs(k * trial[0]) + abs(trial[2]) + two_c_sqrt_k):
        for A in range(3):
            y[A] = trial[A]
            for B in range(3):
                D[A, B] = a[A, B]
        return ELASTIC
    df = (k, 0.0, -1.0)
    dg = (m, 0.0, -1.0)
    a_dg = _matvec(a, dg)
    df_a = _vecmat(df, a)
    denom = _dot(df, a_dg)
    ratio = f / denom
    plane = (trial[0] - ratio * a_dg[0], trial[1] - ratio * a_dg[1], trial[2] - ratio * a_dg[2])
    breaks_12 = plane[1] > plane[0]
    breaks_23 = plane[2] > plane[1]
    if not (breaks_12 or breaks_23):
        for A in range(3):
            y[A] = plane[A]
            for B in range(3):
                D[A, B] = a[A, B] - a_dg[A] * df_a[B] / denom
        return PLANE
    if breaks_12:
        region, point, direction, potential = LINE_1, p1, (1.0, 1.0, k), (1.0, 1.0, m)
    else:
        region, point, direction, potential = LINE_2, p2, (1.0, k, k), (1.0, m, m)
    Cg = _matvec(C, potential)
    den = _dot(direction, Cg)
    t = _dot((trial[0] - point[0], trial[1] - point[1], trial[2] - point[2]), Cg) / den
    line = (point[0] + t * direction[0], point[1] + t * direction[1], point[2] + t * direction[2])
    if breaks_12:
        on_apex = breaks_23 or line[0] < line[2]
    else:
        on_apex = line[0] < line[1]
    if on_apex and has_apex:
        for A in range(3):
            y[A] = apex
            for B in range(3):
                D[A, B] = 0.0
        return APEX
    for A in range(3):
        y[A] = line[A]
        for B in range(3):
            D[A, B] = direction[A] * potential[B] / den
    return region


def plane_strain(dF: np.ndarray, b_n: np.ndarray) -> bool:
    """Whether the loops may decompose b^tr in closed form: the third axis is principal.

    It is when neither ΔF nor b^e_n couples the third axis to the plane: a plane
    strain ΔF (n, 2, 2), or one embedded in 3D, as the u-p forms' mixed return hands
    it to the law (its ΔF_33 is the volumetric shift's, its off-plane entries zero).

    Args:
        dF: Deformation gradient increments (n, g, g).
        b_n: b^e at t_n (n, 3, 3).
    """
    coupled = b_n[:, 2, :2].any() or b_n[:, :2, 2].any()
    if dF.shape[1] == 3:
        coupled = coupled or dF[:, 2, :2].any() or dF[:, :2, 2].any()
    return not coupled


@jit
def trial_point(p, dF, b_n, plane, F3, x, Q, b, work):
    """b^tr of point ``p`` into ``b``, ΔF embedded in 3D into ``F3[p]``, its eigen-pairs.

    ``x[p]`` (descending) and ``Q[p]`` (columns) are written: in closed form if
    ``plane`` (:func:`plane_strain`), else by Jacobi rotations; ``work`` is a (3, 3)
    scratch array.
    """
    g = dF.shape[1]
    for i in range(3):
        F3[p, i, i] = 1.0
    for i in range(g):
        for j in range(g):
            F3[p, i, j] = dF[p, i, j]
    for i in range(3):
        for j in range(3):
            work[i, j] = (
                F3[p, i, 0] * b_n[p, 0, j] + F3[p, i, 1] * b_n[p, 1, j] + F3[p, i, 2] * b_n[p, 2, j]
            )
    for i in range(3):
        for j in range(3):
            b[i, j] = work[i, 0] * F3[p, j, 0] + work[i, 1] * F3[p, j, 1] + work[i, 2] * F3[p, j, 2]
    if plane:
        _plane_eigen(b, x, Q, p)
    else:
        _jacobi_eigen(b, x, Q, p, work)


@jit
def from_principal_point(Q, p, values, out):
    """Σ_A v_A n_A⊗n_A of point ``p`` into ``out[p]`` (3, 3); ``values`` a 3-tuple or (3,)."""
    for i in range(3):
        for j in range(3):
            out[p, i, j] = (
                Q[p, i, 0] * values[0] * Q[p, j, 0]
                + Q[p, i, 1] * values[1] * Q[p, j, 1]
                + Q[p, i, 2] * values[2] * Q[p, j, 2]
            )


@jit
def clear_point(y_p, D_p):
    """Zero one point's scratch ``y_p`` (3,) and ``D_p`` (3, 3) before its return writes them."""
    for A in range(3):
        y_p[A] = 0.0
        for B in range(3):
            D_p[A, B] = 0.0


@jit
def store_point(y, D, p, y_p, D_p):
    """Copy one point's principal stresses ``y_p`` (3,) and ``D_p`` (3, 3) into row ``p``."""
    for A in range(3):
        y[p, A] = y_p[A]
        for B in range(3):
            D[p, A, B] = D_p[A, B]


@jit
def point_arrays(n):
    """The arrays a loop over ``n`` points writes, zeroed.

    τ, bᵉ (n, 3, 3), a scalar (n,), the region (n,), x (n, 3), Q, F3 (n, 3, 3),
    y (n, 3), ∂y/∂ε^tr (n, 3, 3), two (3, 3) scratch arrays for
    :func:`trial_point`, and one point's y (3,) and ∂y/∂ε^tr (3, 3), which the
    returns write and :func:`store_point` copies.
    """
    return (
        np.zeros((n, 3, 3)),
        np.zeros((n, 3, 3)),
        np.zeros(n),
        np.zeros(n, dtype=np.int8),
        np.zeros((n, 3)),
        np.zeros((n, 3, 3)),
        np.zeros((n, 3, 3)),
        np.zeros((n, 3)),
        np.zeros((n, 3, 3)),
        np.zeros((3, 3)),
        np.zeros((3, 3)),
        np.zeros(3),
        np.zeros((3, 3)),
    )


@jit
def elastic_state_point(Q, p, y, C, out):
    """The elastic left Cauchy–Green tensor of returned point ``p``, into ``out[p]``.

    bᵉ = Σ exp(2εᵉ_A) n_A⊗n_A with εᵉ = a⁻¹ y (``C`` = a⁻¹); returns εᵉ as a 3-tuple.
    """
    strain_e = _vecmat((y[0], y[1], y[2]), C)
    stretch = (
        math.exp(2.0 * strain_e[0]),
        math.exp(2.0 * strain_e[1]),
        math.exp(2.0 * strain_e[2]),
    )
    from_principal_point(Q, p, stretch, out)
    return strain_e


@jit
def _mohr_coulomb_loop(dF, b_n, plane, a, C, k, m, two_c_sqrt_k, p1, p2, apex, has_apex, tolerance):
    n = dF.shape[0]
    tau, be, increment, region, x, Q, F3, y, D, work, b, y_p, D_p = point_arrays(n)
    for p in range(n):
        trial_point(p, dF, b_n, plane, F3, x, Q, b, work)
        eps = (0.5 * math.log(x[p, 0]), 0.5 * math.log(x[p, 1]), 0.5 * math.log(x[p, 2]))
        clear_point(y_p, D_p)
        region[p] = _return(
            eps, a, C, k, m, two_c_sqrt_k, p1, p2, apex, has_apex, tolerance, y_p, D_p
        )
        store_point(y, D, p, y_p, D_p)
        from_principal_point(Q, p, y_p, tau)
        if region[p] == ELASTIC:  # b^e_{n+1} = b^tr, no plastic strain
            for i in range(3):
                for j in range(3):
                    be[p, i, j] = b[i, j]
        else:
            strain_e = elastic_state_point(Q, p, y_p, C, be)
            s = 0.0
            for A in range(3):
                s += (eps[A] - strain_e[A]) ** 2
            increment[p] = _SQRT_2_3 * math.sqrt(s)
    return tau, be, increment, region, x, Q, F3, y, D


def mohr_coulomb_points(
    surface: MohrCoulombSurface, dF: np.ndarray, b_n: np.ndarray
) -> dict[str, np.ndarray]:
    """The Mohr-Coulomb step of every point, compiled.

    Args:
        surface: Elastic constants and yield surface.
        dF: Deformation gradient increments (n, g, g).
        b_n: b^e at t_n (n, 3, 3).

    Returns:
        ``tau`` (n, 3, 3) Pa, ``be`` (n, 3, 3), ``increment`` (n,) of the equivalent
        plastic strain, ``region`` (n,) int8, and for :func:`spectral_derivative`
        the eigenvalues ``x`` (n, 3), eigenvectors ``Q`` (n, 3, 3), ``F3`` (n, 3, 3),
        principal stresses ``y`` (n, 3) and ``dy_deps`` = ∂y/∂ε^tr (n, 3, 3).
    """
    dF = np.ascontiguousarray(dF, dtype=float)
    b_n = np.ascontiguousarray(b_n, dtype=float)
    plane = plane_strain(dF, b_n)
    k, m = surface.k, surface.m
    p1, p2 = surface.line_points()
    apex = surface.apex()
    out = _mohr_coulomb_loop(
        dF,
        b_n,
        plane,
        surface.elastic,
        surface.compliance,
        k,
        m,
        2.0 * surface.cohesion * math.sqrt(k),
        tuple(p1),
        tuple(p2),
        np.nan if apex is None else apex,
        apex is not None,
        YIELD_TOLERANCE,
    )
    names = ("tau", "be", "increment", "region", "x", "Q", "F3", "y", "dy_deps")
    return dict(zip(names, out, strict=True))


@jit
def _derivative_loop(x, Q, y, dy_dx, F3, b_n, g, repeated):
    n = x.shape[0]
    out = np.zeros((n, 3, 3, g, g))
    theta, db, dtau = np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3))
    work, M, half = np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3))
    for p in range(n):
        scale = max(abs(x[p, 0]), abs(x[p, 1]), abs(x[p, 2]))
        for A, B in ((0, 1), (0, 2), (1, 2)):
            gap = x[p, A] - x[p, B]
            if abs(gap) <= repeated * scale:
                value = 0.5 * (dy_dx[p, A, A] - dy_dx[p, A, B] + dy_dx[p, B, B] - dy_dx[p, B, A])
            else:
                value = (y[p, A] - y[p, B]) / gap
            theta[A, B] = theta[B, A] = value
        for i in range(3):  # M = b_n F3ᵀ Q
            for j in range(3):
                work[i, j] = (
                    b_n[p, i, 0] * F3[p, j, 0]
                    + b_n[p, i, 1] * F3[p, j, 1]
                    + b_n[p, i, 2] * F3[p, j, 2]
                )
        for i in range(3):
            for j in range(3):
                M[i, j] = (
                    work[i, 0] * Q[p, 0, j] + work[i, 1] * Q[p, 1, j] + work[i, 2] * Q[p, 2, j]
                )
        for kk in range(g):
            for ll in range(g):
                for A in range(3):
                    for B in range(3):
                        db[A, B] = Q[p, kk, A] * M[ll, B] + Q[p, kk, B] * M[ll, A]
                for A in range(3):
                    s = 0.0
                    for B in range(3):
                        s += db[B, B] * dy_dx[p, A, B]
                    dtau[A, A] = s
                    for B in range(3):
                        if B != A:
                            dtau[A, B] = theta[A, B] * db[A, B]
                # Q dτ' Qᵀ in two 3x3 products, the symmetric result's upper half only.
                for A in range(3):
                    for j in range(3):
                        half[A, j] = (
                            dtau[A, 0] * Q[p, j, 0]
                            + dtau[A, 1] * Q[p, j, 1]
                            + dtau[A, 2] * Q[p, j, 2]
                        )
                for i in range(3):
                    for j in range(i, 3):
                        s = (
                            Q[p, i, 0] * half[0, j]
                            + Q[p, i, 1] * half[1, j]
                            + Q[p, i, 2] * half[2, j]
                        )
                        out[p, i, j, kk, ll] = s
                        out[p, j, i, kk, ll] = s
    return out


def tangent_of(out: dict[str, np.ndarray], b_n: np.ndarray, g: int):
    """The tangent of a principal return's ``out``, computed when called.

    ``out`` has the eigen-pairs ``x``, ``Q``, ``F3``, the principal stresses ``y``
    and ``dy_deps`` = ∂y/∂ε^tr of :func:`mohr_coulomb_points` or
    :func:`~fe_mpm.materials.cone_return.cone_points`; ε^tr = ½ ln x, so
    ∂y/∂x = ∂y/∂ε^tr / (2x). Returns a function giving ∂τ/∂ΔF (n, 3, 3, g, g).
    """

    def tangent() -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):
            dy_dx = out["dy_deps"] / (2.0 * out["x"][:, None, :])
        return spectral_derivative(out["x"], out["Q"], out["y"], dy_dx, out["F3"], b_n, g)

    return tangent


def spectral_derivative(
    x: np.ndarray,
    Q: np.ndarray,
    y: np.ndarray,
    dy_dx: np.ndarray,
    F3: np.ndarray,
    b_n: np.ndarray,
    g: int = 3,
) -> np.ndarray:
    """∂τ_ij/∂ΔF_kl (n, 3, 3, g, g), compiled; arguments as in ``derivative_wrt_dF``."""
    arrays = (x, Q, y, dy_dx, F3, b_n)
    # REPEATED (and YIELD_TOLERANCE above) go in as arguments: numba would freeze a
    # global into its on-disk cache, which only this file's changes invalidate.
    return _derivative_loop(
        *(np.ascontiguousarray(v, dtype=float) for v in arrays), int(g), float(REPEATED)
    )
