"""tools/account_kitti.py: the cause of each miss, pinned on hand-made objects and cameras."""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from usdworld.geometry.camera import PinholeCamera

_TOOLS = Path(__file__).parents[1] / "tools"
sys.path.insert(0, str(_TOOLS))
_spec = importlib.util.spec_from_file_location("account_kitti", _TOOLS / "account_kitti.py")
account = importlib.util.module_from_spec(_spec)
sys.modules["account_kitti"] = account  # dataclasses look their module up
_spec.loader.exec_module(account)

K = np.array([[720.0, 0.0, 610.0], [0.0, 720.0, 175.0], [0.0, 0.0, 1.0]])
TRUE_HEIGHT_M = 1.65
#: The true road plane in the camera frame: y = 1.65 (n . p + d = 0 with n = (0, -1, 0), d = 1.65).
ROAD_NORMAL = np.array([0.0, -1.0, 0.0])


def level_camera(height_m: float) -> PinholeCamera:
    return PinholeCamera(1242, 375, K, height_m, 0.0, 0.0, 0.0)


def evidence(
    build_height_m: float = TRUE_HEIGHT_M,
    ground_below_camera_m: float = TRUE_HEIGHT_M,
    h_true: float = 1.5,
    f_ratio: float = 1.0,
    truncated: float = 0.0,
    occluded: int = 0,
    depth_m: float = 20.0,
) -> "account.DepthEvidence":
    """A car 20 m ahead whose cues read exactly what the geometry gives them.

    The build's camera is level at ``build_height_m``; the car stands ``ground_below_camera_m``
    below the true camera (1.65 m above the true road plane); its true height is ``h_true``
    against the Car prior's 1.5 m; the build's focal length is ``f_ratio`` times the true one.
    """
    bottom = np.array([0.0, ground_below_camera_m, depth_m])
    camera = level_camera(build_height_m)
    s = account.ground_factor(camera, bottom, 0.0)
    S = s * f_ratio  # a centred point: the build's ray for its pixel is the true ray scaled by f_ratio in depth
    s_true = account.plane_factor(ROAD_NORMAL, TRUE_HEIGHT_M, bottom)
    contact = depth_m * S
    height = depth_m * f_ratio * 1.5 / h_true
    sc, sh = 0.2 * depth_m, 0.1 * depth_m
    wc, wh = 1 / sc**2, 1 / sh**2
    fused = math.exp((wc * math.log(contact) + wh * math.log(height)) / (wc + wh))
    return account.DepthEvidence(
        depth_pred=fused,
        depth_true=depth_m,
        contact=contact,
        contact_sigma=sc,
        height=height,
        height_sigma=sh,
        f_ratio=f_ratio,
        ground_build=S,
        ground_true=s_true,
        h_true=h_true,
        h_class=1.5,
        h_class_std=0.12,
        partial=account.is_partial(truncated, "fused"),
        occluded=occluded >= 2,
    )


def test_ground_factor_of_a_low_camera():
    """A level camera 0.3 m low meets the true bottom's ray at 1.35 / 1.65 of its depth."""
    s = account.ground_factor(level_camera(1.35), np.array([0.0, 1.65, 20.0]), 0.0)
    assert s == pytest.approx(1.35 / 1.65)
    assert account.plane_factor(ROAD_NORMAL, 1.65, np.array([0.0, 1.95, 20.0])) == pytest.approx(1.65 / 1.95)


def test_exact_everything_misses_nothing():
    ev = evidence()
    assert ev.depth_pred == pytest.approx(20.0)
    parts = account.depth_contributions(ev)
    assert all(parts[k] == pytest.approx(0.0, abs=1e-12) for k in account.DEPTH_CAUSES[1:])


def test_a_cut_off_label_is_cut_off():
    assert account.depth_cause(evidence(build_height_m=1.35, truncated=0.4)) == "cut_off"
    assert account.is_partial(0.0, "contact_partial")
    assert account.is_partial(0.0, "behind_car_0001")
    assert not account.is_partial(0.0, "fused")


def test_a_largely_occluded_label_is_cut_off_only_when_its_box_misreads():
    """Largely occluded: a wrong class height stays class height; a cue misread from the box is the occlusion's."""
    assert account.depth_cause(evidence(h_true=1.86, occluded=2)) == "class_height"
    misread = replace(evidence(occluded=2), height=20.0 * 0.85)
    misread = replace(misread, depth_pred=misread.height)
    assert account.depth_cause(misread) == "cut_off"
    assert account.depth_cause(replace(misread, occluded=False)) == "box"


def test_a_tall_car_with_an_exact_camera_is_class_height():
    ev = evidence(h_true=1.86)
    parts = account.depth_contributions(ev)
    assert account.depth_cause(ev) == "class_height"
    assert parts["class_height"] == pytest.approx(parts["w_height"] * math.log(1.5 / 1.86))
    assert parts["camera"] == pytest.approx(0.0, abs=1e-12)


def test_a_camera_0_3_m_low_is_camera():
    ev = evidence(build_height_m=1.35)
    parts = account.depth_contributions(ev)
    assert account.depth_cause(ev) == "camera"
    assert parts["camera"] == pytest.approx(parts["w_contact"] * math.log(1.35 / 1.65))
    assert parts["off_plane"] == pytest.approx(0.0, abs=1e-12)


def test_a_car_on_ground_0_3_m_below_the_plane_is_off_plane():
    """The build's camera is exact; the car's road lies 0.3 m below the camera's plane."""
    ev = evidence(ground_below_camera_m=1.95)
    assert account.depth_cause(ev) == "off_plane"
    assert account.depth_contributions(ev)["camera"] == pytest.approx(0.0, abs=1e-12)


def test_a_long_focal_length_is_intrinsics():
    ev = evidence(f_ratio=1.12)
    assert ev.depth_pred == pytest.approx(20.0 * 1.12)
    assert account.depth_cause(ev) == "intrinsics"
    assert account.depth_contributions(ev)["intrinsics"] == pytest.approx(math.log(1.12))


def test_a_fusion_that_moves_the_depth_is_other():
    ev = replace(evidence(), depth_pred=22.0)
    assert account.depth_cause(ev) == "other"


@given(
    st.floats(1.0, 2.5),
    st.floats(1.0, 2.5),
    st.floats(1.2, 2.2),
    st.floats(0.7, 1.4),
    st.floats(5.0, 80.0),
    st.floats(0.8, 1.25),
)
def test_contributions_add_up_to_the_log_error(build_h, ground, h_true, f_ratio, depth, fusion):
    """Whatever the evidence, the parts add up exactly to log(predicted / true depth)."""
    ev = evidence(build_h, ground, h_true, f_ratio, depth_m=depth)
    ev = replace(ev, depth_pred=ev.depth_pred * fusion)
    parts = account.depth_contributions(ev)
    total = sum(parts[k] for k in account.DEPTH_CAUSES[1:])
    assert total == pytest.approx(math.log(ev.depth_pred / ev.depth_true), abs=1e-9)
    assert parts["w_contact"] + parts["w_height"] == pytest.approx(1.0)


def test_heading_causes():
    assert account.heading_cause(False, False, 0.0) == "not_placed"
    assert account.heading_cause(True, True, 5.0) == "cut_off"
    assert account.heading_cause(True, False, 8.0) == "front_back_flip"
    assert account.heading_cause(True, False, 80.0) == "wrong_line"


def test_lineup_causes():
    assert account.lineup_cause(False, 0.0, 0.0) == "not_placed"
    assert account.lineup_cause(True, 0.6, 0.2) == "principal_point"
    assert account.lineup_cause(True, 0.3, 0.7) == "focal_length"
    assert account.lineup_cause(True, 0.3, 0.3) == "placement"


def test_summary_counts_every_miss():
    misses = [
        {"kind": "depth", "cause": "camera"},
        {"kind": "depth", "cause": "camera"},
        {"kind": "heading", "cause": "wrong_line"},
        {"kind": "lineup", "cause": "principal_point"},
    ]
    summary = account.summarise_causes(misses)
    assert summary["depth"]["camera"] == 2 and sum(summary["depth"].values()) == 2
    assert summary["heading"] == {"not_placed": 0, "cut_off": 0, "front_back_flip": 0, "wrong_line": 1}
    assert summary["lineup"]["principal_point"] == 1


def test_missing_frames_are_an_input_error(tmp_path, capsys):
    (tmp_path / "image_2").mkdir()
    assert account.main([str(tmp_path)]) == 2
    assert "holds none of the frames" in capsys.readouterr().err


def test_account_of_kitti_frame_8(shared_data, capsys):
    """Frame 000008 with its calibration: every depth miss is over 3 %, the true camera comes from its road plane."""
    data = shared_data / "kitti" / "training"
    if not (data / "planes" / "000008.txt").is_file():
        pytest.skip(f"{data} has no KITTI frame 000008 with a road plane")
    assert account.main([str(data), "--frames", "000008", "--json"]) == 0
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    frame = out["frames"]["000008"]
    assert frame["focal_sources"] == ["given"] and frame["f_used"] == pytest.approx(frame["f_true"])
    assert 1.5 < frame["height_true_m"] < 1.9
    depth = [m for m in out["rows"] if m["kind"] == "depth"]
    assert depth and all(abs(m["signed_error"]) > account.DEPTH_TARGET for m in depth if m["placed"])
    assert sum(out["summary"]["depth"].values()) == len(depth)
