"""Read one sample of an mmdetection3d nuScenes info file as a view set
(``usdworld build --layout nuscenes --views INFO``).

The info file is the JSON copy of mmdetection3d's ``*.pkl`` (v1.x layout; pickles are
refused, as ``--camera INFO.json#CAM`` refuses them). Of the sample (the first, or the one
whose ``token`` is given):

* every camera under ``images`` is a view, in file order (CAM_FRONT first in nuScenes
  infos), ``cam2img`` its intrinsics. The world frame is the sample's ego frame (x
  forward, y left, z up, metres, ground z = 0) at the sample's (the LiDAR's) time. Each
  camera fired a few tens of milliseconds apart while the car moved (0.3 m at 9 m/s in
  the demo sample), and ``cam2ego`` is relative to the ego at the camera's own time; the
  pose used is therefore ``lidar2ego @ inverse(lidar2cam)``, where mmdetection3d's
  ``lidar2cam`` holds that motion. Without ``lidar2cam`` or ``lidar2ego``, ``cam2ego``;
* the photo is ``img_path``'s file name, found beside the info file;
* the detections are the camera's ``cam_instances`` 2D boxes, classes named by
  ``metainfo -> categories`` (label -1, an ignored class, is skipped). They are projections
  of the annotated 3D boxes clipped to the image, so they are amodal; each box's
  ``truncated`` (the share of the projected box outside the image, as KITTI's field) is
  measured from the same annotation's camera-frame box (``bbox_3d``: gravity centre,
  dims [l, h, w], yaw about the camera's y axis), its corners kept at least
  :data:`NEAR_PLANE_M` in front of the camera.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from usdworld.errors import InputError
from usdworld.io.camera_infos import info_matrix, is_info_document, is_pickle, parse_info_json
from usdworld.io.hashing import PathLike, read_input
from usdworld.io.images import read_image
from usdworld.io.types import Detection, Detections, InputFile
from usdworld.views.manifest import check_view_name
from usdworld.views.types import ViewSet, ViewSpec, check_pose

#: Depth below which a projected box corner is clamped when measuring truncation, metres.
NEAR_PLANE_M = 0.1


def _sample(doc: dict[str, Any], name: str, token: str | None) -> tuple[int, dict[str, Any]]:
    samples = doc.get("data_list")
    if not isinstance(samples, list) or not samples or not all(isinstance(s, dict) for s in samples):
        raise InputError(
            f"{name}: an mmdetection3d info file without samples (data_list is empty or not a list)"
        )
    if token is None:
        return 0, samples[0]
    for i, s in enumerate(samples):
        if s.get("token") == token:
            return i, s
    tokens = [str(s.get("token")) for s in samples[:5]]
    more = ", ..." if len(samples) > 5 else ""
    raise InputError(f"{name}: no sample with token {token!r}; its samples are {', '.join(tokens)}{more}")


def _pose(entry: dict[str, Any], sample: dict[str, Any], where: str) -> np.ndarray:
    """The camera's pose in the sample's ego frame (see the module docstring)."""
    lidar = sample.get("lidar_points")
    if "lidar2cam" in entry and isinstance(lidar, dict) and "lidar2ego" in lidar:
        ego_from_lidar = info_matrix(lidar["lidar2ego"], f"{where} -> lidar_points -> lidar2ego", ((4, 4),))
        cam_from_lidar = info_matrix(entry["lidar2cam"], f"{where} -> lidar2cam", ((4, 4),))
        return check_pose(
            ego_from_lidar @ np.linalg.inv(cam_from_lidar), f"{where} -> lidar2ego @ inverse(lidar2cam)"
        )
    return check_pose(info_matrix(entry["cam2ego"], f"{where} -> cam2ego", ((4, 4),)), f"{where} -> cam2ego")


def box_corners_cam(box_3d: np.ndarray) -> np.ndarray:
    """The 8 corners of a camera-frame nuScenes box.

    Args:
        box_3d: (7,) float64 ``[x, y, z, l, h, w, yaw]``: gravity centre (OpenCV camera
            frame, metres), length along the heading, height along y, width, and yaw about
            the camera's y axis (heading ``(cos yaw, 0, -sin yaw)``).

    Returns:
        (8, 3) float64 corners in the camera frame.
    """
    x, y, z, l, h, w, yaw = (float(v) for v in box_3d)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.float64)
    local = signs * np.array([l, h, w]) / 2.0
    c, s = np.cos(yaw), np.sin(yaw)
    rotation = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return local @ rotation.T + np.array([x, y, z])


def truncation(box_3d: np.ndarray, K: np.ndarray, width: int, height: int) -> float:
    """Share of a 3D box's projected 2D box that lies outside the image, in [0, 1].

    Args:
        box_3d: (7,) float64 camera-frame box (:func:`box_corners_cam`).
        K: (3, 3) float64 intrinsics.
        width: image width, pixels.
        height: image height, pixels.
    """
    corners = box_corners_cam(box_3d)
    corners[:, 2] = np.maximum(corners[:, 2], NEAR_PLANE_M)
    px = corners @ K.T
    px = px[:, :2] / px[:, 2:3]
    u0, v0 = px.min(axis=0)
    u1, v1 = px.max(axis=0)
    full = max(u1 - u0, 1e-9) * max(v1 - v0, 1e-9)
    inside = max(min(u1, width) - max(u0, 0.0), 0.0) * max(min(v1, height) - max(v0, 0.0), 0.0)
    return float(np.clip(1.0 - inside / full, 0.0, 1.0))


def info_detections(
    boxes: Any, categories: dict[int, str], K: np.ndarray, size: tuple[int, int], file: InputFile, where: str
) -> Detections:
    """A camera's 2D boxes (mmdetection3d ``cam_instances`` entries: ``bbox``, ``bbox_label``,
    optional ``bbox_3d``) as amodal detections, their truncation measured from the 3D box.

    Args:
        boxes: the entries, as parsed.
        categories: class name by ``bbox_label``; a label not listed (-1: ignored) is skipped.
        K: (3, 3) float64 the camera's intrinsics.
        size: (width, height) of the photo, pixels.
        file: the input file the detections name.
        where: the entries' place in the input, for errors.

    Raises:
        InputError: not a list, an entry without bbox or bbox_label, or an empty box.
    """
    if not isinstance(boxes, list):
        raise InputError(f"{where}: must be a list of boxes")
    items = []
    for i, b in enumerate(boxes):
        at = f"{where} -> [{i}]"
        if not isinstance(b, dict) or "bbox" not in b or "bbox_label" not in b:
            raise InputError(f"{at}: a camera box needs bbox and bbox_label")
        label = categories.get(int(b["bbox_label"]))
        if label is None:  # -1: an ignored class
            continue
        box = info_matrix([b["bbox"]], f"{at} -> bbox", ((1, 4),))[0]
        if not (box[2] > box[0] and box[3] > box[1]):
            raise InputError(f"{at} -> bbox: {box.tolist()} has non-positive size")
        truncated = 0.0
        if "bbox_3d" in b:
            truncated = truncation(info_matrix([b["bbox_3d"]], f"{at} -> bbox_3d", ((1, 7),))[0], K, *size)
        items.append(Detection(label=label, box_px=box, score=1.0, amodal=True, truncated=truncated))
    return Detections(items=tuple(items), file=file)


#: EXIF orientations that turn a JPEG by 90 degrees (OpenCV applies them when it decodes).
_QUARTER_TURNS = frozenset({5, 6, 7, 8})


def photo_size(path: Path) -> tuple[int, int]:
    """(width, height) of a photo as :func:`~usdworld.io.images.read_image` gives it, to
    measure the boxes' truncation against.

    Only the file's header is read (nothing is decoded: about 1 ms against 30 ms for a
    1600x900 JPEG); a JPEG whose EXIF orientation turns it by 90 degrees has the two
    swapped, as decoding it gives. A file whose header Pillow cannot read is read whole,
    so that its error is ``read_image``'s.

    Raises:
        InputError: the photo is missing or unreadable.
    """
    from PIL import Image  # imported where first needed, as in io/exif.py

    try:
        with Image.open(path) as image:
            width, height = image.size
            turned = image.format == "JPEG" and image.getexif().get(0x0112) in _QUARTER_TURNS
    except Exception:  # noqa: BLE001  (any failure: read_image says what is wrong with the file)
        image_rgb = read_image(path)
        return image_rgb.width, image_rgb.height
    if width <= 0 or height <= 0:
        image_rgb = read_image(path)
        return image_rgb.width, image_rgb.height
    return (height, width) if turned else (width, height)


def read_info_document(path: PathLike) -> tuple[dict[str, Any], InputFile]:
    """An mmdetection3d info JSON, parsed, and its file.

    Raises:
        InputError: unreadable, a pickle, not JSON, or not an info file (no ``data_list``).
    """
    data, file = read_input(path, "views")
    if is_pickle(data):
        raise InputError(
            f"{file.name}: a Python pickle (an mmdetection3d info file?); usdworld does not unpickle files (that "
            "can run code): convert it to JSON (numpy arrays as lists) and pass that instead"
        )
    doc = parse_info_json(data, file.name)
    if not is_info_document(doc):
        raise InputError(
            f"{file.name}: not an mmdetection3d info file (no data_list); --layout nuscenes reads one"
        )
    return doc, file


def read_nuscenes_views(path: PathLike, token: str | None = None) -> ViewSet:
    """The views of one nuScenes sample of an mmdetection3d info JSON (see the module docstring).

    Args:
        path: the info JSON.
        token: the sample's token, or None for the first sample.

    Returns:
        One view per camera, with its intrinsics, its ego-frame pose and its 2D boxes as detections.

    Raises:
        InputError: a pickle, not an info file, no such sample, a missing photo or a malformed matrix.
    """
    doc, file = read_info_document(path)
    index, sample = _sample(doc, file.name, token)
    meta = doc.get("metainfo") if isinstance(doc.get("metainfo"), dict) else {}
    categories = {int(v): str(k) for k, v in (meta.get("categories") or {}).items()}
    base = f"{file.name} -> data_list[{index}]"
    images = sample.get("images")
    if not isinstance(images, dict) or not images:
        raise InputError(f"{base}: no cameras (images is missing or empty)")
    instances = sample.get("cam_instances") or {}
    folder = Path(path).parent
    views = []
    for cam, entry in images.items():
        where = f"{base} -> images -> {cam}"
        if not isinstance(entry, dict) or not {"cam2img", "cam2ego", "img_path"} <= set(entry):
            raise InputError(f"{where}: a nuScenes camera needs cam2img, cam2ego and img_path")
        check_view_name(cam, where)
        K = info_matrix(entry["cam2img"], f"{where} -> cam2img", ((3, 3), (3, 4), (4, 4)))[:3, :3]
        pose = _pose(entry, sample, where)
        image = folder / Path(str(entry["img_path"])).name
        if not image.is_file():
            raise InputError(
                f"{where} -> img_path: {image.name} is not beside {file.name}; put the photos there"
            )
        dets_file = InputFile("detections", f"{file.name}#{cam}", file.sha256)
        dets = info_detections(
            instances.get(cam, []),
            categories,
            K,
            photo_size(image),
            dets_file,
            f"{base} -> cam_instances -> {cam}",
        )
        timestamp = float(entry["timestamp"]) if isinstance(entry.get("timestamp"), (int, float)) else None
        views.append(ViewSpec(cam, image, pose, K=K, timestamp=timestamp, detection_items=dets))
    return ViewSet(tuple(views), file, f"ego frame of sample {sample.get('token', index)}")
