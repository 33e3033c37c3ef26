"""The retry ladder of ``Simulation.run``: its attempts in order, and the step length."""

import pytest

from fe_mpm.retry import Attempt, RetryLadder, StepLength


def test_a_static_step_gets_four_attempts_in_the_documented_order():
    attempts = RetryLadder("bt", hold_cells=True).attempts("basic", can_hold=True)
    assert attempts == [Attempt(True, None), Attempt(True, "bt"),
                        Attempt(False, None), Attempt(False, "bt")]


@pytest.mark.parametrize("ladder, configured, can_hold, expected", [
    (RetryLadder("bt", True), "basic", False, [(True, None), (True, "bt")]),
    (RetryLadder("bt", True), "bt", True, [(True, None), (False, None)]),
    (RetryLadder(None, True), "basic", True, [(True, None), (False, None)]),
    (RetryLadder("bt", False), "basic", True, [(True, None), (True, "bt")]),
    (RetryLadder(None, False), "basic", True, [(True, None)]),
])
def test_attempts_drop_what_the_run_cannot_or_need_not_try(ladder, configured, can_hold,
                                                            expected):
    """No hold in a dynamic run or before the first step; no fallback equal to Newton's
    own line search; each option switched off on its own."""
    attempts = ladder.attempts(configured, can_hold)
    assert [(a.rebin, a.line_search) for a in attempts] == expected


def test_the_step_halves_to_its_floor_and_doubles_back_after_two_successes():
    length = StepLength(nominal=1.0, floor=0.25)
    assert length.cut() and length.dt == 0.5
    length.accepted()
    assert length.dt == 0.5  # one success is not enough
    assert length.cut() and length.dt == 0.25  # a failure resets the count
    length.accepted()
    length.accepted()
    assert length.dt == 0.5
    length.accepted()
    assert length.dt == 0.5  # growing resets the count: two more successes are needed
    length.accepted()
    assert length.dt == 1.0
    length.accepted()
    length.accepted()
    assert length.dt == 1.0  # never beyond the nominal step
    assert length.cut() and length.cut()  # 0.5, then the floor itself
    assert not length.cut()  # 0.125 < 0.25
