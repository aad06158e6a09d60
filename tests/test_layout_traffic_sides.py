"""The road's centre line from the vehicles' span (layout.traffic_sides, layout.heading.vehicle_span_centre).

Known answers on a KITTI-like camera 1.65 m above the origin looking along a road along
+x, with no road region seen (the axis's centre line unmeasured): on a road two lanes
wide each way a car one lane to the camera's left moves with the camera once an
oncoming car three lanes over shows how wide the road is.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.authoring.asset_library import library_dirs
from usdworld.authoring.asset_measures import asset_catalogue
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import load_class_table
from usdworld.io.label_table import label_lookups
from usdworld.io.types import Detection, Detections, InputFile
from usdworld.layout.boxes import box_corners
from usdworld.layout.heading import lateral_offset, vehicle_span_centre
from usdworld.layout.placement import place_objects
from usdworld.layout.traffic_sides import along_the_road
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.objects import objects_from_detections

K = np.array([[721.5, 0.0, 609.6], [0.0, 721.5, 172.9], [0.0, 0.0, 1.0]])
CAM = PinholeCamera(1242, 375, K, 1.65)
LANE = PlacementParams().lane_width_m


def test_span_centre_known_answers():
    # Vehicles from 3 m right to 11 m left of the camera: the centre line 4 m left.
    np.testing.assert_allclose(
        vehicle_span_centre(np.array([[30.0, 2.5], [40.0, 11.0], [20.0, -3.0]]), 0.0), [0.0, 4.0]
    )
    # The camera is on the road: vehicles only to its left span from the camera.
    np.testing.assert_allclose(vehicle_span_centre(np.array([[30.0, 6.0]]), 0.0), [0.0, 3.0])
    # No vehicle: the camera's own line.
    np.testing.assert_allclose(vehicle_span_centre(np.zeros((0, 2)), 0.3), [0.0, 0.0], atol=1e-12)
    # A road turned 90 degrees left: offsets are measured across it.
    turned = vehicle_span_centre(np.array([[-4.0, 10.0]]), np.pi / 2)
    np.testing.assert_allclose(turned, [-2.0, 0.0], atol=1e-12)


@settings(max_examples=50, deadline=None)
@given(
    offsets=st.lists(st.floats(-20.0, 20.0), min_size=1, max_size=8),
    angle=st.floats(-1.0, 1.0),
    along=st.floats(5.0, 60.0),
)
def test_span_centre_lies_midway_between_the_outermost(offsets, angle, along):
    d, left = np.array([np.cos(angle), np.sin(angle)]), np.array([-np.sin(angle), np.cos(angle)])
    pts = np.array([along * d + t * left for t in offsets])
    centre = vehicle_span_centre(pts, angle)
    t = lateral_offset(centre, angle)
    lo, hi = min(offsets + [0.0]), max(offsets + [0.0])
    assert t == pytest.approx(0.5 * (lo + hi), abs=1e-9)
    assert abs(float(np.dot(centre, d))) < 1e-9  # abreast of the camera
    # Another vehicle inside the span moves nothing.
    inner = np.vstack([pts, along * d + 0.5 * (lo + hi) * left])
    np.testing.assert_allclose(vehicle_span_centre(inner, angle), centre, atol=1e-9)


def test_along_the_road_either_way():
    assert along_the_road(0.1, 0.0) and along_the_road(np.pi - 0.1, 0.0)
    assert not along_the_road(np.pi / 2 + 0.2, 0.0) and not along_the_road(-np.pi / 2, 0.0)
    assert along_the_road(np.pi / 2, np.pi / 2 - 0.3)


def _cars(cars: list[tuple[tuple[float, float], float]]):
    dets = []
    for centre, yaw in cars:
        px, _ = CAM.project(box_corners(np.array(centre), yaw, np.array([4.2, 1.8, 1.5])))
        box = np.array([px[:, 0].min(), px[:, 1].min(), px[:, 0].max(), px[:, 1].max()])
        dets.append(Detection("Car", box, amodal=True))
    detections = Detections(tuple(dets), InputFile("detections", "d.txt", "0" * 64))
    return objects_from_detections(detections, CAM.width, CAM.height, lookups=label_lookups())


def _place(objects, center_source: str):
    sizes = asset_catalogue((o.class_name for o in objects), library_dirs(None))
    axis = RoadAxis(0.0, np.zeros(2), "vanishing_point", "right", center_source)
    placements, _ = place_objects(
        objects, CAM, np.linalg.inv(CAM.px_from_ground()), axis, sizes, load_class_table(), PlacementParams()
    )
    return {p.obj.instance_id: p for p in placements}


def _faces_away(yaw: float) -> bool:
    return abs(float(np.angle(np.exp(1j * yaw)))) < np.radians(30.0)


def _faces_camera(yaw: float) -> bool:
    return abs(float(np.angle(np.exp(1j * yaw)))) > np.radians(150.0)


def test_a_wide_road_read_from_its_vehicles_keeps_the_left_lane_with_the_camera():
    # Two lanes each way, the camera in the right one: a car one lane to its left moves
    # with it, an oncoming car three lanes over and a car parked at the right kerb (its
    # centre 0.8 lane right of the camera's). A car a whole lane right would put the span's
    # middle, (-LANE + 3 LANE) / 2, exactly on the left-lane car, whose side millimetres
    # of placement error would then decide.
    objects = _cars([((30.0, LANE), 0.0), ((45.0, 3.0 * LANE), np.pi), ((25.0, -0.8 * LANE), 0.0)])
    placed = _place(objects, "camera")
    left_lane, oncoming, right = (placed[i] for i in range(3))
    assert _faces_away(left_lane.yaw) and "vehicle_span_traffic_right_same_side" in left_lane.yaw_source
    assert _faces_camera(oncoming.yaw)
    assert oncoming.yaw_source.endswith("vehicle_span_traffic_right_opposite_side")
    assert _faces_away(right.yaw)
    assert 0.5 <= left_lane.yaw_confidence < 1.0


def test_a_seen_road_region_keeps_its_centre_line():
    # The same cars with a road region whose centre is the camera's line: the region
    # decides, and the car one lane left is oncoming.
    objects = _cars([((30.0, LANE), 0.0), ((45.0, 3.0 * LANE), np.pi), ((25.0, -LANE), 0.0)])
    placed = _place(objects, "road_region")
    assert _faces_camera(placed[0].yaw) and "vehicle_span" not in placed[0].yaw_source


def test_the_axis_says_what_gave_its_centre_line():
    from usdworld.layout.yaw import road_axis

    pts = np.column_stack([np.linspace(5, 40, 200), np.where(np.arange(200) % 2, 4.0, -6.0)])
    assert road_axis(pts, vanishing_angle=0.02).center_source == "road_region"
    assert road_axis(pts).center_source == "road_region"
    assert road_axis(None, vanishing_angle=0.02).center_source == "camera"
    assert road_axis(None).center_source == "camera"
    with pytest.raises(ValueError, match="center_source"):
        RoadAxis(0.0, np.zeros(2), "camera_forward", "right", "kerb")
