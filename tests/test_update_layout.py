"""The update vector of a step: one layout builds it and reads it back."""

import numpy as np
import pytest

from fe_mpm.errors import ConvergenceError
from fe_mpm.particles import MaterialPoints
from fe_mpm.point_update import checked_update
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
    assert np.array_equal(new.dF, values[:, g : g + g * g].reshape(n, g, g))
    assert np.array_equal(new.stress, values[:, g + g * g : g + g * g + 9].reshape(n, 3, 3))
    if dynamic:
        assert np.array_equal(new.acceleration, values[:, g + g * g + 9 : 2 * g + g * g + 9])
    else:
        assert new.acceleration is None
    assert np.array_equal(new.history["be"], values[:, -10:-1])
    assert np.array_equal(new.history["plastic_strain"], values[:, -1:])


def test_a_point_may_move_exactly_max_step_cells_and_no_farther():
    """checked_update refuses a point that moves *farther* than max_step_cells sizes of
    its cell: Δu = 1 m in a 0.5 m cell is exactly 2 sizes (exact in binary) and passes
    max_step_cells = 2; 2⁻⁴⁰ m more is refused, naming the point and the distance."""
    layout = UpdateLayout(2, False, {})
    points = MaterialPoints(np.array([[0.25, 0.25], [0.75, 0.25]]), np.ones(2), np.ones(2))
    values = np.zeros((2, layout.width))
    values[:, layout.columns["dF"]] = np.eye(2).reshape(-1)
    values[1, 0] = 1.0
    new = checked_update(values, layout, points, np.full(2, 0.5), 2.0, 3, 0.75)
    np.testing.assert_allclose(new.du, [[0.0, 0.0], [1.0, 0.0]], rtol=0, atol=0)
    values[1, 0] = 1.0 + 2.0**-40
    with pytest.raises(
        ConvergenceError,
        match=r"^point 1 \(x = \[0\.75 0\.25\]\) would move 2 cell sizes \(1 m\) "
        r"in static step 3 \(t = 0\.75\), more than max_step_cells = 2",
    ):
        checked_update(values, layout, points, np.full(2, 0.5), 2.0, 3, 0.75)
