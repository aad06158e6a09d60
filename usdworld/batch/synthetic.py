"""Small synthetic Cityscapes trees for tests, demos and benchmarks of ``usdworld batch``.

Each frame is drawn with numpy and OpenCV, not rendered: sky, a building band, two
sidewalks, a road, and cars and people as rectangles standing on the ground where a
camera of the frame's calibration would see them. The files follow the Cityscapes
layout and naming::

    ROOT/leftImg8bit/<split>/<city>/<city>_<seq>_<frame>_leftImg8bit.png
    ROOT/gtFine/<split>/<city>/<city>_<seq>_<frame>_gtFine_labelIds.png
    ROOT/gtFine/<split>/<city>/<city>_<seq>_<frame>_gtFine_instanceIds.png
    ROOT/camera/<split>/<city>/<city>_<seq>_<frame>_camera.json

The same arguments give the same bytes.

Example:
    >>> from usdworld.batch.synthetic import write_cityscapes_tree
    >>> ids = write_cityscapes_tree("/tmp/cs", 3, width=512, height=256)  # doctest: +SKIP
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np

from usdworld.errors import OutputError

#: Cityscapes label ids drawn.
SKY, BUILDING, SIDEWALK, ROAD, PERSON, CAR = 23, 11, 8, 7, 24, 26
#: Class colours of the photo (RGB).
_COLOURS = {SKY: (70, 130, 180), BUILDING: (90, 80, 70), SIDEWALK: (170, 165, 160), ROAD: (60, 60, 65)}
_THING_COLOURS = {CAR: (20, 30, 140), PERSON: (200, 40, 60)}
#: Cityscapes intrinsics at 2048 x 1024 (cityscapesScripts' sample annotation).
CITYSCAPES_FX, CITYSCAPES_FY, CITYSCAPES_U0, CITYSCAPES_V0 = 2262.52, 2265.30, 1096.98, 513.14
CAMERA_HEIGHT_M = 1.3
CAMERA_PITCH = 0.02


def camera_document(width: int, height: int) -> dict:
    """The Cityscapes camera JSON of the synthetic camera at ``width`` x ``height`` pixels."""
    s = width / 2048.0
    return {
        "extrinsic": {
            "baseline": 0.2,
            "pitch": CAMERA_PITCH,
            "roll": 0,
            "x": 1.7,
            "y": 0,
            "yaw": 0,
            "z": CAMERA_HEIGHT_M,
        },
        "intrinsic": {
            "fx": round(CITYSCAPES_FX * s, 4),
            "fy": round(CITYSCAPES_FY * s, 4),
            "u0": round(CITYSCAPES_U0 * s, 4),
            "v0": round(CITYSCAPES_V0 * height / 1024.0, 4),
        },
    }


def _ground_row(depth_m: float, fy: float, v0: float) -> float:
    """Image row of a ground point ``depth_m`` ahead of the synthetic camera."""
    return v0 + fy * math.tan(math.atan2(CAMERA_HEIGHT_M, depth_m) - CAMERA_PITCH)


def draw_frame(width: int, height: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Draw one frame.

    Args:
        width: image width in pixels (>= 64).
        height: image height in pixels (>= 32).
        seed: picks the objects' positions and the photo's noise.

    Returns:
        rgb: (H, W, 3) uint8 photo.
        label_ids: (H, W) uint8 Cityscapes label ids.
        instance_ids: (H, W) uint16, ``class*1000+k`` on cars and people, the label id elsewhere.
    """
    rng = np.random.default_rng(seed)
    cam = camera_document(width, height)["intrinsic"]
    fx, fy, u0, v0 = cam["fx"], cam["fy"], cam["u0"], cam["v0"]
    labels = np.full((height, width), SKY, np.uint8)
    horizon = round(_ground_row(1e6, fy, v0))
    labels[int(0.2 * height) : horizon, :] = BUILDING
    labels[horizon:, :] = SIDEWALK
    # road: ground between y = -4 m and y = +4 m (left positive), drawn as a trapezoid
    far_row, near_row = _ground_row(60.0, fy, v0), float(height - 1)
    pts = []
    for row, depth in (
        (far_row, 60.0),
        (near_row, CAMERA_HEIGHT_M / math.tan(math.atan2(near_row - v0, fy) + CAMERA_PITCH)),
    ):
        for lateral in (4.0, -4.0):
            pts.append((u0 - fx * lateral / depth, row))
    road = np.array([pts[0], pts[1], pts[3], pts[2]], np.float64)
    cv2.fillPoly(labels, [np.round(road).astype(np.int32)], ROAD)
    instances = labels.astype(np.uint16)
    things = []
    for k in range(int(rng.integers(2, 5))):
        things.append((CAR, k + 1, float(rng.uniform(8.0, 35.0)), float(rng.uniform(-3.0, 3.0)), 1.8, 1.5))
    for k in range(int(rng.integers(1, 4))):
        side = 1.0 if k % 2 == 0 else -1.0
        things.append(
            (PERSON, k + 1, float(rng.uniform(14.0, 30.0)), side * float(rng.uniform(4.5, 5.5)), 0.6, 1.75)
        )
    for class_id, k, depth, lateral, w_m, h_m in sorted(things, key=lambda t: -t[2]):  # far first
        bottom = _ground_row(depth, fy, v0)
        u = u0 - fx * lateral / depth
        half_w, h_px = 0.5 * fx * w_m / depth, fy * h_m / depth
        x0, x1 = round(u - half_w), round(u + half_w)
        y0, y1 = round(bottom - h_px), round(bottom)
        if x1 <= 0 or x0 >= width - 1 or y1 >= height - 1:
            continue
        labels[max(y0, 0) : y1, max(x0, 0) : x1] = class_id
        instances[max(y0, 0) : y1, max(x0, 0) : x1] = class_id * 1000 + k
    rgb = np.zeros((height, width, 3), np.uint8)
    for class_id, colour in {**_COLOURS, **_THING_COLOURS}.items():
        rgb[labels == class_id] = colour
    noise = rng.integers(-12, 13, size=(height, width, 1), dtype=np.int16)
    rgb = np.clip(rgb.astype(np.int16) + noise, 0, 255).astype(np.uint8)
    return rgb, labels, instances


def _write_png(path: Path, image: np.ndarray) -> None:
    ok, buf = cv2.imencode(".png", image, [cv2.IMWRITE_PNG_COMPRESSION, 1])
    if not ok:
        raise OutputError(f"{path}: PNG encoding failed")
    path.write_bytes(buf.tobytes())


def frame_name(city: str, index: int) -> str:
    """Cityscapes frame id ``<city>_000000_<index:06d>``."""
    return f"{city}_000000_{index:06d}"


def write_cityscapes_frame(
    root: str | Path, split: str, city: str, index: int, width: int, height: int
) -> str:
    """Write one synthetic frame into a Cityscapes tree and return its frame id.

    Args:
        root: the tree's root folder (created if missing).
        split: ``train``, ``val`` or ``test``.
        city: city folder name.
        index: frame number (also the random seed).
        width: image width in pixels.
        height: image height in pixels.
    """
    root = Path(root)
    name = frame_name(city, index)
    rgb, labels, instances = draw_frame(width, height, index)
    folders = {kind: root / kind / split / city for kind in ("leftImg8bit", "gtFine", "camera")}
    try:
        for folder in folders.values():
            folder.mkdir(parents=True, exist_ok=True)
        _write_png(folders["leftImg8bit"] / f"{name}_leftImg8bit.png", rgb[:, :, ::-1])
        _write_png(folders["gtFine"] / f"{name}_gtFine_labelIds.png", labels)
        _write_png(folders["gtFine"] / f"{name}_gtFine_instanceIds.png", instances)
        doc = json.dumps(camera_document(width, height), indent=2) + "\n"
        (folders["camera"] / f"{name}_camera.json").write_text(doc)
    except OSError as exc:
        raise OutputError(f"{root}: cannot write the synthetic tree ({exc})") from exc
    return name


def write_cityscapes_tree(
    root: str | Path,
    frames: int,
    *,
    width: int = 2048,
    height: int = 1024,
    split: str = "val",
    city: str = "synthcity",
) -> list[str]:
    """Write ``frames`` synthetic frames into one split and city of a Cityscapes tree.

    Args:
        root: the tree's root folder.
        frames: how many frames.
        width: image width in pixels.
        height: image height in pixels.
        split: split folder name.
        city: city folder name.

    Returns:
        The frame ids, in order.
    """
    return [write_cityscapes_frame(root, split, city, i, width, height) for i in range(frames)]
