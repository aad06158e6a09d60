"""Tests for usdworld.io.camera_files."""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.errors import CalibrationError, InputError
from usdworld.frames import WORLD_FROM_CAM_LEVEL, rotation_world_from_vehicle
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.camera_files import (
    cam2_offset_from_projection,
    pose_from_ground_plane,
    read_camera,
    read_kitti_projection,
)
from usdworld.io.images import read_image
from usdworld.io.types import CameraSpec, InputFile, SourceImage

SHARED = SHARED_DATA  # $USDWORLD_DATA or ../shared/data
KITTI = SHARED / "kitti" / "training"

CITYSCAPES_CAM = {
    "extrinsic": {
        "baseline": 0.209313,
        "pitch": 0.038,
        "roll": 0.0,
        "x": 1.7,
        "y": 0.1,
        "yaw": -0.0195,
        "z": 1.22,
    },
    "intrinsic": {"fx": 2262.52, "fy": 2265.3017905988554, "u0": 1096.98, "v0": 513.137},
}

P2_000000 = [
    7.070493e02,
    0.0,
    6.040814e02,
    4.575831e01,
    0.0,
    7.070493e02,
    1.805066e02,
    -3.454157e-01,
    0.0,
    0.0,
    1.0,
    4.981016e-03,
]


def _image(h: int, w: int) -> SourceImage:
    return SourceImage(rgb=np.zeros((h, w, 3), np.uint8), file=InputFile("image", "frame.png", "0" * 64))


def _write_json(tmp_path: Path, doc: object, name: str = "cam.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def _write_calib(tmp_path: Path, p2: list[float], name: str = "calib.txt") -> Path:
    path = tmp_path / name
    numbers = " ".join(f"{v:.12e}" for v in p2)
    path.write_text(f"P0: {numbers}\nP1: {numbers}\nP2: {numbers}\nR0_rect: 1 0 0 0 1 0 0 0 1\n")
    return path


def _write_plane(tmp_path: Path, abcd: np.ndarray | list[float], name: str = "plane.txt") -> Path:
    path = tmp_path / name
    path.write_text("# Matrix\nWIDTH 4\nHEIGHT 1\n" + " ".join(f"{v:.9e}" for v in abcd) + " \n")
    return path


def _up_cam(pitch: float, roll: float) -> np.ndarray:
    """World up (0, 0, 1) in camera axes, from usdworld.frames' rotation."""
    R_world_from_cam = rotation_world_from_vehicle(pitch, roll, 0.0) @ WORLD_FROM_CAM_LEVEL
    return R_world_from_cam.T @ np.array([0.0, 0.0, 1.0])


# --- Cityscapes -----------------------------------------------------------------------


def test_cityscapes_values(tmp_path: Path) -> None:
    spec = read_camera(_write_json(tmp_path, CITYSCAPES_CAM), _image(1024, 2048))
    assert spec.K is not None
    expected = np.array([[2262.52, 0, 1096.98], [0, 2265.3017905988554, 513.137], [0, 0, 1]])
    np.testing.assert_allclose(spec.K, expected)
    assert (spec.height_m, spec.pitch, spec.roll, spec.yaw) == (1.22, 0.038, 0.0, -0.0195)
    assert spec.source == "cityscapes" and spec.file.role == "camera" and spec.extra_files == ()


def test_cityscapes_missing_field(tmp_path: Path) -> None:
    doc = json.loads(json.dumps(CITYSCAPES_CAM))
    del doc["intrinsic"]["fy"]
    with pytest.raises(InputError, match=r"^cam\.json -> intrinsic -> fy: missing$"):
        read_camera(_write_json(tmp_path, doc))


def test_cityscapes_negative_focal(tmp_path: Path) -> None:
    doc = json.loads(json.dumps(CITYSCAPES_CAM))
    doc["intrinsic"]["fx"] = -3.0
    with pytest.raises(CalibrationError, match=r"^cam\.json -> intrinsic -> fx: must be > 0, got -3$"):
        read_camera(_write_json(tmp_path, doc))


def test_full_resolution_calibration_on_shrunk_image(tmp_path: Path) -> None:
    with pytest.raises(
        CalibrationError,
        match=r"^cam\.json -> intrinsic -> u0: principal point \(1096\.98, 513\.137\) is far outside "
        r"the 256x128 image frame\.png, so the calibration is for an image of about 2194x1026; "
        r"scale fx, fy, cx, cy",
    ):
        read_camera(_write_json(tmp_path, CITYSCAPES_CAM), _image(128, 256))


def test_pitch_limit(tmp_path: Path) -> None:
    doc = json.loads(json.dumps(CITYSCAPES_CAM))
    doc["extrinsic"]["pitch"] = 2.0  # degrees written where radians belong
    with pytest.raises(
        CalibrationError, match=r"extrinsic -> pitch: pitch must be within \+-45 degrees, got 114\.6"
    ):
        read_camera(_write_json(tmp_path, doc))


# --- plain JSON -----------------------------------------------------------------------


def test_plain_json_K_and_degrees(tmp_path: Path) -> None:
    doc = {
        "K": [[800, 0, 320], [0, 810, 240], [0, 0, 1]],
        "height_m": 1.5,
        "pitch_deg": 2.0,
        "roll_deg": -1.0,
    }
    spec = read_camera(_write_json(tmp_path, doc), _image(480, 640))
    np.testing.assert_array_equal(spec.K, doc["K"])
    assert spec.height_m == 1.5 and spec.yaw is None and spec.source == "plain"
    assert spec.pitch == pytest.approx(math.radians(2.0)) and spec.roll == pytest.approx(math.radians(-1.0))


def test_plain_json_separate_intrinsics_and_empty(tmp_path: Path) -> None:
    spec = read_camera(_write_json(tmp_path, {"fx": 500, "fy": 500, "cx": 100, "cy": 50}))
    np.testing.assert_array_equal(spec.K, [[500, 0, 100], [0, 500, 50], [0, 0, 1]])
    empty = read_camera(_write_json(tmp_path, {}, "empty.json"))
    assert empty == CameraSpec(None, None, None, None, None, "plain", empty.file)


@pytest.mark.parametrize(
    ("doc", "error", "message"),
    [
        ({"fx": 500, "fy": 500, "cx": 100}, InputError, r"^cam\.json -> cy: missing$"),
        ({"K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "fx": 2}, InputError, r"gives both K and fx"),
        ({"K": [[1, 0, 0], [0, 1, 0], [1, 0, 1]]}, InputError, r"cam\.json -> K: must be \[\[fx, s, cx\]"),
        ({"K": [[1, 0, 0], [0, 1, 0]]}, InputError, r"cam\.json -> K: must be 3 rows"),
        ({"heigth_m": 1.5}, InputError, r"cam\.json -> heigth_m: unknown key; the keys are K, fx"),
        (
            {"height_m": -1.5},
            CalibrationError,
            r"^cam\.json -> height_m: camera height must be > 0 m, got -1\.5$",
        ),
        ({"height_m": "1.5"}, InputError, r"^cam\.json -> height_m: must be a number, got string$"),
        ({"roll_deg": 60}, CalibrationError, r"cam\.json -> roll_deg: roll must be within"),
        ({"fx": 0, "fy": 1, "cx": 1, "cy": 1}, CalibrationError, r"^cam\.json -> fx: must be > 0, got 0$"),
    ],
)
def test_plain_json_errors(
    tmp_path: Path, doc: dict[str, object], error: type[Exception], message: str
) -> None:
    with pytest.raises(error, match=message):
        read_camera(_write_json(tmp_path, doc))


def test_principal_point_outside_image_warns(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING):
        read_camera(_write_json(tmp_path, {"fx": 500, "fy": 500, "cx": 700, "cy": 240}), _image(480, 640))
    assert "outside the 640x480 image" in caplog.text


def test_unrecognised_file(tmp_path: Path) -> None:
    path = tmp_path / "cam.txt"
    path.write_text("focal 700\n")
    with pytest.raises(InputError, match=r"^cam\.txt: not a camera file usdworld knows"):
        read_camera(path)
    path.write_text("{not json")
    with pytest.raises(InputError, match=r"^cam\.txt: not valid JSON"):
        read_camera(path)


# --- KITTI ----------------------------------------------------------------------------


def test_kitti_calib_K_and_offset(tmp_path: Path) -> None:
    path = _write_calib(tmp_path, P2_000000)
    spec = read_camera(path, _image(370, 1224))
    assert spec.K is not None
    np.testing.assert_allclose(spec.K, np.reshape(P2_000000, (3, 4))[:, :3])
    assert spec.source == "kitti" and spec.height_m is None and spec.pitch is None
    P = read_kitti_projection(path)
    t = cam2_offset_from_projection(P)
    # P = K [I | t]  =>  K @ t is the 4th column.
    np.testing.assert_allclose(spec.K @ t, P[:, 3], atol=1e-9)
    assert t[0] == pytest.approx(0.06047, abs=1e-4)


def test_kitti_calib_errors(tmp_path: Path) -> None:
    path = tmp_path / "calib.txt"
    path.write_text("P0: 1 2 3\nP2: 1 0 0 0 0 1 0 0 0 0 1\n")
    with pytest.raises(InputError, match=r"calib\.txt -> P2 \(line 2\): 11 numbers, expected 12"):
        read_camera(path)
    path.write_text("P2: 1 0 0 0 0 1 0 0 0 0 1 x\n")
    with pytest.raises(InputError, match=r"calib\.txt -> P2 \(line 1\): could not convert"):
        read_camera(path)
    path.write_text("P2: -7 0 600 0 0 7 180 0 0 0 1 0\n")
    with pytest.raises(CalibrationError, match=r"calib\.txt -> P2 \(line 1\)\[0,0\] \(fx\): must be > 0"):
        read_camera(path)


@settings(max_examples=40, deadline=None)
@given(
    height=st.floats(0.3, 5.0),
    pitch_deg=st.floats(-30.0, 30.0),
    roll_deg=st.floats(-30.0, 30.0),
    scale=st.floats(-3.0, 3.0).filter(lambda s: abs(s) > 0.1),
)
def test_plane_pose_round_trip(height: float, pitch_deg: float, roll_deg: float, scale: float) -> None:
    pitch, roll = math.radians(pitch_deg), math.radians(roll_deg)
    up = _up_cam(pitch, roll)
    # Ground points p satisfy up . p = -height; any non-zero multiple describes the same plane.
    normal, d = scale * up, scale * height
    h, p, r = pose_from_ground_plane(normal, d)
    assert h == pytest.approx(height, rel=1e-9)
    assert p == pytest.approx(pitch, abs=1e-9)
    assert r == pytest.approx(roll, abs=1e-9)


def test_plane_file_known_pitch_down(tmp_path: Path) -> None:
    # A camera 1.6 m up, pitched 5 degrees down: in its frame the ground rises ahead,
    # so the up normal has a negative z component.
    up = _up_cam(math.radians(5.0), 0.0)
    assert up[2] < 0 and up[1] < 0
    calib = _write_calib(tmp_path, [700, 0, 600, 0, 0, 700, 180, 0, 0, 0, 1, 0])
    spec = read_camera(calib, None, _write_plane(tmp_path, [*up, 1.6]))
    assert spec.height_m == pytest.approx(1.6)
    assert math.degrees(spec.pitch or 0.0) == pytest.approx(5.0)
    assert spec.roll == pytest.approx(0.0, abs=1e-9)
    assert [f.role for f in spec.extra_files] == ["ground_plane"]


def test_plane_moved_to_camera_2(tmp_path: Path) -> None:
    # Camera 2 0.5 m to the right and 0.1 m below camera 0 (y down): t = -(0.5, 0.1, 0).
    K = np.array([[700.0, 0, 600], [0, 700, 180], [0, 0, 1]])
    t = np.array([-0.5, -0.1, 0.0])
    P2 = np.column_stack([K, K @ t])
    up = _up_cam(0.0, 0.0)
    spec = read_camera(_write_calib(tmp_path, P2.ravel().tolist()), None, _write_plane(tmp_path, [*up, 1.6]))
    assert spec.height_m == pytest.approx(1.5)


def test_plane_with_extrinsics_rejected(tmp_path: Path) -> None:
    plane = _write_plane(tmp_path, [0, -1, 0, 1.6])
    with pytest.raises(InputError, match=r"cam\.json: already gives extrinsic -> z; a ground-plane file"):
        read_camera(_write_json(tmp_path, CITYSCAPES_CAM), None, plane)


def test_plane_file_malformed(tmp_path: Path) -> None:
    calib = _write_calib(tmp_path, P2_000000)
    path = tmp_path / "plane.txt"
    path.write_text("# Matrix\nWIDTH 3\nHEIGHT 1\n0 -1 0\n")
    with pytest.raises(InputError, match=r"plane\.txt: line 2: 'WIDTH 3', expected WIDTH 4"):
        read_camera(calib, None, path)
    path.write_text("# Matrix\nWIDTH 4\nHEIGHT 1\n0 -1 0\n")
    with pytest.raises(InputError, match=r"plane\.txt: expected one line 'a b c d'"):
        read_camera(calib, None, path)
    path.write_text("# Matrix\nWIDTH 4\nHEIGHT 1\n0 0 0 1\n")
    with pytest.raises(InputError, match=r"normal \(a, b, c\) must be finite and non-zero"):
        read_camera(calib, None, path)
    path.write_text("# Matrix\nWIDTH 4\nHEIGHT 1\n0 0 1 1.6\n")  # a wall, not the ground
    with pytest.raises(
        CalibrationError, match=r"plane\.txt -> plane: pitch must be within \+-45 degrees, got -90\.0"
    ):
        read_camera(calib, None, path)


def _check_ground_agrees(spec: CameraSpec, image: SourceImage, normal: np.ndarray, d: float) -> None:
    """Rays of a PinholeCamera built from the spec hit the ground where they hit the plane."""
    assert spec.K is not None and spec.height_m is not None
    camera = PinholeCamera(
        image.width, image.height, spec.K, spec.height_m, spec.pitch or 0.0, spec.roll or 0.0
    )
    pixels = np.array(
        [
            [100.0, image.height - 5.0],
            [image.width / 2, image.height * 0.8],
            [image.width - 50.0, image.height - 1.0],
        ]
    )
    _, depth = camera.ground_points(pixels)
    rays_cam = np.column_stack([pixels, np.ones(3)]) @ np.linalg.inv(spec.K).T  # z = 1
    depth_plane = -d / (rays_cam @ normal)
    np.testing.assert_allclose(depth, depth_plane, rtol=1e-9)


def test_synthetic_plane_agrees_with_pinhole_camera(tmp_path: Path) -> None:
    normal = np.array([0.03, -0.998, -0.05])
    calib = _write_calib(tmp_path, [700, 0, 600, 0, 0, 700, 180, 0, 0, 0, 1, 0])
    image = _image(375, 1242)
    spec = read_camera(calib, image, _write_plane(tmp_path, [*normal, 1.7]))
    _check_ground_agrees(spec, image, normal, 1.7)


@pytest.mark.shared_data
@pytest.mark.skipif(not KITTI.is_dir(), reason="real sample data $USDWORLD_DATA/kitti is absent")
def test_real_kitti_frame_000000() -> None:
    image = read_image(KITTI / "image_2/000000.png")
    spec = read_camera(KITTI / "calib/000000.txt", image, KITTI / "planes/000000.txt")
    assert spec.K is not None and spec.K[0, 0] == pytest.approx(707.0493)
    # planes/000000.txt: (-0.00705, -0.99978, -0.01980), d = 1.680 in camera 0; camera 2 sits
    # 1.2 mm closer to the road, the ground rises ahead -> pitched down by ~1.13 degrees.
    assert spec.height_m == pytest.approx(1.679, abs=5e-4)
    assert math.degrees(spec.pitch or 0.0) == pytest.approx(1.135, abs=0.01)
    assert math.degrees(spec.roll or 0.0) == pytest.approx(0.404, abs=0.01)
    normal = np.array([-7.051729e-03, -9.997791e-01, -1.980151e-02])
    t = cam2_offset_from_projection(read_kitti_projection(KITTI / "calib/000000.txt"))
    _check_ground_agrees(spec, image, normal, 1.680367 - float(normal @ t))


@pytest.mark.shared_data
@pytest.mark.skipif(
    not (SHARED / "nuscenes/kitti_format").is_dir(), reason="real sample data $USDWORLD_DATA/nuscenes is absent"
)
def test_real_nuscenes_calib_has_no_extrinsics() -> None:
    image = read_image(SHARED / "nuscenes/kitti_format/image_2/nus_front.png")
    spec = read_camera(SHARED / "nuscenes/kitti_format/calib/nus_front.txt", image)
    assert spec.K is not None and spec.K[0, 0] == pytest.approx(1266.417203047)
    assert (spec.height_m, spec.pitch, spec.roll, spec.yaw) == (None, None, None, None)
