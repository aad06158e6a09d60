"""Cameras of mmdetection3d info files (``--camera INFO.json#CAM_FRONT``).

An mmdetection3d info file (v1.x format: ``{"metainfo": {...}, "data_list": [sample, ...]}``)
describes every camera of a sample under ``data_list[0] -> images -> <CAM>``:

* ``cam2img``: the intrinsics, (3, 3) ``K`` or a (3|4, 4) projection whose left (3, 3) block is ``K``;
* ``cam2ego`` (nuScenes): the (4, 4) rigid camera -> ego transform, metres. The ego frame
  is Z up with its origin on the ground, so it also gives the camera's height and tilt.
  Without it (KITTI infos) only the intrinsics are read.

One file holds several cameras, so the camera is named after a ``#``: ``info.json#CAM_FRONT``.
Info files are pickles as mmdetection3d writes them; those are refused (unpickling can run
code) with a message saying how to convert one to JSON. A JSON copy may hold ``NaN`` (in box
fields of a nuScenes info, e.g. velocities), so it is read as ``usdworld evaluate --gt`` reads
it; the values taken for the camera must be finite.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from usdworld.errors import InputError
from usdworld.io.hashing import PathLike

#: Separates an info file from the camera it names: ``info.json#CAM_FRONT``.
CAMERA_SEPARATOR = "#"
#: Largest deviation from a rotation tolerated in ``cam2ego`` (it is stored as float32).
ROTATION_TOLERANCE = 1e-4


@dataclass(frozen=True)
class InfoCamera:
    """One camera of an info file.

    Attributes:
        K: (3, 3) float64 camera matrix (pixels).
        K_where: where ``K`` came from, for messages (``info.json -> ... -> cam2img``).
        up_cam: (3,) float64 unit ground normal (up) in the OpenCV camera frame, or None
            without ``cam2ego``.
        height_m: camera height above the ground (the ego frame's z = 0), or None.
        pose_where: where the pose came from (``... -> cam2ego``), or ``""``.
    """

    K: np.ndarray
    K_where: str
    up_cam: np.ndarray | None
    height_m: float | None
    pose_where: str


def split_camera_ref(path: PathLike) -> tuple[Path, str | None]:
    """``info.json#CAM_FRONT`` -> (``info.json``, ``CAM_FRONT``); any other path -> (path, None).

    A file whose own name holds ``#`` is taken as it is when it exists.
    """
    p = Path(path)
    text = str(path)
    if CAMERA_SEPARATOR not in p.name or p.exists():
        return p, None
    file, camera = text.rsplit(CAMERA_SEPARATOR, 1)
    return Path(file), camera


def is_pickle(data: bytes) -> bool:
    """True for a Python pickle (protocol 2 to 5), as mmdetection3d writes its ``*.pkl`` info files."""
    return len(data) > 2 and data[0] == 0x80 and 2 <= data[1] <= 5


def pickle_message(name: str) -> str:
    """The one-line refusal of a pickled info file."""
    return (
        f"{name}: a Python pickle (an mmdetection3d info file?); usdworld does not unpickle files (that can "
        "run code): convert it to JSON (numpy arrays as lists) and pass 'INFO.json#CAM_FRONT', or pass a "
        "Cityscapes, KITTI or plain camera file"
    )


def parse_info_json(data: bytes, name: str) -> Any:
    """The JSON document of an info file; ``NaN`` allowed, as ``usdworld evaluate --gt`` reads it.

    Raises:
        InputError: not UTF-8 JSON.
    """
    try:
        return json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{name}: not valid JSON ({exc})") from None


def is_info_document(doc: Any) -> bool:
    """True for an mmdetection3d info document (a dict with ``data_list``)."""
    return isinstance(doc, dict) and "data_list" in doc


def _images(doc: dict[str, Any], name: str) -> dict[str, Any]:
    samples = doc.get("data_list")
    if not isinstance(samples, list) or not samples or not isinstance(samples[0], dict):
        raise InputError(
            f"{name}: an mmdetection3d info file without samples (data_list is empty or not a list)"
        )
    images = samples[0].get("images")
    if not isinstance(images, dict) or not any(
        isinstance(v, dict) and "cam2img" in v for v in images.values()
    ):
        raise InputError(
            f"{name} -> data_list[0]: an mmdetection3d info sample without cameras (images -> cam2img)"
        )
    return images


def cameras_of(doc: dict[str, Any], name: str) -> list[str]:
    """Names of the cameras with intrinsics in the first sample, in file order.

    Raises:
        InputError: no sample or no camera.
    """
    return [k for k, v in _images(doc, name).items() if isinstance(v, dict) and "cam2img" in v]


def info_without_camera_message(doc: dict[str, Any], name: str) -> str:
    """The one-line message for an info file passed without ``#CAMERA``: what it is, how to pick one."""
    meta = doc.get("metainfo") if isinstance(doc.get("metainfo"), dict) else {}
    dataset = " ".join(str(meta[k]) for k in ("dataset", "version") if k in meta)
    samples = len(doc["data_list"]) if isinstance(doc.get("data_list"), list) else 0
    cameras = cameras_of(doc, name)
    kind = f"an mmdetection3d {dataset} info file" if dataset else "an mmdetection3d info file"
    first = "CAM_FRONT" if "CAM_FRONT" in cameras else cameras[0]
    return (
        f"{name}: {kind} ({samples} sample(s), cameras {', '.join(cameras)}); "
        f"name one camera of its first sample: --camera '{name}{CAMERA_SEPARATOR}{first}'"
    )


def info_matrix(value: Any, where: str, shapes: tuple[tuple[int, int], ...]) -> np.ndarray:
    """``value`` as a finite float64 matrix of one of ``shapes``; InputError naming ``where`` otherwise."""
    try:
        m = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{where}: must be a matrix of numbers") from None
    if m.shape not in shapes:
        want = " or ".join(f"{r}x{c}" for r, c in shapes)
        raise InputError(f"{where}: must be {want}, got shape {list(m.shape)}")
    if not np.all(np.isfinite(m)):
        raise InputError(f"{where}: holds non-finite numbers (NaN or infinity); fix the info file")
    return m


def read_info_camera(doc: dict[str, Any], name: str, camera: str) -> InfoCamera:
    """One camera of an info document: ``K``, and the ground below it when ``cam2ego`` is there.

    Args:
        doc: the info document (:func:`parse_info_json`).
        name: the file name, for messages.
        camera: the camera's key under ``images`` (``CAM_FRONT``, ``CAM2`` ...).

    Raises:
        InputError: no such camera (the message lists them), or a malformed matrix.
    """
    images = _images(doc, name)
    cameras = cameras_of(doc, name)
    if camera not in cameras:
        raise InputError(
            f"{name}: no camera {camera!r} in its first sample; the cameras are {', '.join(cameras)}"
        )
    base = f"{name} -> data_list[0] -> images -> {camera}"
    entry = images[camera]
    projection = info_matrix(entry["cam2img"], f"{base} -> cam2img", ((3, 3), (3, 4), (4, 4)))
    K = projection[:3, :3].copy()
    if "cam2ego" not in entry:
        return InfoCamera(K, f"{base} -> cam2img", None, None, "")
    pose_where = f"{base} -> cam2ego"
    ego_from_cam = info_matrix(entry["cam2ego"], pose_where, ((4, 4),))
    rotation = ego_from_cam[:3, :3]
    if (
        not np.allclose(rotation.T @ rotation, np.eye(3), atol=ROTATION_TOLERANCE)
        or np.linalg.det(rotation) <= 0
    ):
        raise InputError(f"{pose_where}: the upper-left 3x3 block is not a rotation; fix the info file")
    # ego frame: Z up, ground z = 0. Up in the camera frame is R^T e_z; the camera is t_z above the ground.
    up_cam = rotation.T @ np.array([0.0, 0.0, 1.0])
    return InfoCamera(
        K, f"{base} -> cam2img", up_cam / np.linalg.norm(up_cam), float(ego_from_cam[2, 3]), pose_where
    )
