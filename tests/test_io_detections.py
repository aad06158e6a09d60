"""Tests for usdworld.io.detections (KITTI labels, detections JSON, COCO RLE)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from usdworld.errors import InputError
from usdworld.io.detections import (
    read_detections_json,
    read_kitti_labels,
    rle_decode,
    rle_encode,
    rle_from_string,
    rle_to_string,
)
from usdworld.io.images import read_image
from usdworld.io.types import InputFile, SourceImage

SHARED = SHARED_DATA  # $USDWORLD_DATA or ../shared/data


def _image(h: int = 100, w: int = 200) -> SourceImage:
    return SourceImage(rgb=np.zeros((h, w, 3), np.uint8), file=InputFile("image", "frame.png", "0" * 64))


# --- COCO RLE -------------------------------------------------------------------------


def test_rle_known_small_mask() -> None:
    # Column-major: column 0 = (0, 1), column 1 = (1, 1) -> 0,1,1,1 -> runs [1, 3].
    mask = np.array([[0, 1], [1, 1]], bool)
    assert rle_encode(mask) == [1, 3]
    assert rle_to_string([1, 3]) == "13"
    np.testing.assert_array_equal(rle_decode([1, 3], 2, 2), mask)
    # Starts with ones: a leading zero-length run.
    assert rle_encode(np.ones((2, 3), bool)) == [0, 6]


def test_rle_string_hand_checked() -> None:
    # 100 = 0b11_00100: low group 4 with "more" (4 | 0x20 = 36 -> 'T'), then 3 -> '3'.
    assert rle_to_string([100]) == "T3"
    # From the 4th count on the delta to the count two places before is stored:
    # 1 - 2 = -1 -> group 0x1f with the sign bit set, no "more" -> chr(31 + 48) = 'O'.
    assert rle_to_string([5, 2, 3, 1]) == "523O"
    assert rle_from_string("523O") == [5, 2, 3, 1]
    assert rle_from_string("T3") == [100]


def test_rle_string_errors() -> None:
    with pytest.raises(ValueError, match="outside"):
        rle_from_string("12~")
    with pytest.raises(ValueError, match="ends inside a number"):
        rle_from_string("T")
    with pytest.raises(ValueError, match="sum to 5"):
        rle_decode([2, 3], 2, 3)


@settings(max_examples=60, deadline=None)
@given(arrays(bool, st.tuples(st.integers(1, 12), st.integers(1, 12))))
def test_rle_round_trip_both_forms(mask: np.ndarray) -> None:
    counts = rle_encode(mask)
    assert sum(counts) == mask.size
    np.testing.assert_array_equal(rle_decode(counts, *mask.shape), mask)
    np.testing.assert_array_equal(rle_decode(rle_from_string(rle_to_string(counts)), *mask.shape), mask)


# --- KITTI labels ---------------------------------------------------------------------

KITTI_LINES = """\
Car 0.00 0 1.85 387.63 181.54 423.81 203.12 1.67 1.87 3.69 -16.53 2.39 58.49 1.57
DontCare -1 -1 -10 503.89 169.71 590.61 190.13 -1 -1 -1 -1000 -1000 -1000 -10

Pedestrian 0.00 0 0.2 -5.0 10.0 20.0 250.0 1.7 0.6 0.8 1.0 1.6 10.0 0.1 0.75
"""


def test_kitti_labels_parsed_and_clipped(tmp_path: Path) -> None:
    path = tmp_path / "000001.txt"
    path.write_text(KITTI_LINES)
    dets = read_kitti_labels(path, _image(h=240, w=1242))
    assert [d.label for d in dets.items] == ["Car", "Pedestrian"]
    np.testing.assert_allclose(dets.items[0].box_px, [387.63, 181.54, 423.81, 203.12])
    assert dets.items[0].score == 1.0 and dets.items[0].mask is None
    assert all(d.amodal for d in dets.items)  # projected 3D boxes
    np.testing.assert_allclose(dets.items[1].box_px, [0.0, 10.0, 20.0, 240.0])
    assert dets.items[1].score == 0.75
    assert dets.file.role == "detections" and dets.file.name == "000001.txt"
    unclipped = read_kitti_labels(path)
    np.testing.assert_allclose(unclipped.items[1].box_px, [-5.0, 10.0, 20.0, 250.0])


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("Car 0 0 0 10 10 5 20 1 1 1 0 0 0 0", r"line 2: box \[10, 10, 5, 20\] has non-positive size"),
        (
            "Car 0 0 0 300 10 310 20 1 1 1 0 0 0 0",
            r"line 2: box \[300, 10, 310, 20\] lies entirely outside the 200x100",
        ),
        ("Car 0 0 0 10 10 20", r"line 2: 7 fields, expected 15"),
        ("Car 0 0 0 10 abc 20 20 1 1 1 0 0 0 0", r"line 2: y1 = 'abc' is not a finite number"),
        ("Car 0 0 0 10 10 20 20 1 1 1 0 0 0 0 3.5", r"line 2: score must be in \[0, 1\], got 3\.5"),
    ],
)
def test_kitti_label_errors(tmp_path: Path, line: str, message: str) -> None:
    path = tmp_path / "l.txt"
    path.write_text("Car 0 0 0 1 1 5 5 1 1 1 0 0 0 0\n" + line + "\n")
    with pytest.raises(InputError, match=r"^l\.txt: " + message):
        read_kitti_labels(path, _image())


def test_kitti_empty_file_is_no_objects(tmp_path: Path) -> None:
    path = tmp_path / "l.txt"
    path.write_text("\n")
    assert read_kitti_labels(path).items == ()


@pytest.mark.shared_data
@pytest.mark.skipif(not (SHARED / "kitti").is_dir(), reason="real sample data $USDWORLD_DATA/kitti is absent")
def test_real_kitti_labels() -> None:
    image = read_image(SHARED / "kitti/training/image_2/000001.png")
    dets = read_kitti_labels(SHARED / "kitti/training/label_2/000001.txt", image)
    assert [d.label for d in dets.items] == ["Truck", "Car", "Cyclist"]
    np.testing.assert_allclose(dets.items[0].box_px, [599.41, 156.40, 629.75, 189.25])


# --- detections JSON ------------------------------------------------------------------


def _write_json(tmp_path: Path, doc: object) -> Path:
    path = tmp_path / "dets.json"
    path.write_text(json.dumps(doc))
    return path


def test_detections_json_all_forms(tmp_path: Path) -> None:
    image = _image(h=8, w=10)
    mask = np.zeros((8, 10), bool)
    mask[2:5, 3:7] = True
    doc = {
        "model": "any extra keys are ignored",
        "detections": [
            {
                "class": "car",
                "box": [3, 2, 7, 5],
                "score": 0.9,
                "mask": {"size": [8, 10], "counts": rle_encode(mask)},
            },
            {
                "class": "car",
                "box": [3, 2, 7, 5],
                "mask": {"size": [8, 10], "counts": rle_to_string(rle_encode(mask))},
            },
            {"class": "person", "box": [-2, 0, 3, 4], "polygon": [[0, 0], [2, 0], [2, 3], [0, 3]]},
            {"class": "sign", "box": [1, 1, 2, 2], "amodal": True},
        ],
    }
    dets = read_detections_json(_write_json(tmp_path, doc), image)
    a, b, c, d = dets.items
    assert d.amodal and not (a.amodal or b.amodal or c.amodal)
    assert a.score == 0.9 and b.score == 1.0
    assert a.mask is not None and b.mask is not None
    np.testing.assert_array_equal(a.mask, mask)
    np.testing.assert_array_equal(b.mask, mask)
    np.testing.assert_allclose(c.box_px, [0, 0, 3, 4])
    assert c.mask is not None and c.mask.sum() == 12 and c.mask[3, 2] and not c.mask[4, 0]
    assert d.mask is None and d.label == "sign"


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ([], r"the top level must be an object"),
        ({"dets": []}, r" -> detections: missing"),
        ({"detections": [{"box": [0, 0, 1, 1]}]}, r"detections -> \[0\] -> class: missing"),
        (
            {"detections": [{"class": "car", "box": [0, 0, 1]}]},
            r"detections -> \[0\] -> box: must hold 4 numbers, got 3",
        ),
        (
            {"detections": [{"class": "car", "box": [0, 0, 1, 1], "score": 2}]},
            r"-> score: score must be in \[0, 1\]",
        ),
        (
            {"detections": [{"class": "car", "box": [20, 0, 30, 1]}]},
            r"-> box: box \[20, 0, 30, 1\] lies entirely outside",
        ),
        (
            {
                "detections": [
                    {"class": "car", "box": [0, 0, 1, 1], "mask": {"size": [4, 10], "counts": [40]}}
                ]
            },
            r"-> mask -> size: \[4, 10\] but the image frame\.png is \[8, 10\]",
        ),
        (
            {
                "detections": [
                    {"class": "car", "box": [0, 0, 1, 1], "mask": {"size": [8, 10], "counts": [70]}}
                ]
            },
            r"-> mask -> counts: run lengths sum to 70, but the mask has 8x10 = 80 pixels",
        ),
        (
            {
                "detections": [
                    {"class": "car", "box": [0, 0, 1, 1], "mask": {"size": [8, 10], "counts": [80]}}
                ]
            },
            r"-> mask: covers no pixel of the image",
        ),
        (
            {
                "detections": [
                    {"class": "car", "box": [0, 0, 1, 1], "mask": {"size": [8, 10], "counts": "1~"}}
                ]
            },
            r"-> mask -> counts: character '~' at position 1 is outside",
        ),
        (
            {
                "detections": [
                    {
                        "class": "car",
                        "box": [0, 0, 1, 1],
                        "polygon": [[0, 0], [1, 1], [0, 1]],
                        "mask": {"size": [8, 10], "counts": [80]},
                    }
                ]
            },
            r"has both polygon and mask; keep one",
        ),
        (
            {"detections": [{"class": "car", "box": [0, 0, 1, 1], "amodal": "yes"}]},
            r"-> amodal: must be true or false, got string 'yes'",
        ),
    ],
)
def test_detections_json_errors(tmp_path: Path, doc: object, message: str) -> None:
    with pytest.raises(InputError, match=r"^dets\.json.*" + message):
        read_detections_json(_write_json(tmp_path, doc), _image(h=8, w=10))


def test_detections_json_syntax_error(tmp_path: Path) -> None:
    path = tmp_path / "dets.json"
    path.write_text('{"detections": [')
    with pytest.raises(InputError, match=r"^dets\.json: not valid JSON"):
        read_detections_json(path, _image())
