"""Fill in what the camera file did not say: intrinsics, height and pitch.

Objects of known class-height distribution constrain the camera height and the
horizon (Hoiem, Efros and Hebert 2006, "Putting Objects in Perspective"): an object
standing on the ground whose bottom is at row ``v_b`` and top at ``v_t`` has, for a
camera at height ``h`` pitched by ``theta``, a predicted top row that depends only on
``(h, theta)`` and its metric height. We search ``(h, theta)`` for the maximum a
posteriori fit: robust (Cauchy) image residuals of every usable object plus Gaussian
priors on the height and pitch of a vehicle-mounted camera. The top row of the road
region bounds the horizon from below when it is known.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usdworld.errors import CalibrationError
from usdworld.geometry.camera import PinholeCamera, intrinsics_from_fov

#: Horizontal field of view assumed when no intrinsics are given (degrees).
DEFAULT_HFOV_DEG = 60.0
#: Prior mean and spread of a vehicle camera's height above the road (metres):
#: KITTI 1.65, nuScenes about 1.5, Cityscapes 1.22.
CAMERA_HEIGHT_PRIOR_M = (1.5, 0.3)
#: Prior spread of the camera pitch around level (degrees).
PITCH_PRIOR_STD_DEG = 3.0
#: Pixel noise of a box edge (pixels).
EDGE_NOISE_PX = 1.5

_HEIGHT_RANGE_M = (0.5, 4.0)
_PITCH_RANGE_DEG = (-15.0, 15.0)


@dataclass(frozen=True)
class HeightObservations:
    """Objects usable for calibration: upright, bottom and top visible.

    Attributes:
        u: (N,) float64 column of the object's centre, pixels.
        v_bottom: (N,) float64 row where the object meets the ground, pixels.
        v_top: (N,) float64 row of the object's top, pixels.
        height_m: (N,) float64 expected metric height of each object's class.
        height_std_m: (N,) float64 spread of that height.
    """

    u: np.ndarray
    v_bottom: np.ndarray
    v_top: np.ndarray
    height_m: np.ndarray
    height_std_m: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.u)
        for name in ("v_bottom", "v_top", "height_m", "height_std_m"):
            if len(getattr(self, name)) != n:
                raise CalibrationError(f"height observations: {name} has a different length than u")

    def __len__(self) -> int:
        return len(self.u)


@dataclass(frozen=True)
class CameraEstimate:
    """The camera used for the world, and how each part of it was obtained.

    Attributes:
        camera: the full camera.
        estimated: names of the parameters that were not given (``K``, ``height_m``,
            ``pitch``, ``roll``, ``yaw``).
        method: one line saying how the missing parameters were obtained.
        n_objects: objects that constrained the estimate.
        residual_px: median absolute top-row residual of those objects, pixels (0 without).
        sigma_height_m: standard deviation of the camera height (0 when it was given).
        sigma_pitch: standard deviation of the pitch, radians (0 when it was given).
    """

    camera: PinholeCamera
    estimated: tuple[str, ...]
    method: str
    n_objects: int
    residual_px: float
    sigma_height_m: float = 0.0
    sigma_pitch: float = 0.0


def predicted_top_rows(
    h: np.ndarray, pitch: np.ndarray, K: np.ndarray, obs: HeightObservations
) -> tuple[np.ndarray, np.ndarray]:
    """Top rows predicted for each object under each candidate (height, pitch); zero roll.

    Args:
        h: (G,) float64 candidate camera heights, metres.
        pitch: (G,) float64 candidate pitches, radians.
        K: (3, 3) float64 camera matrix.
        obs: the N objects.

    Returns:
        v_top: (G, N) float64 predicted top rows (NaN where the bottom is above the horizon).
        depth: (G, N) float64 depth of the object's top along the optical axis.
    """
    fy, cy = K[1, 1], K[1, 2]
    b = ((obs.v_bottom - cy) / fy)[None, :]
    c, s = np.cos(pitch)[:, None], np.sin(pitch)[:, None]
    hh = h[:, None]
    denom = s + b * c
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(denom > 1e-9, hh / denom, np.nan)
        forward = t * (c - b * s)
        dz = obs.height_m[None, :] - hh
        z_cam = c * forward - s * dz
        y_cam = -(s * forward + c * dz)
        v_top = cy + fy * y_cam / z_cam
    v_top = np.where(z_cam > 0.1, v_top, np.nan)
    return v_top, z_cam


def _cost(
    h: np.ndarray,
    pitch: np.ndarray,
    K: np.ndarray,
    obs: HeightObservations,
    road_top_v: float | None,
) -> np.ndarray:
    """Negative log posterior (up to a constant) of each candidate; (G,) float64."""
    mean_h, std_h = CAMERA_HEIGHT_PRIOR_M
    cost = 0.5 * ((h - mean_h) / std_h) ** 2 + 0.5 * (np.degrees(pitch) / PITCH_PRIOR_STD_DEG) ** 2
    if len(obs):
        v_top, z = predicted_top_rows(h, pitch, K, obs)
        sigma = np.sqrt((K[1, 1] * obs.height_std_m[None, :] / np.maximum(z, 0.1)) ** 2 + EDGE_NOISE_PX**2)
        r = (v_top - obs.v_top[None, :]) / sigma
        cost = cost + np.where(np.isfinite(r), np.log1p(r**2), 10.0).sum(axis=1)
    if road_top_v is not None:
        horizon = K[1, 2] - K[1, 1] * np.tan(pitch)
        excess = np.maximum(horizon - road_top_v, 0.0)
        cost = cost + 0.5 * (excess / 2.0) ** 2
    return cost


def _search(
    K: np.ndarray,
    obs: HeightObservations,
    road_top_v: float | None,
    fixed_h: float | None,
    fixed_pitch: float | None,
) -> tuple[float, float]:
    """Coarse-to-fine grid search of the (height, pitch) posterior."""
    h_lo, h_hi = _HEIGHT_RANGE_M
    p_lo, p_hi = np.radians(_PITCH_RANGE_DEG)
    h_step, p_step = 0.05, np.radians(0.25)
    best_h, best_p = fixed_h, fixed_pitch
    for _ in range(3):
        hs = np.array([fixed_h]) if fixed_h is not None else np.arange(h_lo, h_hi + 1e-9, h_step)
        ps = np.array([fixed_pitch]) if fixed_pitch is not None else np.arange(p_lo, p_hi + 1e-12, p_step)
        H, P = np.meshgrid(hs, ps, indexing="ij")
        cost = _cost(H.ravel(), P.ravel(), K, obs, road_top_v)
        k = int(np.argmin(cost))
        best_h, best_p = float(H.ravel()[k]), float(P.ravel()[k])
        h_lo, h_hi = best_h - 2 * h_step, best_h + 2 * h_step
        p_lo, p_hi = best_p - 2 * p_step, best_p + 2 * p_step
        h_step, p_step = h_step / 10, p_step / 10
    assert best_h is not None and best_p is not None
    return best_h, best_p


def _laplace_sigma(f, x0: float, step: float) -> float:
    """Standard deviation from the curvature of a negative log posterior at its minimum."""
    c0, cp, cm = f(x0), f(x0 + step), f(x0 - step)
    curvature = (cp + cm - 2.0 * c0) / step**2
    return float(1.0 / np.sqrt(curvature)) if curvature > 0 else float("inf")


def estimate_camera(
    width: int,
    height: int,
    K: np.ndarray | None,
    height_m: float | None,
    pitch: float | None,
    roll: float | None,
    yaw: float | None,
    observations: HeightObservations,
    road_top_v: float | None = None,
) -> CameraEstimate:
    """Complete a partially known camera.

    Args:
        width: image width in pixels.
        height: image height in pixels.
        K: (3, 3) float64 camera matrix, or None to assume :data:`DEFAULT_HFOV_DEG`.
        height_m: camera height in metres, or None to estimate.
        pitch: radians (positive looking down), or None to estimate.
        roll: radians, or None (then 0 is assumed).
        yaw: radians, or None (then 0: the world's X axis is the camera's heading).
        observations: upright objects with visible bottom and top.
        road_top_v: highest image row (smallest v) of the road region, or None.

    Returns:
        The camera and a record of what was estimated and how.
    """
    estimated = []
    notes = []
    if K is None:
        K = intrinsics_from_fov(width, height, DEFAULT_HFOV_DEG)
        estimated.append("K")
        notes.append(f"intrinsics assumed: {DEFAULT_HFOV_DEG:g} deg horizontal FOV, centred principal point")
    if roll is None:
        estimated.append("roll")
        notes.append("roll assumed level (0)")
        roll = 0.0
    if yaw is None:
        yaw = 0.0
    residual = 0.0
    n_used = 0
    sigma_h = sigma_p = 0.0
    if height_m is None or pitch is None:
        if height_m is None:
            estimated.append("height_m")
        if pitch is None:
            estimated.append("pitch")
        usable = observations
        h_est, p_est = _search(np.asarray(K), usable, road_top_v, height_m, pitch)
        n_used = len(usable)
        if n_used:
            v_top, _ = predicted_top_rows(np.array([h_est]), np.array([p_est]), np.asarray(K), usable)
            res = np.abs(v_top[0] - usable.v_top)
            residual = float(np.nanmedian(res)) if np.isfinite(res).any() else 0.0
            notes.append(
                f"height/pitch fitted to {n_used} object(s) of known class height"
                + (" and the road's top row" if road_top_v is not None else "")
                + f" (median residual {residual:.1f} px)"
            )
        elif road_top_v is not None:
            notes.append("no usable objects: height from the prior, pitch bounded by the road's top row")
        else:
            notes.append(
                f"nothing to go on: default camera height {CAMERA_HEIGHT_PRIOR_M[0]:g} m and level pitch"
            )
        Kf = np.asarray(K)
        if "height_m" in estimated:
            sigma_h = _laplace_sigma(
                lambda x: float(_cost(np.array([x]), np.array([p_est]), Kf, usable, road_top_v)[0]), h_est, 0.01
            )
        if "pitch" in estimated:
            sigma_p = _laplace_sigma(
                lambda x: float(_cost(np.array([h_est]), np.array([x]), Kf, usable, road_top_v)[0]),
                p_est,
                np.radians(0.05),
            )
        height_m, pitch = h_est, p_est
    method = "; ".join(notes) if notes else "all camera parameters given"
    camera = PinholeCamera(width, height, np.asarray(K), float(height_m), float(pitch), float(roll), float(yaw))
    return CameraEstimate(camera, tuple(estimated), method, n_used, residual, sigma_h, sigma_p)
