"""A small synthetic rig for the multi-view tests: two cameras with known poses that see a known street.

``front`` looks along +X from (1.5, 0, 1.5); ``left`` from (1.5, 0.5, 1.5) turned 45 degrees
left. Their 67-degree views overlap between 11 and 34 degrees left of +X. The photos are
plain grey; each view's detections are the amodal image boxes of the objects' 3D boxes
(class prior sizes), as a nuScenes camera's 2D boxes are.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np

WIDTH, HEIGHT = 800, 450
K = np.array([[600.0, 0.0, 400.0], [0.0, 600.0, 225.0], [0.0, 0.0, 1.0]])
#: view name -> (camera position (x, y, z), heading in degrees).
CAMERAS = {"front": ((1.5, 0.0, 1.5), 0.0), "left": ((1.5, 0.5, 1.5), 45.0)}
#: (class, x, y, yaw in degrees, size [l, w, h]) of the street's objects, world frame.
OBJECTS = (
    ("car", 20.0, -3.0, 0.0, (4.2, 1.8, 1.5)),  # front only
    ("car", 15.0, 6.0, 0.0, (4.2, 1.8, 1.5)),  # both views
    ("car", 8.0, 12.0, 90.0, (4.2, 1.8, 1.5)),  # left only
    ("person", 12.0, 4.0, 0.0, (0.6, 0.6, 1.75)),  # both views
    ("person", 25.0, 1.0, 0.0, (0.6, 0.6, 1.75)),  # front only
)


def world_from_cam(position: tuple[float, float, float], heading_deg: float) -> np.ndarray:
    """(4, 4) pose of a level OpenCV camera at ``position`` looking ``heading_deg`` left of +X."""
    psi = math.radians(heading_deg)
    T = np.eye(4)
    T[:3, 0] = (math.sin(psi), -math.cos(psi), 0.0)  # camera x: right
    T[:3, 1] = (0.0, 0.0, -1.0)  # camera y: down
    T[:3, 2] = (math.cos(psi), math.sin(psi), 0.0)  # camera z: forward
    T[:3, 3] = position
    return T


def box_corners(
    x: float, y: float, yaw_deg: float, size: tuple[float, float, float], ground_z: float = 0.0
) -> np.ndarray:
    """(8, 3) corners of an object's box standing on the ground (``ground_z`` above the plane z = 0)."""
    l, w, h = size
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    out = []
    for dx in (-l / 2, l / 2):
        for dy in (-w / 2, w / 2):
            for z in (ground_z, ground_z + h):
                out.append((x + c * dx - s * dy, y + s * dx + c * dy, z))
    return np.array(out)


def image_box(pose: np.ndarray, corners: np.ndarray) -> list[float] | None:
    """The clipped image box of world corners seen by a camera, or None when not wholly in front and in view."""
    cam = (np.linalg.inv(pose) @ np.c_[corners, np.ones(len(corners))].T)[:3].T
    if (cam[:, 2] < 0.5).any():
        return None
    px = cam @ K.T
    px = px[:, :2] / px[:, 2:3]
    x0, y0 = px.min(axis=0)
    x1, y1 = px.max(axis=0)
    if x0 < 0 or x1 > WIDTH or y0 < 0 or y1 > HEIGHT:
        return None  # the test scene keeps to objects wholly inside a view
    return [float(x0), float(y0), float(x1), float(y1)]


def write_rig(folder: Path, objects: tuple = OBJECTS, ground_z: tuple[float, ...] | None = None) -> Path:
    """Write the rig's photos, detections and manifest into ``folder``; return the manifest.

    ``objects`` are (class, x, y, yaw in degrees, size) as :data:`OBJECTS`; ``ground_z`` the height
    of the ground each stands on (default: all on the plane z = 0).
    """
    views = []
    heights = ground_z if ground_z is not None else (0.0,) * len(objects)
    for name, (position, heading) in CAMERAS.items():
        pose = world_from_cam(position, heading)
        dets = []
        for (cls, x, y, yaw, size), z0 in zip(objects, heights):
            box = image_box(pose, box_corners(x, y, yaw, size, z0))
            if box is not None:
                dets.append({"class": cls, "box": box, "amodal": True})
        cv2.imwrite(str(folder / f"{name}.png"), np.full((HEIGHT, WIDTH, 3), 128, np.uint8))
        (folder / f"{name}_dets.json").write_text(json.dumps({"detections": dets}))
        views.append(
            {
                "name": name,
                "image": f"{name}.png",
                "K": K.tolist(),
                "camera_to_world": pose.tolist(),
                "detections": f"{name}_dets.json",
            }
        )
    manifest = folder / "views.json"
    manifest.write_text(json.dumps({"views": views}))
    return manifest


def seen_by(cls_x_y: tuple[str, float, float]) -> list[str]:
    """The views whose detections hold the object at (x, y)."""
    for cls, x, y, yaw, size in OBJECTS:
        if (cls, x, y) == cls_x_y:
            return [
                n
                for n, (p, h) in CAMERAS.items()
                if image_box(world_from_cam(p, h), box_corners(x, y, yaw, size))
            ]
    raise KeyError(cls_x_y)
