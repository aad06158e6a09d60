"""Read one sample of the official nuScenes dataset layout through ``nuscenes-devkit``
(``usdworld build --layout nuscenes --dataroot DIR [--sample TOKEN]``).

The devkit (the ``nuscenes`` extra, installed without its numpy<2 pin: :data:`EXTRA_HINT`) loads the
tables of ``DIR/<version>/`` (``scene``, ``sample``, ``sample_data``, ``calibrated_sensor``,
``ego_pose``, ``sensor``, ``log``, ``category``, ``instance``, ``sample_annotation``,
``attribute``, ``visibility``, ``map``); the version is the one folder of ``DIR`` that holds
``sample.json`` and the sample (when several do, the first in name order that has it).
The view set is what :mod:`usdworld.views.nuscenes` makes of mmdetection3d's info file
for the same sample, computed from the tables:

* every camera of the sample (its key-frame ``sample_data``) is a view, CAM_FRONT first
  (:data:`CAMERA_ORDER`), ``camera_intrinsic`` its K, ``DIR/<filename>`` its photo, its
  timestamp in seconds;
* the world frame is the ego frame at the sample's LIDAR_TOP time (the sample's time; x
  forward, y left, z up, ground z = 0); each camera's pose chains its calibration with the
  ego pose at its own time: ``inverse(global_from_ego(lidar)) @ global_from_ego(camera) @
  ego_from_camera``, which is what mmdetection3d's ``lidar2cam`` holds;
* the detections are the sample's annotated 3D boxes (``get_sample_data`` in the camera
  frame), projected: the box of the corners in front of the camera, clipped to the image
  (amodal), as mmdetection3d's ``cam_instances`` (which clips the corners' convex hull, the
  same box unless the hull leaves the image across a corner), with its truncation measured
  as :func:`usdworld.views.nuscenes.truncation` does; classes by mmdetection3d's mapping
  of the nuScenes categories (:data:`CATEGORY_CLASSES`), others skipped.
"""

from __future__ import annotations

import contextlib
import io
import math
from pathlib import Path
from typing import Any

import numpy as np

from usdworld.errors import InputError
from usdworld.io.types import Detections, InputFile
from usdworld.views.nuscenes import info_detections, photo_size
from usdworld.views.types import ViewSet, ViewSpec, check_pose

#: The nuScenes cameras, in the order mmdetection3d's info files list them.
CAMERA_ORDER = (
    "CAM_FRONT",
    "CAM_FRONT_RIGHT",
    "CAM_FRONT_LEFT",
    "CAM_BACK",
    "CAM_BACK_LEFT",
    "CAM_BACK_RIGHT",
)
#: mmdetection3d's ``NuScenesDataset`` class of each nuScenes category (its ``NameMapping``).
CATEGORY_CLASSES = {
    "movable_object.barrier": "barrier",
    "vehicle.bicycle": "bicycle",
    "vehicle.bus.bendy": "bus",
    "vehicle.bus.rigid": "bus",
    "vehicle.car": "car",
    "vehicle.construction": "construction_vehicle",
    "vehicle.motorcycle": "motorcycle",
    "human.pedestrian.adult": "pedestrian",
    "human.pedestrian.child": "pedestrian",
    "human.pedestrian.construction_worker": "pedestrian",
    "human.pedestrian.police_officer": "pedestrian",
    "movable_object.trafficcone": "traffic_cone",
    "vehicle.trailer": "trailer",
    "vehicle.truck": "truck",
}
#: How to install the devkit when it is missing: the nuscenes extra without its numpy<2 pin.
EXTRA_HINT = (
    'the nuscenes extra: pip install --no-deps "nuscenes-devkit==1.2.0" && '
    "pip install pyquaternion matplotlib scikit-learn cachetools (as tools/setup_test_env.sh)"
)


def _devkit() -> Any:
    try:
        from nuscenes.nuscenes import NuScenes
    except ImportError as exc:
        raise InputError(
            f"--dataroot: reading the nuScenes dataset layout needs nuscenes-devkit ({exc.name or exc} "
            f"is missing): {EXTRA_HINT}"
        ) from None
    return NuScenes


def _version(dataroot: Path, token: str | None) -> str:
    import json

    if not dataroot.is_dir():
        raise InputError(f"--dataroot {dataroot}: no such folder; pass the nuScenes root (holding v1.0-*/)")
    versions = sorted(p.name for p in dataroot.iterdir() if (p / "sample.json").is_file())
    if not versions:
        raise InputError(
            f"--dataroot {dataroot}: no <version>/sample.json in it (e.g. v1.0-mini/); pass the nuScenes root"
        )
    if token is None or len(versions) == 1:
        return versions[0]
    for version in versions:
        try:
            samples = json.loads((dataroot / version / "sample.json").read_text())
        except (OSError, ValueError):
            continue
        if any(isinstance(s, dict) and s.get("token") == token for s in samples):
            return version
    return versions[0]  # the devkit's lookup then names the missing token


def rotation_from_quaternion(q: Any) -> np.ndarray:
    """(3, 3) float64 rotation of a unit quaternion (w, x, y, z), as nuScenes stores them (normalised first).

    Example:
        >>> np.round(rotation_from_quaternion([0.0, 0.0, 0.0, 1.0]), 12).tolist()  # 180 degrees about z
        [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    w, x, y, z = np.asarray(q, dtype=np.float64) / np.linalg.norm(np.asarray(q, dtype=np.float64))
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _matrix(record: dict[str, Any]) -> np.ndarray:
    """(4, 4) float64 transform of a devkit record's ``translation`` and ``rotation`` (w, x, y, z)."""
    T = np.eye(4)
    T[:3, :3] = rotation_from_quaternion(record["rotation"])
    T[:3, 3] = np.asarray(record["translation"], dtype=np.float64)
    return T


def _camera_box(box: Any, K: np.ndarray, size: tuple[int, int]) -> dict[str, Any] | None:
    """An info-file style camera box (``bbox``, ``bbox_3d``) of a camera-frame devkit Box; None when unseen."""
    corners = np.asarray(box.corners(), dtype=np.float64).T  # (8, 3)
    front = corners[corners[:, 2] > 0]
    if not len(front):
        return None
    px = front @ K.T
    px = px[:, :2] / px[:, 2:3]
    width, height = size
    u0, v0 = max(float(px[:, 0].min()), 0.0), max(float(px[:, 1].min()), 0.0)
    u1, v1 = min(float(px[:, 0].max()), float(width)), min(float(px[:, 1].max()), float(height))
    if not (u1 > u0 and v1 > v0):
        return None
    heading = box.orientation.rotation_matrix @ np.array([1.0, 0.0, 0.0])
    w, l, h = (float(v) for v in box.wlh)
    yaw = math.atan2(-float(heading[2]), float(heading[0]))
    return {"bbox": [u0, v0, u1, v1], "bbox_3d": [*map(float, box.center), l, h, w, yaw]}


def load_devkit(dataroot: Path, token: str | None) -> tuple[str, Any]:
    """(version, ``NuScenes``) of a dataroot: the tables of the version that holds ``token``.

    Raises:
        InputError: the devkit is missing, or it cannot load the tables.
    """
    NuScenes = _devkit()
    version = _version(dataroot, token)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            return version, NuScenes(version=version, dataroot=str(dataroot), verbose=False)
    except (AssertionError, KeyError, OSError, ValueError, TypeError, IndexError) as exc:
        raise InputError(
            f"--dataroot {dataroot}: nuscenes-devkit cannot load {version}/ ({type(exc).__name__}: {exc})"
        ) from None


def read_devkit_views(dataroot: Path, token: str | None = None) -> ViewSet:
    """The views of one sample of a nuScenes dataroot (see the module docstring).

    Args:
        dataroot: the nuScenes root (holding ``v1.0-*/`` and ``samples/``).
        token: the sample's token, or None for the first sample.

    Returns:
        One view per camera, with its intrinsics, its pose in the sample's ego frame and its boxes.

    Raises:
        InputError: the devkit is missing, no tables, no such sample, or a missing photo.
    """
    dataroot = Path(dataroot)
    version, nusc = load_devkit(dataroot, token)  # first: it says how to install a missing devkit
    from nuscenes.utils.geometry_utils import BoxVisibility
    if token is None:
        if not nusc.sample:
            raise InputError(f"--dataroot {dataroot}: {version}/sample.json holds no sample")
        sample = nusc.sample[0]
    else:
        try:
            sample = nusc.get("sample", token)
        except KeyError:
            tokens = [s["token"] for s in nusc.sample[:5]]
            more = ", ..." if len(nusc.sample) > 5 else ""
            raise InputError(
                f"--sample {token}: no such sample in {version}/; its samples are {', '.join(tokens)}{more}"
            ) from None
    data = sample["data"]
    reference = data.get("LIDAR_TOP") or next(iter(data.values()))
    reference_pose = nusc.get("ego_pose", nusc.get("sample_data", reference)["ego_pose_token"])
    ego_from_global = np.linalg.inv(_matrix(reference_pose))
    cameras = [c for c in data if nusc.get("sample_data", data[c])["sensor_modality"] == "camera"]
    cameras.sort(key=lambda c: (CAMERA_ORDER.index(c) if c in CAMERA_ORDER else len(CAMERA_ORDER), c))
    if not cameras:
        raise InputError(f"--sample {sample['token']}: the sample has no camera")
    digest = _tables_digest(dataroot / version)
    source = InputFile("views", f"{version}/sample.json#{sample['token']}", digest)
    views = []
    for cam in cameras:
        sd = nusc.get("sample_data", data[cam])
        image = dataroot / sd["filename"]
        if not image.is_file():
            raise InputError(
                f"--dataroot {dataroot}: the photo {sd['filename']} of {cam} is missing; put it there"
            )
        cs = nusc.get("calibrated_sensor", sd["calibrated_sensor_token"])
        K = np.asarray(cs["camera_intrinsic"], dtype=np.float64)
        if K.shape != (3, 3):
            raise InputError(
                f"{version}/calibrated_sensor.json -> {cs['token']}: camera_intrinsic must be 3x3"
            )
        pose = ego_from_global @ _matrix(nusc.get("ego_pose", sd["ego_pose_token"])) @ _matrix(cs)
        pose = check_pose(pose, f"{version} -> {cam} pose")
        size = photo_size(image)
        _, boxes, _ = nusc.get_sample_data(sd["token"], box_vis_level=BoxVisibility.NONE)
        labels = sorted(set(CATEGORY_CLASSES.values()))
        instances = []
        for box in boxes:
            cls = CATEGORY_CLASSES.get(box.name)
            seen = _camera_box(box, K, size) if cls is not None else None
            if seen is not None:
                instances.append({**seen, "bbox_label": labels.index(str(cls))})
        dets: Detections = info_detections(
            instances,
            dict(enumerate(labels)),
            K,
            size,
            InputFile("detections", f"{version}/sample_annotation.json#{cam}", source.sha256),
            f"{version} -> {cam}",
        )
        seconds = float(sd["timestamp"]) * 1e-6  # nuScenes timestamps are microseconds
        views.append(ViewSpec(cam, image, pose, K=K, timestamp=seconds, detection_items=dets))
    return ViewSet(tuple(views), source, f"ego frame of sample {sample['token']}")


def _tables_digest(folder: Path) -> str:
    """SHA-256 over the version folder's table files (names and bytes)."""
    import hashlib

    h = hashlib.sha256()
    for path in sorted(folder.glob("*.json")):
        h.update(path.name.encode() + b"\0" + hashlib.sha256(path.read_bytes()).hexdigest().encode() + b"\0")
    return h.hexdigest()
