"""Segmentation without a network: the label table, model classes to Cityscapes ids, instances."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.errors import InputError
from usdworld.io.label_table import by_name, label_lookups
from usdworld.io.segment_labels import parse_segment_labels, segment_labels
from usdworld.perception.segment.classes import class_map, unknown_pixels
from usdworld.perception.segment.instances import instances_from_panoptic, instances_from_semantic

CITYSCAPES_19 = (
    "road", "sidewalk", "building", "wall", "fence", "pole", "traffic light", "traffic sign", "vegetation",
    "terrain", "sky", "person", "rider", "car", "truck", "bus", "train", "motorcycle", "bicycle",
)  # fmt: skip
CAR, PERSON, ROAD = by_name("car").id, by_name("person").id, by_name("road").id


def test_shipped_table_covers_the_three_label_sets_and_follows_cityscapes_rules() -> None:
    table = segment_labels()
    assert all(table[name] == name for name in CITYSCAPES_19)
    assert len([n for n in table]) == 200  # 19 + 150 ADE20K + 66 Mapillary Vistas v1.2, shared names once
    known = {
        "curb": "sidewalk", "lane marking - general": "road", "street light": "pole", "van": "car",
        "traffic sign (front)": "traffic sign", "bicyclist": "rider", "tree": "vegetation", "bed": "",
        "on rails": "train", "ego vehicle": "ego vehicle",
    }  # fmt: skip
    assert {k: table[k] for k in known} == known


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("label,placed_as\n", "header must be label,cityscapes,dataset"),
        ("label,cityscapes,dataset\nCurb,sidewalk,x\n", "row 2: label 'Curb' must be non-empty, lower case"),
        ("label,cityscapes,dataset\ncurb,sidewalk,x\ncurb,road,y\n", "row 3: label 'curb' is listed twice"),
        ("label,cityscapes,dataset\ncurb,kerb,x\n", "row 2: 'kerb' is not a Cityscapes class name"),
    ],
)
def test_bad_table_rows_are_named(text: str, message: str) -> None:
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        parse_segment_labels(text)


def test_class_map_table_then_cityscapes_names_then_unknown() -> None:
    lookups = label_lookups()
    classes = class_map({"0": "Curb", "1": "bed", "2": "Caravan ", "4": "zebra"}, {"curb": "sidewalk", "bed": ""}, lookups)
    # curb by the table, bed known but unlabelled, caravan as a Cityscapes name, 3 missing, zebra unknown
    assert classes.label_ids.tolist() == [8, 0, by_name("caravan").id, 0, 0]
    assert classes.unknown.tolist() == [False, False, False, True, True]
    assert classes.names == ("Curb", "bed", "Caravan ", "3", "zebra")
    per_pixel = np.array([[0, 4, 4], [3, -1, 1]])
    assert unknown_pixels(per_pixel, classes) == (("3", 1), ("zebra", 2))
    with pytest.raises(InputError, match="no id2label"):
        class_map({}, {}, lookups)


def test_semantic_things_split_into_components_in_reading_order() -> None:
    labels = np.full((12, 20), ROAD, np.uint8)
    labels[6:10, 10:16] = CAR  # second in reading order
    labels[2:5, 1:4] = CAR
    labels[1:3, 17:19] = PERSON
    labels[11, 0] = CAR  # one pixel: below the smallest instance
    inst = instances_from_semantic(labels, label_lookups(), min_area_px=2)
    assert inst[3, 2] == CAR * 1000 and inst[7, 12] == CAR * 1000 + 1 and inst[1, 17] == PERSON * 1000
    assert inst[11, 0] == CAR and inst[0, 0] == ROAD
    assert len(np.unique(inst)) == 5


def test_detection_boxes_split_a_merged_component_the_nearest_box_in_front() -> None:
    labels = np.zeros((10, 20), np.uint8)
    labels[2:8, 2:14] = CAR  # two cars seen as one blob
    boxes = np.array([[0, 0, 9, 6], [6, 2, 14, 8]], float)  # overlap at u 6..8: the second box's bottom is lower
    inst = instances_from_semantic(labels, label_lookups(), 1, boxes, ("car", "car"))
    assert set(np.unique(inst[labels == CAR])) == {CAR * 1000, CAR * 1000 + 1, CAR * 1000 + 2}
    assert inst[3, 3] == CAR * 1000 and inst[3, 7] == CAR * 1000 + 1  # the shared columns go to the nearer box
    assert inst[7, 3] == CAR * 1000 + 2  # below the first box and outside the second: its own piece
    one_box = instances_from_semantic(labels, label_lookups(), 1, boxes[:1], ("car",))
    assert set(np.unique(one_box[labels == CAR])) == {CAR * 1000}  # one box: nothing to split
    other = instances_from_semantic(labels, label_lookups(), 1, boxes, ("car", "person"))
    assert set(np.unique(other[labels == CAR])) == {CAR * 1000}  # a person's box does not cut a car
    with pytest.raises(InputError, match="2 boxes but 1 classes"):
        instances_from_semantic(labels, label_lookups(), 1, boxes, ("car",))


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 15), st.integers(0, 15), st.integers(1, 6), st.integers(1, 6), st.sampled_from([CAR, PERSON, ROAD])), max_size=8),
    st.lists(
        st.tuples(st.integers(0, 15), st.integers(0, 15), st.integers(1, 10), st.integers(1, 10), st.sampled_from(["car", "person"])),
        max_size=4,
    ),
)
def test_instances_agree_with_labels(rects, boxes) -> None:
    labels = np.zeros((16, 16), np.uint8)
    for x, y, w, h, label in rects:
        labels[y : y + h, x : x + w] = label
    box_arr = np.array([[x, y, x + w, y + h] for x, y, w, h, _ in boxes], float).reshape(-1, 4)
    classes = [c for *_, c in boxes]
    inst = instances_from_semantic(labels, label_lookups(), 3, box_arr, classes)
    things = inst >= 1000
    assert np.array_equal(inst[things] // 1000, labels[things].astype(np.int32))
    assert np.array_equal(inst[~things], labels[~things].astype(np.int32))
    for iid in np.unique(inst[things]):
        assert (inst == iid).sum() >= 3
    assert np.array_equal(instances_from_semantic(labels, label_lookups(), 3, box_arr, classes), inst)  # deterministic


def test_panoptic_segments_numbered_per_thing_class() -> None:
    seg = np.array([[1, 1, 2, 3], [0, 4, 4, -1]])
    class_ids = np.array([ROAD, CAR, PERSON], np.uint8)  # model classes 0..2
    labels, inst = instances_from_panoptic(seg, [(1, 0), (4, 1), (2, 1), (3, 2)], class_ids, label_lookups())
    assert labels.tolist() == [[ROAD, ROAD, CAR, PERSON], [0, CAR, CAR, 0]]
    assert inst.tolist() == [[ROAD, ROAD, CAR * 1000, PERSON * 1000], [0, CAR * 1000 + 1, CAR * 1000 + 1, 0]]
