"""The third vanishing point: the horizontal direction across the street, and what the three measure.

Crossings, stop lines, kerbs of side streets, the rears of cars and the window rows of
facades that face the camera run horizontally *across* the street. Their lines converge
on a vanishing point on the horizon, the image of the direction orthogonal to both the
street and the vertical. With the street's (:func:`usdworld.geometry.vanishing.find_vanishing_point`)
and the vertical's (:func:`~usdworld.geometry.vanishing.find_vertical_vanishing_point`)
it completes the three orthogonal directions of a street scene. Orthogonal directions
have vanishing points with (square pixels, principal point ``c``)

    ``(v1 - c) . (v2 - c) = -f^2``  (Caprile and Torre 1990; Hartley and Zisserman, 2nd ed., 8.8),

so a focal length and a roll (the horizon's angle through the street's point) fix where
the lateral point must be (:func:`lateral_point`). :func:`lateral_focal_cue` searches
(log f, roll) for the point the near-horizontal segments point at best and turns the
profile likelihood of log f into a :class:`~usdworld.geometry.focal.FocalCue`, its spread
including the unknown principal point, the street point's row error and structures only
roughly square to the street. :func:`tilt_from_vanishing_points` gives the pitch and roll
the points and a focal length imply.

A camera looking straight along the street sees this point far to the side (at
``c_x - f^2 / (u_street - c_x)``): its lines are nearly parallel, the profile is flat and
the principal point's lever arm long, so the cue is weak or absent, as it should be; a
photo taken across a corner or turned off the street puts it in or near the frame.

Frames: image pixels (u right, v down); camera directions in OpenCV's camera frame
(x right, y down, z forward). Homogeneous points ``(u, v, w)`` in pixels, ``w = 0`` at infinity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usdworld.geometry.focal import FocalCue
from usdworld.geometry.vanishing import VanishingPoint, _support, _support_h, principal_point_f2_sigma
from usdworld.parameters.camera import DEFAULT_CAMERA, CameraParams


@dataclass(frozen=True)
class LateralVanishingPoint:
    """The vanishing point of the horizontal direction across the street, possibly at infinity.

    Attributes:
        point_h: (3,) float64 homogeneous ``(u, v, w)`` pixels, unit norm, ``w >= 0``.
        inliers: (M, 4) float64 the segments within ``vp_angle_tol_deg`` of pointing at it,
            ``u0, v0, u1, v1`` pixels.
    """

    point_h: np.ndarray
    inliers: np.ndarray


def _across(segments: np.ndarray, street: VanishingPoint, width: int, params: CameraParams) -> np.ndarray:
    """Segments long enough, within ``lateral_max_slant_deg`` of horizontal, not pointing at the street's point."""
    d = segments[:, 2:] - segments[:, :2]
    length = np.hypot(d[:, 0], d[:, 1])
    slant = np.degrees(np.arctan2(np.abs(d[:, 1]), np.abs(d[:, 0])))
    keep = (length >= max(params.vp_min_length_px, params.vp_min_length_fraction * width)) & (
        slant <= params.lateral_max_slant_deg
    )
    keep &= _support(segments, np.array([street.u, street.v])) >= params.vp_angle_tol_deg
    return segments[keep]


def lateral_point(street_px: np.ndarray, f_px: np.ndarray, roll: np.ndarray, center_px: np.ndarray) -> np.ndarray:
    """The lateral vanishing point a focal length and a roll imply, homogeneous, pixels.

    The point lies on the horizon, the line through the street's point ``s`` at the roll
    angle (direction ``e = (cos r, sin r)``), where its ray is orthogonal to the street's:
    ``(s - c) . (L - c) = -f^2``. In centred coordinates
    ``L = ((s . e) s - (f^2 + |s|^2) e, s . e)``, at infinity along the horizon when the
    street's point is the principal point.

    Args:
        street_px: (2,) float64 the street's vanishing point, pixels.
        f_px: (...,) float64 focal lengths, pixels.
        roll: (...,) float64 rolls, radians (broadcast with ``f_px``).
        center_px: (2,) float64 principal point, pixels.

    Returns:
        (..., 3) float64 homogeneous points ``(u, v, w)``, pixels.
    """
    sx, sy = np.asarray(street_px, dtype=np.float64) - center_px
    f, r = np.broadcast_arrays(np.asarray(f_px, dtype=np.float64), np.asarray(roll, dtype=np.float64))
    ex, ey = np.cos(r), np.sin(r)
    se = sx * ex + sy * ey
    k = f**2 + sx**2 + sy**2
    x, y = se * sx - k * ex, se * sy - k * ey
    return np.stack([x + center_px[0] * se, y + center_px[1] * se, se], axis=-1)


def _angle_residuals(segments: np.ndarray, points_h: np.ndarray) -> np.ndarray:
    """(G, N) signed angle, radians, between each segment and the direction from its middle to each point."""
    mid = 0.5 * (segments[:, :2] + segments[:, 2:])
    d = segments[:, 2:] - segments[:, :2]
    to_u = points_h[:, None, 0] - mid[None, :, 0] * points_h[:, None, 2]
    to_v = points_h[:, None, 1] - mid[None, :, 1] * points_h[:, None, 2]
    ang = np.arctan2(d[None, :, 0] * to_v - d[None, :, 1] * to_u, d[None, :, 0] * to_u + d[None, :, 1] * to_v)
    return (ang + np.pi / 2) % np.pi - np.pi / 2


def lateral_focal_cue(
    street: VanishingPoint,
    segments: np.ndarray,
    width: int,
    height: int,
    params: CameraParams = DEFAULT_CAMERA,
) -> tuple[FocalCue | None, LateralVanishingPoint | None]:
    """The focal length the lines across the street measure with the street's vanishing point.

    A grid over (log f, roll) predicts the lateral point (:func:`lateral_point`) and scores
    the Cauchy residuals of every candidate segment's direction (near horizontal, not
    pointing at the street's point) against the direction to it; each segment's angular
    spread is ``sqrt(2) params.segment_end_noise_px / length``, and the roll has a normal
    prior of ``params.roll_prior_std_deg``. The profile likelihood of log f (the best roll
    per focal length) gives the mode and, from its curvature, the spread (as
    :func:`usdworld.geometry.focal.box_shape_cue`). The unknown principal point
    (:func:`~usdworld.geometry.vanishing.principal_point_f2_sigma` at the mode), the
    street point's row error with ``params.road_slope_sigma_deg`` of road slope, and
    structures only roughly square to the street (``params.lateral_direction_std_deg``:
    ``f^2`` moves by ``|ray_s| |ray_L| sin(delta)``, the rays ``(p - c, f)``) are added.
    Lines that are nearly parallel in the image (a camera looking along the street) give a
    flat profile and so a weak cue, or none.

    Args:
        street: the street's vanishing point.
        segments: (N, 4) ``u0, v0, u1, v1`` the photo's segments, pixels.
        width: image width, pixels.
        height: image height, pixels.
        params: filters, noise, priors and the grid (``shape_focal_range``, ``shape_grid[0]``).

    Returns:
        (cue, point): the cue and the lateral point at its mode with the segments within
        ``params.vp_angle_tol_deg`` of it; (None, None) with fewer than ``params.vp_min_inliers``
        candidate segments, no maximum inside the searched focal lengths, or a spread above
        ``params.focal_max_sigma_log``.
    """
    seg = _across(np.asarray(segments, dtype=np.float64).reshape(-1, 4), street, width, params)
    if len(seg) < params.vp_min_inliers:
        return None, None
    c = np.array([width / 2.0, height / 2.0])
    diag = float(np.hypot(width, height))
    s_px = np.array([street.u, street.v])
    n_f = params.shape_grid[0]
    fs = diag * np.exp(np.linspace(*np.log(params.shape_focal_range), n_f))
    sigma_r = np.radians(params.roll_prior_std_deg)
    rolls = np.linspace(-3 * sigma_r, 3 * sigma_r, params.lateral_roll_steps)
    F, R = (a.ravel() for a in np.meshgrid(fs, rolls, indexing="ij"))
    pts = lateral_point(s_px, F, R, c)
    length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
    sig = np.sqrt(2.0) * params.segment_end_noise_px / length
    resid = _angle_residuals(seg, pts) / sig[None, :]
    cost = np.log1p(resid**2).sum(axis=1) + 0.5 * (R / sigma_r) ** 2
    log_lik = -(cost - cost.min()).reshape(n_f, len(rolls)).min(axis=1)
    k = int(np.argmax(log_lik))
    if k < 2 or k > n_f - 3:
        return None, None
    logf = np.log(fs)
    near = np.zeros(n_f, dtype=bool)
    near[k - 2 : k + 3] = True
    near |= log_lik >= log_lik[k] - 2.0
    a, b, _ = np.polyfit(logf[near], log_lik[near], 2)
    if a >= 0:
        return None, None
    mean = float(np.clip(-b / (2 * a), logf[0], logf[-1]))
    f = float(np.exp(mean))
    roll = float(rolls[int(np.argmin(cost.reshape(n_f, len(rolls))[k]))])
    point = lateral_point(s_px, np.array(f), np.array(roll), c)
    point = point / np.linalg.norm(point)
    point = point if point[2] >= 0 else -point
    f2 = f * f
    var_f2 = (2 * f2) ** 2 * (-1.0 / (2 * a))  # sigma_f2 = 2 f^2 sigma_log
    if point[2] > 1e-12:
        p_lat = point[:2] / point[2]
        row_sigma = float(np.hypot(street.sigma_v_px, f * np.tan(np.radians(params.road_slope_sigma_deg))))
        var_f2 += (abs(p_lat[1] - c[1]) * row_sigma) ** 2
        var_f2 += principal_point_f2_sigma(s_px, p_lat, c, diag, params) ** 2
        # lines across the street are square to it only within lateral_direction_std_deg: a turn by
        # delta changes (s - c).(L - c) + f^2 = |ray_s| |ray_L| cos(90 deg + delta) by about that much
        ray_s = np.hypot(f, np.linalg.norm(s_px - c))
        ray_l = np.hypot(f, np.linalg.norm(p_lat - c))
        var_f2 += (ray_s * ray_l * np.sin(np.radians(params.lateral_direction_std_deg))) ** 2
    else:
        var_f2 = np.inf  # a point at infinity: the principal point's lever arm is unbounded
    sigma = 0.5 * float(np.sqrt(var_f2)) / f2
    inliers = seg[_support_h(seg, point) < params.vp_angle_tol_deg]
    lateral = LateralVanishingPoint(point, inliers)
    if not np.isfinite(sigma) or sigma > params.focal_max_sigma_log:
        return None, lateral
    cue = FocalCue(
        "lateral_vanishing_point",
        f,
        max(sigma, params.focal_min_sigma_log),
        f"street point ({street.u:.0f}, {street.v:.0f}) and {len(inliers)} of {len(seg)} near-horizontal segments across it",
    )
    return cue, lateral


def tilt_from_vanishing_points(
    f_px: float,
    width: int,
    height: int,
    vertical_h: np.ndarray | None,
    street: VanishingPoint | None,
    lateral_h: np.ndarray | None,
) -> tuple[float, float] | None:
    """The camera's pitch and roll (ISO 8855, :mod:`usdworld.frames`) the vanishing points imply.

    The world's down direction in the camera is ``(sin r cos p, cos r cos p, sin p)``
    (pitch ``p`` positive looking down, roll ``r``). It is the vertical point's ray
    ``(u - c_x, v - c_y, f w)`` when that point is known, else the cross product of the
    street's and the lateral point's rays (both horizontal).

    Args:
        f_px: focal length, pixels.
        width: image width, pixels.
        height: image height, pixels.
        vertical_h: (3,) float64 the vertical's point, homogeneous pixels, or None.
        street: the street's point, or None.
        lateral_h: (3,) float64 the lateral point, homogeneous pixels, or None.

    Returns:
        (pitch, roll) radians, or None when neither the vertical nor both horizontal points are known.
    """
    c = np.array([width / 2.0, height / 2.0])

    def ray(p_h: np.ndarray) -> np.ndarray:
        return np.array([p_h[0] - c[0] * p_h[2], p_h[1] - c[1] * p_h[2], f_px * p_h[2]])

    if vertical_h is not None:
        down = ray(np.asarray(vertical_h, dtype=np.float64))
    elif street is not None and lateral_h is not None:
        down = np.cross(ray(np.array([street.u, street.v, 1.0])), ray(np.asarray(lateral_h, dtype=np.float64)))
    else:
        return None
    down = down / np.linalg.norm(down)
    if down[1] < 0:
        down = -down
    return float(np.arcsin(np.clip(down[2], -1.0, 1.0))), float(np.arctan2(down[0], down[1]))
