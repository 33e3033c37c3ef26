"""Measures of solution quality."""

import numpy as np
import pytest

from fe_mpm import diagnostics
from fe_mpm.diagnostics import contiguous_front, stress_oscillation


def test_contiguous_front_ignores_points_thrown_ahead():
    x = np.column_stack([np.linspace(0.0, 0.5, 51), np.zeros(51)])
    assert contiguous_front(x, gap=0.02) == pytest.approx(0.5)
    thrown = np.vstack([x, [[0.6, 0.0], [0.61, 0.0]]])
    assert contiguous_front(thrown, gap=0.02) == pytest.approx(0.5)
    assert contiguous_front(thrown, gap=0.2) == pytest.approx(0.61)


def test_stress_oscillation_sees_scatter_and_not_a_smooth_field_block_by_block(monkeypatch):
    """A linear field over a lattice deviates from its neighbours' mean only along
    the edges (measured 0.025, its gradient times half the spacing), a ±0.3 scatter by
    about its own size (measured 0.291); computed a block of points at a time (here 7
    blocks), the answer is that of all pairs at once to the last bit."""
    side = np.linspace(0.0, 1.0, 21)
    x = np.array(np.meshgrid(side, side)).reshape(2, -1).T  # spacing 0.05
    smooth = 2.0 * x[:, 0] + x[:, 1]
    scatter = smooth + 0.3 * np.where(np.arange(len(x)) % 2 == 0, 1.0, -1.0)
    whole = stress_oscillation(x, scatter)
    assert stress_oscillation(x, smooth) < 0.05
    assert 0.2 < whole < 0.4
    monkeypatch.setattr(diagnostics, "PAIRS_PER_BLOCK", 64 * len(x))
    assert stress_oscillation(x, scatter) == whole
    with pytest.raises(ValueError, match="more than 8 points"):
        stress_oscillation(x[:8], smooth[:8])
