"""The horizon from the photo itself: the vanishing point of the street's lines (and the vertical's).

Lane markings, kerbs, roof lines and window rows run along the street; in the image
they converge on one vanishing point, which lies on the horizon. With a level roll the
horizon row fixes the camera pitch (``v_h = c_y - f_y tan(pitch)``), the part of the
camera that objects of known height constrain worst when there are few of them.

Line segments come from OpenCV's LSD detector. A deterministic RANSAC over pairs of
segments finds the point most segments point at (within ``vp_angle_tol_deg`` of
:class:`~usdworld.parameters.CameraParams`, weighted by length); a weighted least-squares
fit over its inliers refines it. The estimate is
kept only when enough segments from both sides of the point agree, so a single facade
or a fence does not decide it.

The vertical's vanishing point (:func:`find_vertical_vanishing_point`: poles and building
edges, within ``vertical_max_tilt_deg`` of the image vertical; homogeneous, as it is at
infinity for a level camera) and the street's are images of orthogonal directions; together
they measure the focal length (:func:`vanishing_focal_cue`) when no camera file gives it.

Frames: image pixels (u right, v down, origin at the top-left corner).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

from usdworld.parameters.camera import DEFAULT_CAMERA, CameraParams

if TYPE_CHECKING:
    from usdworld.geometry.focal import FocalCue


@dataclass(frozen=True)
class VanishingPoint:
    """The street's vanishing point.

    Attributes:
        u: column, pixels.
        v: row, pixels (the horizon's row when the roll is level).
        sigma_v_px: standard error of ``v`` from the inliers' scatter, pixels.
        n_inliers: segments supporting it.
        n_segments: slanted segments considered.
    """

    u: float
    v: float
    sigma_v_px: float
    n_inliers: int
    n_segments: int


def detect_segments(rgb: np.ndarray, params: CameraParams = DEFAULT_CAMERA) -> np.ndarray:
    """Line segments of a photo (found at most ``params.vp_max_width_px`` wide, for speed).

    Args:
        rgb: (H, W, 3) uint8 image.
        params: the detection width.

    Returns:
        (N, 4) float64 ``u0, v0, u1, v1`` in the photo's pixels.
    """
    gray = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY)
    scale = min(1.0, params.vp_max_width_px / gray.shape[1])
    if scale < 1.0:
        size = (round(gray.shape[1] * scale), round(gray.shape[0] * scale))
        gray = cv2.resize(gray, size, interpolation=cv2.INTER_AREA)
    lines = cv2.createLineSegmentDetector().detect(gray)[0]
    if lines is None:
        return np.zeros((0, 4))
    return lines.reshape(-1, 4).astype(np.float64) / scale


def _slanted(segments: np.ndarray, width: int, params: CameraParams) -> np.ndarray:
    d = segments[:, 2:] - segments[:, :2]
    length = np.hypot(d[:, 0], d[:, 1])
    angle = np.degrees(np.arctan2(np.abs(d[:, 1]), np.abs(d[:, 0])))
    keep = (
        (length >= max(params.vp_min_length_px, params.vp_min_length_fraction * width))
        & (angle >= params.vp_min_slant_deg)
        & (angle <= 90 - params.vp_min_slant_deg)
    )
    return segments[keep]


def _support(segments: np.ndarray, point: np.ndarray) -> np.ndarray:
    """(N,) angle in degrees between each segment and the direction from its middle to ``point``."""
    mid = 0.5 * (segments[:, :2] + segments[:, 2:])
    d = segments[:, 2:] - segments[:, :2]
    to = point[None, :] - mid
    cross = np.abs(d[:, 0] * to[:, 1] - d[:, 1] * to[:, 0])
    dot = np.abs(np.sum(d * to, axis=1))
    return np.degrees(np.arctan2(cross, dot))


def _support_scores(segments: np.ndarray, length: np.ndarray, points: np.ndarray, tol_deg: float, block: int = 64) -> np.ndarray:
    """(M,) the summed length of the segments pointing at each of ``points`` (within ``tol_deg``).

    :func:`_support` for a block of points at once (the same operations per element, so the
    same values), each point's sum taken over its own inliers as a loop over points would.

    Args:
        segments: (N, 4) ``u0, v0, u1, v1`` pixels.
        length: (N,) float64 segment lengths.
        points: (M, 2) float64 candidate points, pixels.
        tol_deg: largest angle between a segment and the direction to the point, degrees.
        block: points compared at once (memory ``block x N`` float64 per temporary).
    """
    mid = 0.5 * (segments[:, :2] + segments[:, 2:])
    d = segments[:, 2:] - segments[:, :2]
    scores = np.empty(len(points))
    for start in range(0, len(points), block):
        p = points[start : start + block]
        to_u = p[:, 0:1] - mid[None, :, 0]
        to_v = p[:, 1:2] - mid[None, :, 1]
        cross = np.abs(d[:, 0] * to_v - d[:, 1] * to_u)
        dot = np.abs(d[:, 0] * to_u + d[:, 1] * to_v)
        inliers = np.degrees(np.arctan2(cross, dot)) < tol_deg
        scores[start : start + len(p)] = [length[row].sum() for row in inliers]
    return scores


def segment_lines(segments: np.ndarray) -> np.ndarray:
    """(N, 3) homogeneous lines through the segments, normalised so a^2 + b^2 = 1."""
    p = np.column_stack([segments[:, :2], np.ones(len(segments))])
    q = np.column_stack([segments[:, 2:], np.ones(len(segments))])
    lines = np.cross(p, q)
    return lines / np.linalg.norm(lines[:, :2], axis=1, keepdims=True)


def _refine(segments: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, float]:
    """Weighted least-squares intersection of the lines; the point and the sigma of its v."""
    lines = segment_lines(segments)
    A, b = lines[:, :2], -lines[:, 2]
    w = np.sqrt(weights)
    sol, *_ = np.linalg.lstsq(A * w[:, None], b * w, rcond=None)
    resid = A @ sol - b
    dof = max(len(b) - 2, 1)
    s2 = float(np.sum(weights * resid**2) / np.sum(weights)) * len(b) / dof
    cov = s2 * np.linalg.pinv((A * weights[:, None]).T @ A / np.mean(weights))
    return sol, float(np.sqrt(max(cov[1, 1], 0.0)))


def _pair_intersections(seg: np.ndarray, params: CameraParams) -> tuple[np.ndarray, np.ndarray]:
    """The RANSAC hypotheses of both vanishing-point searches: each segment's length, and the
    homogeneous intersections of ``params.vp_trials`` random pairs of segments (fixed seed).

    Args:
        seg: (N, 4) ``u0, v0, u1, v1`` pixels, N >= 2.

    Returns:
        (N,) float64 lengths and (M, 3) float64 homogeneous points (M <= ``vp_trials``).
    """
    lines = segment_lines(seg)
    length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
    rng = np.random.default_rng(0)
    pairs = rng.integers(0, len(seg), size=(params.vp_trials, 2))
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    return length, np.cross(lines[pairs[:, 0]], lines[pairs[:, 1]])


def find_vanishing_point(
    segments: np.ndarray, width: int, height: int, params: CameraParams = DEFAULT_CAMERA
) -> VanishingPoint | None:
    """The point the most (length-weighted) slanted segments converge on.

    Args:
        segments: (N, 4) ``u0, v0, u1, v1`` pixels.
        width: image width, pixels.
        height: image height, pixels.
        params: the segment filters and the RANSAC's tolerance, trials and support.

    Returns:
        The vanishing point, or None when too few segments agree (fewer than
        ``params.vp_min_inliers``, or fewer than ``params.vp_min_per_side`` on either side
        of it) or it lies outside the image rows.
    """
    seg = _slanted(np.asarray(segments, dtype=np.float64).reshape(-1, 4), width, params)
    n = len(seg)
    tol = params.vp_angle_tol_deg
    if n < params.vp_min_inliers:
        return None
    length, points = _pair_intersections(seg, params)
    ok = np.abs(points[:, 2]) > 1e-9
    points = points[ok, :2] / points[ok, 2:3]
    inside = (points[:, 1] >= 0) & (points[:, 1] < height) & (np.abs(points[:, 0] - width / 2) < width)
    points = points[inside]
    if not len(points):
        return None
    scores = _support_scores(seg, length, points, tol)
    best = points[int(np.argmax(scores))]
    inliers = _support(seg, best) < tol
    for _ in range(2):
        if inliers.sum() < params.vp_min_inliers:
            return None
        best, sigma_v = _refine(seg[inliers], length[inliers])
        inliers = _support(seg, best) < tol
    mid_u = 0.5 * (seg[inliers, 0] + seg[inliers, 2])
    if min((mid_u < best[0]).sum(), (mid_u > best[0]).sum()) < params.vp_min_per_side or not (0 <= best[1] < height):
        return None
    return VanishingPoint(float(best[0]), float(best[1]), sigma_v, int(inliers.sum()), n)


def street_vanishing_point(rgb: np.ndarray, params: CameraParams = DEFAULT_CAMERA) -> VanishingPoint | None:
    """:func:`find_vanishing_point` of the photo's LSD segments."""
    return find_vanishing_point(detect_segments(rgb, params), rgb.shape[1], rgb.shape[0], params)


def horizon_measurement(
    vp: VanishingPoint, fy: float, params: CameraParams = DEFAULT_CAMERA
) -> tuple[float, float]:
    """The horizon row the vanishing point measures and its standard error, pixels.

    The error adds the point's own scatter and ``params.road_slope_sigma_deg`` of road slope.
    """
    return vp.v, float(np.hypot(vp.sigma_v_px, fy * np.tan(np.radians(params.road_slope_sigma_deg))))


@dataclass(frozen=True)
class VerticalVanishingPoint:
    """The vanishing point of the world's vertical (poles, building edges), possibly at infinity.

    Attributes:
        point_h: (3,) float64 homogeneous ``(u, v, w)`` pixels, unit norm, ``w >= 0``
            (``w = 0``: the verticals are parallel in the image, a level camera).
        inliers: (M, 4) float64 the supporting segments.
    """

    point_h: np.ndarray
    inliers: np.ndarray


def _upright(segments: np.ndarray, width: int, params: CameraParams) -> np.ndarray:
    d = segments[:, 2:] - segments[:, :2]
    length = np.hypot(d[:, 0], d[:, 1])
    tilt = np.degrees(np.arctan2(np.abs(d[:, 0]), np.abs(d[:, 1])))
    keep = (length >= max(params.vp_min_length_px, params.vp_min_length_fraction * width)) & (
        tilt <= params.vertical_max_tilt_deg
    )
    return segments[keep]


def _support_h(segments: np.ndarray, point_h: np.ndarray) -> np.ndarray:
    """(N,) angle in degrees between each segment and the direction to a homogeneous point."""
    mid = 0.5 * (segments[:, :2] + segments[:, 2:])
    d = segments[:, 2:] - segments[:, :2]
    to = point_h[None, :2] - mid * point_h[2]
    cross = np.abs(d[:, 0] * to[:, 1] - d[:, 1] * to[:, 0])
    dot = np.abs(np.sum(d * to, axis=1))
    return np.degrees(np.arctan2(cross, dot))


def _refine_h(segments: np.ndarray, center: np.ndarray, scale: float) -> np.ndarray:
    """Length-weighted least-squares homogeneous intersection (unit norm, w >= 0), pixels."""
    norm = (segments.reshape(-1, 2) - center) / scale
    seg = norm.reshape(-1, 4)
    lines = segment_lines(seg)
    length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
    _, _, vt = np.linalg.svd(lines * np.sqrt(length)[:, None])
    p = vt[-1]
    p_px = np.array([p[0] * scale + center[0] * p[2], p[1] * scale + center[1] * p[2], p[2]])
    p_px /= np.linalg.norm(p_px)
    return p_px if p_px[2] >= 0 else -p_px


def find_vertical_vanishing_point(
    segments: np.ndarray, width: int, height: int, params: CameraParams = DEFAULT_CAMERA
) -> VerticalVanishingPoint | None:
    """The point near-vertical segments converge on (RANSAC over pairs, least-squares refit).

    Args:
        segments: (N, 4) ``u0, v0, u1, v1`` pixels.
        width: image width, pixels.
        height: image height, pixels.
        params: the segment filters, tolerance, trials and support.

    Returns:
        The vertical vanishing point, or None with fewer than ``params.vp_min_inliers``
        supporting segments.
    """
    seg = _upright(np.asarray(segments, dtype=np.float64).reshape(-1, 4), width, params)
    n = len(seg)
    if n < params.vp_min_inliers:
        return None
    length, points = _pair_intersections(seg, params)
    points /= np.maximum(np.linalg.norm(points, axis=1, keepdims=True), 1e-12)
    scores = np.array([length[_support_h(seg, p) < params.vp_angle_tol_deg].sum() for p in points])
    best = points[int(np.argmax(scores))]
    center, scale = np.array([width / 2.0, height / 2.0]), float(np.hypot(width, height))
    for _ in range(2):
        inliers = _support_h(seg, best) < params.vp_angle_tol_deg
        if inliers.sum() < params.vp_min_inliers:
            return None
        best = _refine_h(seg[inliers], center, scale)
    inliers = _support_h(seg, best) < params.vp_angle_tol_deg
    return VerticalVanishingPoint(best, seg[inliers])


def principal_point_f2_sigma(
    vp1_px: np.ndarray, vp2_px: np.ndarray, center_px: np.ndarray, diagonal_px: float, params: CameraParams = DEFAULT_CAMERA
) -> float:
    """Standard error of ``f^2 = -(v1 - c) . (v2 - c)`` from the unknown principal point, pixels^2.

    The gradient of ``f^2`` in ``c`` is ``(v1 - c) + (v2 - c)``; with an isotropic spread
    ``params.principal_point_sigma_fraction * diagonal_px`` per axis the error is its norm
    times that spread. A level camera looking along the street puts one point near the
    centre and the other far away: the far one's lever arm makes the pair weak, as it is.

    Args:
        vp1_px: (2,) float64 first vanishing point, pixels.
        vp2_px: (2,) float64 second, pixels.
        center_px: (2,) float64 assumed principal point (the image centre), pixels.
        diagonal_px: image diagonal, pixels.
        params: the principal point's spread.
    """
    grad = (np.asarray(vp1_px) - center_px) + (np.asarray(vp2_px) - center_px)
    return float(np.linalg.norm(grad)) * params.principal_point_sigma_fraction * diagonal_px


def vanishing_focal_cue(
    street: VanishingPoint | None,
    vertical: VerticalVanishingPoint | None,
    width: int,
    height: int,
    params: CameraParams = DEFAULT_CAMERA,
) -> FocalCue | None:
    """The focal length the street's and the vertical vanishing points give together.

    The street runs horizontally, so its direction is orthogonal to the vertical:
    ``f^2 = -(v_street - c) . (v_vertical - c)``
    (:func:`usdworld.geometry.focal.focal_from_orthogonal_vps`, principal point at the
    centre). The spread adds a bootstrap over the vertical's inliers
    (``params.vertical_bootstrap`` resamples) and the street point's row error, which
    includes ``params.road_slope_sigma_deg`` of road slope (a sloped street is not
    orthogonal to the vertical), and the unknown principal point
    (:func:`principal_point_f2_sigma`). A nearly level camera puts the vertical point near
    infinity and the street point near the centre's row: the cue is then weak, and says so.

    Args:
        street: the street's vanishing point, or None.
        vertical: the vertical's vanishing point (:func:`find_vertical_vanishing_point`), or None.
        width: image width, pixels.
        height: image height, pixels.
        params: the spread settings.

    Returns:
        A :class:`~usdworld.geometry.focal.FocalCue`, or None when a point is missing or
        the two are not orthogonal for any focal length.
    """
    from usdworld.geometry.focal import FocalCue, focal_from_orthogonal_vps, principal_point

    if street is None:
        return None
    if vertical is None or vertical.point_h[2] <= 1e-12:
        return None
    c = principal_point(width, height)
    p_street = np.array([street.u, street.v])
    p_vert = vertical.point_h[:2] / vertical.point_h[2]
    f = focal_from_orthogonal_vps(p_street, p_vert, c)
    if f is None:
        return None
    rng = np.random.default_rng(0)
    scale = float(np.hypot(width, height))
    f2s = []
    for _ in range(params.vertical_bootstrap):
        pick = vertical.inliers[rng.integers(0, len(vertical.inliers), len(vertical.inliers))]
        p = _refine_h(pick, c, scale)
        f2s.append(-float(np.dot(p_street - c, p[:2] - c * p[2])) / p[2] if p[2] > 1e-12 else -np.inf)
    f2s_arr = np.array(f2s)
    if np.mean(f2s_arr > 0) < 0.8:
        return None
    sigma_f2_vert = float(np.std(f2s_arr[f2s_arr > 0]))
    slope_px = f * np.tan(np.radians(params.road_slope_sigma_deg))
    sigma_f2_street = abs(p_vert[1] - c[1]) * float(np.hypot(street.sigma_v_px, slope_px))
    sigma_f2_pp = principal_point_f2_sigma(p_street, p_vert, c, scale, params)
    sigma = 0.5 * float(np.sqrt(sigma_f2_vert**2 + sigma_f2_street**2 + sigma_f2_pp**2)) / f**2
    sigma = max(sigma, params.focal_min_sigma_log)
    return FocalCue(
        "vanishing_points",
        f,
        sigma,
        f"street point ({street.u:.0f}, {street.v:.0f}) and the vertical of {len(vertical.inliers)} upright segments",
    )
