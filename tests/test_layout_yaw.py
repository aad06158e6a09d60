"""Yaw from a box's aspect (layout.yaw.view_angle_from_box / yaw_from_view_angle)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.geometry.camera import PinholeCamera
from usdworld.io.label_table import label_lookups
from usdworld.io.types import Detection, Detections, InputFile
from usdworld.layout.boxes import box_corners, fit_view_angle
from usdworld.layout.yaw import view_angle_from_box, yaw_from_view_angle
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.objects import objects_from_detections

K = np.array([[721.5, 0.0, 609.6], [0.0, 721.5, 172.9], [0.0, 0.0, 1.0]])
CAM = PinholeCamera(1242, 375, K, 1.65)
CAR = (4.2, 1.8, 1.5)


#: A long lens, so that whole-pixel boxes barely round the aspect.
TELE = PinholeCamera(
    6000, 1500, np.array([[6000.0, 0.0, 3000.0], [0.0, 6000.0, 700.0], [0.0, 0.0, 1.0]]), 1.65
)


def _box(
    centre_xy: np.ndarray, yaw: float, lwh: tuple[float, float, float], cam: PinholeCamera = CAM
) -> np.ndarray:
    px, _ = cam.project(box_corners(centre_xy, yaw, np.array(lwh)))
    return np.array([px[:, 0].min(), px[:, 1].min(), px[:, 0].max(), px[:, 1].max()])


def test_end_on_and_side_on():
    assert view_angle_from_box(100.0, 100.0, CAR) == 0.0  # narrower than the width: end on
    peak = np.arctan2(CAR[0], CAR[1])
    assert view_angle_from_box(400.0, 100.0, CAR) == pytest.approx(peak)  # ambiguous: the middle


@settings(max_examples=40, deadline=None)
@given(depth=st.floats(15.0, 50.0), lateral=st.floats(-2.0, 2.0), turn_deg=st.floats(0.0, 50.0))
def test_turn_recovered_from_a_projected_box(depth: float, lateral: float, turn_deg: float):
    # A turn below about W / d leaves the far face inside the near face's columns (the near
    # face looks bigger), so the aspect cannot tell it from end on.
    # Up to 50 m: farther, seen nearly flat, a 50 degree turn's box is wider for its height
    # than the side-on one (4.2 sin 50 + 1.8 cos 50 = 4.37 m of span against 4.2 m), and
    # fit_view_angle answers an aspect beyond the side-on one with the peak, as documented
    # (69 degrees; 40 of 1,353 cases at 52.8-60 m and 50 degrees). Nearer, perspective keeps
    # it below. The ambiguity is known, not fixed (this session's closing note).
    centre = np.array([depth, lateral])
    box = _box(centre, np.arctan2(lateral, depth) + np.radians(turn_deg), CAR, TELE)
    dets = Detections((Detection("Car", box, amodal=True),), InputFile("detections", "d.txt", "0" * 64))
    (obj,) = objects_from_detections(dets, TELE.width, TELE.height, lookups=label_lookups())
    hidden = np.degrees(CAR[1] / depth)
    assert np.degrees(fit_view_angle(TELE, centre, np.array(CAR), obj, PlacementParams())) == pytest.approx(
        turn_deg, abs=1.0 + hidden
    )


def test_camera_free_turn_is_close_far_away_and_short_near():
    # Without the camera, perspective (a near car's box is taller) reads as less turn.
    angles = []
    for depth in (50.0, 12.0):
        box = _box(np.array([depth, 0.0]), np.radians(20.0), CAR)
        angles.append(np.degrees(view_angle_from_box(box[2] - box[0], box[3] - box[1], CAR)))
    assert angles[0] == pytest.approx(20.0, abs=3.5)
    assert 5.0 < angles[1] < angles[0]


def test_candidate_nearest_the_road_and_its_facing():
    bearing = np.radians(10.0)
    # The road runs along +X, with traffic: the turn of 25 degrees goes to the side nearer 0.
    assert np.degrees(yaw_from_view_angle(np.radians(25.0), bearing, 0.0)) == pytest.approx(-15.0)
    # Oncoming (road yaw pi): same line, facing the other way.
    assert np.degrees(yaw_from_view_angle(np.radians(25.0), bearing, np.pi)) == pytest.approx(165.0)


def test_road_axis_takes_the_vanishing_direction_and_refuses_a_crossing():
    from usdworld.layout.yaw import road_axis

    pts = np.column_stack([np.linspace(5, 40, 200), np.where(np.arange(200) % 2, 4.0, -6.0)])  # lopsided
    axis = road_axis(pts, vanishing_angle=np.radians(2.0))
    assert axis.source == "vanishing_point" and axis.angle == pytest.approx(np.radians(2.0))
    np.testing.assert_allclose(axis.center_ground, np.median(pts, axis=0))
    assert road_axis(pts, vanishing_angle=np.radians(70.0)).source == "road_pca"
    assert road_axis(None, vanishing_angle=np.radians(3.0)).source == "vanishing_point"
    assert road_axis(None).source == "camera_forward"
