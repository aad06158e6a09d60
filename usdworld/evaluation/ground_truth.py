"""Metric 3D ground truth for evaluating a world: synth JSON, KITTI ``label_2``, nuScenes info.

Every reader returns a :class:`GroundTruth`: objects with their placed class (the asset
class usdworld would place for them), bottom centre, heading and size, in the frame the
source gives them in:

* **synth** (``<name>_gt.json`` of ``usdworld synth``, format ``usdworld-synth-gt/1``): the
  world frame of the synthetic scene (Z up, origin on the ground below the camera), with
  Cityscapes instance ids and visible pixel counts.
* **KITTI** (``label_2/*.txt``): the rectified camera-0 frame, moved into the camera-2
  frame the image was taken in by the ``P2`` offset of the calibration file (found as
  ``../calib/<same name>.txt`` when not given); ``DontCare`` lines are skipped and each
  object's instance id is its index among the remaining lines (the id ``usdworld build``
  gives a detection).
* **nuScenes** (the mmdetection3d info file as JSON, ``*.pkl.DERIVED.json``):
  ``cam_instances[CAMERA]`` boxes in the camera frame, gravity centre moved down by half
  the height; classes as in the KITTI-layout copy (car, truck / trailer / bus /
  construction vehicle -> truck, bicycle / motorcycle -> rider (KITTI "Cyclist"),
  pedestrian -> person; barriers and traffic cones are not placed and are left out).

Camera-frame headings follow KITTI: ``rotation_y`` turns about the camera's y axis (down)
and the heading is ``(cos ry, 0, -sin ry)``.
"""

from __future__ import annotations

import hashlib
import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from usdworld.errors import InputError
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.camera_files import cam2_offset_from_projection, read_kitti_projection
from usdworld.io.label_table import label_lookups
from usdworld.perception.classes import placed_class_for_label

log = logging.getLogger(__name__)

SYNTH_FORMAT = "usdworld-synth-gt/1"
#: nuScenes category -> placed class (as its KITTI-layout copy maps them, then as ``build`` maps KITTI types).
NUSCENES_CLASSES = {
    "car": "car",
    "truck": "truck",
    "trailer": "truck",
    "bus": "truck",
    "construction_vehicle": "truck",
    "bicycle": "rider",
    "motorcycle": "rider",
    "pedestrian": "person",
}
DEFAULT_NUSCENES_CAMERA = "CAM_FRONT"


def _frozen(values: Any, shape: tuple[int, ...] = (3,)) -> np.ndarray:
    a = np.array(values, dtype=np.float64)
    if a.shape != shape or not np.all(np.isfinite(a)):
        raise ValueError(f"expected {shape} finite numbers, got {values!r}")
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class GtObject:
    """One ground-truth object.

    Attributes:
        name: a readable id (``car_0003``, ``000008:2``).
        class_name: the placed class (``car``, ``person``, ``tree`` ...).
        instance_id: Cityscapes instance id (synth) or detection index (KITTI); -1 when none.
        bottom_centre: (3,) float64 centre of the box's bottom face, in the ground truth's frame.
        heading: (3,) float64 unit vector of the object's length axis (front), same frame.
        size_lwh: (3,) float64 length, width, height in metres.
        visible_px: pixels of the object visible in the image (synth), or None when unknown.
    """

    name: str
    class_name: str
    instance_id: int
    bottom_centre: np.ndarray
    heading: np.ndarray
    size_lwh: np.ndarray
    visible_px: int | None = None

    def __post_init__(self) -> None:
        for field_name in ("bottom_centre", "heading", "size_lwh"):
            object.__setattr__(self, field_name, _frozen(getattr(self, field_name)))


@dataclass(frozen=True)
class GroundTruth:
    """The ground truth of one frame.

    Attributes:
        kind: ``synth``, ``kitti`` or ``nuscenes``.
        frame: ``world`` (Z up, origin below the camera) or ``cam`` (OpenCV camera frame).
        objects: the objects.
        file_name: the ground-truth file's name.
        sha256: hex digest of the file's bytes.
        camera: the true camera (synth only), else None.
        sun_direction_world: (3,) float64 unit vector towards the true sun (synth only), else None.
        overcast: the scene is lit by the sky only (synth only; False in ground truth written
            before synth made overcast scenes), else None.
    """

    kind: str
    frame: str
    objects: tuple[GtObject, ...]
    file_name: str
    sha256: str
    camera: PinholeCamera | None = None
    sun_direction_world: np.ndarray | None = None
    overcast: bool | None = None

    def __post_init__(self) -> None:
        if self.frame not in ("world", "cam"):
            raise ValueError(f"GroundTruth.frame must be 'world' or 'cam', got {self.frame!r}")


def _read_bytes(path: Path) -> bytes:
    if not path.is_file():
        raise InputError(
            f"{path}: no such ground-truth file; pass --gt with a synth *_gt.json, a KITTI label_2 .txt or a nuScenes info JSON"
        )
    try:
        return path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror})") from None


def _json(data: bytes, name: str) -> Any:
    try:
        return json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{name}: not valid JSON ({exc})") from None


def _synth(doc: dict[str, Any], name: str, digest: str) -> GroundTruth:
    try:
        cam = doc["camera"]
        camera = PinholeCamera(
            width=int(cam["width"]),
            height=int(cam["height"]),
            K=np.array(cam["K"], dtype=np.float64),
            height_m=float(cam["height_m"]),
            pitch=float(cam["pitch"]),
            roll=float(cam["roll"]),
            yaw=float(cam["yaw"]),
        )
        objects = []
        for i, o in enumerate(doc["objects"]):
            yaw = float(o["yaw_rad"])
            objects.append(
                GtObject(
                    name=str(o["name"]),
                    class_name=str(o["class"]),
                    instance_id=int(o["instance_id"]) if int(o["instance_id"]) >= 1000 else -1,
                    bottom_centre=np.array(o["centre_world"], dtype=np.float64),
                    heading=np.array([np.cos(yaw), np.sin(yaw), 0.0]),
                    size_lwh=np.array(o["size_m"], dtype=np.float64),
                    visible_px=int(o["visible_pixels"]),
                )
            )
        sun = None
        if "sun_direction_world" in doc:
            sun = np.array(doc["sun_direction_world"], dtype=np.float64)
            if sun.shape != (3,) or not np.all(np.isfinite(sun)) or not np.linalg.norm(sun) > 0:
                raise ValueError(f"sun_direction_world: 3 finite numbers, not all 0, got {doc['sun_direction_world']}")
            sun = sun / np.linalg.norm(sun)
        overcast = bool(doc.get("overcast", False))
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise InputError(
            f"{name}: malformed synth ground truth ({type(exc).__name__}: {exc}); regenerate it with usdworld synth"
        ) from None
    return GroundTruth("synth", "world", tuple(objects), name, digest, camera, sun, overcast)


def _heading_cam(ry: float) -> np.ndarray:
    return np.array([np.cos(ry), 0.0, -np.sin(ry)])


def read_kitti_ground_truth(label_path: Path, calib_path: Path | None = None) -> GroundTruth:
    """KITTI ``label_2`` objects in the camera-2 frame (see the module docstring).

    Args:
        label_path: the label text file.
        calib_path: its calibration file; default ``../calib/<name>`` beside the label folder.
            Without one the camera-0 frame is used as is (about 6 cm off for KITTI camera 2).
    """
    data = _read_bytes(label_path)
    if calib_path is None:
        guess = label_path.parent.parent / "calib" / label_path.name
        calib_path = guess if guess.is_file() else None
    if calib_path is not None:
        offset = cam2_offset_from_projection(read_kitti_projection(calib_path))
    else:
        log.warning("%s: no calibration file found; using the camera-0 frame", label_path.name)
        offset = np.zeros(3)
    objects = []
    index = 0
    for line_no, line in enumerate(data.decode("utf-8", errors="replace").splitlines(), start=1):
        f = line.split()
        if not f:
            continue
        if f[0] == "DontCare":
            continue
        if len(f) not in (15, 16):
            raise InputError(
                f"{label_path.name}: line {line_no} has {len(f)} fields, expected 15 or 16 (KITTI label_2)"
            )
        try:
            h, w, l, x, y, z, ry = (float(v) for v in f[8:15])
        except ValueError:
            raise InputError(f"{label_path.name}: line {line_no}: a 3D field is not a number") from None
        cls = placed_class_for_label(f[0], label_lookups())
        if cls is not None:
            objects.append(
                GtObject(
                    name=f"{label_path.stem}:{index}",
                    class_name=cls,
                    instance_id=index,
                    bottom_centre=np.array([x, y, z]) + offset,
                    heading=_heading_cam(ry),
                    size_lwh=np.array([l, w, h]),
                )
            )
        index += 1
    return GroundTruth("kitti", "cam", tuple(objects), label_path.name, hashlib.sha256(data).hexdigest())


def _nuscenes(doc: dict[str, Any], name: str, digest: str, camera: str) -> GroundTruth:
    try:
        categories = {int(v): str(k) for k, v in doc["metainfo"]["categories"].items()}
        sample = doc["data_list"][0]
        boxes = sample["cam_instances"][camera]
    except (KeyError, IndexError, TypeError, AttributeError) as exc:
        raise InputError(
            f"{name}: not an mmdetection3d nuScenes info file with cam_instances['{camera}'] ({exc})"
        ) from None
    objects = []
    for i, b in enumerate(boxes):
        cls = NUSCENES_CLASSES.get(categories.get(int(b.get("bbox_label_3d", -1)), ""))
        if cls is None:
            continue
        x, y, z, l, h, w, yaw = (float(v) for v in b["bbox_3d"])
        objects.append(
            GtObject(
                name=f"{camera}:{i}",
                class_name=cls,
                instance_id=-1,
                bottom_centre=np.array([x, y + h / 2.0, z]),
                heading=_heading_cam(yaw),
                size_lwh=np.array([l, w, h]),
            )
        )
    return GroundTruth("nuscenes", "cam", tuple(objects), name, digest)


def read_ground_truth(
    path: str | Path, calib: str | Path | None = None, camera: str = DEFAULT_NUSCENES_CAMERA
) -> GroundTruth:
    """Read any supported ground truth, recognised by its content.

    Args:
        path: a synth ``*_gt.json``, a KITTI ``label_2`` ``.txt`` or a nuScenes info JSON.
        calib: KITTI calibration file (KITTI only; found beside the labels when None).
        camera: nuScenes camera whose boxes are used.

    Raises:
        InputError: missing, unreadable or unrecognised file.
    """
    p = Path(path)
    if p.suffix.lower() == ".txt":
        return read_kitti_ground_truth(p, Path(calib) if calib is not None else None)
    data = _read_bytes(p)
    digest = hashlib.sha256(data).hexdigest()
    doc = _json(data, p.name)
    if isinstance(doc, dict) and str(doc.get("format", "")).startswith("usdworld-synth-gt/"):
        if doc["format"] != SYNTH_FORMAT:
            raise InputError(
                f"{p.name}: ground-truth format {doc['format']!r}; this usdworld reads {SYNTH_FORMAT}"
            )
        return _synth(doc, p.name, digest)
    if isinstance(doc, dict) and "data_list" in doc:
        return _nuscenes(doc, p.name, digest, camera)
    raise InputError(
        f"{p.name}: not a recognised ground truth; pass a usdworld synth *_gt.json, a KITTI label_2 .txt or a nuScenes info JSON"
    )
