"""The paper's ordering rules, one test per rule."""

from __future__ import annotations

import numpy as np
import pytest

from usdworld.layout.ordering import apply_ordering_rules
from usdworld.parameters.placement import PlacementParams

PAPER = {
    "delta_m": PlacementParams().ordering_delta_m,
    "similar_rows_px": PlacementParams().ordering_similar_rows_px,
}


def test_rule1_similar_rows_take_the_closer_depth():
    result = apply_ordering_rules(
        contact_v=np.array([300.0, 301.0]),
        depth_m=np.array([10.0, 12.5]),
        boxes_px=np.array([[0, 200, 50, 300], [400, 200, 450, 301]], dtype=float),
        **PAPER,
    )
    np.testing.assert_allclose(result.depth_m, [10.0, 10.0])
    assert list(result.rule) == ["", "rule1"]


def test_rule1_ignores_small_differences():
    result = apply_ordering_rules(
        np.array([300.0, 301.0]),
        np.array([10.0, 10.9]),
        np.array([[0, 0, 1, 1], [5, 0, 6, 1]], dtype=float),
        **PAPER,
    )
    np.testing.assert_allclose(result.depth_m, [10.0, 10.9])


def test_rule2_higher_overlapping_object_moves_behind():
    # Object 0 is lower in the image (closer by the ground lines) but the depth map says
    # it is farther than object 1, which it overlaps: object 1 moves behind it.
    result = apply_ordering_rules(
        contact_v=np.array([400.0, 300.0]),
        depth_m=np.array([15.0, 12.0]),
        boxes_px=np.array([[100, 250, 300, 400], [200, 200, 350, 300]], dtype=float),
        delta_m=1.0,
        similar_rows_px=2.0,
    )
    np.testing.assert_allclose(result.depth_m, [15.0, 16.0])
    assert result.rule[1] == "rule2"


def test_rule2_needs_horizontal_overlap():
    result = apply_ordering_rules(
        np.array([400.0, 300.0]),
        np.array([15.0, 12.0]),
        np.array([[0, 0, 100, 400], [500, 0, 600, 300]], dtype=float),
        **PAPER,
    )
    np.testing.assert_allclose(result.depth_m, [15.0, 12.0])


@pytest.mark.parametrize("seed", range(5))
def test_order_independent(seed):
    rng = np.random.default_rng(seed)
    v = rng.uniform(200, 400, 8)
    d = rng.uniform(5, 40, 8)
    x0 = rng.uniform(0, 800, 8)
    boxes = np.column_stack([x0, v - 50, x0 + 120, v])
    base = apply_ordering_rules(v, d, boxes, **PAPER).depth_m
    perm = rng.permutation(8)
    np.testing.assert_allclose(
        apply_ordering_rules(v[perm], d[perm], boxes[perm], **PAPER).depth_m, base[perm]
    )
