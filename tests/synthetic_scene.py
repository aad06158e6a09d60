"""A small known street drawn by projection: the ground truth for end-to-end tests.

Objects are asset meshes placed at known positions; their triangles are projected
with the camera and filled into the label and instance images far to near (objects do
not interpenetrate, so per-object painter's order is exact for the silhouettes).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from usdworld.authoring.asset_library import load_mesh
from usdworld.geometry.camera import PinholeCamera

ROAD, SIDEWALK, SKY, TERRAIN = 7, 8, 23, 22
CLASS_IDS = {"car": 26, "person": 24, "truck": 27}


@dataclass(frozen=True)
class TruthObject:
    class_name: str
    instance_id: int
    center_world: tuple[float, float]
    yaw: float


def default_objects() -> list[TruthObject]:
    """Cars on the road (both directions), people on the sidewalks, one truck."""
    spec = [
        ("car", (18.0, -1.9), 0.0),
        ("car", (12.0, -4.8), 0.0),
        ("car", (20.0, 1.9), np.pi),
        ("car", (30.0, 5.0), np.pi),
        ("car", (16.0, 4.8), np.pi),
        ("truck", (45.0, -1.9), 0.0),
        ("person", (14.0, -7.0), np.pi / 2),
        ("person", (14.0, 7.0), -np.pi / 2),
        ("person", (35.0, -7.5), np.pi),
    ]
    counters: dict[str, int] = {}
    out = []
    for cls, pos, yaw in spec:
        k = counters.get(cls, 0)
        counters[cls] = k + 1
        out.append(TruthObject(cls, CLASS_IDS[cls] * 1000 + k, pos, yaw))
    return out


def default_camera(width: int = 1024, height: int = 512) -> PinholeCamera:
    f = 0.8 * width
    K = np.array([[f, 0.0, width / 2 - 3.0], [0.0, f, height / 2 + 2.0], [0.0, 0.0, 1.0]])
    return PinholeCamera(width, height, K, height_m=1.5, pitch=np.radians(1.0))


#: Sidewalks are raised by a kerb, as in real streets (and as usdworld assumes).
KERB_M = 0.15
ROAD_HALF_WIDTH_M = 6.0


def _fill_ground(label: np.ndarray, cam: PinholeCamera, y0: float, y1: float, value: int, z: float = 0.0) -> None:
    xs = np.array([2.0, 200.0])
    corners = np.array([[xs[0], y0, z], [xs[1], y0, z], [xs[1], y1, z], [xs[0], y1, z]])
    px, _ = cam.project(corners)
    cv2.fillPoly(label, [np.round(px * 16).astype(np.int32)], int(value), shift=4)


def draw(cam: PinholeCamera, objects: list[TruthObject]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """RGB, labelIds and instanceIds images of the scene."""
    H, W = cam.height, cam.width
    label = np.full((H, W), SKY, dtype=np.uint8)
    horizon = int(np.ceil(cam.horizon_v()))
    label[horizon:] = TERRAIN  # open ground beyond the sidewalks
    _fill_ground(label, cam, -9.5, -ROAD_HALF_WIDTH_M, SIDEWALK, KERB_M)
    _fill_ground(label, cam, ROAD_HALF_WIDTH_M, 9.5, SIDEWALK, KERB_M)
    _fill_ground(label, cam, -ROAD_HALF_WIDTH_M, ROAD_HALF_WIDTH_M, ROAD)
    inst = label.astype(np.int32)
    order = sorted(objects, key=lambda o: -np.hypot(*o.center_world))
    for obj in order:
        mesh = load_mesh(obj.class_name)
        c, s = np.cos(obj.yaw), np.sin(obj.yaw)
        R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        z = KERB_M if abs(obj.center_world[1]) > ROAD_HALF_WIDTH_M else 0.0
        pts = mesh.vertices @ R.T + [obj.center_world[0], obj.center_world[1], z]
        px, depth = cam.project(pts)
        tris = np.round(px[mesh.faces] * 16).astype(np.int32)
        mask = np.zeros((H, W), dtype=np.uint8)
        for tri in tris:
            cv2.fillConvexPoly(mask, tri, 1, shift=4)
        on = mask.astype(bool)
        label[on] = CLASS_IDS[obj.class_name]
        inst[on] = obj.instance_id
    palette = np.zeros((256, 3), dtype=np.uint8)
    palette[[SKY, TERRAIN, SIDEWALK, ROAD, 24, 26, 27]] = [
        (130, 180, 230), (110, 140, 80), (190, 185, 175), (70, 70, 75), (200, 60, 60), (40, 60, 160), (90, 90, 140)
    ]
    rgb = palette[label]
    return rgb, label, inst


def write_scene(out_dir: Path, cam: PinholeCamera | None = None, objects: list[TruthObject] | None = None) -> dict[str, Path]:
    """Write a Cityscapes-format frame (image, labelIds, instanceIds, camera JSON)."""
    cam = cam or default_camera()
    objects = objects if objects is not None else default_objects()
    rgb, label, inst = draw(cam, objects)
    out_dir.mkdir(parents=True, exist_ok=True)
    name = "synth_000000_000001"
    paths = {
        "image": out_dir / f"{name}_leftImg8bit.png",
        "labels": out_dir / f"{name}_gtFine_labelIds.png",
        "instances": out_dir / f"{name}_gtFine_instanceIds.png",
        "camera": out_dir / f"{name}_camera.json",
    }
    cv2.imwrite(str(paths["image"]), rgb[:, :, ::-1])
    cv2.imwrite(str(paths["labels"]), label)
    cv2.imwrite(str(paths["instances"]), inst.astype(np.uint16))
    camera_json = {
        "extrinsic": {"baseline": 0.2, "pitch": cam.pitch, "roll": cam.roll, "x": 1.7, "y": 0.0, "yaw": cam.yaw, "z": cam.height_m},
        "intrinsic": {"fx": cam.fx, "fy": cam.fy, "u0": cam.cx, "v0": cam.cy},
    }
    paths["camera"].write_text(json.dumps(camera_json))
    return paths
