"""Known-answer and property tests of the lateral (across-the-street) vanishing point and the tilt."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.focal import FocalCue, FocalEstimate
from usdworld.geometry.lateral import lateral_focal_cue, lateral_point, tilt_from_vanishing_points
from usdworld.geometry.vanishing import VanishingPoint
from usdworld.parameters.camera import CameraParams

W, H = 1280, 720


def _camera(f: float, pitch_deg: float, roll_deg: float, yaw_deg: float) -> PinholeCamera:
    K = np.array([[f, 0.0, W / 2.0], [0.0, f, H / 2.0], [0.0, 0.0, 1.0]])
    return PinholeCamera(W, H, K, 1.5, np.radians(pitch_deg), np.radians(roll_deg), np.radians(yaw_deg))


def _vp_h(cam: PinholeCamera, direction_world: np.ndarray) -> np.ndarray:
    """Homogeneous pixel vanishing point of a world direction (unit norm, w >= 0)."""
    d_cam = np.asarray(direction_world, dtype=np.float64) @ cam.rotation_world_from_cam
    p = cam.K @ d_cam
    p = p / np.linalg.norm(p)
    return p if p[2] >= 0 else -p


def _segments(cam: PinholeCamera, pairs: list[tuple[tuple[float, float, float], tuple[float, float, float]]]) -> np.ndarray:
    out = []
    for a, b in pairs:
        px, depth = cam.project(np.array([a, b], dtype=np.float64))
        assert np.all(depth > 0)
        out.append([*px[0], *px[1]])
    return np.array(out)


def _corner_scene(cam: PinholeCamera) -> np.ndarray:
    """Kerbs and facade lines along the street (world X), crossings, stop lines and window rows across it (Y)."""
    pairs = []
    for y in (-6.0, -3.0, 3.0, 6.0):
        for z in (0.0, 3.0, 6.0):
            pairs.append(((12.0, y, z), (40.0, y, z)))
    for x in (10.0, 14.0, 18.0, 24.0, 30.0):
        for z in (0.0, 2.5, 5.0):
            pairs.append(((x, -5.0, z), (x, 5.0, z)))
    return _segments(cam, pairs)


def _street(cam: PinholeCamera) -> VanishingPoint:
    p = _vp_h(cam, np.array([1.0, 0.0, 0.0]))
    return VanishingPoint(float(p[0] / p[2]), float(p[1] / p[2]), 0.5, 12, 12)


def test_lateral_point_known_answers():
    c = np.array([W / 2.0, H / 2.0])
    f = 800.0
    # street point f to the right of the centre, level horizon: the lateral one f to the left
    p = lateral_point(c + [f, 0.0], np.array(f), np.array(0.0), c)
    np.testing.assert_allclose(p[:2] / p[2], c - [f, 0.0], atol=1e-9)
    # street point at the centre: the lateral point is at infinity along the horizon's direction
    p = lateral_point(c, np.array(f), np.array(np.radians(10.0)), c)
    assert p[2] == pytest.approx(0.0, abs=1e-9)
    assert np.arctan2(p[1], p[0]) % np.pi == pytest.approx(np.radians(10.0))


@settings(max_examples=60, deadline=None)
@given(
    su=st.floats(-2000, 2000),
    sv=st.floats(-300, 300),
    f=st.floats(100, 3000),
    roll_deg=st.floats(-10, 10),
)
def test_lateral_point_is_orthogonal_to_the_street_and_on_its_horizon(su, sv, f, roll_deg):
    c = np.array([W / 2.0, H / 2.0])
    s = c + [su, sv]
    r = np.radians(roll_deg)
    p = lateral_point(s, np.array(f), np.array(r), c)
    # rays (p - c w, f w) and (s - c, f) are orthogonal
    ray_l = np.array([p[0] - c[0] * p[2], p[1] - c[1] * p[2], f * p[2]])
    ray_s = np.array([su, sv, f])
    assert abs(ray_l @ ray_s) <= 1e-9 * np.linalg.norm(ray_l) * np.linalg.norm(ray_s)
    # the point lies on the line through s at the roll angle
    e = np.array([np.cos(r), np.sin(r)])
    off = p[:2] - s * p[2]
    assert abs(off[0] * e[1] - off[1] * e[0]) <= 1e-9 * (np.linalg.norm(off) + 1.0)


@pytest.mark.parametrize("f,pitch,roll,yaw", [(800.0, 3.0, 0.0, 35.0), (1100.0, 5.0, 2.0, -40.0), (600.0, 0.0, -1.5, 30.0)])
def test_a_corner_view_gives_f_back(f, pitch, roll, yaw):
    """A camera turned 30-40 deg off the street sees the crossing lines converge in or near the
    frame: they and the street's point give f within 3 %, with a spread of a measurement."""
    cam = _camera(f, pitch, roll, yaw)
    cue, lateral = lateral_focal_cue(_street(cam), _corner_scene(cam), W, H, CameraParams())
    assert cue is not None and lateral is not None
    assert cue.source == "lateral_vanishing_point"
    assert cue.f_px == pytest.approx(f, rel=0.03)
    assert cue.sigma_log < 0.3
    true_lat = _vp_h(cam, np.array([0.0, 1.0, 0.0]))
    assert np.degrees(np.arccos(min(1.0, abs(float(true_lat @ lateral.point_h))))) < 1.0


def test_looking_along_the_street_the_crossing_lines_say_little():
    """Straight down the street the lateral point is far to the side: no cue, or one weaker than the prior."""
    cam = _camera(800.0, 2.0, 0.0, 3.0)
    pairs = [((x, y, z), (x, y + 6.0, z)) for x in (10.0, 14.0, 18.0, 24.0, 30.0) for y in (-8.0, 1.0) for z in (0.0, 2.5, 5.0)]
    pairs += [((12.0, y, z), (40.0, y, z)) for y in (-6.0, -3.0, 3.0, 6.0) for z in (0.0, 3.0)]
    cue, _ = lateral_focal_cue(_street(cam), _segments(cam, pairs), W, H, CameraParams())
    assert cue is None or cue.sigma_log > CameraParams().focal_prior_sigma_log


@pytest.mark.parametrize("pitch,roll,yaw", [(4.0, 2.0, 35.0), (-3.0, -5.0, -20.0), (10.0, 0.0, 0.0)])
def test_tilt_from_exact_vanishing_points(pitch, roll, yaw):
    """The vertical's point, or the street's with the lateral one, give the camera's pitch and roll exactly."""
    f = 900.0
    cam = _camera(f, pitch, roll, yaw)
    vertical = _vp_h(cam, np.array([0.0, 0.0, -1.0]))
    street = _street(cam)
    lateral = _vp_h(cam, np.array([0.0, 1.0, 0.0]))
    for got in (
        tilt_from_vanishing_points(f, W, H, vertical, None, None),
        tilt_from_vanishing_points(f, W, H, None, street, lateral),
    ):
        assert got is not None
        assert np.degrees(got[0]) == pytest.approx(pitch, abs=1e-6)
        assert np.degrees(got[1]) == pytest.approx(roll, abs=1e-6)
    assert tilt_from_vanishing_points(f, W, H, None, street, None) is None


def test_the_summary_states_the_tilt():
    est = FocalEstimate(
        800.0, 0.1, (FocalCue("prior", 800.0, 0.3, "p"),), tilt=(np.radians(2.0), np.radians(-1.0)), tilt_source="the vertical"
    )
    assert est.describe().endswith("; tilt from the vertical: pitch 2.0 deg, roll -1.0 deg (reported, not used)")
    assert "pitch" not in FocalEstimate(800.0, 0.1, (FocalCue("prior", 800.0, 0.3, "p"),)).describe()
