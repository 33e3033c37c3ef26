"""When a Newton iterate counts as converged, and what a Newton solve returns.

:class:`ForceTest` replaces SNES's own tests: a residual small against the forces
in play, with a floor at the round-off of the internal forces.
:class:`NewtonResult` is what :meth:`~fe_mpm.newton.NewtonSolver.solve` returns.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from petsc4py import PETSc

import numpy as np

#: The residual of a converged iterate may be as large as the forces that a
#: displacement error of ``ROUND_OFF_FACTOR`` machine epsilons of a cell would
#: cause, ``ROUND_OFF_FACTOR ε h ‖diag K‖``: below that, ‖R‖ is round-off of the
#: internal forces (computed from total deformations, about ε E ‖F‖ per point), not
#: an equilibrium error. Measured floors where Newton stagnates: 0.015 to 0.2 times
#: ε h ‖diag K‖ (Cook u, u-p, P2/P1 and J2; 2D and 3D gravity blocks with E from
#: 1e7 to 1e9 Pa; the strip footing), so 10 leaves a margin of 50 or more.
ROUND_OFF_FACTOR = 10.0

#: Machine epsilon of float64.
EPS = float(np.finfo(float).eps)

#: The pressure rows are in strain units times volume: they pass below
#: ``max(rtol, PRESSURE_ROUND_OFF) ‖V‖``, this many ε being their round-off floor.
PRESSURE_ROUND_OFF = 1e3 * EPS

#: A Newton solve whose ‖R‖ has grown this many times over the smallest ‖R‖ of its
#: iterates 1, 2, … has diverged. Full Newton steps on a perfectly plastic body can
#: run away once points pile onto the yield surface's corners (strip footing on
#: stiff soil, h = 0.1: from ‖R‖ ≈ 30 to 1e14 over 25 iterations); stopping at 1e4
#: ends such an attempt after 5–10 iterations, and the step's next attempt (the
#: backtracking line search) starts sooner: 12 % fewer iterations on the h = 0.1
#: footing to s/B = 2, with the same curve to three decimals. Below the acceptance
#: tolerance the smallest counts as the tolerance: round-off may wander.
DIVERGENCE_FACTOR = 1e4

#: A Newton solve whose ‖R‖ has not fallen clearly below the smallest of its iterates
#: 1, 2, … (:data:`STALL_PROGRESS`) for this many iterations in a row has stalled.
#: Full Newton steps can cycle between two iterates without end: on Mast's aluminium
#: Taylor bar (1 cm grid) from t = 65 µs a step's ‖R‖ fell from 4.9e6 to 1.6e2 in four
#: iterations, then swung between 2.0e2 and 2.5e2 up to the limit of 25, with the whole
#: residual on a few grid nodes at the mushroom's rim, before the backtracking attempt
#: converged in 9. A line search that backtracks lowers ‖R‖ at every iterate or fails,
#: so this ends only attempts that cycle, wander or crawl. The step's next attempt then
#: starts (:mod:`fe_mpm.retry`).
STALL_ITERATIONS = 6

#: A new smallest ‖R‖ counts as progress only below this fraction of the last one.
#: A backtracking line search that has lost its way crawls: on the strip footing with
#: point domains (h = 0.2, no ghost penalty, 32 base points per cell) a step's ‖R‖
#: went 3.057, then 2.893 for 19 iterations, each a little lower in the fourth digit,
#: before the limit of 25 (each iteration a factorisation), where any decrease reset
#: the count. A Newton phase that converges, even linearly, gains far more than 0.1 %.
STALL_PROGRESS = 0.999


@dataclass
class NewtonResult:
    """Outcome of one Newton solve.

    Attributes:
        converged: Whether the last iterate passed :class:`ForceTest`.
        iterations: Newton iterations taken.
        reason: Why the solve ended, in words (e.g. ``"‖R‖ = 3.1e-12 of the force
            scale 1.234e+03"``), or PETSc's reason when it failed.
        residual_norms: ‖R‖ at each iterate (displacement and pressure rows).
        force_scale: The forces in play, S (N; N/m in 2D): at the passing iterate of a
            converged solve, at the iterate of smallest ‖R‖ of a failed one.
        tolerance: The largest ‖R‖ accepted at that scale (N).
        force_residual: ‖R_u‖ over the displacement rows (N) at that iterate.
        attempts: The line searches of the solves joined in ``residual_norms``, and
            how many of its entries each gave (:meth:`RetryLadder.solve` joins them);
            empty for one solve.
    """

    converged: bool
    iterations: int
    reason: str
    residual_norms: list[float]
    force_scale: float = 0.0
    tolerance: float = 0.0
    attempts: list[tuple[str, int]] = field(default_factory=list)
    force_residual: float = np.inf

    @property
    def relative_residual(self) -> float:
        """‖R_u‖ over the force scale (inf when there are no forces).

        The displacement rows only, as :class:`ForceTest` judges them: ‖R‖ over every
        row added the pressure or averaged-volume rows (volume × strain, m² in 2D) to
        forces (N/m), and a converged u-nbva step read 1.5e-13 in metres and 6.8e-10 in
        millimetres (a helper's scenes in five unit systems, 2026-12-08). Of a failed
        solve, the closest iterate's.
        """
        return self.force_residual / self.force_scale if self.force_scale > 0 else np.inf


class ForceTest:
    r"""When a Newton iterate counts as converged: a residual small against the forces.

    The relative test of PETSc, ‖R‖ ≤ rtol ‖R₀‖, compares a step with its own start.
    Once the loads stop changing, ‖R₀‖ is only the imbalance left by re-binning,
    and a converged step cannot reach rtol times it (Newton then fails on a body at
    rest); and a step whose update was unusable can end on the step-length test
    with ‖R‖ not fallen at all. Here an iterate is accepted only when

    .. math::

        \|R_u\| \le \max(\mathrm{rtol}\, S,\ \mathrm{atol},\ f_\varepsilon), \qquad
        S = \max(\|f_{ext}\|, \|f_{int}\|, \|f_M\|),

    over the displacement rows, where :math:`f_{ext}` are the loads (body forces and
    tractions), :math:`f_{int} = R + f_{ext}` everything else — stress
    divergence, inertia, penalties — including the rows of supported dofs, whose
    internal force is the reaction, and :math:`f_M` the inertia forces alone (in a
    dynamic step; with the row-sum mass, a measure of their size). Without
    :math:`f_M` a body with no loads and no supports whose stresses balance its
    inertia (two disks colliding) had :math:`S = \|R\|`: every step quoted a
    relative residual of 1 at a force scale of 1e-13 N/m, where the stresses were
    1 kPa, and Newton iterated down to the round-off floor (a helper's run,
    2026-12-07: 2.32 iterations a step against 2.14 now).
    :math:`f_\varepsilon =` ``ROUND_OFF_FACTOR`` ε h ‖diag K‖ is the round-off floor:
    what a displacement error of 10 ε h (h the largest cell size) would unbalance
    (with volumetric averaging, plus what an error of 10 ε in the averaged volume
    change would: the bulk stiffness couples Δu to it, off the diagonal). The
    pressure rows of a mixed form (volume × strain) pass when
    :math:`\|R_p\| \le \max(\mathrm{rtol}, 1000 ε) \|V\|`, with :math:`\|V\|` the norm
    of the nodal volumes: a volumetric strain error of rtol.
    A step that starts in equilibrium passes at iteration 0.

    Args:
        rtol: Tolerance relative to the force scale (``snes_rtol``).
        atol: Absolute floor (N), ``snes_atol``.
        max_it: Iteration limit (``snes_max_it``).
        length: Largest cell size h (m).
    """

    def __init__(self, rtol: float, atol: float, max_it: int, length: float):
        self.rtol, self.atol, self.max_it, self.length = rtol, atol, max_it, length
        self.loads = 0.0  # ‖f_ext‖ of the step
        self.internal = 0.0  # ‖f_int‖ at the last residual
        self.inertia = 0.0  # ‖f_M‖ at the last residual; 0 in a static step
        self.finite_internal = 0.0  # ‖f_int‖ at the last residual where it was finite
        self.round_off = 0.0  # f_ε from the last tangent (kept across steps for iteration 0)
        self.volume = 0.0  # ‖V‖ of the pressure nodes; 0 without pressure
        self.pressure_norm = 0.0  # ‖R_p‖ at the last residual
        self.displacement_norm = 0.0  # ‖R_u‖ at the last residual
        self.verdict = ""
        self.passed = False
        self.smallest = np.inf  # the smallest ‖R‖ of iterates 1, 2, … of this solve
        self.stalled = 0  # iterates since the smallest
        self.closest = (np.inf, 0.0, np.inf)  # (‖R‖, S, ‖R_u‖) of the smallest ‖R‖, from 0

    def record_internal(self, norm: float) -> None:
        """‖f_int‖ (N) of the residual just assembled, supported rows included."""
        self.internal = norm
        if np.isfinite(norm):
            self.finite_internal = norm

    @property
    def scale(self) -> float:
        """S = max(‖f_ext‖, ‖f_int‖, ‖f_M‖) at the last residual (N)."""
        return max(self.loads, self.internal, self.inertia)

    @property
    def reported_scale(self) -> float:
        """S (N) that a solve's result quotes: the passing iterate's, or the closest one's.

        The closest is the iterate of smallest ‖R‖. A solve that diverged quoted its
        last iterate's blown-up forces (a slope past failure: 9.6e7 N against the
        1.9e6 N in play, 2026-12-06); a non-finite iterate would quote 0
        (``max(loads, nan)``).
        """
        if self.passed or not np.isfinite(self.closest[0]):
            return max(self.loads, self.finite_internal, self.inertia)
        return self.closest[1]

    @property
    def reported_residual(self) -> float:
        """‖R_u‖ (N) that a solve's result quotes: the passing iterate's, or the closest one's."""
        return self.displacement_norm if self.passed else self.closest[2]

    def tolerance_at(self, scale: float) -> float:
        """The largest ‖R_u‖ accepted at the force scale ``scale`` (N)."""
        return max(self.rtol * scale, self.atol, self.round_off)

    @property
    def tolerance(self) -> float:
        """The largest ‖R_u‖ accepted at the last residual (N)."""
        return self.tolerance_at(self.scale)

    def __call__(self, snes, it: int, norms) -> int:
        """SNES's convergence test: a ``PETSc.SNES.ConvergedReason`` for iterate ``it``."""
        _, _, fnorm = norms
        Reason = PETSc.SNES.ConvergedReason
        if it == 0:  # a new solve, whether or not its start is finite
            self.closest = (np.inf, 0.0, np.inf)
        # Non-finite forces only in supported rows leave fnorm finite (the conditions
        # overwrite those rows): the reactions are not finite, so neither is the iterate.
        if not (np.isfinite(fnorm) and np.isfinite(self.internal)):
            self.verdict = "non-finite residual"
            return Reason.DIVERGED_FUNCTION_NANORINF
        if not np.isfinite(self.round_off):
            # An overflowing tangent (a dynamic step of 1e-100 s: the inertia's
            # 1/(β Δt²)) would put the floor at inf and accept any iterate.
            self.verdict = "non-finite tangent: its round-off floor is not finite"
            return Reason.DIVERGED_FUNCTION_NANORINF
        if fnorm < self.closest[0]:
            self.closest = (fnorm, self.scale, self.displacement_norm)
        pressure_ok = self.pressure_norm <= max(self.rtol, PRESSURE_ROUND_OFF) * self.volume
        if self.displacement_norm <= self.tolerance and pressure_ok:
            ratio = self.displacement_norm / self.scale if self.scale > 0 else 0.0
            self.verdict = f"‖R‖ = {ratio:.2e} of the force scale {self.scale:.3e}"
            floor = max(self.atol, self.round_off)
            if self.rtol * self.scale < floor:
                # Forces so small (a body in free flight) that the floor decided.
                self.verdict += (
                    f", within the floor {floor:.3e} N "
                    "(snes_atol, or the round-off of the internal forces)"
                )
            self.passed = True
            return Reason.CONVERGED_FNORM_ABS
        if it >= self.max_it:
            self.verdict = "DIVERGED_MAX_IT"
            return Reason.DIVERGED_MAX_IT
        if it == 0:
            self.smallest, self.stalled = np.inf, 0
        elif fnorm > DIVERGENCE_FACTOR * max(self.smallest, self.tolerance):
            self.verdict = (
                f"DIVERGED_DTOL: ‖R‖ = {fnorm:.3e} grew {DIVERGENCE_FACTOR:.0e}-fold over its "
                f"smallest, {self.smallest:.3e}"
            )
            return Reason.DIVERGED_DTOL
        elif fnorm < STALL_PROGRESS * self.smallest or self.displacement_norm <= self.tolerance:
            # At the tolerance the forces wander in round-off while the pressure rows
            # may still converge: not a stall.
            self.smallest, self.stalled = min(self.smallest, fnorm), 0
        else:
            self.smallest = min(self.smallest, fnorm)
            self.stalled += 1
            if self.stalled >= STALL_ITERATIONS:
                self.verdict = (
                    f"stalled: ‖R‖ = {fnorm:.3e} has not fallen below {STALL_PROGRESS} of "
                    f"its smallest, {self.smallest:.3e}, for {STALL_ITERATIONS} iterations"
                )
                return Reason.DIVERGED_DTOL
        return Reason.ITERATING
