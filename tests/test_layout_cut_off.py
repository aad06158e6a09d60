"""Objects cut by the image border: placed from the cues still seen (known answers on a level camera)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from usdworld.authoring.asset_library import library_dirs
from usdworld.authoring.asset_measures import asset_catalogue
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import load_class_table
from usdworld.io.detections import read_kitti_labels
from usdworld.io.label_table import label_lookups
from usdworld.layout.cues import front_depth, truncated_normal_median
from usdworld.layout.draft import DepthMethod, PlacementContext
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.objects import ImageObject, border_sides, objects_from_detections

TABLE = load_class_table()
PARAMS = PlacementParams()
FORWARD = RoadAxis(0.0, np.zeros(2), "camera_forward")


def _camera(height_m: float, width: int = 1242, height: int = 375, f: float = 721.0, cy: float = 173.0) -> PinholeCamera:
    K = np.array([[f, 0.0, width / 2.0], [0.0, f, cy], [0.0, 0.0, 1.0]])
    return PinholeCamera(width, height, K, height_m)


def _box_of(camera: PinholeCamera, centre: tuple[float, float], size: tuple[float, float, float]) -> np.ndarray:
    """The projected 3D box (world x forward, y left, z up; axis-aligned) as an unclipped 2D box."""
    (x, y), (l, w, h) = centre, size
    corners = np.array([(x + sx * l / 2, y + sy * w / 2, z) for sx in (-1, 1) for sy in (-1, 1) for z in (0.0, h)])
    px, _ = camera.project(corners)
    return np.array([px[:, 0].min(), px[:, 1].min(), px[:, 0].max(), px[:, 1].max()])


def _box_object(camera: PinholeCamera, class_name: str, box: np.ndarray) -> ImageObject:
    """A box-only (amodal, KITTI-like) detection clipped to the image, flagged as perception does."""
    W, H = camera.width, camera.height
    clipped = np.clip(box, [0, 0, 0, 0], [W - 1, H - 1, W - 1, H - 1])
    left, right, top, bottom = border_sides(clipped, W, H)
    ib = np.array([np.floor(clipped[0]), np.floor(clipped[1]), np.ceil(clipped[2]), np.ceil(clipped[3])], np.int64)
    return ImageObject(
        class_name=class_name,
        source_label=class_name,
        instance_id=0,
        box_px=ib,
        mask=np.ones((ib[3] - ib[1], ib[2] - ib[0]), bool),
        contact_px=np.array([(clipped[0] + clipped[2]) / 2, clipped[3]]),
        bottom_truncated=bottom,
        bottom_occluded=False,
        top_truncated=top,
        left_truncated=left,
        right_truncated=right,
        ref=0,
        box_only=True,
    )


def _ctx(camera: PinholeCamera, class_name: str) -> PlacementContext:
    sizes = asset_catalogue([class_name], library_dirs(None))
    return PlacementContext(camera, np.linalg.inv(camera.px_from_ground()), FORWARD, sizes, TABLE, PARAMS, None)


def test_truncated_normal_median_known_values() -> None:
    assert truncated_normal_median(3.0, 1.0, -100.0, 100.0) == pytest.approx(3.0)
    # A flat prior within the bounds: the midpoint.
    assert truncated_normal_median(0.0, 1e6, 2.0, 4.0) == pytest.approx(3.0, abs=1e-3)
    # Symmetric truncation keeps the mean; one-sided truncation moves the median away from the cut.
    assert truncated_normal_median(3.0, 1.0, 1.0, 5.0) == pytest.approx(3.0)
    assert truncated_normal_median(3.0, 1.0, 0.0, 3.5) < 3.0
    # The interval far in a tail: its end nearer the mean.
    assert truncated_normal_median(100.0, 1.0, 0.0, 5.0) == 5.0


def test_a_car_cut_by_the_bottom_edge_is_placed_from_its_width_and_top_row() -> None:
    camera = _camera(1.65)
    l, w, h = TABLE["car"].size_m
    # Driving away straight ahead, its rear face 3.9 m in front: the rear bottom edge projects
    # ~100 px below the image, both sides are seen.
    box = _box_of(camera, (3.9 + l / 2, 0.0), (l, w, h))
    assert box[3] > camera.height + 50 and 0 < box[0] and box[2] < camera.width
    obj = _box_object(camera, "car", box)
    assert obj.cut_sides == ("bottom",)
    front = front_depth(obj, _ctx(camera, "car"), None)
    assert front.method is DepthMethod.CUT_OFF
    assert front.depth_m == pytest.approx(3.9, rel=0.05)
    cue = {c.name: c for c in front.cues}["cut_off"]
    assert "cut at bottom" in cue.note and "width" in cue.note and "top row" in cue.note
    # The cut edge alone (the old placement) would put its front at the bottom row's ground, ~5.9 m.
    bottom_row_ground = camera.fy * 1.65 / (camera.height - 1 - camera.cy)
    assert bottom_row_ground > 1.4 * 3.9


def test_a_pedestrian_with_cut_feet_is_placed_from_its_head_row() -> None:
    camera = _camera(1.5, width=1024, height=512, f=800.0, cy=256.0)
    l, w, h = TABLE["person"].size_m
    box = _box_of(camera, (3.0, 0.0), (0.0001, w, h))  # a flat person 3 m ahead: head row exact
    obj = _box_object(camera, "person", box)
    assert obj.cut_sides == ("bottom",)
    front = front_depth(obj, _ctx(camera, "person"), None)
    assert front.method is DepthMethod.CUT_OFF
    # Head 0.25 m above the camera, height spread 0.1 m: a broad top-row cue (sigma ~1.2 m)
    # cut at ~4.3 m by the visible height; its median stays within 10 % of the truth.
    assert front.depth_m == pytest.approx(3.0, rel=0.1)
    note = {c.name: c for c in front.cues}["cut_off"].note
    assert "top row" in note and "width" not in note


def test_a_car_cut_at_the_bottom_and_a_side_uses_no_width_and_stays_within_its_bounds() -> None:
    camera = _camera(1.65)
    l, w, h = TABLE["car"].size_m
    box = _box_of(camera, (4.0 + l / 2, 3.0), (l, w, h))  # beside the camera, running out at the left
    obj = _box_object(camera, "car", box)
    assert obj.cut_sides == ("left", "bottom")
    front = front_depth(obj, _ctx(camera, "car"), None)
    assert front.method is DepthMethod.CUT_OFF
    note = {c.name: c for c in front.cues}["cut_off"].note
    assert "width" not in note and "cut at left, bottom" in note
    bound = camera.fy * 1.65 / (obj.contact_px[1] - camera.cy)
    assert 0.0 < front.depth_m < bound


def test_a_truck_cut_at_the_top_bottom_and_side_is_placed_in_the_middle_of_its_bounds() -> None:
    """With no cue still seen, the uniform prior within (near plane, bound] decides: its middle.

    A truck beside the camera, its rear 2 m ahead, fills the image's left edge from top to
    bottom. The bound (the image's bottom row's ground, nearer than the cut height's depth)
    is the farthest it can be; the middle of the interval is the median of the uniform prior.
    """
    camera = _camera(1.65)
    l, w, h = TABLE["truck"].size_m
    box = _box_of(camera, (2.0 + l / 2, 2.5), (l, w, h))
    obj = _box_object(camera, "truck", box)
    assert obj.cut_sides == ("left", "top", "bottom")
    front = front_depth(obj, _ctx(camera, "truck"), None)
    assert front.method is DepthMethod.CUT_OFF
    contact_bound = camera.fy * 1.65 / (obj.contact_px[1] - camera.cy)
    height_bound = camera.fy * h / obj.height_px
    hi = min(contact_bound, height_bound)
    assert hi == pytest.approx(contact_bound)
    assert front.depth_m == pytest.approx(0.5 * (PARAMS.near_plane_m + hi), rel=1e-9)
    cue = {c.name: c for c in front.cues}["cut_off"]
    assert "no cue still seen" in cue.note and "cut at left, top, bottom" in cue.note
    assert cue.sigma_m == pytest.approx((hi - PARAMS.near_plane_m) / np.sqrt(12.0))
    # Nearer the truth (2 m) than the bound the placement used to take (~5.9 m).
    assert abs(front.depth_m - 2.0) < 0.5 * abs(hi - 2.0)


def test_border_sides() -> None:
    assert border_sides(np.array([0.0, 10.0, 50.0, 374.0]), 1242, 375) == (True, False, False, True)
    assert border_sides(np.array([1100.0, 1.0, 1241.0, 300.0]), 1242, 375) == (False, True, True, False)
    assert border_sides(np.array([10.0, 10.0, 50.0, 300.0]), 1242, 375) == (False, False, False, False)
    # Marked truncated, touching no border: cut on the side nearest it (here the left).
    assert border_sides(np.array([3.0, 10.0, 50.0, 300.0]), 1242, 375, 0.2) == (True, False, False, False)


def test_a_kitti_label_marked_truncated_is_cut(tmp_path: Path) -> None:
    path = tmp_path / "000000.txt"
    path.write_text(
        "Car 0.88 3 -0.69 0.00 192.37 402.31 374.00 1.60 1.57 3.23 -2.70 1.74 3.68 -1.29\n"
        "Car 0.30 0 -0.69 3.00 192.37 102.31 300.00 1.60 1.57 3.23 -2.70 1.74 8.68 -1.29\n"
        "Car 0.00 0 1.74 741.18 168.83 792.25 208.43 1.70 1.63 4.08 7.24 1.55 33.20 1.95\n"
        "Car -1 -1 1.74 741.18 168.83 792.25 208.43 1.70 1.63 4.08 7.24 1.55 33.20 1.95 0.9\n"
    )
    dets = read_kitti_labels(path)
    assert [d.truncated for d in dets.items] == [0.88, 0.30, 0.0, 0.0]
    objs = sorted(objects_from_detections(dets, 1242, 375, lookups=label_lookups()), key=lambda o: o.ref)
    assert [o.cut_sides for o in objs] == [("left", "bottom"), ("left",), (), ()]
    bad = tmp_path / "bad.txt"
    bad.write_text("Car 1.5 0 0 0 10 50 300 1 1 1 0 0 5 0\n")
    with pytest.raises(Exception, match="truncated"):
        read_kitti_labels(bad)
