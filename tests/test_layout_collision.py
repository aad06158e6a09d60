"""AABB collision resolution: known answer and the properties of the issue."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from usdworld.layout.collision import TOLERANCE_M, footprint_half_extents, overlaps, resolve_collisions


def test_two_boxes_known_answer():
    centers = np.array([[0.0, 0.0], [1.0, 0.2]])
    half = np.array([[1.0, 0.5], [1.0, 0.5]])
    result = resolve_collisions(centers, half, priority=np.array([0.0, 1.0]))
    # The first stays; the second moves the shortest way out: along y by 0.8 m (+clearance).
    np.testing.assert_allclose(result.displacement[0], [0.0, 0.0])
    assert abs(result.displacement[1, 0]) < 1e-12
    assert 0.8 <= result.displacement[1, 1] <= 0.8 + TOLERANCE_M


def test_footprint_half_extents_rotated():
    half = footprint_half_extents(np.array([[4.0, 2.0], [4.0, 2.0]]), np.array([0.0, np.pi / 2]))
    np.testing.assert_allclose(half, [[2.0, 1.0], [1.0, 2.0]], atol=1e-12)


boxes = st.integers(1, 25).flatmap(
    lambda n: st.tuples(
        st.lists(st.tuples(st.floats(-20, 20), st.floats(-20, 20)), min_size=n, max_size=n),
        st.lists(st.tuples(st.floats(0.2, 3), st.floats(0.2, 3)), min_size=n, max_size=n),
        st.lists(st.floats(0, 100), min_size=n, max_size=n),
        st.randoms(use_true_random=False),
    )
)


@given(boxes)
def test_no_overlap_idempotent_order_independent(data):
    centers, half, priority, rnd = (np.array(data[0]), np.array(data[1]), np.array(data[2]), data[3])
    result = resolve_collisions(centers, half, priority)
    assert overlaps(result.centers, half) == []
    again = resolve_collisions(result.centers, half, priority)
    np.testing.assert_allclose(again.displacement, 0.0)
    perm = np.array(rnd.sample(range(len(centers)), len(centers)))
    shuffled = resolve_collisions(centers[perm], half[perm], priority[perm])

    def rows(c, h, p, out):  # input -> output pairs as a sorted table (identical inputs are interchangeable)
        table = np.column_stack([c, h, p, out])
        return table[np.lexsort(table.T[::-1])]

    np.testing.assert_allclose(
        rows(centers[perm], half[perm], priority[perm], shuffled.centers), rows(centers, half, priority, result.centers)
    )


@given(boxes)
def test_separated_boxes_do_not_move(data):
    centers = np.array([[10.0 * i, 0.0] for i in range(len(data[0]))])
    half = np.array(data[1])
    result = resolve_collisions(centers, half, np.array(data[2]))
    np.testing.assert_allclose(result.displacement, 0.0)
