"""Merging repeated detections: IoU known answers, NMS order and ties, the two thresholds, the warning."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from usdworld.parameters.collision import CollisionParams
from usdworld.perception.dedupe import box_iou, merge_duplicates, suppress
from usdworld.perception.objects import ImageObject


def _obj(box, score=1.0, cls="car", ref=0, occluded_by=-1, instance_id=None):
    box = np.array(box, dtype=np.int64)
    return ImageObject(
        class_name=cls,
        source_label=cls,
        instance_id=ref if instance_id is None else instance_id,
        box_px=box,
        mask=np.ones((box[3] - box[1], box[2] - box[0]), dtype=bool),
        contact_px=np.array([(box[0] + box[2]) / 2.0, float(box[3])]),
        bottom_truncated=False,
        bottom_occluded=occluded_by >= 0,
        top_truncated=False,
        score=score,
        occluded_by=occluded_by,
        ref=ref,
        box_only=True,
    )


def test_box_iou_known_answers():
    iou = box_iou(np.array([0, 0, 10, 10]), np.array([[0, 0, 10, 10], [5, 0, 15, 10], [20, 20, 30, 30], [0, 0, 10, 5]]))
    np.testing.assert_allclose(iou, [1.0, 50 / 150, 0.0, 0.5])
    assert box_iou(np.array([0, 0, 0, 0]), np.array([[0, 0, 0, 0]]))[0] == 0.0


def test_suppress_keeps_highest_score_ties_by_index_and_respects_classes():
    boxes = np.array([[0, 0, 10, 10], [0, 0, 10, 10], [0, 0, 10, 10], [0, 0, 10, 10], [50, 0, 60, 10]], dtype=float)
    into = suppress(boxes, np.array([0.5, 0.9, 0.9, 0.9, 0.1]), ["car", "car", "car", "person", "car"], 0.95)
    # 1 and 2 tie on the highest score: the earlier one (1) is kept; 0 merges into it;
    # the person on the same box and the far car stay.
    np.testing.assert_array_equal(into, [1, 1, 1, 3, 4])


@given(st.lists(st.tuples(st.integers(0, 50), st.integers(0, 50), st.integers(1, 30), st.integers(1, 30)), min_size=1, max_size=30))
def test_suppress_properties(rows):
    boxes = np.array([[x, y, x + w, y + h] for x, y, w, h in rows], dtype=float)
    scores = np.linspace(1.0, 0.5, len(boxes))
    into = suppress(boxes, scores, ["car"] * len(boxes), 0.5)
    kept = np.nonzero(into == np.arange(len(boxes)))[0]
    # Kept boxes overlap each other below the threshold; every dropped box overlaps its keeper at least that much.
    for a in kept:
        others = kept[kept != a]
        assert np.all(box_iou(boxes[a], boxes[others]) < 0.5)
    for k in np.nonzero(into != np.arange(len(boxes)))[0]:
        assert into[into[k]] == into[k] and box_iou(boxes[into[k]], boxes[k : k + 1])[0] >= 0.5


def test_identical_boxes_always_merge_with_a_warning(caplog):
    objs = [_obj([10, 10, 50, 40], score=0.8, ref=0), _obj([10, 10, 50, 40], score=0.9, ref=1), _obj([100, 10, 140, 40], ref=2)]
    with caplog.at_level(logging.WARNING):
        kept = merge_duplicates(objs)
    assert [o.ref for o in kept] == [1, 2]
    assert "merged 1 of 3 thing detections" in caplog.text


def test_a_queue_of_cars_is_not_merged_below_the_dense_count(caplog):
    # Boxes of a car and the one behind it (smaller, higher) overlap with IoU 0.8: two cars.
    objs = [_obj([100, 100, 200, 180], ref=0), _obj([105, 96, 195, 168], ref=1)]
    assert 0.7 < box_iou(objs[0].box_px, objs[1].box_px[None])[0] < 0.95
    with caplog.at_level(logging.WARNING):
        assert merge_duplicates(objs) == objs
    assert caplog.text == ""
    # The same pair in a raw detector output above the dense count is one car.
    dense = merge_duplicates(objs, CollisionParams(dense_detections=1))
    assert [o.ref for o in dense] == [0]


def test_stuff_passes_through_and_occluders_are_redirected():
    stuff = _obj([0, 0, 300, 100], cls="building", ref=7, instance_id=-1)
    front = _obj([10, 60, 50, 90], score=0.9, ref=0)
    twin = _obj([10, 60, 50, 90], score=0.5, ref=1)
    behind = _obj([20, 50, 45, 80], ref=2, occluded_by=1)  # hidden by the copy that goes away
    kept = merge_duplicates([stuff, front, twin, behind])
    assert [o.ref for o in kept] == [7, 0, 2]
    assert kept[2].occluded_by == 0


@pytest.mark.parametrize("n", [1000])
def test_many_identical_detections_collapse_to_one(n):
    objs = [_obj([10, 10, 50, 40], score=0.5, ref=k) for k in range(n)]
    assert [o.ref for o in merge_duplicates(objs)] == [0]
