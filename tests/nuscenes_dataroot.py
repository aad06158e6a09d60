"""A tiny fake nuScenes dataroot of the multi-view test rig (views_support), in the devkit's table layout.

One scene, one sample: CAM_FRONT and CAM_FRONT_LEFT are the rig's ``front`` and ``left``
cameras, LIDAR_TOP gives the sample's time. The ego stands at a global pose that is not the
identity (so the reader must chain ego and calibration poses), and the rig's objects are the
sample's annotations, in global coordinates as nuScenes stores them.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
from views_support import CAMERAS, HEIGHT, K, OBJECTS, WIDTH, world_from_cam

VERSION = "v1.0-mini"
SAMPLE = "sample0"
#: The rig's view name of each nuScenes camera.
CHANNELS = {"CAM_FRONT": "front", "CAM_FRONT_LEFT": "left"}
#: The ego's pose in the global frame: 30 degrees yaw, away from the origin.
GLOBAL_YAW = math.radians(30.0)
GLOBAL_T = np.array([400.0, 1100.0, 0.0])
CATEGORY = {"car": "vehicle.car", "person": "human.pedestrian.adult"}


def quaternion_z(yaw: float) -> list[float]:
    """(w, x, y, z) of a rotation by ``yaw`` about +Z."""
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def quaternion(R: np.ndarray) -> list[float]:
    """(w, x, y, z) of a rotation matrix."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(R).as_quat()
    return [float(w), float(x), float(y), float(z)]


def global_from_ego() -> np.ndarray:
    T = np.eye(4)
    c, s = math.cos(GLOBAL_YAW), math.sin(GLOBAL_YAW)
    T[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    T[:3, 3] = GLOBAL_T
    return T


def write_dataroot(root: Path) -> Path:
    """Write the tables, photos and map mask under ``root``; return ``root``."""
    tables = root / VERSION
    tables.mkdir(parents=True)
    (root / "maps").mkdir()
    cv2.imwrite(str(root / "maps" / "mask.png"), np.zeros((4, 4), np.uint8))
    G = global_from_ego()
    t = {
        "log": [{"token": "log0", "logfile": "fake", "vehicle": "v", "date_captured": "2026-11-27", "location": "x"}],
        "map": [{"token": "map0", "log_tokens": ["log0"], "category": "semantic_prior", "filename": "maps/mask.png"}],
        "scene": [
            {
                "token": "scene0",
                "log_token": "log0",
                "nbr_samples": 1,
                "first_sample_token": SAMPLE,
                "last_sample_token": SAMPLE,
                "name": "scene-0001",
                "description": "the test rig",
            }
        ],
        "sample": [{"token": SAMPLE, "timestamp": 1_000_000, "prev": "", "next": "", "scene_token": "scene0"}],
        "ego_pose": [
            {"token": "ego0", "timestamp": 1_000_000, "rotation": quaternion_z(GLOBAL_YAW), "translation": G[:3, 3].tolist()}
        ],
        "sensor": [{"token": "s_lidar", "channel": "LIDAR_TOP", "modality": "lidar"}],
        "calibrated_sensor": [
            {
                "token": "cs_lidar",
                "sensor_token": "s_lidar",
                "translation": [0.9, 0.0, 1.8],
                "rotation": [1.0, 0.0, 0.0, 0.0],
                "camera_intrinsic": [],
            }
        ],
        "sample_data": [
            {
                "token": "sd_lidar",
                "sample_token": SAMPLE,
                "ego_pose_token": "ego0",
                "calibrated_sensor_token": "cs_lidar",
                "timestamp": 1_000_000,
                "fileformat": "pcd",
                "is_key_frame": True,
                "height": 0,
                "width": 0,
                "filename": "samples/LIDAR_TOP/lidar.pcd.bin",
                "prev": "",
                "next": "",
            }
        ],
        "category": [{"token": f"cat_{c}", "name": n, "description": c} for c, n in CATEGORY.items()],
        "attribute": [{"token": "attr0", "name": "vehicle.parked", "description": ""}],
        "visibility": [{"token": "4", "level": "v80-100", "description": ""}],
        "instance": [],
        "sample_annotation": [],
    }
    for i, (channel, view) in enumerate(CHANNELS.items()):
        position, heading = CAMERAS[view]
        pose = world_from_cam(position, heading)  # ego_from_cam: the ego frame is the rig's world
        (root / "samples" / channel).mkdir(parents=True)
        name = f"samples/{channel}/{channel}_photo.jpg"
        cv2.imwrite(str(root / name), np.full((HEIGHT, WIDTH, 3), 128, np.uint8))
        t["sensor"].append({"token": f"s{i}", "channel": channel, "modality": "camera"})
        t["calibrated_sensor"].append(
            {
                "token": f"cs{i}",
                "sensor_token": f"s{i}",
                "translation": pose[:3, 3].tolist(),
                "rotation": quaternion(pose[:3, :3]),
                "camera_intrinsic": K.tolist(),
            }
        )
        t["sample_data"].append(
            {
                "token": f"sd{i}",
                "sample_token": SAMPLE,
                "ego_pose_token": "ego0",
                "calibrated_sensor_token": f"cs{i}",
                "timestamp": 1_000_000 + 5_000 * (i + 1),
                "fileformat": "jpg",
                "is_key_frame": True,
                "height": HEIGHT,
                "width": WIDTH,
                "filename": name,
                "prev": "",
                "next": "",
            }
        )
    for j, (cls, x, y, yaw_deg, (length, width, height)) in enumerate(OBJECTS):
        centre = G @ np.array([x, y, height / 2.0, 1.0])
        t["instance"].append(
            {
                "token": f"inst{j}",
                "category_token": f"cat_{cls}",
                "nbr_annotations": 1,
                "first_annotation_token": f"ann{j}",
                "last_annotation_token": f"ann{j}",
            }
        )
        t["sample_annotation"].append(
            {
                "token": f"ann{j}",
                "sample_token": SAMPLE,
                "instance_token": f"inst{j}",
                "attribute_tokens": [],
                "visibility_token": "4",
                "translation": centre[:3].tolist(),
                "size": [width, length, height],
                "rotation": quaternion_z(GLOBAL_YAW + math.radians(yaw_deg)),
                "prev": "",
                "next": "",
                "num_lidar_pts": 10,
                "num_radar_pts": 0,
            }
        )
    for name, rows in t.items():
        (tables / f"{name}.json").write_text(json.dumps(rows))
    return root
