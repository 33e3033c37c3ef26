"""What :meth:`Simulation.run <fe_mpm.Simulation.run>` does when Newton fails a step.

At one step length it makes up to four attempts, in this order (:meth:`RetryLadder.attempts`):

1. the points re-binned into the cells they now lie in, Newton as configured
   (full steps by default);
2. the same, with the fallback line search (``"bt"`` by default), from the same
   start;
3. in a static run, every point held in the cell it was in during the last step
   (``Simulation.step(rebin=False)``), Newton as configured;
4. held, with the fallback line search.

Why both: full Newton steps can diverge from a poor start, and a backtracking
search can crawl where full steps converge; on the strip footing each of the two
alone stopped short of s/B = 2, on different grids, and together they reach it.
Why hold: the points that crossed cells change the grid's discrete equilibrium at
once, and on a perfectly plastic body that change can leave Newton with no nearby
solution, however short the step. A held point stays in its old cell while it lies
within half a cell of it (barycentric coordinates there all ≥ −1/2) and reads that
cell's linear field extended beyond the cell: one more step as a finite element
method with moving quadrature points would take; it is re-binned at the next step.
Dynamic runs never hold: their mass projection would weigh held points by negative
shape function values.

Attempts 2 and 4 start from the step's start, or, with ``resume``
(``Simulation(fallback_from_best=True)``), from the iterate of smallest ‖R‖ of the
attempt before them: the same equations, from where Newton came closest.

Attempts 1–2 and 3–4 share their set-up (tracking, packing), so a step's report
counts the Newton iterations of both attempts of the set-up that converged. When
all attempts fail the step is halved (:class:`StepLength`), and it grows back by
doubling, up to the nominal length, after two successes; below the floor the run
stops with the last failure's message.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

from fe_mpm.errors import ConvergenceError
from fe_mpm.force_test import NewtonResult

T = TypeVar("T")

#: Successes in a row after which a cut step length doubles again.
SUCCESSES_TO_GROW = 2


@dataclass(frozen=True)
class Attempt:
    """One way to take a step.

    Attributes:
        rebin: Re-bin the points into the cells they lie in (False: hold each in the
            cell of the last step).
        line_search: The SNES line search, or None for the solver's configured one.
    """

    rebin: bool
    line_search: str | None


@dataclass(frozen=True)
class RetryLadder:
    """The attempts at one step length, in order.

    Args:
        fallback_line_search: Line search of the retry of the same set-up, or None;
            ``"auto"``: ``"basic"`` when Newton's own is ``"bt"``, else ``"bt"``.
        hold_cells: Whether a static step is retried with the points held.
        resume: Whether that retry starts from the failed solve's iterate of
            smallest ‖R‖ (False: from the step's start).
    """

    fallback_line_search: str | None = "auto"
    hold_cells: bool = True
    resume: bool = False

    def placements(self, can_hold: bool) -> list[bool]:
        """Re-bin (True), then hold (False) where allowed: each is one set-up of the step.

        Args:
            can_hold: Whether holding the points is possible: a static run that has
                taken a step before.
        """
        return [True, False] if self.hold_cells and can_hold else [True]

    def line_searches(self, configured: str) -> list[str | None]:
        """Newton's own line search (None), then the fallback, tried from the same start.

        Args:
            configured: Newton's configured line search; a fallback equal to it adds
                no attempt.
        """
        fallback = self.fallback_line_search
        if fallback == "auto":
            fallback = "basic" if configured == "bt" else "bt"
        if fallback in (None, configured):
            return [None]
        return [None, fallback]

    def take_step(self, step: Callable[[bool], T], can_hold: bool) -> T:
        """``step(rebin)`` with each placement of :meth:`placements` until one succeeds.

        Raises:
            ConvergenceError: The last placement's failure.
        """
        placements = self.placements(can_hold)
        for rebin in placements[:-1]:
            try:
                return step(rebin)
            except ConvergenceError:
                pass
        return step(placements[-1])

    def solve(
        self, newton: Callable[[str | None, bool], NewtonResult], configured: str
    ) -> NewtonResult:
        """Newton with each line search of :meth:`line_searches` until one converges.

        Args:
            newton: ``newton(search, resume)`` solves the step with the given line
                search (None: the configured one), from the step's start or, with
                ``resume``, from the last solve's iterate of smallest ‖R‖.
            configured: Newton's configured line search.

        Returns:
            The last attempt's result, with the iterations and ‖R‖ history of all
            attempts.
        """
        result = None
        for search in self.line_searches(configured):
            attempt = newton(search, self.resume and result is not None)
            tried = (search or configured, len(attempt.residual_norms))
            if result is not None:
                attempt.residual_norms = result.residual_norms + attempt.residual_norms
                attempt.iterations += result.iterations
                attempt.attempts = [*result.attempts, tried]
            else:
                attempt.attempts = [tried]
            result = attempt
            if result.converged:
                break
        return result

    def attempts(self, configured: str, can_hold: bool) -> list[Attempt]:
        """Every attempt at one step length, in order (see the module's docstring)."""
        return [
            Attempt(rebin, search)
            for rebin in self.placements(can_hold)
            for search in self.line_searches(configured)
        ]


class StepLength:
    """The step length of a run: halved after a failure, doubled back after successes.

    Args:
        nominal: The run's step length (s or pseudo-time), > 0.
        floor: The shortest step allowed (same unit).
        advice: Gives what the message of a run that stops adds, if anything (what in
            the run's set-up may have left Newton without a solution); called only
            then, on every rank (it may be collective).
    """

    def __init__(self, nominal: float, floor: float, advice: Callable[[], str] | None = None):
        self.nominal, self.floor, self.advice = nominal, floor, advice
        self.dt, self._successes = nominal, 0

    def cut(self) -> bool:
        """Halve the step after a failure; False if it then falls below the floor."""
        self.dt /= 2
        self._successes = 0
        return self.dt >= self.floor

    def cut_after(self, failure: ConvergenceError) -> None:
        """:meth:`cut` after ``failure``.

        Raises:
            ConvergenceError: The halved step falls below the floor; the message is
                the failure's, and says so.
        """
        if not self.cut():
            advice = self.advice() if self.advice is not None else ""
            raise ConvergenceError(
                f"{failure} The step was cut to {2 * self.dt:.3g} without success, "
                f"and the floor is min_step = {self.floor:.3g}." + (f" {advice}" if advice else "")
            ) from None

    def accepted(self) -> None:
        """Count a success; after enough of them in a row a cut step doubles again."""
        self._successes += 1
        if self.dt < self.nominal and self._successes >= SUCCESSES_TO_GROW:
            self.dt, self._successes = min(2 * self.dt, self.nominal), 0
