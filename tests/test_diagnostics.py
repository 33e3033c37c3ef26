"""Measures of solution quality."""

import numpy as np
import pytest

from fe_mpm.diagnostics import contiguous_front


def test_contiguous_front_ignores_points_thrown_ahead():
    x = np.column_stack([np.linspace(0.0, 0.5, 51), np.zeros(51)])
    assert contiguous_front(x, gap=0.02) == pytest.approx(0.5)
    thrown = np.vstack([x, [[0.6, 0.0], [0.61, 0.0]]])
    assert contiguous_front(thrown, gap=0.02) == pytest.approx(0.5)
    assert contiguous_front(thrown, gap=0.2) == pytest.approx(0.61)
