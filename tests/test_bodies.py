"""The separate bodies the occupied cells form (fe_mpm/bodies.py)."""

import numpy as np
import pytest

from fe_mpm.bodies import body_labels


def _labels_by_search(cell_nodes: np.ndarray) -> np.ndarray:
    """The same labels by a plain search from each unlabelled cell, for comparison."""
    labels = np.full(cell_nodes.shape[0], -1)
    body = 0
    for start in range(cell_nodes.shape[0]):
        if labels[start] >= 0:
            continue
        labels[start], frontier = body, [start]
        while frontier:
            cell = frontier.pop()
            joined = np.flatnonzero(np.isin(cell_nodes, cell_nodes[cell]).any(axis=1))
            for other in joined[labels[joined] < 0]:
                labels[other] = body
                frontier.append(other)
        body += 1
    return labels


@pytest.mark.parametrize("seed", range(20))
def test_body_labels_match_a_search_on_random_cells(seed):
    rng = np.random.default_rng(seed)
    nodes = int(rng.integers(5, 200))
    cells = rng.integers(0, nodes, size=(int(rng.integers(1, 120)), 3))
    assert np.array_equal(body_labels(cells), _labels_by_search(cells))


def test_a_long_chain_is_one_body_and_empty_is_none():
    chain = np.column_stack([np.arange(500), np.arange(1, 501), np.arange(2, 502)])[::-1]
    assert np.all(body_labels(chain) == 0)
    assert body_labels(np.zeros((0, 3), dtype=np.int64)).size == 0
