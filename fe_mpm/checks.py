"""Input validation that names the owner, the field and the valid range or kind.

A wrong kind (a string, a bool, a complex number) raises ``TypeError``; a number
of the right kind outside its range, or not finite, raises ``ValueError``.
"""

from __future__ import annotations

import math
import numbers
import reprlib

import numpy as np

# Real numeric dtypes: signed and unsigned integers and floats (not bool, complex,
# strings or objects, which np.asarray(..., dtype=float) would convert silently).
_REAL_KINDS = "iuf"


def as_number(owner: str, field: str, value: object) -> float:
    """Return ``value`` as a float or raise ``TypeError`` unless it is one real number.

    Python ints and floats, numpy integer and floating scalars, and numeric
    arrays of size 1 are accepted. Strings, bytes, bools, None, complex numbers
    and arrays of any other size are refused: ``float()`` would turn ``"1e6"``
    and ``True`` into numbers without a word.

    Args:
        owner: What the field belongs to, e.g. ``"NeoHookean"``.
        field: The field name, e.g. ``"E"``.
        value: The value given.
    """
    if isinstance(value, np.ndarray) and value.size == 1 and value.dtype.kind in _REAL_KINDS:
        value = value.reshape(-1)[0]
    # bool is an int subclass (and np.bool_ is not numbers.Real): refuse both explicitly.
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise TypeError(f"{owner}: {field} must be a number, got {reprlib.repr(value)}")
    return float(value)


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
    """Return ``float(value)`` or raise naming the field and its range.

    Args:
        owner: What the field belongs to, e.g. ``"NeoHookean"``.
        field: The field name, e.g. ``"nu"``.
        value: The value given.
        lo: Lower bound of the valid interval.
        hi: Upper bound of the valid interval.
        lo_open: Whether the lower bound is excluded.
        hi_open: Whether the upper bound is excluded.

    Raises:
        TypeError: ``value`` is not a real number (see :func:`as_number`).
        ValueError: ``value`` is not finite or lies outside the interval.
    """
    v = as_number(owner, field, value)
    below = v <= lo if lo_open else v < lo
    above = v >= hi if hi_open else v > hi
    if not math.isfinite(v) or below or above:
        # Infinite bounds are never reached: a value must be finite.
        left = "(" if lo_open or lo == -math.inf else "["
        right = ")" if hi_open or hi == math.inf else "]"
        raise ValueError(f"{owner}: {field} must lie in {left}{lo:g}, {hi:g}{right}, got {v:g}")
    return v


def check_int(
    owner: str, field: str, value: object, *, lo: int | None = None, hi: int | None = None
) -> int:
    """Return ``value`` as an int or raise unless it is an integer in ``[lo, hi]``.

    Raises:
        TypeError: ``value`` is not an integer (2.5, 3.0, ``"3"`` and ``True`` are refused).
        ValueError: ``value`` lies outside ``[lo, hi]``.
    """
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{owner}: {field} must be an int, got {reprlib.repr(value)}")
    v = int(value)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        left = "(-inf" if lo is None else f"[{lo}"
        right = "inf)" if hi is None else f"{hi}]"
        raise ValueError(f"{owner}: {field} must lie in {left}, {right}, got {v}")
    return v


def check_finite(owner: str, field: str, value: object, *, what: str = "entry") -> np.ndarray:
    """Return ``value`` as a float64 array or raise unless it holds finite real numbers.

    Args:
        owner: What the field belongs to, e.g. ``"MaterialPoints"``.
        field: The field name, e.g. ``"x"``.
        value: A number or an array-like of numbers, any shape.
        what: What the first axis counts, for the message (e.g. ``"point"``).

    Raises:
        TypeError: ``value`` holds something other than real numbers.
        ValueError: ``value`` holds nan or inf; the message names the first bad
            index along the first axis.
    """
    try:
        a = np.asarray(value)
    except ValueError:  # a ragged nesting such as [[1, 2], [3]]
        raise TypeError(
            f"{owner}: {field} must be an array of numbers, got {reprlib.repr(value)}"
        ) from None
    if a.dtype.kind not in _REAL_KINDS:
        raise TypeError(
            f"{owner}: {field} must hold real numbers, got {reprlib.repr(value)} (dtype {a.dtype})"
        )
    a = a.astype(np.float64, copy=False)
    finite = np.isfinite(a)
    if not finite.all():
        if a.ndim == 0:
            raise ValueError(f"{owner}: {field} must be finite, got {a.item():g}")
        bad = np.flatnonzero(~finite.reshape(a.shape[0], int(np.prod(a.shape[1:]))).all(axis=1))
        i = int(bad[0])
        raise ValueError(
            f"{owner}: {field} must be finite; {what} {i} is {a[i].tolist()} "
            f"({bad.size} of {a.shape[0]} {_plural(what)} non-finite)"
        )
    return a


def _plural(noun: str) -> str:
    """``noun`` in the plural: entry -> entries, point -> points."""
    return noun[:-1] + "ies" if noun.endswith("y") else noun + "s"


def check_choice(owner: str, field: str, value: str, choices: tuple[str, ...]) -> str:
    """Return ``value`` or raise ``ValueError`` listing the valid choices."""
    if value not in choices:
        raise ValueError(f"{owner}: unknown {field} {value!r}; choose one of {', '.join(choices)}")
    return value


def check_indices(
    owner: str,
    field: str,
    values: object,
    size: int,
    *,
    what: str = "indices",
    counted: str = "",
) -> np.ndarray:
    """``values`` as int32 indices into ``size`` entities, or raise naming the field.

    A boolean mask, fractional numbers or an index past the end are refused: cast
    silently they read as the indices 0 and 1, truncate, or reach past an array in
    compiled code (``facet_points`` with facet 999 of 16 ended the process).

    Args:
        owner: Who asks, e.g. ``"seed"``.
        field: The argument, e.g. ``"cells"``.
        values: What was given.
        size: How many entities there are: the indices lie in [0, size).
        what: What the indices are, in the messages (``"cell indices"``).
        counted: Said after the valid range, e.g. what ``size`` counts.

    Raises:
        TypeError: A mask, or not integers.
        ValueError: Not one-dimensional, or an index outside [0, size).
    """
    a = np.asarray(values)
    if a.dtype.kind == "b":
        raise TypeError(
            f"{owner}: {field} must be {what}, got a boolean mask; use np.flatnonzero(mask)"
        )
    if a.ndim != 1:
        raise ValueError(f"{owner}: {field} must be a 1-D array of {what}, got shape {a.shape}")
    if a.dtype.kind == "f" and np.all(np.isfinite(a) & (a == np.trunc(a))):
        a = a.astype(np.int64)  # whole floats such as 3.0 are indices
    if a.size and a.dtype.kind not in "iu":
        raise TypeError(
            f"{owner}: {field} must be integer {what}, got {reprlib.repr(values)} (dtype {a.dtype})"
        )
    outside = np.flatnonzero((a < 0) | (a >= size))
    if outside.size:
        raise ValueError(
            f"{owner}: {field} must lie in [0, {size - 1}]{counted}, got {a[outside[0]]}"
        )
    return a.astype(np.int32)
