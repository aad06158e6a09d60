"""Pinhole camera above a flat ground plane.

The world frame is Z up, X forward, Y left, metres, with its origin on the ground
straight below the camera centre (see :mod:`usdworld.frames`). The camera sits at
``(0, 0, height_m)`` and is rotated by ISO 8855 pitch (positive looks down), roll and
yaw.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from usdworld.errors import CalibrationError
from usdworld.frames import WORLD_FROM_CAM_LEVEL, rotation_world_from_vehicle


@dataclass(frozen=True)
class PinholeCamera:
    """Intrinsics and pose of the source camera.

    Attributes:
        width: image width in pixels.
        height: image height in pixels.
        K: (3, 3) float64 camera matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.
        height_m: camera centre height above the ground, metres (> 0).
        pitch: radians, positive looking down.
        roll: radians.
        yaw: radians, positive turned left.
    """

    width: int
    height: int
    K: np.ndarray
    height_m: float
    pitch: float = 0.0
    roll: float = 0.0
    yaw: float = 0.0
    _world_from_cam: np.ndarray = field(init=False, repr=False, compare=False)
    _cam_from_px: np.ndarray = field(init=False, repr=False, compare=False)
    _center_world: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        K = np.asarray(self.K, dtype=np.float64)
        if K.shape != (3, 3) or not np.all(np.isfinite(K)):
            raise CalibrationError(f"camera matrix K must be a finite 3x3 matrix, got shape {K.shape}")
        if K[0, 0] <= 0 or K[1, 1] <= 0:
            raise CalibrationError(f"focal lengths must be > 0, got fx={K[0, 0]}, fy={K[1, 1]}")
        if self.width <= 0 or self.height <= 0:
            raise CalibrationError(f"image size must be positive, got {self.width}x{self.height}")
        if not (np.isfinite(self.height_m) and self.height_m > 0):
            raise CalibrationError(f"camera height must be > 0 m, got {self.height_m}")
        K = K.copy()
        K.setflags(write=False)
        object.__setattr__(self, "K", K)
        R = rotation_world_from_vehicle(self.pitch, self.roll, self.yaw) @ WORLD_FROM_CAM_LEVEL
        R.setflags(write=False)
        object.__setattr__(self, "_world_from_cam", R)
        K_inv = np.linalg.inv(K)  # once: rays are cast for every object several times
        K_inv.setflags(write=False)
        object.__setattr__(self, "_cam_from_px", K_inv)
        center = np.array([0.0, 0.0, self.height_m])
        center.setflags(write=False)
        object.__setattr__(self, "_center_world", center)

    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def cx(self) -> float:
        return float(self.K[0, 2])

    @property
    def cy(self) -> float:
        return float(self.K[1, 2])

    @property
    def rotation_world_from_cam(self) -> np.ndarray:
        """(3, 3) float64 rotation taking camera axes to world axes."""
        return self._world_from_cam

    @property
    def center_world(self) -> np.ndarray:
        """(3,) float64 camera centre in the world frame (read-only)."""
        return self._center_world

    def world_from_cam(self) -> np.ndarray:
        """(4, 4) float64 rigid transform taking camera points to world points."""
        T = np.eye(4)
        T[:3, :3] = self._world_from_cam
        T[:3, 3] = self.center_world
        return T

    def cam_from_world_points(self, points_world: np.ndarray) -> np.ndarray:
        """Transform world points into the camera frame.

        Args:
            points_world: (N, 3) float64 world points.

        Returns:
            (N, 3) float64 camera-frame points.
        """
        p = np.asarray(points_world, dtype=np.float64).reshape(-1, 3)
        return (p - self.center_world) @ self._world_from_cam

    def project(self, points_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project world points to pixels.

        Args:
            points_world: (N, 3) float64 world points.

        Returns:
            points_px: (N, 2) float64 pixel coordinates (u, v); NaN behind the camera.
            depth: (N,) float64 depth along the optical axis, metres.
        """
        p_cam = self.cam_from_world_points(points_world)
        depth = p_cam[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uvw = p_cam @ self.K.T
            px = uvw[:, :2] / uvw[:, 2:3]
        px[depth <= 1e-9] = np.nan
        return px, depth

    def project_stacked(self, points_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project stacks of world points, each stack as :meth:`project` would, bit for bit.

        The transforms are applied as one stacked matrix product per stack (the same
        shape of product :meth:`project` does for one stack), so every pixel has the
        last bits it would have from :meth:`project` on its own stack.

        Args:
            points_world: (S, N, 3) float64 world points, S stacks of N.

        Returns:
            points_px: (S, N, 2) float64 pixel coordinates (u, v); NaN behind the camera.
            depth: (S, N) float64 depth along the optical axis, metres.
        """
        p = np.asarray(points_world, dtype=np.float64)
        if p.ndim != 3 or p.shape[2] != 3:
            raise ValueError(f"points_world must have shape (S, N, 3), got {p.shape}")
        p_cam = (p - self.center_world) @ self._world_from_cam
        depth = p_cam[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uvw = p_cam @ self.K.T
            px = uvw[..., :2] / uvw[..., 2:3]
        px[depth <= 1e-9] = np.nan
        return px, depth

    def rays_world(self, points_px: np.ndarray) -> np.ndarray:
        """Viewing-ray directions of pixels.

        Args:
            points_px: (N, 2) float64 pixel coordinates.

        Returns:
            (N, 3) float64 world directions scaled so that their camera-z (depth) is 1.
        """
        px = np.asarray(points_px, dtype=np.float64).reshape(-1, 2)
        homog = np.empty((len(px), 3))  # (u, v, 1), as np.column_stack makes it
        homog[:, :2] = px
        homog[:, 2] = 1.0
        rays_cam = homog @ self._cam_from_px.T
        return rays_cam @ self._world_from_cam.T

    def px_from_ground(self) -> np.ndarray:
        """(3, 3) float64 homography taking ground points (x, y, 1) to pixels (u, v, 1) up to scale."""
        R_cam_from_world = self._world_from_cam.T
        t = -R_cam_from_world @ self.center_world
        return self.K @ np.column_stack([R_cam_from_world[:, 0], R_cam_from_world[:, 1], t])

    def horizon_v(self, u: float | None = None) -> float:
        """Image row of the horizon (vanishing line of the ground) at column ``u`` (default: centre)."""
        u = self.cx if u is None else u
        # Horizon: pixels whose ray is horizontal, i.e. world-z component 0.
        r = self._cam_from_px.T @ self._world_from_cam.T[:, 2]  # line coefficients a u + b v + c = 0
        if abs(r[1]) < 1e-12:
            raise CalibrationError("the horizon is vertical in the image (camera rolled by 90 degrees)")
        return float(-(r[0] * u + r[2]) / r[1])

    def ground_points(self, points_px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Intersect pixel rays with the ground plane z = 0.

        Args:
            points_px: (N, 2) float64 pixel coordinates.

        Returns:
            points_ground: (N, 2) float64 ground points; NaN where the ray misses the ground.
            depth: (N,) float64 depth of the ground point along the optical axis; NaN likewise.
        """
        rays = self.rays_world(points_px)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -self.height_m / rays[:, 2]
        t[~(t > 0)] = np.nan
        ground = rays[:, :2] * t[:, None]
        return ground, t

    def vanishing_point(self, direction_world: np.ndarray) -> tuple[float, float] | None:
        """Image point where lines along a world direction meet; None when it points backwards.

        Args:
            direction_world: (3,) float64 direction.

        Returns:
            (u, v) pixels, or None when the direction is parallel to the image plane or
            points behind the camera.
        """
        d_cam = self._world_from_cam.T @ np.asarray(direction_world, dtype=np.float64)
        if d_cam[2] <= 1e-6:
            return None
        p = self.K @ (d_cam / d_cam[2])
        return (float(p[0]), float(p[1]))

    def replace(self, **changes: object) -> "PinholeCamera":
        """A copy with some fields changed."""
        values = {
            "width": self.width,
            "height": self.height,
            "K": self.K,
            "height_m": self.height_m,
            "pitch": self.pitch,
            "roll": self.roll,
            "yaw": self.yaw,
        }
        values.update(changes)
        return PinholeCamera(**values)  # type: ignore[arg-type]


def intrinsics_from_fov(width: int, height: int, hfov_deg: float) -> np.ndarray:
    """Camera matrix with square pixels, the principal point at the image centre and a horizontal FOV.

    Args:
        width: image width in pixels.
        height: image height in pixels.
        hfov_deg: horizontal field of view in degrees, in (0, 180).

    Returns:
        (3, 3) float64 camera matrix.
    """
    if not 0 < hfov_deg < 180:
        raise CalibrationError(f"horizontal field of view must be in (0, 180) degrees, got {hfov_deg}")
    f = (width / 2.0) / np.tan(np.radians(hfov_deg) / 2.0)
    return np.array([[f, 0.0, width / 2.0], [0.0, f, height / 2.0], [0.0, 0.0, 1.0]])


def ground_correspondences(
    camera: PinholeCamera, grid: tuple[int, int] = (4, 5), horizon_margin: float = 0.05
) -> tuple[np.ndarray, np.ndarray]:
    """A grid of pixels below the horizon and their ground points under the camera model.

    These are the correspondences the paper picked by hand, generated instead.

    Args:
        camera: the camera.
        grid: rows x columns of the pixel grid.
        horizon_margin: the grid starts this fraction of the image height below the horizon.

    Returns:
        points_px: (N, 2) float64 pixels.
        points_ground: (N, 2) float64 their ground points, metres.
    """
    horizon = max(camera.horizon_v(0.0), camera.horizon_v(float(camera.width)))
    top = max(horizon + horizon_margin * camera.height, 0.0)
    if top >= camera.height - 1:
        top = camera.height * 0.5
    rows, cols = grid
    U, V = np.meshgrid(np.linspace(0.0, camera.width - 1.0, cols), np.linspace(top, camera.height - 1.0, rows))
    px = np.column_stack([U.ravel(), V.ravel()])
    ground, _ = camera.ground_points(px)
    ok = np.isfinite(ground).all(axis=1)
    return px[ok], ground[ok]
