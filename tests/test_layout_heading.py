"""Headings from the side of the road and the traffic direction (layout.heading, layout.yaw.heading_for).

Known answers on a synthetic camera 1.65 m above the origin looking along +x and a road
along +x: a car ahead in the camera's lane moves away, an oncoming car one lane to the
left (right-hand traffic) faces the camera, ``traffic="left"`` mirrors both, a car
crossing ahead moves as on the crossing road's near side, and a person on the sidewalk
faces along the street.
"""

from __future__ import annotations

import numpy as np
import pytest

from usdworld.errors import InputError
from usdworld.io.class_table import load_class_table
from usdworld.io.types import Detection, Detections, InputFile
from usdworld.io.label_table import label_lookups
from usdworld.layout.boxes import box_corners, object_heading
from usdworld.layout.heading import (
    Heading,
    along_road_heading,
    crossing_heading,
    lateral_offset,
    traffic_heading,
)
from usdworld.layout.yaw import RoadAxis, heading_for
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.objects import objects_from_detections
from usdworld.geometry.camera import PinholeCamera

LANE = PlacementParams().lane_width_m
K = np.array([[721.5, 0.0, 609.6], [0.0, 721.5, 172.9], [0.0, 0.0, 1.0]])
CAM = PinholeCamera(1242, 375, K, 1.65)


def _axis(traffic: str = "right", angle: float = 0.0, centre=(0.0, 0.0)) -> RoadAxis:
    return RoadAxis(angle, np.array(centre, dtype=np.float64), "vanishing_point", traffic)


def _away(yaw: float, axis_angle: float = 0.0) -> bool:
    return abs(np.angle(np.exp(1j * (yaw - axis_angle)))) < 1e-9


def _towards(yaw: float, axis_angle: float = 0.0) -> bool:
    return abs(abs(np.angle(np.exp(1j * (yaw - axis_angle)))) - np.pi) < 1e-9


def test_lateral_offset_known_answers():
    assert lateral_offset(np.array([10.0, 2.0]), 0.0) == pytest.approx(2.0)
    assert lateral_offset(np.array([10.0, -3.0]), 0.0) == pytest.approx(-3.0)
    # A road turned 90 degrees left: a point ahead of the camera lies right of it.
    assert lateral_offset(np.array([5.0, 0.0]), np.pi / 2) == pytest.approx(-5.0)


def test_car_ahead_in_the_camera_lane_faces_away():
    h = heading_for("road", np.array([25.0, 0.6]), _axis())
    assert _away(h.yaw)
    assert h.source == "vanishing_point_traffic_right_camera_lane"


def test_lead_car_just_left_of_the_camera_line_is_not_flipped():
    # The old rule put the dividing line through the camera: a lead car 0.6 m left of it
    # was turned to face the camera (KITTI 000007).
    for y in (0.1, 0.6, 0.5 * LANE - 0.01):
        assert _away(heading_for("road", np.array([25.0, y]), _axis()).yaw)


def test_oncoming_car_on_the_left_faces_the_camera():
    h = heading_for("road", np.array([30.0, LANE]), _axis())
    assert _towards(h.yaw)
    assert h.source == "vanishing_point_traffic_right_opposite_side"
    far = traffic_heading(np.array([30.0, 1.5 * LANE]), 0.0, np.zeros(2), "right", LANE)
    assert far.confidence == pytest.approx(1.0)  # one lane past the divider; exactly on it 0.5
    on_line = traffic_heading(np.array([30.0, 0.5 * LANE]), 0.0, np.zeros(2), "right", LANE)
    assert on_line.confidence == pytest.approx(0.5)


def test_confidence_grows_from_the_divider():
    half = traffic_heading(np.array([30.0, LANE]), 0.0, np.zeros(2), "right", LANE)
    assert half.confidence == pytest.approx(0.75)


def test_car_on_the_right_moves_with_the_traffic():
    h = heading_for("road", np.array([20.0, -5.0]), _axis())
    assert _away(h.yaw)
    assert h.source.endswith("traffic_right_same_side")


def test_left_hand_traffic_mirrors():
    oncoming_right = heading_for("road", np.array([30.0, -LANE]), _axis("left"))
    with_traffic_left = heading_for("road", np.array([30.0, LANE]), _axis("left"))
    lead = heading_for("road", np.array([25.0, -0.6]), _axis("left"))
    assert _towards(oncoming_right.yaw) and oncoming_right.source.endswith("traffic_left_opposite_side")
    assert _away(with_traffic_left.yaw) and with_traffic_left.source.endswith("traffic_left_same_side")
    assert _away(lead.yaw)
    # The same car one lane left flips with the traffic side.
    assert _towards(heading_for("road", np.array([30.0, LANE]), _axis("right")).yaw)


def test_wide_road_centre_moves_the_divider():
    # Two lanes each way, the camera in the right one: the road region's centre line lies
    # one and a half lanes to its left, so a car one lane left moves with the camera.
    axis = _axis(centre=(20.0, LANE))
    assert _away(heading_for("road", np.array([30.0, LANE]), axis).yaw)
    assert _towards(heading_for("road", np.array([30.0, 2.0 * LANE]), axis).yaw)


def test_turned_road_axis():
    angle = np.radians(20.0)
    d, left = np.array([np.cos(angle), np.sin(angle)]), np.array([-np.sin(angle), np.cos(angle)])
    axis = _axis(angle=angle)
    assert _away(heading_for("road", 30.0 * d + 0.3 * left, axis).yaw, angle)
    assert _towards(heading_for("road", 30.0 * d + LANE * left, axis).yaw, angle)


def test_person_on_the_sidewalk_faces_along_the_street():
    for y in (-7.0, 7.0):
        h = heading_for("along_road", np.array([15.0, y]), _axis())
        assert _away(h.yaw) or _towards(h.yaw)
        assert h.confidence == 0.5
        assert h.source.startswith("vanishing_point_along_road_traffic_right_")
    assert _away(along_road_heading(np.array([15.0, -7.0]), 0.0, np.zeros(2), "right", LANE).yaw)


def test_unknown_traffic_side_is_refused():
    with pytest.raises(InputError, match="--traffic"):
        RoadAxis(0.0, np.zeros(2), "camera_forward", "middle")
    with pytest.raises(InputError):
        traffic_heading(np.array([1.0, 0.0]), 0.0, np.zeros(2), "up", LANE)


def test_heading_validates():
    with pytest.raises(ValueError):
        Heading(float("nan"), "x", 1.0)
    with pytest.raises(ValueError):
        Heading(0.0, "x", 1.5)


def _box_object(centre: np.ndarray, yaw: float):
    px, _ = CAM.project(box_corners(centre, yaw, np.array([4.2, 1.8, 1.5])))
    box = np.array([px[:, 0].min(), px[:, 1].min(), px[:, 0].max(), px[:, 1].max()])
    dets = Detections((Detection("Car", box, amodal=True),), InputFile("detections", "d.txt", "0" * 64))
    (obj,) = objects_from_detections(dets, CAM.width, CAM.height, lookups=label_lookups())
    return obj


@pytest.mark.parametrize(
    "centre, true_yaw, traffic",
    [
        (np.array([20.0, 0.3]), 0.0, "right"),  # lead car, slightly turned box
        (np.array([25.0, 3.5]), np.pi, "right"),  # oncoming on the left
        (np.array([25.0, 3.5]), 0.0, "left"),  # left-hand traffic: same side
        (np.array([25.0, -3.5]), np.pi, "left"),  # left-hand traffic: oncoming on the right
    ],
)
def test_box_aspect_keeps_the_side_rule_direction(centre, true_yaw, traffic):
    obj = _box_object(centre, true_yaw)
    prior = load_class_table()["car"]
    h = object_heading(prior, centre, _axis(traffic), obj, CAM, PlacementParams())
    assert h.source.startswith("box_aspect_vanishing_point_traffic_")
    assert abs(np.degrees(np.angle(np.exp(1j * (h.yaw - true_yaw))))) < 15.0


def test_crossing_traffic_moves_as_on_the_near_side():
    right, left = crossing_heading(0.1, "right"), crossing_heading(0.1, "left")
    assert np.degrees(right.yaw) == pytest.approx(np.degrees(0.1) - 90.0)  # left to right
    assert np.degrees(left.yaw) == pytest.approx(np.degrees(0.1) + 90.0)  # right to left
    assert right.confidence == left.confidence == 0.5
    assert right.source == "crossing_traffic_right_near_side"
    assert left.source == "crossing_traffic_left_near_side"
    with pytest.raises(InputError):
        crossing_heading(0.0, "middle")


@pytest.mark.parametrize(
    "centre, traffic",
    [
        (np.array([22.0, -9.0]), "right"),  # ahead on the right, crossing left to right
        (np.array([30.0, 6.0]), "right"),  # ahead on the left
        (np.array([22.0, -9.0]), "left"),  # left-hand traffic: right to left
    ],
)
def test_a_box_turned_across_the_road_crosses_it(centre, traffic):
    true_yaw = -np.pi / 2 if traffic == "right" else np.pi / 2
    obj = _box_object(centre, true_yaw)
    prior = load_class_table()["car"]
    h = object_heading(prior, centre, _axis(traffic), obj, CAM, PlacementParams())
    assert h.source == f"box_aspect_vanishing_point_crossing_traffic_{traffic}_near_side"
    assert abs(np.degrees(np.angle(np.exp(1j * (h.yaw - true_yaw))))) < 10.0
    assert h.confidence == 0.5
