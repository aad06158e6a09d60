"""``--camera INFO.json#CAM``: one camera of an mmdetection3d info file, and the one-line messages
for an info file without a camera, a pickled info file and a KITTI calib file without P2."""

from __future__ import annotations

import json
import math
import pickle
from pathlib import Path

import numpy as np
import pytest

from usdworld.cli.main import main
from usdworld.errors import CalibrationError, InputError
from usdworld.io.camera_files import read_camera
from usdworld.io.camera_infos import split_camera_ref

K = [[1266.4, 0.0, 816.3], [0.0, 1266.4, 491.5], [0.0, 0.0, 1.0]]
PITCH_DEG, HEIGHT_M = 2.0, 1.5


def _cam2ego(pitch_deg: float, height_m: float) -> list[list[float]]:
    """Camera -> ego (Z up, ground z = 0): looking along ego +X, tilted down by ``pitch_deg``."""
    s, c = math.sin(math.radians(pitch_deg)), math.cos(math.radians(pitch_deg))
    x_cam, z_cam = np.array([0.0, -1.0, 0.0]), np.array([c, 0.0, -s])  # right, forward
    m = np.eye(4)
    m[:3, :3] = np.column_stack([x_cam, np.cross(z_cam, x_cam), z_cam])
    m[:3, 3] = [1.7, 0.0, height_m]
    return m.tolist()


def _nuscenes_info(path: Path) -> Path:
    """A small nuScenes info JSON in mmdetection3d's layout; a box velocity is NaN, as in real ones."""
    images = {
        "CAM_FRONT": {"img_path": "front.jpg", "cam2img": K, "cam2ego": _cam2ego(PITCH_DEG, HEIGHT_M)},
        "CAM_BACK": {"img_path": "back.jpg", "cam2img": K, "cam2ego": _cam2ego(-1.0, 1.6)},
    }
    doc = {
        "metainfo": {"dataset": "nuscenes", "version": "v1.0-mini", "categories": {"car": 0}},
        "data_list": [{"images": images, "instances": [{"velocity": [float("nan"), float("nan")]}]}],
    }
    path.write_text(json.dumps(doc))  # writes the NaN literal
    return path


def test_a_camera_of_a_nuscenes_info_file(tmp_path: Path) -> None:
    info = _nuscenes_info(tmp_path / "info.json")
    assert "NaN" in info.read_text()
    spec = read_camera(f"{info}#CAM_FRONT")
    np.testing.assert_allclose(spec.K, K)
    assert spec.height_m == pytest.approx(HEIGHT_M)
    assert math.degrees(spec.pitch) == pytest.approx(PITCH_DEG)
    assert spec.roll == pytest.approx(0.0, abs=1e-12) and spec.yaw is None
    assert (spec.source, spec.file.role, spec.file.name) == ("info", "camera", "info.json#CAM_FRONT")
    back = read_camera(f"{info}#CAM_BACK")
    assert back.height_m == pytest.approx(1.6) and math.degrees(back.pitch) == pytest.approx(-1.0)


def test_an_info_file_without_a_camera_names_its_cameras(tmp_path: Path) -> None:
    info = _nuscenes_info(tmp_path / "info.json")
    with pytest.raises(InputError) as exc:
        read_camera(info)
    assert str(exc.value) == (
        "info.json: an mmdetection3d nuscenes v1.0-mini info file (1 sample(s), cameras CAM_FRONT, CAM_BACK); "
        "name one camera of its first sample: --camera 'info.json#CAM_FRONT'"
    )
    with pytest.raises(
        InputError,
        match=r"^info.json: no camera 'CAM_SIDE' in its first sample; the cameras are CAM_FRONT, CAM_BACK$",
    ):
        read_camera(f"{info}#CAM_SIDE")


def test_a_kitti_info_gives_only_the_intrinsics(tmp_path: Path) -> None:
    P2 = [[721.5, 0.0, 609.6, 44.9], [0.0, 721.5, 172.9, 0.2], [0.0, 0.0, 1.0, 0.003], [0.0, 0.0, 0.0, 1.0]]
    doc = {
        "metainfo": {"dataset": "kitti"},
        "data_list": [{"images": {"CAM2": {"cam2img": P2, "lidar2cam": P2}}}],
    }
    (tmp_path / "kitti_infos.json").write_text(json.dumps(doc))
    spec = read_camera(tmp_path / "kitti_infos.json#CAM2")
    np.testing.assert_allclose(spec.K, np.array(P2)[:3, :3])
    assert (spec.height_m, spec.pitch, spec.roll) == (None, None, None)


def test_bad_info_cameras_are_named(tmp_path: Path) -> None:
    doc = json.loads(_nuscenes_info(tmp_path / "info.json").read_text())
    doc["data_list"][0]["images"]["CAM_FRONT"]["cam2img"][0][0] = float("nan")
    (tmp_path / "nan.json").write_text(json.dumps(doc))
    with pytest.raises(
        InputError, match=r"^nan.json -> data_list\[0\] -> images -> CAM_FRONT -> cam2img: holds non-finite"
    ):
        read_camera(f"{tmp_path / 'nan.json'}#CAM_FRONT")
    doc = json.loads(_nuscenes_info(tmp_path / "info.json").read_text())
    doc["data_list"][0]["images"]["CAM_FRONT"]["cam2ego"] = _cam2ego(PITCH_DEG, -1.5)
    (tmp_path / "below.json").write_text(json.dumps(doc))
    with pytest.raises(CalibrationError, match="the camera is -1.5 m above the ground; must be > 0"):
        read_camera(f"{tmp_path / 'below.json'}#CAM_FRONT")
    (tmp_path / "plain.json").write_text('{"height_m": 1.5}')
    with pytest.raises(
        InputError, match=r"^plain.json: not an mmdetection3d info file \(no data_list\), so '#CAM_FRONT'"
    ):
        read_camera(f"{tmp_path / 'plain.json'}#CAM_FRONT")


def test_a_pickled_info_file_is_refused_unopened(tmp_path: Path) -> None:
    (tmp_path / "nuscenes_infos_val.pkl").write_bytes(pickle.dumps({"data_list": []}, protocol=4))
    with pytest.raises(InputError) as exc:
        read_camera(tmp_path / "nuscenes_infos_val.pkl")
    assert str(exc.value).startswith(
        "nuscenes_infos_val.pkl: a Python pickle (an mmdetection3d info file?); usdworld does not unpickle files"
    )


def test_a_kitti_calib_without_p2(tmp_path: Path) -> None:
    numbers = " ".join(["0.0"] * 12)
    (tmp_path / "000000.txt").write_text(f"P0: {numbers}\nP1: {numbers}\nR0_rect: {' '.join(['0.0'] * 9)}\n")
    with pytest.raises(InputError) as exc:
        read_camera(tmp_path / "000000.txt")
    assert str(exc.value) == (
        "000000.txt: a KITTI-style calib file without a P2 line (it has P0, P1, R0_rect); "
        "usdworld reads camera 2, the left colour camera, from P2: pass the frame's full calib/<id>.txt"
    )


def test_split_camera_ref(tmp_path: Path) -> None:
    assert split_camera_ref("a/info.json#CAM_FRONT") == (Path("a/info.json"), "CAM_FRONT")
    assert split_camera_ref("a/calib.txt") == (Path("a/calib.txt"), None)
    odd = tmp_path / "odd#name.json"
    odd.write_text("{}")
    assert split_camera_ref(odd) == (odd, None)  # an existing file is taken as it is


def test_cli_info_file_without_camera_is_one_line_exit_2(tmp_path: Path, capsys) -> None:
    info = _nuscenes_info(tmp_path / "info.json")
    image = tmp_path / "frame.png"
    import cv2

    cv2.imwrite(str(image), np.zeros((900, 1600, 3), np.uint8))
    labels = tmp_path / "frame_labelIds.png"
    cv2.imwrite(str(labels), np.zeros((900, 1600), np.uint8))
    assert main(["build", str(image), "--labels", str(labels), "--camera", str(info), "-o", str(tmp_path / "w")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(
        "error: info.json: an mmdetection3d nuscenes v1.0-mini info file"
    )


def test_the_real_nuscenes_info_file(shared_data: Path) -> None:
    info = shared_data / "nuscenes" / "demo" / "n015-2018-07-24-11-22-45+0800.pkl.DERIVED.json"
    with pytest.raises(InputError, match="cameras CAM_FRONT, CAM_FRONT_RIGHT, CAM_FRONT_LEFT, CAM_BACK"):
        read_camera(info)
    spec = read_camera(f"{info}#CAM_FRONT")
    assert spec.K[0, 0] == pytest.approx(1266.417203046554) and spec.K[1, 2] == pytest.approx(
        491.50706579294757
    )
    assert spec.height_m == pytest.approx(1.5109575986862183)
    assert math.degrees(spec.pitch) == pytest.approx(0.323, abs=1e-3)  # cam2ego's optical axis dips 0.0056
