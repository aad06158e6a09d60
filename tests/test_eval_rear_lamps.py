"""tools/eval_rear_lamps.py: the red rear-lamp cue on drawn vehicle ends (known answers), its table."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.errors import InputError

_spec = importlib.util.spec_from_file_location(
    "eval_rear_lamps", Path(__file__).parents[1] / "tools" / "eval_rear_lamps.py"
)
eval_rear_lamps = importlib.util.module_from_spec(_spec)
sys.modules["eval_rear_lamps"] = eval_rear_lamps  # its dataclass looks its module up
_spec.loader.exec_module(eval_rear_lamps)

CAR_BODY_ROWS = (0.45, 0.9)
GREY = (120, 120, 125)
LAMP_RED = (190, 25, 25)


def _vehicle_end(
    px_per_m: float,
    body: tuple[int, int, int] = GREY,
    left: tuple[int, int, int] | None = LAMP_RED,
    right: tuple[int, int, int] | None = LAMP_RED,
    lamp_m: tuple[float, float] = (0.25, 0.15),
) -> np.ndarray:
    """(H, W, 3) uint8 a 1.8 m wide, 1.5 m tall vehicle end filling its box: a dark window
    from 1.0 m up and a lamp of ``lamp_m`` (width, height) at each outer edge from 0.85 m up."""
    w, h = round(1.8 * px_per_m), round(1.5 * px_per_m)
    img = np.empty((h, w, 3), dtype=np.uint8)
    img[:] = body
    img[: h - round(1.0 * px_per_m)] = (30, 32, 36)
    lw, lh = round(lamp_m[0] * px_per_m), round(lamp_m[1] * px_per_m)
    top = h - round(0.85 * px_per_m) - lh
    if left is not None:
        img[top : top + lh, 2 : 2 + lw] = left
    if right is not None:
        img[top : top + lh, w - 2 - lw : w - 2] = right
    return img


def test_back_with_red_lamps_shows_its_lamps():
    """A grey car's back, two red lamps of 0.25 x 0.15 m at 60 px/m: each blob 15 x 9 px = 0.0375 m^2."""
    cue = eval_rear_lamps.lamp_cue(_vehicle_end(60.0), 1.5, CAR_BODY_ROWS)
    assert cue.px_per_m == pytest.approx(60.0)
    assert cue.left_m2 == pytest.approx(15 * 9 / 60.0**2)
    assert cue.right_m2 == pytest.approx(15 * 9 / 60.0**2)
    assert cue.lamps_seen


def test_front_with_white_and_amber_lamps_shows_none():
    """The front: white headlamps and amber indicators where the back has its red lamps."""
    img = _vehicle_end(60.0, left=(240, 240, 230), right=(240, 240, 230))
    img[40:45, 20:26] = (255, 165, 0)
    img[40:45, 82:88] = (255, 165, 0)
    cue = eval_rear_lamps.lamp_cue(img, 1.5, CAR_BODY_ROWS)
    assert (cue.left_m2, cue.right_m2) == (0.0, 0.0)
    assert not cue.lamps_seen


def test_red_car_without_lamp_contrast_gives_no_evidence():
    """A red car whose lamps are hardly redder than its paint: its own red is the reference."""
    cue = eval_rear_lamps.lamp_cue(_vehicle_end(60.0, body=(170, 30, 30)), 1.5, CAR_BODY_ROWS)
    assert (cue.left_m2, cue.right_m2) == (0.0, 0.0)
    assert not cue.lamps_seen


def test_one_lamp_alone_is_not_a_pair():
    """One lamp hidden (by another car, the border): the pair's smaller half has none."""
    cue = eval_rear_lamps.lamp_cue(_vehicle_end(60.0, left=None), 1.5, CAR_BODY_ROWS)
    assert cue.left_m2 == 0.0 and cue.right_m2 > eval_rear_lamps.MIN_LAMP_AREA_M2
    assert not cue.lamps_seen


def test_lamps_smaller_than_a_stop_lamp_lens_are_not_counted():
    """At 100 px/m a 6 x 6 px lamp is 36 cm^2, under SAE J586's 50 cm^2; an 8 x 8 px one is 64 cm^2."""
    small = eval_rear_lamps.lamp_cue(_vehicle_end(100.0, lamp_m=(0.06, 0.06)), 1.5, CAR_BODY_ROWS)
    large = eval_rear_lamps.lamp_cue(_vehicle_end(100.0, lamp_m=(0.08, 0.08)), 1.5, CAR_BODY_ROWS)
    assert small.paired_m2 == pytest.approx(0.0036)
    assert large.paired_m2 == pytest.approx(0.0064)
    assert not small.lamps_seen and large.lamps_seen


def test_red_below_the_lamp_band_is_not_a_lamp():
    """Red 0.05 to 0.2 m above the box's bottom (a kerb, a road marking) lies below ECE R48's 0.35 m."""
    img = _vehicle_end(60.0, left=None, right=None)
    img[78:87, 2:17] = LAMP_RED
    img[78:87, 91:106] = LAMP_RED
    assert not eval_rear_lamps.lamp_cue(img, 1.5, CAR_BODY_ROWS).lamps_seen
    img[60:69, 2:17] = LAMP_RED  # 0.35 to 0.5 m: inside the band
    img[60:69, 91:106] = LAMP_RED
    assert eval_rear_lamps.lamp_cue(img, 1.5, CAR_BODY_ROWS).lamps_seen


@settings(max_examples=25, deadline=None)
@given(px_per_m=st.floats(20.0, 80.0), left=st.booleans(), right=st.booleans())
def test_mirrored_box_swaps_the_halves(px_per_m, left, right):
    img = _vehicle_end(px_per_m, left=LAMP_RED if left else None, right=LAMP_RED if right else None)
    cue = eval_rear_lamps.lamp_cue(img, 1.5, CAR_BODY_ROWS)
    mirrored = eval_rear_lamps.lamp_cue(img[:, ::-1], 1.5, CAR_BODY_ROWS)
    assert (mirrored.left_m2, mirrored.right_m2) == pytest.approx((cue.right_m2, cue.left_m2))
    assert cue.lamps_seen == (left and right)


def test_bad_crops_are_input_errors():
    with pytest.raises(InputError, match=r"lamp_cue: the crop must be \(H, W, 3\)"):
        eval_rear_lamps.lamp_cue(np.zeros((1, 5, 3), dtype=np.uint8), 1.5, CAR_BODY_ROWS)
    with pytest.raises(InputError, match="class_height_m must be > 0"):
        eval_rear_lamps.lamp_cue(np.zeros((5, 5, 3), dtype=np.uint8), 0.0, CAR_BODY_ROWS)


def test_true_facing_known_answers():
    """KITTI's heading is (cos ry, -sin ry) in the camera's x-z plane."""
    assert eval_rear_lamps.true_facing(-np.pi / 2, 0.0, 20.0) == "away"
    assert eval_rear_lamps.true_facing(np.pi / 2, 0.0, 20.0) == "towards"
    assert eval_rear_lamps.true_facing(0.0, 0.0, 20.0) == "side"
    # 10 m right, 10 m ahead, moving straight ahead: 45 degrees off the ray, still its back
    assert eval_rear_lamps.true_facing(-np.pi / 2, 10.0, 10.0) == "away"


def test_tool_table_on_a_drawn_frame(tmp_path, capsys):
    """One frame: a car's back with lamps 20 m ahead (away) and a front without (towards)."""
    (tmp_path / "image_2").mkdir()
    (tmp_path / "label_2").mkdir()
    photo = np.full((200, 400, 3), 90, dtype=np.uint8)
    photo[50:140, 20:128] = _vehicle_end(60.0)
    photo[50:140, 200:308] = _vehicle_end(60.0, left=(240, 240, 230), right=(240, 240, 230))
    cv2.imwrite(str(tmp_path / "image_2" / "000000.png"), photo[..., ::-1])
    (tmp_path / "label_2" / "000000.txt").write_text(
        "Car 0.00 0 0.00 20.00 50.00 128.00 140.00 1.50 1.80 4.20 -3.00 1.60 20.00 -1.5708\n"
        "DontCare -1 -1 -10 150.00 60.00 160.00 70.00 -1 -1 -1 -1000 -1000 -1000 -10\n"
        "Car 0.00 0 0.00 200.00 50.00 308.00 140.00 1.50 1.80 4.20 1.00 1.60 20.00 1.5708\n"
    )
    assert eval_rear_lamps.main([str(tmp_path), "--verbose"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split() == (
        "000000 0 Car away left 375.0 cm2 right 375.0 cm2 60.0 px/m lamps".split()
    )
    assert out[1].split()[:4] == ["000000", "1", "Car", "towards"] and out[1].split()[-1] == "-"
    assert out[2:6] == [
        "truth     vehicles  lamps seen   none  resolved  lamps seen   none",
        "away             1           1      0         1           1      0",
        "towards          1           0      1         1           0      1",
        "side             0           0      0         0           0      0",
    ]
    assert out[6] == "AUC of the paired area, away against towards: 1.000"
    # Jeffreys: lamps seen (1.5 / 2) / (0.5 / 2) = 3, none (0.5 / 2) / (1.5 / 2) = 1/3
    assert out[7] == "likelihood ratio back:front (all), lamps seen 3.00, none 0.33"
    assert out[8] == "likelihood ratio back:front (resolved), lamps seen 3.00, none 0.33"


def test_far_vehicles_are_unresolved():
    """At 19 px/m a 50 cm^2 lens covers 1.8 px (< 2): too few to tell from a colour fringe; 20 px/m: 2 px."""
    far = eval_rear_lamps.lamp_cue(_vehicle_end(19.0), 1.5, CAR_BODY_ROWS)
    near = eval_rear_lamps.lamp_cue(_vehicle_end(20.0), 1.5, CAR_BODY_ROWS)
    assert far.lamps_seen and not far.resolved
    assert near.lamps_seen and near.resolved


def test_tool_without_frames_is_an_input_error(tmp_path, capsys):
    (tmp_path / "image_2").mkdir()
    assert eval_rear_lamps.main([str(tmp_path)]) == 2
    assert capsys.readouterr().err == f"error: {tmp_path}/image_2 holds no PNG frames\n"
