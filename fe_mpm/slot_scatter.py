"""Writing points' rows into a kernel's coefficient array, compiled (numba).

A pointwise law's stress and tangent change at every Newton iterate, and every
kernel that reads them needs them in its own packed array, each point's values in
its entity's row at its slot. numpy's fancy assignment into that strided block cost
1.5 ms per call for 27 000 points (the tangent's 36 values each), more than the law's
return; a plain loop copies it at the speed of memory. Imported only when such a
field is first packed, so that scenes without one start without numba.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def _scatter(array, start, entity, slot, values):
    size = values.shape[1]
    for k in range(values.shape[0]):
        row, base = entity[k], start + slot[k] * size
        for j in range(size):
            array[row, base + j] = values[k, j]


def scatter_rows(
    array: np.ndarray, start: int, entity: np.ndarray, slot: np.ndarray, values: np.ndarray
) -> None:
    """Write ``values[k]`` (n, size) to ``array[entity[k], start + slot[k]·size :][:size]``.

    ``array`` is a kernel's packed coefficients (E, width), C-ordered, changed in place.
    """
    _scatter(array, int(start), entity, slot, np.ascontiguousarray(values, dtype=float))
