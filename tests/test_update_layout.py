"""The update vector of a step: one layout builds it and reads it back."""

import numpy as np
import pytest

from fe_mpm.step_forms import UpdateLayout


@pytest.mark.parametrize("g, dynamic", [(2, False), (2, True), (3, True)])
def test_columns_follow_the_documented_order_and_decode_reads_them_back(g, dynamic):
    history = {"be": (3, 3), "plastic_strain": ()}
    layout = UpdateLayout(g, dynamic, history)
    sizes = [g, g * g, 9] + ([g] if dynamic else []) + [9, 1]
    assert layout.width == sum(sizes)
    names = ["du", "dF", "stress"] + (["acceleration"] if dynamic else []) + list(history)
    assert list(layout.columns) == names
    starts = np.cumsum([0] + sizes[:-1])
    for name, start, size in zip(names, starts, sizes, strict=True):
        assert layout.columns[name] == slice(start, start + size)
    n = 4
    values = np.arange(n * layout.width, dtype=float).reshape(n, layout.width)
    new = layout.decode(values)
    assert np.array_equal(new.du, values[:, :g])
    assert np.array_equal(new.dF, values[:, g:g + g * g].reshape(n, g, g))
    assert np.array_equal(new.stress, values[:, g + g * g:g + g * g + 9].reshape(n, 3, 3))
    if dynamic:
        assert np.array_equal(new.acceleration, values[:, g + g * g + 9:2 * g + g * g + 9])
    else:
        assert new.acceleration is None
    assert np.array_equal(new.history["be"], values[:, -10:-1])
    assert np.array_equal(new.history["plastic_strain"], values[:, -1:])
