"""Tests for usdworld.io.labels and usdworld.io.label_table."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from conftest import SHARED_DATA

from usdworld.errors import InputError
from usdworld.io.images import read_image
from usdworld.io.label_table import LabelClass, by_id, by_name, label_mask, label_table, label_values
from usdworld.io.labels import decode_segmentation, read_polygons, read_segmentation
from usdworld.io.types import InputFile, SourceImage

SHARED = SHARED_DATA  # $USDWORLD_DATA or ../shared/data
CITYSCAPES = SHARED / "cityscapes"

ROAD, CAR, PERSON, SKY = 7, 26, 24, 23


def _image(h: int, w: int) -> SourceImage:
    return SourceImage(rgb=np.zeros((h, w, 3), np.uint8), file=InputFile("image", "frame.png", "0" * 64))


def _write(path: Path, array: np.ndarray) -> Path:
    assert cv2.imwrite(str(path), array)
    return path


def _labels_and_instances() -> tuple[np.ndarray, np.ndarray]:
    labels = np.full((10, 20), ROAD, np.uint8)
    labels[:3] = SKY
    labels[5:8, 2:6] = CAR
    labels[4:9, 10:12] = PERSON
    instances = labels.astype(np.uint16)
    instances[5:8, 2:6] = CAR * 1000
    instances[4:9, 10:12] = PERSON * 1000 + 1
    return labels, instances


# --- class table ----------------------------------------------------------------------


def test_label_table_known_rows() -> None:
    table = label_table()
    assert len(table) == 34 and table is label_table()
    car = by_name("car")
    assert car == LabelClass(26, "car", "vehicle", True, (0, 0, 142), "car")
    assert by_id(7).name == "road" and by_id(7).placed_as is None
    assert by_name("traffic sign").placed_as == "traffic_sign"
    assert [c.id for c in table] == list(range(34))


def test_label_table_unknown() -> None:
    with pytest.raises(InputError, match="label id 99 is not in the Cityscapes class table"):
        by_id(99)
    with pytest.raises(InputError, match="class name 'Car' is not in"):
        by_name("Car")


# --- labelIds / instanceIds -----------------------------------------------------------


def test_read_labels_and_instances(tmp_path: Path) -> None:
    labels, instances = _labels_and_instances()
    seg = read_segmentation(
        _write(tmp_path / "f_labelIds.png", labels),
        _write(tmp_path / "f_instanceIds.png", instances),
        _image(10, 20),
    )
    np.testing.assert_array_equal(seg.label_ids, labels)
    assert seg.label_ids.dtype == np.uint8
    assert seg.instance_ids is not None and seg.instance_ids.dtype == np.int32
    np.testing.assert_array_equal(seg.instance_ids, instances)
    assert [f.role for f in seg.files] == ["labels", "instances"]
    assert [f.name for f in seg.files] == ["f_labelIds.png", "f_instanceIds.png"]


def test_labels_only(tmp_path: Path) -> None:
    labels, _ = _labels_and_instances()
    seg = read_segmentation(_write(tmp_path / "l.png", labels))
    assert seg.instance_ids is None and len(seg.files) == 1


def test_labels_size_differs_from_image(tmp_path: Path) -> None:
    labels, _ = _labels_and_instances()
    path = _write(tmp_path / "frame_labelIds.png", labels)
    with pytest.raises(
        InputError, match=r"^frame_labelIds\.png: 20x10 but the image frame\.png is 40x20; pass the labels"
    ):
        read_segmentation(path, image=_image(20, 40))


@pytest.mark.parametrize("instances", ["8-bit", "missing", "other size", "other frame"])
def test_decoded_before_the_photo_the_labels_size_error_still_comes_first(tmp_path: Path, instances: str) -> None:
    """Decoded without the photo, checked against it after: the errors in read_segmentation's order."""
    labels, inst = _labels_and_instances()
    lp = _write(tmp_path / "frame_labelIds.png", labels)
    other = inst.copy()
    other[other >= 1000] = SKY * 1000
    bad = {"8-bit": labels, "other size": inst[:5], "other frame": other}
    ip = tmp_path / "i.png" if instances == "missing" else _write(tmp_path / "i.png", bad[instances])
    decoded = decode_segmentation(lp, ip)  # the instance map's error waits
    with pytest.raises(InputError, match=r"^frame_labelIds\.png: 20x10 but the image frame\.png is 40x20"):
        decoded.checked(_image(20, 40))
    with pytest.raises(InputError, match=r"i\.png: "):
        decoded.checked(_image(10, 20))
    with pytest.raises(InputError, match=r"i\.png: "):
        read_segmentation(lp, ip, _image(10, 20))


def test_colour_labels_rejected(tmp_path: Path) -> None:
    path = _write(tmp_path / "f_color.png", np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(
        InputError, match=r"f_color\.png: is a RGB colour image; .*labelIds\.png.*not \*_color\.png"
    ):
        read_segmentation(path)


def test_16bit_labels_rejected(tmp_path: Path) -> None:
    path = _write(tmp_path / "x.png", np.zeros((4, 4), np.uint16))
    with pytest.raises(InputError, match="16-bit where 8-bit labelIds are expected"):
        read_segmentation(path)


def test_unknown_ids_listed_at_most_five(tmp_path: Path) -> None:
    labels = np.arange(40, 48, dtype=np.uint8).reshape(2, 4)
    labels[0, 0] = ROAD
    with pytest.raises(InputError, match=r"ids 41, 42, 43, 44, 45 \(and 2 more\) are not in"):
        read_segmentation(_write(tmp_path / "l.png", labels))


def test_train_ids_hint(tmp_path: Path) -> None:
    labels = np.array([[0, 255]], np.uint8)
    with pytest.raises(InputError, match=r"ids 255 .*labelTrainIds\.png: pass \*_labelIds\.png instead"):
        read_segmentation(_write(tmp_path / "l.png", labels))


def test_8bit_instances_rejected(tmp_path: Path) -> None:
    labels, _ = _labels_and_instances()
    lp = _write(tmp_path / "l.png", labels)
    ip = _write(tmp_path / "i.png", labels)
    with pytest.raises(InputError, match=r"^i\.png: 8-bit where 16-bit instanceIds are expected"):
        read_segmentation(lp, ip)


def test_instances_size_mismatch(tmp_path: Path) -> None:
    labels, instances = _labels_and_instances()
    lp = _write(tmp_path / "l.png", labels)
    ip = _write(tmp_path / "i.png", instances[:5])
    with pytest.raises(InputError, match=r"i\.png: 20x5 but the labels l\.png are 20x10"):
        read_segmentation(lp, ip)


def test_instance_class_mismatch(tmp_path: Path) -> None:
    labels, instances = _labels_and_instances()
    instances[5:8, 2:6] = 27000  # truck instance over car labels: 12 of 22 instance pixels
    lp = _write(tmp_path / "l.png", labels)
    ip = _write(tmp_path / "i.png", instances)
    with pytest.raises(InputError, match=r"at 12 of 22 instance pixels \(54\.5 %\) the class"):
        read_segmentation(lp, ip)


def test_instance_class_mismatch_below_threshold_accepted(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    labels = np.full((20, 20), CAR, np.uint8)
    instances = np.full((20, 20), CAR * 1000, np.uint16)
    instances[0, 0] = PERSON * 1000  # 1 of 400 pixels = 0.25 %
    seg = read_segmentation(_write(tmp_path / "l.png", labels), _write(tmp_path / "i.png", instances))
    assert seg.instance_ids is not None
    assert "at 1 of 400 instance pixels" in caplog.text


def test_jpeg_labels_rejected(tmp_path: Path) -> None:
    path = _write(tmp_path / "l.jpg", np.zeros((8, 8), np.uint8))
    with pytest.raises(InputError, match="lossy"):
        read_segmentation(path)


# --- polygons -------------------------------------------------------------------------


def _polygons(tmp_path: Path, objects: list[dict[str, object]], w: int = 20, h: int = 10) -> Path:
    path = tmp_path / "f_gtFine_polygons.json"
    path.write_text(json.dumps({"imgWidth": w, "imgHeight": h, "objects": objects}))
    return path


def _rect(x0: int, y0: int, x1: int, y1: int) -> list[list[int]]:
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def test_polygons_order_groups_and_instances(tmp_path: Path) -> None:
    path = _polygons(
        tmp_path,
        [
            {"label": "road", "polygon": _rect(0, 0, 19, 9)},
            {"label": "car", "polygon": _rect(1, 1, 5, 5)},
            {"label": "cargroup", "polygon": _rect(8, 1, 10, 3)},
            {"label": "car", "polygon": _rect(4, 4, 7, 7)},  # over the first car
            {"label": "person", "polygon": _rect(12, 2, 13, 8)},
            {"label": "polegroup", "polygon": _rect(16, 0, 16, 9)},
            {"label": "license plate", "polygon": _rect(2, 2, 3, 3)},
            {"label": "sky", "polygon": _rect(18, 0, 19, 1), "deleted": 1},
        ],
    )
    seg = read_polygons(path, _image(10, 20))
    inst = seg.instance_ids
    assert inst is not None
    assert seg.label_ids[0, 0] == ROAD and inst[0, 0] == ROAD
    assert inst[2, 2] == 26000 and seg.label_ids[2, 2] == CAR  # license plate not drawn
    assert inst[5, 5] == 26001 and inst[7, 7] == 26001  # later car drawn over earlier
    assert inst[2, 9] == CAR and seg.label_ids[2, 9] == CAR  # group: class id, no instance
    assert inst[5, 12] == 24000
    assert seg.label_ids[5, 16] == 18 and inst[5, 16] == 18  # polegroup is a class of its own
    assert seg.label_ids[0, 19] == ROAD  # deleted object skipped
    assert seg.files[0].role == "polygons"


def test_polygons_unknown_label(tmp_path: Path) -> None:
    path = _polygons(
        tmp_path,
        [
            {"label": "road", "polygon": _rect(0, 0, 2, 2)},
            {"label": "spaceship", "polygon": _rect(0, 0, 2, 2)},
        ],
    )
    with pytest.raises(InputError, match=r"objects -> \[1\] -> label: 'spaceship' is not a Cityscapes class"):
        read_polygons(path)


def test_polygons_size_mismatch(tmp_path: Path) -> None:
    path = _polygons(tmp_path, [])
    with pytest.raises(InputError, match=r"f_gtFine_polygons\.json: 20x10 but the image frame\.png is 40x20"):
        read_polygons(path, _image(20, 40))


def test_polygons_malformed(tmp_path: Path) -> None:
    path = _polygons(tmp_path, [{"label": "car", "polygon": [[0, 0], [1, 1]]}])
    with pytest.raises(InputError, match=r"objects -> \[0\] -> polygon: needs at least 3"):
        read_polygons(path)
    path.write_text('{"imgWidth": 4, "objects": []}')
    with pytest.raises(InputError, match=r"f_gtFine_polygons\.json -> imgHeight: missing"):
        read_polygons(path)
    path.write_text('{"imgWidth": 4, "imgHeight": 2, "objects": [}')
    with pytest.raises(InputError, match=r"not valid JSON \(line 1 column"):
        read_polygons(path)
    path.write_text(
        '{"imgWidth": 4, "imgHeight": 2, "objects": '
        '[{"label": "car", "polygon": [[0, 0], [1, "a"], [2, 2]]}]}'
    )
    with pytest.raises(InputError, match=r"polygon -> \[1\] -> \[1\]: must be a number, got string"):
        read_polygons(path)


@pytest.mark.shared_data
@pytest.mark.skipif(not CITYSCAPES.is_dir(), reason="real sample data $USDWORLD_DATA/cityscapes is absent")
def test_real_cityscapes_frame() -> None:
    stem = CITYSCAPES / "frankfurt_000000_000294"
    image = read_image(f"{stem}_leftImg8bit.png")
    seg = read_segmentation(f"{stem}_gtFine_labelIds.png", f"{stem}_gtFine_instanceIds.png", image)
    assert seg.label_ids.shape == (128, 256)
    assert seg.instance_ids is not None
    things = sorted(int(i) for i in np.unique(seg.instance_ids) if i >= 1000)
    assert things == [24000, 24001, 24002, 24003, 26000, 26001, 26002]
    with pytest.raises(InputError, match="labelTrainIds"):
        read_segmentation(f"{stem}_gtFine_labelTrainIds.png")


@settings(max_examples=60, deadline=None)
@given(
    st.integers(0, 2**31 - 1), st.lists(st.integers(0, 255), max_size=5), st.sampled_from(["uint8", "int32"])
)
def test_label_mask_is_np_isin(seed: int, ids: list[int], dtype: str) -> None:
    labels = np.random.default_rng(seed).integers(0, 40, size=(7, 11)).astype(dtype)
    got = label_mask(labels, ids)
    assert got.dtype == bool and np.array_equal(got, np.isin(labels, ids))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_label_values_are_the_tables_value_per_label(seed: int) -> None:
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, 256, size=(5, 13)).astype(np.uint8)
    table = rng.integers(0, 256, size=256).astype(np.uint8)
    got = label_values(labels, table)
    assert got.dtype == np.uint8 and np.array_equal(got, table[labels])
