r"""A pressure-dependent law in the u-p forms: its return at the pressure of the field.

In the mixed forms the mean stress is not the law's to choose: the grid pressure
:math:`p` gives the Kirchhoff mean stress :math:`\bar\tau_m = -J p` at a point, and
the law supplies the deviatoric stress and the volumetric equation. For a law whose
yield surface depends on the mean stress (Mohr-Coulomb, Drucker–Prager,
Matsuoka–Nakai) the return must therefore run *at* :math:`\bar\tau_m`.

**The volumetric shift.** Any of fe-mpm's Hencky laws maps the trial principal
strains :math:`\varepsilon^{tr}` to a stress. Shift the trial volumetrically,
:math:`\varepsilon^* = \varepsilon^{tr} + \tfrac{\delta}{3}\mathbf 1` (the same as
scaling :math:`\Delta F` by :math:`e^{\delta/3}`), and choose :math:`\delta` so that the
returned mean stress is the field's: :math:`\tau_m(\varepsilon^*) = \bar\tau_m`. At
:math:`\varepsilon^*` the law's own return then has elastic volumetric strain
:math:`\bar\tau_m/K`, the plastic strain of the mixed problem, and the deviator
:math:`s = \operatorname{dev}\tau(\varepsilon^*)`. What the displacement asked for
and the law accepted differ by

.. math::  v = \varepsilon_v^{tr} - \varepsilon_v^* = -\delta,

the volumetric equation of the point in strain units: elastic, it is
:math:`\varepsilon_v^{tr} - \bar\tau_m/K`, the Hencky form of the
:math:`(J - 1) + p/K` of :mod:`fe_mpm.forms.mixed_up`; plastic, it subtracts the plastic
volume change :math:`\Delta\varepsilon_v^p` (e.g. :math:`3\varrho_G\Delta\gamma` on
Drucker–Prager's cone). When the mixed problem has converged with :math:`v = 0`,
the point's stress is the one the law gives under the displacement alone.

**What a point keeps.** A point that stepped elastically keeps bᵉ at the volume its
displacement gave it, :math:`e^{-2\delta/3} b^{e*} = \Delta F\, b^e_n\, \Delta F^T`, so
the next step's :math:`v` counts the mismatch left over (kept at the shifted volume,
each step forgot it, and a geostatic Mohr–Coulomb layer held in u-p crept); a point
that yielded, or lies beyond the apex, keeps the return's :math:`b^{e*}` and forgets
it (kept there too, points crossing cells swelled Mast's sand column).

:math:`\tau_m(\delta)` is piecewise smooth and nondecreasing (linear within each
region for the cones and Mohr-Coulomb), so :math:`\delta` is found by Newton's
method with the law's own slope :math:`\partial\tau_m/\partial\delta`, kept in the
bracket the iterates build; each evaluation is the law's compiled return.

**Tangent.** With :math:`D = \partial\tau/\partial\Delta F^*` at
:math:`\Delta F^* = e^{\delta/3}\Delta F` (3D, so that the shift scales
:math:`\Delta F_{33}` too in plane strain), :math:`m = \tfrac13\operatorname{tr} D` and
:math:`h = \partial\tau_m/\partial\delta = \tfrac13\, m : \Delta F^*`, the implicit
function theorem gives

.. math::

    \frac{\partial\delta}{\partial\Delta F} = -\frac{e^{\delta/3}\, m}{h}, \quad
    \frac{\partial\delta}{\partial\bar\tau_m} = \frac1h, \quad
    \frac{\partial s}{\partial\Delta F} = \operatorname{dev} D\, e^{\delta/3}
      + \tfrac13 (\operatorname{dev} D : \Delta F^*)
        \otimes \frac{\partial\delta}{\partial\Delta F},

and :math:`\partial s/\partial\bar\tau_m = \tfrac13(\operatorname{dev} D : \Delta F^*)/h`.

**Beyond the apex.** A cone's mean stress cannot exceed its apex (or cutoff)
:math:`\tau_{max}`: there :math:`\tau_m(\delta)` is flat and has no inverse. From
:math:`\tau_a = \tau_{max}` less 1e-9 of the stresses on, the point keeps the return
at :math:`\delta_{apex}`, where its trial reaches :math:`\tau_a` (on the cone's or the
elastic side: its deviator, history and tangent), and δ goes on by a spring, stiff
up to the apex and soft beyond,

.. math::  \delta = \delta_{apex} + \frac{\min(\bar\tau_m, \tau_{max}) - \tau_a}{K}
   + \frac{\max(\bar\tau_m - \tau_{max}, 0)}{K_{apex}},
   \qquad K_{apex} = 10^{-3} K,

which keeps :math:`v` and :math:`s` continuous and pins the pressure within
:math:`K_{apex}` times the excess dilation of the apex (a sand pulled apart carries no
tension; :math:`K_{apex} = K` would give it a spurious tensile stiffness). The
derivatives are those above at :math:`\delta_{apex}`, with
:math:`\partial s/\partial\bar\tau_m = 0` and :math:`\partial\delta/\partial\bar\tau_m`
the spring's 1/K or 1/K_apex. Both choices matter for a cohesionless soil at rest:
its points sit exactly at the apex (zero stress), where the first iterate of a u-p
step (p = 0) finds them. The saturated return there has no shear stiffness, and
the soft spring no volumetric one; the apex's return from its elastic side and the
stiff spring give the first iterate the elastic tangent
(``test_a_cohesionless_block_under_gravity_starts_from_rest_in_up``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from fe_mpm.materials import route
from fe_mpm.materials.spectral import deviator, embedded_3d

#: The soft volumetric stiffness beyond the apex, as a fraction of K (see above).
APEX_STIFFNESS_FRACTION = 1e-3
#: Relative tolerance on τ_m of the volumetric shift.
SHIFT_TOLERANCE = 1e-14
#: The volumetric shift (strain) at which the largest mean stress is read: far enough
#: past any elastic trial that the return is at its apex or cutoff.
LARGEST_SHIFT = 1.0
#: The first step down (strain) from where τ_m is flat above its target: about a
#: step's deviatoric strain, so that the next iterate is below the root.
FLAT_STEP = 1e-3
#: Iterations before the search for the shift gives up.
MAX_ITERATIONS = 100

#: Region code of a point held beyond the apex by the soft spring.
BEYOND_APEX = 9


@dataclass(frozen=True)
class MixedReturnResult:
    """A law's return at prescribed Kirchhoff mean stresses, for ``n`` points.

    Attributes:
        deviator: Deviatoric Kirchhoff stress s (n, 3, 3), Pa.
        volumetric: The volumetric equation's value v = ε_v^tr − ε_v* (n,), strain.
        derivative: Computes the four blocks, read through :attr:`tangent`.
        history: Internal variables at t_{n+1}, by name: the return's, except that a
            point that stepped elastically has bᵉ at its displacement's volume,
            e^{−2δ/3} bᵉ* = ΔF bᵉₙ ΔFᵀ (see :func:`return_at_mean_stress`).
        region: The law's return region per point (n,), or :data:`BEYOND_APEX`.
    """

    deviator: np.ndarray
    volumetric: np.ndarray
    derivative: Callable[[], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]
    history: dict[str, np.ndarray]
    region: np.ndarray

    @cached_property
    def tangent(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """∂s/∂ΔF (n, 3, 3, g, g) Pa, ∂s/∂τ̄_m (n, 3, 3), ∂v/∂ΔF (n, g, g), ∂v/∂τ̄_m (n,) 1/Pa.

        Computed on first access.
        """
        return self.derivative()


def _subset(history: dict[str, np.ndarray], index: np.ndarray) -> dict[str, np.ndarray]:
    return {name: value[index] for name, value in history.items()}


def _det3(A: np.ndarray) -> np.ndarray:
    """Determinants of (n, 3, 3) matrices by Sarrus's rule (LAPACK per point costs more)."""
    return (
        A[:, 0, 0] * (A[:, 1, 1] * A[:, 2, 2] - A[:, 1, 2] * A[:, 2, 1])
        - A[:, 0, 1] * (A[:, 1, 0] * A[:, 2, 2] - A[:, 1, 2] * A[:, 2, 0])
        + A[:, 0, 2] * (A[:, 1, 0] * A[:, 2, 1] - A[:, 1, 1] * A[:, 2, 0])
    )


class _Shifted:
    """The law's returns for volumetrically shifted trials, each point's last one kept.

    A point's search ends at an iterate that was evaluated, so the return at its
    shift is already at hand: :meth:`last` gathers them. Each evaluation addresses its
    points by increasing indices (``np.flatnonzero``), which :meth:`last` relies on.

    Args:
        law: The pointwise law.
        F3: The points' ΔF embedded in 3D (n, 3, 3).
        history: The law's internal variables at t_n, each (n, ...).
    """

    def __init__(self, law, F3: np.ndarray, history: dict[str, np.ndarray]):
        self.law, self.F3, self.history = law, F3, history
        self.parts: list[tuple[np.ndarray, np.ndarray, object]] = []  # index, δ, return
        self.owner = np.full(len(F3), -1)  # the part holding each point's last return

    def mean_and_slope(self, delta: np.ndarray, index: np.ndarray):
        """τ_m (Pa) and ∂τ_m/∂δ = ⅑ Σ_AB ∂τ_A/∂ε^tr_B (Pa; None if the law lacks it)."""
        out = self.evaluate(delta, index)
        self.owner[index] = len(self.parts)
        self.parts.append((index, delta, out))
        mean = np.trace(out.tau, axis1=1, axis2=2) / 3.0
        D = out.principal_tangent
        return mean, None if D is None else D.sum(axis=(1, 2)) / 9.0

    def evaluate(self, delta: np.ndarray, index: np.ndarray):
        """The law's return at the points ``index`` shifted by ``delta`` (not kept)."""
        # A wild Newton iterate (a pressure of many K) may overflow here: its NaN or
        # inf reaches the residual, where Newton reports it with the step.
        with np.errstate(over="ignore", invalid="ignore"):
            scaled = self.F3[index] * np.exp(delta / 3.0)[:, None, None]
            return self.law.return_map(scaled, _subset(self.history, index))

    def last(self) -> _Gathered:
        """Every point's last return."""
        if np.any(self.owner < 0):
            raise RuntimeError("mixed return: a point was gathered before any return of it")
        return _Gathered(self)


class _Gathered:
    """Stress, region, history and (on demand) tangent of returns kept by :class:`_Shifted`."""

    def __init__(self, shifted: _Shifted):
        self.shifted, self.owner = shifted, shifted.owner
        n = len(self.owner)
        self.tau = np.empty((n, 3, 3))
        self.region = np.zeros(n, dtype=np.int8)
        self.history = {k: np.empty_like(v) for k, v in shifted.history.items()}
        for part in np.unique(self.owner):
            rows, where = self._rows(part)
            out = shifted.parts[part][2]
            self.tau[rows] = out.tau[where]
            if out.region is not None:
                self.region[rows] = out.region[where]
            for key, value in out.history.items():
                self.history[key][rows] = value[where]

    def _rows(self, part: int) -> tuple[np.ndarray, np.ndarray]:
        """The points whose last return ``part`` holds, and where they sit in it."""
        rows = np.flatnonzero(self.owner == part)
        return rows, np.searchsorted(self.shifted.parts[part][0], rows)

    def tangent(self) -> np.ndarray:
        """∂τ/∂ΔF* (n, 3, 3, 3, 3) at the shifted trials.

        A part holding few of these points is evaluated again on them alone: the
        tangent costs about as much per point as the return.
        """
        # A wild iterate's returns may hold inf: quiet, its NaN reaches Newton.
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            return self._tangent()

    def _tangent(self) -> np.ndarray:
        n = len(self.owner)
        parts = list(np.unique(self.owner))
        # The part of all points holding most of their last returns (the first
        # evaluation, where most points are elastic) lends its own array, which the
        # rest then overwrites: only they are copied, and that part's tangent is spent.
        D = None
        for part in parts:
            index, delta, out = self.shifted.parts[part]
            if len(index) == n and 2 * np.sum(self.owner == part) >= n:
                D = out.tangent.reshape(n, 81)
                parts.remove(part)
                break
        if D is None:
            D = np.empty((n, 81))
        for part in parts:
            rows, where = self._rows(part)
            index, delta, out = self.shifted.parts[part]
            if 2 * len(rows) < len(index):
                out, where = self.shifted.evaluate(delta[where], index[where]), slice(None)
            D[rows] = out.tangent.reshape(-1, 81)[where]
        return D.reshape(n, 3, 3, 3, 3)


def _solve_shift(
    shifted: _Shifted, target: np.ndarray, start: np.ndarray, K: float, tolerance: np.ndarray
) -> np.ndarray:
    """δ with τ_m(δ) = target per point (n,), NaN where not found (targets below the apex).

    ``target`` (n,) and ``tolerance`` (n,) are in Pa, ``start`` (n,) is the first δ
    (strain), K the bulk modulus (Pa). Newton with the law's own slope ∂τ_m/∂δ,
    safeguarded by the bracket the iterates build (bisection where a step leaves
    it). τ_m is nondecreasing in δ and, for the cones and Mohr-Coulomb, linear in
    each return region; where it is also concave (dilatant flow: the slope falls
    from K to the cone's to 0 at the apex), Newton from below the root never passes
    it and lands on it from within its region. Where τ_m is flat above the target
    (the apex), the step goes down by :data:`FLAT_STEP`, doubling until below. Every
    point's search ends at an iterate that was evaluated (``shifted`` keeps it).
    """
    n = len(target)
    delta, lo, hi = start.copy(), np.full(n, -np.inf), np.full(n, np.inf)
    down = np.full(n, FLAT_STEP)  # the flat steps, doubling
    active = np.ones(n, dtype=bool)
    for _ in range(MAX_ITERATIONS):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            return delta
        d = delta[idx]
        mean, slope = shifted.mean_and_slope(d, idx)
        g = mean - target[idx]
        wild = ~np.isfinite(g)  # an iterate the law cannot return: no search helps
        if np.any(wild):
            delta[idx[wild]] = np.nan
            active[idx[wild]] = False
            idx, d, mean, g = idx[~wild], d[~wild], mean[~wild], g[~wild]
            slope = None if slope is None else slope[~wild]
        if slope is None:  # a law without its principal tangent: the elastic slope
            slope = np.full(idx.size, K)
        below = g < 0.0
        lo[idx[below]] = np.maximum(lo[idx[below]], d[below])
        hi[idx[~below]] = np.minimum(hi[idx[~below]], d[~below])
        l, h = lo[idx], hi[idx]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = d - g / slope
        # The apex's slope is 0 up to round-off of the principal tangent (~1e-16 K).
        flat = ~(slope > 1e-8 * K)
        x = np.where(flat & ~below, d - np.maximum(down[idx], g / K), x)
        down[idx[flat & ~below]] *= 2.0
        outside = ~np.isfinite(x) | (x <= l) | (x >= h) | (np.abs(x - d) > LARGEST_SHIFT)
        bracketed = np.isfinite(l) & np.isfinite(h)
        x = np.where(outside & bracketed, 0.5 * (l + h), x)
        x = np.where(outside & ~bracketed, d + np.clip(x - d, -0.1, 0.1), x)
        tiny = 4.0 * np.finfo(float).eps * np.maximum(1.0, np.abs(d))
        converged = (np.abs(g) <= tolerance[idx]) | (bracketed & (h - l <= tiny))
        converged |= np.abs(x - d) <= tiny
        # Nor can δ do better than its resolution: the trial is ΔF e^{δ/3}, and e^{δ/3}
        # resolves δ to ~eps, so τ_m moves in steps of about K eps. Where the law's
        # slope is round-off (a Matsuoka-Nakai point at its apex: negative), the step
        # above would not see it, and the search went down and bisected back to
        # where it started, 15-25 returns for nothing. Where the slope is small but
        # true, δ may stop K tiny / slope short of the root: measured at most 1.3e-11
        # (Matsuoka-Nakai points held beyond the apex; other laws 1.4e-14).
        converged |= np.abs(g) <= K * tiny
        delta[idx[~converged]] = x[~converged]
        active[idx[converged]] = False
    # Not found (a wild Newton iterate): NaN, which Newton reports with the step.
    delta[active] = np.nan
    return delta


def spring_start(top: np.ndarray, mu: float) -> np.ndarray:
    """The mean stress (Pa) from which on the soft spring holds a point.

    1e-9 of the stress scale below the law's largest mean stress ``top`` (Pa), so
    that the apex's derivative is taken on the cone's side; ``mu`` is the shear
    modulus (Pa). A law without an apex (Tresca: ``top`` = inf) has no spring.
    """
    with np.errstate(invalid="ignore"):  # inf − inf where top is inf; kept inf below
        start = top - 1e-9 * (np.abs(top) + mu * 1e-3)
    return np.where(np.isfinite(top), start, top)


def _largest_mean_stress(law, shifted: _Shifted, start: np.ndarray) -> np.ndarray:
    """The law's apex or cutoff mean stress per point (Pa; inf without one).

    The law's own ``largest_mean_stress(history)`` if it has it, else its return far
    out in tension (an evaluation that :class:`_Shifted` does not keep).
    """
    own = getattr(law, "largest_mean_stress", None)
    if own is not None:
        return np.broadcast_to(np.asarray(own(shifted.history), dtype=float), start.shape)
    scaled = shifted.F3 * np.exp((start + LARGEST_SHIFT) / 3.0)[:, None, None]
    tau = law.return_map(scaled, shifted.history).tau
    return np.trace(tau, axis1=1, axis2=2) / 3.0


#: A return is elastic when its bᵉ* is the shifted trial to this share of its size
#: (the laws copy the trial there: it matches to round-off).
ELASTIC_MATCH = 1e-12


def return_at_mean_stress(
    law, dF: np.ndarray, tau_m: np.ndarray, history: dict[str, np.ndarray]
) -> MixedReturnResult:
    """The return of a Hencky principal-space ``law`` at Kirchhoff mean stresses ``tau_m``.

    Args:
        law: A pointwise law (``return_map``, ``bulk_modulus``) whose history has
            the elastic left Cauchy–Green tensor ``be``.
        dF: Deformation gradient increments (n, g, g).
        tau_m: The field's Kirchhoff mean stress −J p at the points (n,), Pa.
        history: The law's internal variables at t_n.
    """
    n, g = dF.shape[0], dF.shape[1]
    K = law.bulk_modulus
    F3 = embedded_3d(dF)
    with np.errstate(invalid="ignore", divide="ignore"):
        eps_v = np.log(_det3(F3)) + 0.5 * np.log(_det3(history["be"]))
    if not (np.all(np.isfinite(eps_v)) and np.all(np.isfinite(tau_m))):
        # An inverted iterate: NaN, which Newton reports with the step.
        return _nan_result(n, g, history)
    shifted = _Shifted(law, F3, history)
    # A level just below the law's largest mean stress, from which on a point is
    # held by the soft spring.
    top = _largest_mean_stress(law, shifted, tau_m / K - eps_v)
    near_top = spring_start(top, law.mu)
    beyond = tau_m > near_top
    target = np.where(beyond, near_top, tau_m)
    # From the elastic shift of the target: a point on the spring then reaches the apex
    # by the same iterates whatever τ̄_m, so its state does not depend on τ̄_m at all.
    start = target / K - eps_v
    scale = np.abs(target) + law.mu * 1e-6
    delta = _solve_shift(shifted, target, start, K, SHIFT_TOLERANCE * scale)
    if not np.all(np.isfinite(delta)):
        return _nan_result(n, g, history)
    # On the spring the point keeps the state where its trial first reaches the apex
    # (its deviator, history and tangent, all from that evaluation); only δ goes on:
    # stiffly (K) up to the apex, 1e-9 of the stresses away, and softly beyond.
    beyond = np.flatnonzero(beyond)
    evaluated = delta.copy()  # the shifts the kept returns were taken at
    final = shifted.last()
    k_apex = APEX_STIFFNESS_FRACTION * K
    over = np.maximum(tau_m[beyond] - top[beyond], 0.0)
    delta[beyond] += (tau_m[beyond] - over - near_top[beyond]) / K + over / k_apex
    spring = np.zeros(n)  # ∂τ̄_m/∂δ on the spring (Pa), 0 elsewhere
    spring[beyond] = np.where(over > 0.0, k_apex, K)
    final.region[beyond] = BEYOND_APEX
    s = deviator(final.tau)
    cols = np.array([3 * k + m for k in range(g) for m in range(g)])  # the kl ΔF varies

    def derivative():
        lam = np.exp(evaluated / 3.0)
        Fs = (F3 * lam[:, None, None]).reshape(n, 9)
        D9 = final.tangent().reshape(n, 9, 9)
        args = (D9, Fs, lam, spring, cols)
        kernels = route.compiled()
        if kernels is not None:
            from fe_mpm.materials import mixed_compiled

            ds_dF, ds_dm, dv_dF, dv_dm = mixed_compiled.blocks(*args)
        else:
            ds_dF, ds_dm, dv_dF, dv_dm = _blocks(*args)
        return (
            ds_dF.reshape(n, 3, 3, g, g),
            ds_dm.reshape(n, 3, 3),
            dv_dF.reshape(n, g, g),
            dv_dm,
        )

    # A point that stepped elastically keeps the volume the displacement gave it: bᵉ
    # less the shift, e^(−2δ/3) bᵉ* = ΔF bᵉₙ ΔFᵀ. Kept at the shifted volume, each step
    # forgot its mismatch v, and a geostatic Mohr-Coulomb layer held in u-p crept to
    # σ_xx 45 % off K₀ σ_yy over 150 steps, no point yielding (PPP's smoothing written
    # into bᵉ step after step; a helper's scene, 2026-12-06). A point that yields, or
    # lies beyond the apex, still forgets it: kept in a flow, the mismatch of points
    # crossing cells swelled Mast's sand column by 1 % in its first 0.1 s.
    history = dict(final.history)
    shifted_F = F3 * np.exp(evaluated / 3.0)[:, None, None]
    trial = shifted_F @ shifted.history["be"] @ np.swapaxes(shifted_F, 1, 2)
    size = np.linalg.norm(trial, axis=(1, 2))
    within = np.linalg.norm(final.history["be"] - trial, axis=(1, 2)) <= ELASTIC_MATCH * size
    within[beyond] = False
    history["be"] = final.history["be"].copy()
    history["be"][within] *= np.exp(-2.0 * evaluated[within] / 3.0)[:, None, None]
    return MixedReturnResult(s, -delta, derivative, history, final.region)


def _volumetric_parts(D9: np.ndarray, Fs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The volumetric parts ⅓ tr ∂τ/∂ΔF* (n, 9) and ⅓ m : ΔF* (n,) of D9 (n, 9, 9)."""
    m = D9[:, [0, 4, 8]].sum(axis=1) / 3.0
    return m, np.einsum("nk,nk->n", m, Fs) / 3.0


def _blocks(D9, Fs, lam, spring, cols):
    """The tangent blocks in numpy.

    Arguments and results as :func:`fe_mpm.materials.mixed_compiled.blocks`, the
    compiled route.
    """
    m, h = _volumetric_parts(D9, Fs)
    devD = D9 - np.eye(3).reshape(9)[None, :, None] * m[:, None, :]
    devD_F = (devD @ Fs[:, :, None])[:, :, 0] / 3.0  # ∂s/∂δ
    on_spring = spring > 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        ddelta_dF = -lam[:, None] * m[:, cols] / h[:, None]
        ddelta_dtau = 1.0 / np.where(on_spring, spring, h)
        # Taken on the spring's points as 0, whose h may be 0 (below): no 0/0 warning
        # (with numpy 2.5 the numpy return lands as flat as the compiled one there).
        ds_dtau = np.where(on_spring[:, None], 0.0, devD_F / h[:, None])
    # A point on the spring whose trial was so far out that its return is the apex's
    # with no stiffness at all (D9 = 0, h = 0): δ gets no slope in ΔF, not 0/0 (a wild
    # iterate of a punch in Mohr-Coulomb sand put NaN in the Jacobian, 2026-12-06).
    ddelta_dF[on_spring & (h == 0.0)] = 0.0
    ds_dF = devD[:, :, cols] * lam[:, None, None] + devD_F[:, :, None] * ddelta_dF[:, None, :]
    return ds_dF, ds_dtau, -ddelta_dF, -ddelta_dtau


def _nan_result(n: int, g: int, history: dict) -> MixedReturnResult:
    """NaN everywhere: what a wild iterate gets, for Newton to report."""

    def derivative():
        return (
            np.full((n, 3, 3, g, g), np.nan),
            np.full((n, 3, 3), np.nan),
            np.full((n, g, g), np.nan),
            np.full(n, np.nan),
        )

    return MixedReturnResult(
        np.full((n, 3, 3), np.nan),
        np.full(n, np.nan),
        derivative,
        {name: np.full_like(value, np.nan) for name, value in history.items()},
        np.zeros(n, dtype=np.int8),
    )
