"""The views of a camera rig, as the readers hand them on (io level: no pxr, no layout).

The world frame of a rig is right-handed, Z up, metres, with the ground at z = 0 (for a
nuScenes sample, the sample's ego frame: x forward, y left). Each view's camera pose is
known: ``world_from_cam`` takes OpenCV camera points (x right, y down, z forward) to the world.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from usdworld.errors import InputError
from usdworld.io.types import Detections, InputFile

#: Largest deviation from a rotation tolerated in a pose (info files store float32).
ROTATION_TOLERANCE = 1e-4


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.setflags(write=False)
    return a


def check_pose(world_from_cam: np.ndarray, where: str) -> np.ndarray:
    """Validate a camera pose: a finite (4, 4) rigid transform with the camera above the ground.

    Args:
        world_from_cam: (4, 4) float64, OpenCV camera -> world (Z up, ground z = 0), metres.
        where: what the message names (``views.json -> views -> [0] -> camera_to_world``).

    Returns:
        The pose as a read-only (4, 4) float64 array.

    Raises:
        InputError: not 4x4, non-finite, not a rotation, a last row other than (0, 0, 0, 1),
            or the camera at or below the ground.
    """
    T = np.asarray(world_from_cam, dtype=np.float64)
    if T.shape != (4, 4):
        raise InputError(f"{where}: must be a 4x4 matrix, got shape {list(T.shape)}")
    if not np.all(np.isfinite(T)):
        raise InputError(f"{where}: holds non-finite numbers (NaN or infinity)")
    if not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
        raise InputError(f"{where}: the last row must be [0, 0, 0, 1], got {T[3].tolist()}")
    R = T[:3, :3]
    if not np.allclose(R.T @ R, np.eye(3), atol=ROTATION_TOLERANCE) or np.linalg.det(R) <= 0:
        raise InputError(f"{where}: the upper-left 3x3 block is not a rotation")
    if not T[2, 3] > 0:
        raise InputError(
            f"{where}: the camera is at z = {T[2, 3]:g} m; the world is Z up with the ground at z = 0, "
            "so a camera must be above it"
        )
    return _frozen(T)


@dataclass(frozen=True)
class ViewSpec:
    """One view of a rig: its photo, intrinsics, known pose and image evidence.

    Attributes:
        name: the view's name, a valid USD prim name (``CAM_FRONT``); its camera becomes
            ``/World/Cameras/<name>``.
        image: the photo.
        world_from_cam: (4, 4) float64 pose, OpenCV camera -> world, metres.
        K: (3, 3) float64 intrinsics, or None when ``camera`` gives them.
        camera: a camera file the single-image build accepts (only its intrinsics are used:
            the pose gives height, pitch and roll), or None when ``K`` is given.
        timestamp: seconds, or None.
        labels: Cityscapes labelIds PNG, or None.
        instances: Cityscapes instanceIds PNG, or None.
        polygons: Cityscapes polygons JSON, or None.
        detections: KITTI label_2 text or a detections JSON, or None.
        detection_items: detections already read (a nuScenes info's 2D boxes), or None.
    """

    name: str
    image: Path
    world_from_cam: np.ndarray
    K: np.ndarray | None = None
    camera: Path | None = None
    timestamp: float | None = None
    labels: Path | None = None
    instances: Path | None = None
    polygons: Path | None = None
    detections: Path | None = None
    detection_items: Detections | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "world_from_cam", _frozen(self.world_from_cam))
        if self.K is not None:
            object.__setattr__(self, "K", _frozen(self.K))
        if (self.K is None) == (self.camera is None):
            raise ValueError(f"view {self.name}: give exactly one of K and camera")
        if self.detections is not None and self.detection_items is not None:
            raise ValueError(f"view {self.name}: give detections as a file or as items, not both")


@dataclass(frozen=True)
class ViewSet:
    """The views of one rig, in order (the first view's camera is the world's SourceCamera).

    Attributes:
        views: the views, at least one, with distinct names.
        source: the manifest or info file the views came from.
        frame: what the world frame is (``ego frame of sample <token>``, ``manifest world``).
    """

    views: tuple[ViewSpec, ...]
    source: InputFile
    frame: str

    def __post_init__(self) -> None:
        if not self.views:
            raise ValueError("a view set needs at least one view")
        names = [v.name for v in self.views]
        if len(set(names)) != len(names):
            raise ValueError(f"view names must be distinct, got {names}")
