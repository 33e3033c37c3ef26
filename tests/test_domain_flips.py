"""Distorted point domains flipped with a neighbour (``fe_mpm/domain_flips.py``).

Two thin triangles sharing the long diagonal of a kite are flipped to the short one:
the pair still covers the kite, and the two points share its volume, mass, momentum
and state as the new triangles cover the old, each taking the new triangle nearer
to it. A pair whose quadrilateral is not convex, whose flip would not improve it or
would leave it distorted, or whose mean F would lose most of its volume is left
alone. The scenes (the squeezed block, the footing, MPI) are in
``tests/test_domains.py`` and ``tests/test_mpi.py``.
"""

import numpy as np
import pytest

import fe_mpm
from fe_mpm import meshes
from fe_mpm.domain_flips import choose_flips, flip_distorted
from fe_mpm.tilings import shape_quality
from fe_mpm.tracker import Tracker

# A kite with its long diagonal a–b shared by two thin triangles.
A, B, C, D = (0.2, 0.5), (0.8, 0.5), (0.5, 0.56), (0.5, 0.41)
D_ASIDE = (0.7, 0.41)


def kite_pair(c=C, d=D):
    corners = np.array([[A, B, c], [B, A, d]], dtype=float)
    mesh = meshes.rectangle_mesh((0.0, 0.0), (1.0, 1.0), (4, 4))
    tracker = Tracker(mesh)
    x = corners.mean(axis=1)
    points = fe_mpm.MaterialPoints(
        x,
        volume=np.array([2.0, 3.0]),
        mass=np.array([5.0, 1.0]),
        F=np.array([np.diag([1.1, 0.9]), np.diag([1.3, 0.8])]),
        velocity=np.array([[1.0, 0.0], [0.0, 2.0]]),
    )
    points.history["plastic_strain"] = np.array([0.1, 0.4])
    points.cell = tracker.locate(x, np.zeros(2, dtype=np.int32))
    return corners, points, tracker


def area(triangle):
    return 0.5 * abs(np.linalg.det(triangle[1:] - triangle[:1]))


def test_two_thin_domains_are_flipped_to_the_other_diagonal_and_share_their_state():
    corners, points, tracker = kite_pair()
    before = points.volume.sum(), points.mass.sum(), points.mass @ points.velocity
    x0_shift = points.x0 - points.x
    limit = np.full(2, 0.5)
    assert np.all(shape_quality(corners) < limit)
    new, flipped = flip_distorted(corners, shape_quality(corners), limit, points, tracker, 1.0)
    assert flipped.tolist() == [True, True]
    assert np.all(shape_quality(new) > 2 * shape_quality(corners))
    # The new triangles share the short diagonal c–d and cover the kite.
    for triangle in new:
        assert {tuple(v) for v in triangle} >= {C, D}
    assert sum(area(t) for t in new) == pytest.approx(sum(area(t) for t in corners), rel=1e-14)
    # Volume, mass and momentum are kept; each point sits at its triangle's centroid.
    assert points.volume.sum() == pytest.approx(before[0], rel=1e-14)
    assert points.mass.sum() == pytest.approx(before[1], rel=1e-14)
    np.testing.assert_allclose(points.mass @ points.velocity, before[2], rtol=1e-14)
    np.testing.assert_allclose(points.x, new.mean(axis=1), rtol=0, atol=1e-15)
    np.testing.assert_allclose(points.x0 - points.x, x0_shift, rtol=0, atol=1e-15)
    # c–d halves a–b, so each new triangle takes half of each old one, and each
    # point's state is the volume-weighted mean of the pair's.
    mean_F = (2.0 * np.diag([1.1, 0.9]) + 3.0 * np.diag([1.3, 0.8])) / 5.0
    np.testing.assert_allclose(points.volume, [2.5, 2.5], rtol=1e-12)
    np.testing.assert_allclose(points.F, [mean_F, mean_F], rtol=1e-12)
    np.testing.assert_allclose(points.history["plastic_strain"], [0.28, 0.28], rtol=1e-12)
    np.testing.assert_allclose(points.velocity, [[5.0 / 6.0, 1.0 / 3.0]] * 2, rtol=1e-12)
    assert np.array_equal(points.cell, tracker.locate(points.x, points.cell))


def test_unequal_parts_go_to_the_triangle_that_covers_them():
    """The diagonals cross off the middle of a–b: each new triangle takes the parts of
    the old ones on its side of c–d, and the volume per area stays the old one's."""
    c, d = (0.3, 0.56), (0.3, 0.41)  # c–d crosses a–b at a sixth of its length
    corners, points, tracker = kite_pair(c, d)
    points.volume[:] = [area(corners[0]), area(corners[1])]  # a volume per area of 1
    new, flipped = flip_distorted(
        corners, shape_quality(corners), np.full(2, 0.4), points, tracker, 1.0
    )
    assert flipped.all()
    np.testing.assert_allclose(points.volume, [area(t) for t in new], rtol=1e-12)


def test_a_pair_whose_quadrilateral_is_not_convex_is_not_flipped():
    corners, points, tracker = kite_pair(c=(0.0, 0.56), d=(0.1, 0.41))  # c–d misses a–b
    assert choose_flips(corners, shape_quality(corners), np.zeros(2), np.array([0, 1]), 1.0) == []
    new, flipped = flip_distorted(
        corners, shape_quality(corners), np.full(2, 0.9), points, tracker, 1.0
    )
    assert new is corners and not flipped.any()


def test_a_flip_that_would_not_improve_the_pair_is_not_made():
    """A square cut by one diagonal: the other gives the same shapes, no gain."""
    corners = np.array([[(0, 0), (1, 1), (0, 1)], [(1, 1), (0, 0), (1, 0)]], dtype=float)
    assert choose_flips(corners, shape_quality(corners), np.zeros(2), np.array([0, 1]), 1.0) == []


def test_a_flip_that_would_leave_a_domain_distorted_is_not_made():
    """The kite's flip lifts its worst quality from 0.23 to 0.73: under a limit of 0.8
    both would still count as distorted, so they are left to be redrawn."""
    corners, points, _ = kite_pair()
    quality = shape_quality(corners)
    assert len(choose_flips(corners, quality, np.full(2, 0.5), np.array([0, 1]), 1.0)) == 1
    assert choose_flips(corners, quality, np.full(2, 0.8), np.array([0, 1]), 1.0) == []


def test_each_point_takes_the_new_triangle_nearer_to_it():
    """c and d apart along a–b: the point of (a, b, c) takes (a, d, c), whose centroid
    lies 0.05 from its own, not (b, c, d), 0.17 away."""
    corners, points, tracker = kite_pair((0.3, 0.56), (0.7, 0.41))
    new, flipped = flip_distorted(
        corners, shape_quality(corners), np.full(2, 0.25), points, tracker, 1.0
    )
    assert flipped.all()
    np.testing.assert_allclose(new[0].mean(axis=0), np.mean([A, D_ASIDE, (0.3, 0.56)], axis=0))


def test_a_pair_whose_mean_f_would_lose_its_volume_is_not_flipped():
    """Two F rotated by ±80° average to one with det 0.03: the flip would crush the
    pair's volume, so it is not made (the domains are then redrawn)."""
    corners, points, tracker = kite_pair()
    turn = np.radians(80.0)
    points.F[:] = [
        [[np.cos(s * turn), -np.sin(s * turn)], [np.sin(s * turn), np.cos(s * turn)]]
        for s in (1, -1)
    ]
    new, flipped = flip_distorted(
        corners, shape_quality(corners), np.full(2, 0.5), points, tracker, 1.0
    )
    assert new is corners and not flipped.any()
