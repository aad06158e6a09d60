"""Camera model: known answers, round trips, errors."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from usdworld.errors import CalibrationError
from usdworld.geometry.camera import PinholeCamera, intrinsics_from_fov

K = np.array([[1000.0, 0.0, 640.0], [0.0, 1000.0, 360.0], [0.0, 0.0, 1.0]])


def test_level_camera_known_answer():
    cam = PinholeCamera(1280, 720, K, height_m=1.5)
    px, depth = cam.project(np.array([[10.0, 0.0, 0.0], [10.0, 2.0, 1.5]]))
    # 10 m ahead on the ground: 1.5 m below the optical axis -> v = cy + f * 1.5 / 10.
    np.testing.assert_allclose(px[0], [640.0, 360.0 + 150.0])
    # 2 m to the left at eye height -> u = cx - f * 2 / 10, on the horizon row.
    np.testing.assert_allclose(px[1], [440.0, 360.0])
    np.testing.assert_allclose(depth, [10.0, 10.0])
    assert cam.horizon_v() == pytest.approx(360.0)


def test_pitched_camera_matches_opencv():
    cam = PinholeCamera(1280, 720, K, height_m=1.6, pitch=0.05, roll=-0.02, yaw=0.1)
    pts = np.array([[12.0, 3.0, 0.0], [40.0, -6.0, 2.0], [7.0, 1.0, 1.0]])
    T = np.linalg.inv(cam.world_from_cam())
    rvec, _ = cv2.Rodrigues(T[:3, :3])
    expected, _ = cv2.projectPoints(pts, rvec, T[:3, 3], K, None)
    px, _ = cam.project(pts)
    np.testing.assert_allclose(px, expected.reshape(-1, 2), atol=1e-9)


def test_horizon_for_pitch():
    cam = PinholeCamera(1280, 720, K, height_m=1.6, pitch=np.radians(2.0))
    assert cam.horizon_v() == pytest.approx(360.0 - 1000.0 * np.tan(np.radians(2.0)))


@given(
    x=st.floats(3.0, 80.0),
    y=st.floats(-15.0, 15.0),
    h=st.floats(1.0, 2.5),
    pitch=st.floats(-0.08, 0.08),
    roll=st.floats(-0.03, 0.03),
)
def test_ground_round_trip(x, y, h, pitch, roll):
    cam = PinholeCamera(1280, 720, K, height_m=h, pitch=pitch, roll=roll)
    px, depth = cam.project(np.array([[x, y, 0.0]]))
    ground, d = cam.ground_points(px)
    np.testing.assert_allclose(ground[0], [x, y], rtol=1e-7, atol=1e-7)
    np.testing.assert_allclose(d, depth, rtol=1e-9)
    H = cam.px_from_ground()
    q = H @ np.array([x, y, 1.0])
    np.testing.assert_allclose(q[:2] / q[2], px[0], rtol=1e-9)


def test_sky_pixels_miss_the_ground():
    cam = PinholeCamera(1280, 720, K, height_m=1.5)
    ground, depth = cam.ground_points(np.array([[640.0, 100.0]]))
    assert np.isnan(ground).all() and np.isnan(depth).all()


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"K": np.diag([-1.0, 1.0, 1.0])}, "focal lengths must be > 0"),
        ({"height_m": 0.0}, "camera height must be > 0"),
        ({"K": np.eye(2)}, "3x3"),
    ],
)
def test_invalid_camera(kwargs, message):
    args = {"width": 100, "height": 50, "K": K, "height_m": 1.5} | kwargs
    with pytest.raises(CalibrationError, match=message):
        PinholeCamera(**args)


def test_intrinsics_from_fov():
    K60 = intrinsics_from_fov(200, 100, 90.0)
    assert K60[0, 0] == pytest.approx(100.0)
    assert (K60[0, 2], K60[1, 2]) == (100.0, 50.0)
    with pytest.raises(CalibrationError):
        intrinsics_from_fov(200, 100, 180.0)


def test_vanishing_point_of_the_road_direction():
    cam = PinholeCamera(1280, 720, K, height_m=1.5, pitch=np.radians(2.0))
    u, v = cam.vanishing_point(np.array([1.0, 0.0, 0.0]))
    assert u == pytest.approx(640.0) and v == pytest.approx(cam.horizon_v())
    # A direction 45 degrees to the left vanishes f * tan(45) = 1000 px left of centre (level camera).
    level = PinholeCamera(1280, 720, K, height_m=1.5)
    assert level.vanishing_point(np.array([1.0, 1.0, 0.0]))[0] == pytest.approx(640.0 - 1000.0)
    assert level.vanishing_point(np.array([-1.0, 0.0, 0.0])) is None


def test_ground_correspondences_lie_on_the_ground():
    from usdworld.geometry.camera import ground_correspondences

    cam = PinholeCamera(1280, 720, K, height_m=1.6, pitch=0.03)
    px, ground = ground_correspondences(cam, (4, 5))
    assert len(px) == 20 and px[:, 1].min() > cam.horizon_v()
    back, _ = cam.project(np.column_stack([ground, np.zeros(len(ground))]))
    np.testing.assert_allclose(back, px, atol=1e-9)
