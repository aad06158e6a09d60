"""Each view's known camera, and where its ground frame lies in the rig's world (layout math).

A view is built as a single image is, in its own *ground frame*: origin on the ground
below the camera, X along the camera's heading, Z up (``usdworld.frames``). Its known pose
``world_from_cam`` fixes the camera's height, pitch and roll above the ground; what is
left is a turn about Z and a shift on the ground, ``world_from_ground``, that takes the
view's placements into the rig's world.
"""

from __future__ import annotations

import math

import numpy as np

from usdworld.errors import CalibrationError
from usdworld.io.camera_files import pose_from_ground_plane

#: Largest mismatch tolerated between the pose and the view camera's rotation after the turn about Z.
ROTATION_TOLERANCE = 1e-6


def ground_pose(world_from_cam: np.ndarray) -> tuple[float, float, float]:
    """The camera's height, pitch and roll above the world's ground plane z = 0.

    Args:
        world_from_cam: (4, 4) float64 pose, OpenCV camera -> world (Z up), metres.

    Returns:
        (height_m, pitch, roll): metres and radians (pitch positive looking down), as
        :class:`~usdworld.geometry.camera.PinholeCamera` takes them.

    Example:
        >>> T = np.eye(4); T[:3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]; T[2, 3] = 1.5
        >>> [round(v, 6) for v in ground_pose(T)]
        [1.5, 0.0, 0.0]
    """
    T = np.asarray(world_from_cam, dtype=np.float64)
    up_cam = T[:3, :3].T @ np.array([0.0, 0.0, 1.0])
    return pose_from_ground_plane(up_cam, float(T[2, 3]))


def world_from_ground(world_from_cam: np.ndarray, ground_from_cam: np.ndarray) -> np.ndarray:
    """The turn about Z and ground shift taking a view's ground frame into the world.

    Args:
        world_from_cam: (4, 4) float64 the camera's known pose in the world.
        ground_from_cam: (4, 4) float64 the same camera in its view's ground frame (the
            view's :meth:`PinholeCamera.world_from_cam`, same height, pitch and roll).

    Returns:
        (4, 4) float64 ``world_from_ground``: a rotation about Z and a translation with z = 0,
        so that ``world_from_ground @ ground_from_cam == world_from_cam``.

    Raises:
        CalibrationError: the two poses differ by more than a turn about Z (their heights,
            pitches or rolls disagree).
    """
    A = np.asarray(world_from_cam, dtype=np.float64)
    B = np.asarray(ground_from_cam, dtype=np.float64)
    R = A[:3, :3] @ B[:3, :3].T
    psi = math.atan2(R[1, 0], R[0, 0])
    c, s = math.cos(psi), math.sin(psi)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    t = A[:3, 3] - Rz @ B[:3, 3]
    if not np.allclose(R, Rz, atol=ROTATION_TOLERANCE) or abs(t[2]) > ROTATION_TOLERANCE:
        raise CalibrationError(
            "the view camera's height, pitch or roll differs from its pose by more than a turn about Z; "
            "this is a bug in the view set-up, please report it"
        )
    out = np.eye(4)
    out[:3, :3] = Rz
    out[:2, 3] = t[:2]
    return out


def heading(world_from_ground_: np.ndarray) -> float:
    """The turn about Z of a ``world_from_ground`` transform, radians."""
    return math.atan2(world_from_ground_[1, 0], world_from_ground_[0, 0])
