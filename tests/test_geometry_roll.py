"""The roll from the vertical vanishing point, fused with a level prior (geometry.roll)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.estimate import HeightObservations, estimate_camera
from usdworld.geometry.roll import RollMeasurement, deroll_points, fuse_roll, roll_from_vertical
from usdworld.geometry.vanishing import find_vertical_vanishing_point
from usdworld.parameters.camera import DEFAULT_CAMERA

W_IMG, H_IMG = 1242, 375
K = np.array([[721.5, 0.0, 621.0], [0.0, 721.5, 187.5], [0.0, 0.0, 1.0]])
C = K[:2, 2]


def _pole_segments(camera: PinholeCamera) -> np.ndarray:
    """(N, 4) image segments of upright poles 3 m tall at both sides of a street, 8-40 m ahead."""
    rows = []
    for x in (8.0, 12.0, 17.0, 23.0, 30.0, 40.0):
        for y in (-5.0, -7.5, 5.0, 7.5):
            px, _ = camera.project(np.array([[x, y, 0.2], [x, y, 3.0]]))
            rows.append(px.ravel())
    return np.array(rows)


@pytest.mark.parametrize("roll_deg", [-2.0, 0.7, 3.0])
def test_roll_from_a_rolled_view(roll_deg):
    cam = PinholeCamera(W_IMG, H_IMG, K, 1.65, math.radians(1.0), math.radians(roll_deg), 0.0)
    vertical = find_vertical_vanishing_point(_pole_segments(cam), W_IMG, H_IMG)
    assert vertical is not None
    m = roll_from_vertical(vertical, W_IMG, H_IMG)
    assert math.degrees(m.roll) == pytest.approx(roll_deg, abs=0.05)
    # exact segments: the spread is the plumb and crossfall floors alone
    floor = math.hypot(DEFAULT_CAMERA.roll_vertical_sigma_deg, DEFAULT_CAMERA.roll_road_crossfall_deg)
    assert math.degrees(m.sigma) == pytest.approx(floor, abs=0.01)


def test_a_consistent_roll_is_fused_by_inverse_variance():
    m = RollMeasurement(math.radians(1.5), math.radians(0.5), "test")
    fused = fuse_roll(m)
    prior = math.radians(DEFAULT_CAMERA.roll_level_std_deg)
    w = prior**2 / (prior**2 + m.sigma**2)
    assert fused.used
    assert fused.roll == pytest.approx(m.roll * w)
    assert fused.sigma == pytest.approx(1.0 / math.sqrt(m.sigma**-2 + prior**-2))
    assert "fused with a level prior" in fused.describe()


def test_a_wrong_vanishing_point_does_not_roll_the_world():
    fused = fuse_roll(RollMeasurement(math.radians(10.0), math.radians(0.5), "a leaning facade"))
    assert not fused.used and fused.roll == 0.0
    assert "dropped as inconsistent" in fused.describe()
    assert fuse_roll(None).roll == 0.0


@settings(max_examples=30, deadline=None)
@given(
    roll_deg=st.floats(-5.0, 5.0),
    pitch_deg=st.floats(-5.0, 5.0),
    x=st.floats(5.0, 60.0),
    y=st.floats(-10.0, 10.0),
    z=st.floats(0.0, 3.0),
)
def test_derolled_points_are_the_level_cameras(roll_deg, pitch_deg, x, y, z):
    rolled = PinholeCamera(W_IMG, H_IMG, K, 1.6, math.radians(pitch_deg), math.radians(roll_deg), 0.0)
    level = rolled.replace(roll=0.0)
    p = np.array([[x, y, z]])
    a, _ = level.project(p)
    b, _ = rolled.project(p)
    assert deroll_points(b, math.radians(roll_deg), C) == pytest.approx(a, abs=1e-6)


def _people(camera: PinholeCamera) -> HeightObservations:
    """People 1.75 m tall (flat tops) across a street, seen by ``camera``."""
    u, vb, vt = [], [], []
    for x, y in [(10, -4), (14, 5), (18, -6), (25, 3), (30, -8), (12, 7), (40, 6), (22, -3)]:
        px, _ = camera.project(np.array([[x, y, 0.0], [x, y, 1.75]], dtype=float))
        u.append(px[0, 0])
        vb.append(px[0, 1])
        vt.append(px[1, 1])
    n = len(u)
    return HeightObservations(np.array(u), np.array(vb), np.array(vt), np.full(n, 1.75), np.full(n, 0.05))


def test_the_fit_turns_a_rolled_photo_back_before_fitting_height_and_pitch():
    truth = PinholeCamera(W_IMG, H_IMG, K, 1.9, math.radians(1.0), math.radians(2.5), 0.0)
    obs = _people(truth)
    m = RollMeasurement(truth.roll, math.radians(0.2), "test")
    with_roll = estimate_camera(W_IMG, H_IMG, K, None, None, None, 0.0, obs, roll_measurement=m)
    level = estimate_camera(W_IMG, H_IMG, K, None, None, None, 0.0, obs)
    assert math.degrees(with_roll.camera.roll) == pytest.approx(2.5 * (1 / (1 + 0.2**2)), abs=0.01)
    assert with_roll.roll is not None and with_roll.roll.used
    assert abs(with_roll.camera.height_m - 1.9) < 0.02
    assert abs(with_roll.camera.height_m - 1.9) < abs(level.camera.height_m - 1.9)
    assert level.camera.roll == 0.0
