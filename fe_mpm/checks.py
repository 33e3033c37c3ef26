"""Input validation that names the field and the valid range."""

from __future__ import annotations

import math


def check_range(
    owner: str,
    field: str,
    value: float,
    *,
    lo: float = -math.inf,
    hi: float = math.inf,
    lo_open: bool = False,
    hi_open: bool = False,
) -> float:
    """Return ``float(value)`` or raise ``ValueError`` naming the field and its range.

    Args:
        owner: What the field belongs to, e.g. ``"NeoHookean"``.
        field: The field name, e.g. ``"nu"``.
        value: The value given.
        lo: Lower bound of the valid interval.
        hi: Upper bound of the valid interval.
        lo_open: Whether the lower bound is excluded.
        hi_open: Whether the upper bound is excluded.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{owner}: {field} must be a number, got {value!r}") from None
    below = v <= lo if lo_open else v < lo
    above = v >= hi if hi_open else v > hi
    if not math.isfinite(v) or below or above:
        left = "(" if lo_open else "["
        right = ")" if hi_open else "]"
        raise ValueError(f"{owner}: {field} must lie in {left}{lo:g}, {hi:g}{right}, got {v:g}")
    return v


def check_choice(owner: str, field: str, value: str, choices: tuple[str, ...]) -> str:
    """Return ``value`` or raise ``ValueError`` listing the valid choices."""
    if value not in choices:
        raise ValueError(f"{owner}: unknown {field} {value!r}; choose one of {', '.join(choices)}")
    return value
