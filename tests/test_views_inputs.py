"""The readers of ``--views``: a views manifest and one sample of an mmdetection3d nuScenes info file."""

from __future__ import annotations

import json
import math
import pickle
from pathlib import Path

import cv2
import numpy as np
import pytest
from views_support import K, world_from_cam

from usdworld.errors import InputError
from usdworld.views.manifest import read_views_manifest
from usdworld.views.nuscenes import box_corners_cam, read_nuscenes_views, truncation

POSE = world_from_cam((1.0, 0.0, 1.5), 0.0)


def _manifest(tmp_path: Path, *views: dict) -> Path:
    path = tmp_path / "views.json"
    path.write_text(json.dumps({"views": list(views)}))
    return path


def test_a_manifest_gives_each_view_its_pose_and_inputs(tmp_path: Path) -> None:
    ego = np.eye(4)
    ego[:3, 3] = (10.0, 5.0, 0.0)
    cam_to_ego = world_from_cam((1.0, 0.0, 1.5), 90.0)
    path = _manifest(
        tmp_path,
        {
            "image": "a.png",
            "K": K.tolist(),
            "camera_to_world": POSE.tolist(),
            "detections": "a.json",
            "timestamp": 1.5,
        },
        {
            "name": "side",
            "image": "/abs/b.png",
            "camera": "cam.json",
            "ego_to_world": ego.tolist(),
            "camera_to_ego": cam_to_ego.tolist(),
        },
    )
    views = read_views_manifest(path)
    a, b = views.views
    assert (a.name, a.image, a.detections, a.timestamp) == (
        "view0",
        tmp_path / "a.png",
        tmp_path / "a.json",
        1.5,
    )
    assert a.world_from_cam == pytest.approx(POSE) and a.K == pytest.approx(K) and a.camera is None
    assert (b.name, b.image, b.camera, b.K) == ("side", Path("/abs/b.png"), tmp_path / "cam.json", None)
    assert b.world_from_cam == pytest.approx(ego @ cam_to_ego)
    assert views.source.name == "views.json" and views.frame == "manifest world"


@pytest.mark.parametrize(
    ("view", "message"),
    [
        (
            {"K": K.tolist(), "camera_to_world": POSE.tolist()},
            r"views.json -> views -> \[0\]: image is missing",
        ),
        (
            {"image": "a.png", "camera_to_world": POSE.tolist()},
            "give the intrinsics as K or as a camera file",
        ),
        (
            {"image": "a.png", "K": K.tolist()},
            "give the pose as camera_to_world, or as ego_to_world and camera_to_ego",
        ),
        ({"image": "a.png", "K": K.tolist(), "camera_to_ego": POSE.tolist()}, "ego_to_world is missing"),
        (
            {"image": "a.png", "K": K.tolist(), "camera_to_world": POSE.tolist(), "labes": "x"},
            r"-> labes: unknown key",
        ),
        ({"image": "a.png", "K": K.tolist(), "camera_to_world": (2 * POSE).tolist()}, "the last row must be"),
        (
            {"image": "a.png", "K": K.tolist(), "camera_to_world": world_from_cam((0, 0, -1), 0).tolist()},
            "the camera is at z = -1 m",
        ),
        (
            {"image": "a.png", "K": K.tolist(), "camera_to_world": POSE.tolist(), "name": "3d"},
            "not a valid USD prim name",
        ),
        (
            {"image": "a.png", "K": K.tolist(), "camera_to_world": POSE.tolist(), "instances": "i.png"},
            "instances needs labels",
        ),
    ],
)
def test_manifest_errors_name_the_field(tmp_path: Path, view: dict, message: str) -> None:
    with pytest.raises(InputError, match=message):
        read_views_manifest(_manifest(tmp_path, view))


def test_manifest_refuses_twin_names_and_an_info_file(tmp_path: Path) -> None:
    v = {"name": "a", "image": "a.png", "K": K.tolist(), "camera_to_world": POSE.tolist()}
    with pytest.raises(InputError, match=r"\[1\] -> name: 'a' is also view \[0\]'s name"):
        read_views_manifest(_manifest(tmp_path, v, v))
    info = tmp_path / "info.json"
    info.write_text('{"data_list": [{"images": {}}], "x": NaN}')
    with pytest.raises(
        InputError,
        match="^info.json: an mmdetection3d info file, not a views manifest; pass --layout nuscenes$",
    ):
        read_views_manifest(info)


def test_truncation_is_the_share_of_the_projected_box_outside_the_image() -> None:
    inside = np.array([0.0, 0.0, 20.0, 4.0, 1.5, 1.8, 0.0])  # centred, 20 m ahead
    assert truncation(inside, K, 800, 450) == 0.0
    corners = box_corners_cam(inside)
    assert corners.min(axis=0) == pytest.approx([-2.0, -0.75, 19.1]) and corners.max(axis=0) == pytest.approx(
        [2.0, 0.75, 20.9]
    )
    # moved right until its projected box's centre column is the image's right edge: about half is cut
    u_half = 400.0 / 600.0 * 20.0
    assert truncation(inside + [u_half, 0, 0, 0, 0, 0, 0], K, 800, 450) == pytest.approx(0.5, abs=0.03)


def _write_info(tmp_path: Path) -> Path:
    cv2.imwrite(str(tmp_path / "front.jpg"), np.zeros((450, 800, 3), np.uint8))
    cam2ego = world_from_cam((1.5, 0.0, 1.5), 0.0)
    box = [2.0, 0.75, 20.0, 4.0, 1.5, 1.8, 0.0]  # gravity centre 0.75 m below the camera: on the ground
    doc = {
        "metainfo": {"categories": {"car": 0, "barrier": 9}},
        "data_list": [
            {
                "token": "t0",
                "images": {
                    "CAM_FRONT": {
                        "img_path": "samples/CAM_FRONT/front.jpg",
                        "cam2img": K.tolist(),
                        "cam2ego": cam2ego.tolist(),
                    }
                },
                "cam_instances": {
                    "CAM_FRONT": [
                        {
                            "bbox": [300, 200, 500, 280],
                            "bbox_label": 0,
                            "bbox_3d": box,
                            "velocity": [float("nan"), 0.0],
                        },
                        {"bbox": [10, 10, 20, 20], "bbox_label": -1},
                    ]
                },
            }
        ],
    }
    path = tmp_path / "info.json"
    path.write_text(json.dumps(doc))  # NaN as in real info copies
    return path


def test_a_nuscenes_sample_gives_one_view_per_camera_with_its_boxes(tmp_path: Path) -> None:
    views = read_nuscenes_views(_write_info(tmp_path))
    (v,) = views.views
    assert (v.name, v.image) == ("CAM_FRONT", tmp_path / "front.jpg")
    assert v.world_from_cam == pytest.approx(world_from_cam((1.5, 0.0, 1.5), 0.0))  # no lidar2cam: cam2ego
    (det,) = v.detection_items.items  # the ignored class (-1) is skipped
    assert (det.label, det.amodal, det.truncated) == ("car", True, 0.0)
    assert det.box_px.tolist() == [300, 200, 500, 280]
    assert v.detection_items.file.name == "info.json#CAM_FRONT"
    assert views.frame == "ego frame of sample t0"
    with pytest.raises(InputError, match="no sample with token 'zz'; its samples are t0"):
        read_nuscenes_views(tmp_path / "info.json", "zz")


def test_a_pickled_info_file_is_refused_with_how_to_convert_it(tmp_path: Path) -> None:
    path = tmp_path / "nuscenes_infos_val.pkl"
    path.write_bytes(pickle.dumps({"data_list": []}, protocol=4))
    with pytest.raises(InputError, match="^nuscenes_infos_val.pkl: a Python pickle .* pass that instead$"):
        read_nuscenes_views(path)


def test_a_nuscenes_photo_must_lie_beside_the_info_file(tmp_path: Path) -> None:
    info = _write_info(tmp_path)
    (tmp_path / "front.jpg").unlink()
    with pytest.raises(InputError, match="img_path: front.jpg is not beside info.json; put the photos there"):
        read_nuscenes_views(info)


def test_the_real_nuscenes_sample(shared_data: Path) -> None:
    info = shared_data / "nuscenes" / "demo" / "n015-2018-07-24-11-22-45+0800.pkl.DERIVED.json"
    views = read_nuscenes_views(info)
    names = [v.name for v in views.views]
    assert names == [
        "CAM_FRONT",
        "CAM_FRONT_RIGHT",
        "CAM_FRONT_LEFT",
        "CAM_BACK",
        "CAM_BACK_LEFT",
        "CAM_BACK_RIGHT",
    ]
    assert [len(v.detection_items.items) for v in views.views] == [47, 18, 2, 10, 2, 5]
    for v in views.views:  # the cameras are about 1.5 m up, on the car
        assert 1.4 < v.world_from_cam[2, 3] < 1.7 and np.hypot(*v.world_from_cam[:2, 3]) < 2.0
    back = views.views[3].world_from_cam
    assert math.degrees(math.atan2(back[1, 2], back[0, 2])) == pytest.approx(180.0, abs=1.0) or math.degrees(
        math.atan2(back[1, 2], back[0, 2])
    ) == pytest.approx(-180.0, abs=1.0)
