"""Geometric depth of the ground plane seen by a known camera (no network).

Every pixel whose ray goes below the horizon gets the depth (along the optical axis)
of the point where the ray meets the ground plane z = 0; pixels at or above the
horizon, and ground points farther than ``max_depth_m``, are invalid. This is exact
on a flat road and meaningless on anything standing on it: it is the reference the
other backends are aligned to, and the ``ground`` backend used when no network is.
"""

from __future__ import annotations

import numpy as np

from usdworld.errors import CalibrationError
from usdworld.geometry.camera import PinholeCamera
from usdworld.perception.depth.base import DepthPrediction, check_camera_matches, check_rgb

#: Ground points farther than this (metres) are invalid: near the horizon a fraction
#: of a pixel changes the depth by tens of metres.
DEFAULT_MAX_DEPTH_M = 250.0


def ground_plane_depth(
    camera: PinholeCamera, max_depth_m: float = DEFAULT_MAX_DEPTH_M
) -> tuple[np.ndarray, np.ndarray]:
    """Depth of the ground plane at every pixel centre.

    Args:
        camera: the photo's camera (size, intrinsics, height and attitude).
        max_depth_m: farthest valid depth, metres (> 0).

    Returns:
        depth_m: (H, W) float32 depth along the optical axis, 0 where invalid.
        valid: (H, W) bool, True below the horizon and within ``max_depth_m``.

    Example:
        >>> import numpy as np
        >>> cam = PinholeCamera(4, 4, np.array([[2.0, 0, 2], [0, 2.0, 2], [0, 0, 1]]), height_m=1.0)
        >>> d, ok = ground_plane_depth(cam)
        >>> round(float(d[3, 0]), 4)  # row 3: pixel centre v = 3.5, 1.5 px below the horizon: f*h/1.5
        1.3333
        >>> bool(ok[1, 0])  # row 1 (v = 1.5) is above the horizon (cy = 2)
        False
    """
    if not (np.isfinite(max_depth_m) and max_depth_m > 0):
        raise CalibrationError(f"ground depth: max_depth_m must be > 0, got {max_depth_m}")
    v_px, u_px = np.mgrid[0 : camera.height, 0 : camera.width].astype(np.float64)
    points_px = np.column_stack([u_px.ravel() + 0.5, v_px.ravel() + 0.5])
    _, depth = camera.ground_points(points_px)
    depth = depth.reshape(camera.height, camera.width)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(depth) & (depth > 0) & (depth <= max_depth_m)
    depth_m = np.where(valid, depth, 0.0).astype(np.float32)
    return depth_m, valid


class GroundDepthBackend:
    """The ``ground`` backend: ground-plane depth from the camera, ignores the pixels.

    Args:
        max_depth_m: farthest valid depth in metres.
    """

    name = "ground"

    def __init__(self, max_depth_m: float = DEFAULT_MAX_DEPTH_M) -> None:
        self.max_depth_m = float(max_depth_m)

    def predict(self, rgb: np.ndarray, camera: PinholeCamera | None = None) -> DepthPrediction:
        """Ground-plane depth for the photo's camera.

        Args:
            rgb: (H, W, 3) uint8 RGB image (only its size is used).
            camera: the photo's camera; required.

        Raises:
            CalibrationError: no camera given.
            InputError: camera and image sizes differ.
        """
        rgb = check_rgb(rgb, self.name)
        if camera is None:
            raise CalibrationError(
                "ground depth needs the camera (intrinsics, height and pitch); none is known"
            )
        check_camera_matches(camera, rgb, self.name)
        depth_m, valid = ground_plane_depth(camera, self.max_depth_m)
        return DepthPrediction(
            depth=depth_m,
            valid=valid,
            name=self.name,
            kind="metric",
            scaling=f"ground plane z=0 seen from {camera.height_m:.3f} m, rays below the horizon",
        )
