"""Argument types for the demos' command lines: a bad value is named by argparse.

``p.add_argument("--dt", type=positive(float))`` makes ``--dt 0`` stop with
``demo.py: error: argument --dt: must be > 0, got '0'`` before anything runs, where
it used to end in a ``ZeroDivisionError`` deep inside the demo, or in a run with
gravity pointing up (a helper running the demos off their defaults, 2026-12-06).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def _checked(kind: type, test: Callable[[float], bool], what: str) -> Callable[[str], float]:
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not {kind.__name__}: {text!r}") from None
        if not (math.isfinite(value) and test(value)):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
        return value

    parse.__name__ = kind.__name__  # argparse names the type in its messages
    return parse


def positive(kind: type = float) -> Callable[[str], float]:
    """An argparse type: a finite number > 0 of ``kind`` (float or int)."""
    return _checked(kind, lambda v: v > 0, "> 0")


def nonnegative(kind: type = float) -> Callable[[str], float]:
    """An argparse type: a finite number ≥ 0 of ``kind``."""
    return _checked(kind, lambda v: v >= 0, ">= 0")


def between(low: float, high: float) -> Callable[[str], float]:
    """An argparse type: a float in the open interval (low, high)."""
    return _checked(float, lambda v: low < v < high, f"in ({low:g}, {high:g})")
