"""Yaw from a box's aspect (layout.yaw.view_angle_from_box, line_from_view_angles and facing;
layout.boxes.fit_view_angle and fit_view_angles)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.geometry.camera import PinholeCamera
from usdworld.io.label_table import label_lookups
from usdworld.io.types import Detection, Detections, InputFile
from usdworld.layout.boxes import box_corners, fit_view_angle, fit_view_angles
from usdworld.layout.yaw import facing, line_from_view_angles, view_angle_from_box
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
    line, across = line_from_view_angles((np.radians(25.0),), bearing, 0.0)
    assert np.degrees(facing(line, 0.0)) == pytest.approx(-15.0) and not across
    # Oncoming (road yaw pi): same line, facing the other way.
    assert np.degrees(facing(line, np.pi)) == pytest.approx(165.0)


def test_a_turn_across_the_road_gives_the_crossing_line():
    # Seen 25 degrees right of ahead and turned 68 degrees from the line of sight: -93
    # degrees lies 3 degrees from across the road, 43 degrees lies 43 from along it.
    line, across = line_from_view_angles((np.radians(68.0),), np.radians(-25.0), 0.0)
    assert across and np.degrees(line) == pytest.approx(-93.0)
    # Exactly half-way (45 degrees either side): along the road.
    line, across = line_from_view_angles((np.radians(45.0),), 0.0, 0.0)
    assert not across and abs(np.degrees(line)) == pytest.approx(45.0)
    # Of two turns, the one that lies along the road wins over one that lies near neither.
    line, across = line_from_view_angles((np.radians(40.0), np.radians(12.0)), np.radians(10.0), 0.0)
    assert not across and np.degrees(line) == pytest.approx(-2.0)


@settings(max_examples=40, deadline=None)
@given(turn=st.floats(0.0, np.pi / 2), bearing=st.floats(-0.8, 0.8), axis=st.floats(-0.5, 0.5))
def test_the_line_kept_is_one_the_turn_allows_and_faces_either_way(turn, bearing, axis):
    line, across = line_from_view_angles((turn,), bearing, axis)
    off = abs(np.angle(np.exp(2j * (line - bearing)))) / 2  # from the line of sight, modulo pi
    assert off == pytest.approx(turn, abs=1e-9)
    from_axis = abs(np.angle(np.exp(2j * (line - axis)))) / 2
    assert across == (from_axis > np.pi / 4)
    for towards in (axis, axis + np.pi):
        assert abs(np.angle(np.exp(1j * (facing(line, towards) - towards)))) <= np.pi / 2 + 1e-12


def test_both_slopes_of_an_aspect_past_side_on():
    # 55 m ahead, a car turned 55 degrees shows a wider box than side on (4.2 sin 55 +
    # 1.8 cos 55 = 4.47 m against 4.2 m), and so does one turned 80 degrees: the aspect is
    # met on both slopes, and the true turn is one of the two (fit_view_angle gives the
    # peak between them, 69 degrees).
    centre = np.array([55.0, 0.5])
    bearing = np.arctan2(centre[1], centre[0])
    for turn_deg in (55.0, 80.0):
        box = _box(centre, bearing + np.radians(turn_deg), CAR, TELE)
        dets = Detections((Detection("Car", box, amodal=True),), InputFile("detections", "d.txt", "0" * 64))
        (obj,) = objects_from_detections(dets, TELE.width, TELE.height, lookups=label_lookups())
        turns = fit_view_angles(TELE, centre, np.array(CAR), obj, PlacementParams())
        assert len(turns) == 2 and turns[0] < turns[1]
        assert min(abs(np.degrees(t) - turn_deg) for t in turns) < 1.5
        peak = np.degrees(fit_view_angle(TELE, centre, np.array(CAR), obj, PlacementParams()))
        assert np.degrees(turns[0]) < peak < np.degrees(turns[1])


def test_road_axis_takes_the_vanishing_direction_and_refuses_a_crossing():
    from usdworld.layout.yaw import road_axis

    pts = np.column_stack([np.linspace(5, 40, 200), np.where(np.arange(200) % 2, 4.0, -6.0)])  # lopsided
    axis = road_axis(pts, vanishing_angle=np.radians(2.0))
    assert axis.source == "vanishing_point" and axis.angle == pytest.approx(np.radians(2.0))
    np.testing.assert_allclose(axis.center_ground, np.median(pts, axis=0))
    assert road_axis(pts, vanishing_angle=np.radians(70.0)).source == "road_pca"
    assert road_axis(None, vanishing_angle=np.radians(3.0)).source == "vanishing_point"
    assert road_axis(None).source == "camera_forward"
