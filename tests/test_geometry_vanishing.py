"""The street's vanishing point from line segments (geometry.vanishing)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from usdworld.geometry.vanishing import (
    _support,
    _support_scores,
    find_vanishing_point,
    horizon_measurement,
    street_vanishing_point,
)

W, H = 1240, 375
VP = np.array([655.0, 168.0])


def _segments_towards(point: np.ndarray, angles_deg: list[float], start: float, stop: float) -> np.ndarray:
    """Segments on rays from ``point`` at the given angles, from ``start`` to ``stop`` px away."""
    a = np.radians(np.asarray(angles_deg))
    d = np.column_stack([np.cos(a), np.sin(a)])
    return np.hstack([point + start * d, point + stop * d])


def test_known_point_from_exact_segments_with_clutter():
    rays = _segments_towards(VP, [15, 25, 35, 50, 130, 145, 155, 165, -20, -160], 60.0, 220.0)
    rng = np.random.default_rng(3)
    clutter = np.hstack([rng.uniform([0, 0], [W, H], (12, 2)), rng.uniform([0, 0], [W, H], (12, 2))])
    vp = find_vanishing_point(np.vstack([rays, clutter]), W, H)
    assert vp is not None
    assert (vp.u, vp.v) == pytest.approx(tuple(VP), abs=1.5)
    assert vp.n_inliers >= 10


def test_lines_on_one_side_only_are_not_trusted():
    # A single facade: all its lines lie left of the point they meet at.
    rays = _segments_towards(VP, [150, 155, 160, 165, 170, 200, 205, 210, 140], 60.0, 300.0)
    assert find_vanishing_point(rays, W, H) is None


def test_too_few_segments():
    assert find_vanishing_point(_segments_towards(VP, [20, 160], 50.0, 200.0), W, H) is None
    assert find_vanishing_point(np.zeros((0, 4)), W, H) is None


def test_drawn_street_photo():
    img = np.full((H, W, 3), 90, np.uint8)
    for angle in (12, 20, 28, 40, 140, 152, 160, 168, -15, -25, -155, -165):
        a = np.radians(angle)
        p0 = VP + 80 * np.array([np.cos(a), np.sin(a)])
        p1 = VP + 900 * np.array([np.cos(a), np.sin(a)])
        cv2.line(img, tuple(int(x) for x in p0), tuple(int(x) for x in p1), (230, 230, 230), 3, cv2.LINE_AA)
    vp = street_vanishing_point(img)
    assert vp is not None
    assert (vp.u, vp.v) == pytest.approx(tuple(VP), abs=2.0)


def test_horizon_measurement_includes_road_slope():
    vp = find_vanishing_point(_segments_towards(VP, [15, 25, 35, 50, 130, 145, 155, 165], 60.0, 220.0), W, H)
    assert vp is not None
    v, sigma = horizon_measurement(vp, 720.0)
    assert v == pytest.approx(VP[1], abs=0.5)
    assert sigma >= 720.0 * np.tan(np.radians(1.0))


def test_support_scores_are_the_pointwise_sums_bit_for_bit():
    # The RANSAC keeps the first best score: a last-bit difference could change the point.
    rng = np.random.default_rng(5)
    seg = rng.random((700, 4)) * [2048, 1024, 2048, 1024]
    length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
    points = rng.random((150, 2)) * [4096, 1024] - [1024, 0]
    expected = [length[_support(seg, p) < 2.0].sum() for p in points]
    assert _support_scores(seg, length, points, 2.0, block=64).tolist() == expected
