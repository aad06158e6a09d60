"""``layout/camera_cues``: the street view, height observations, the road's top row, the vanishing yaw."""

from __future__ import annotations

import numpy as np
import pytest

from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.vanishing import VanishingPoint
from usdworld.io.asset_catalogue import AssetCatalogue, AssetSizes
from usdworld.io.class_table import load_class_table
from usdworld.io.types import CameraSpec, InputFile
from usdworld.layout.camera_cues import height_observations, road_top_row, street_view, vanishing_yaw
from usdworld.parameters import CameraParams, SceneParams
from usdworld.perception.objects import ImageObject

W, H = 1024, 512
K = np.array([[800.0, 0.0, 512.0], [0.0, 800.0, 256.0], [0.0, 0.0, 1.0]])
CURB = 0.15


def test_the_street_view_comes_from_the_vanishing_point_or_a_given_pitch():
    spec = CameraSpec(K, 1.2, np.radians(2.0), 0.0, 0.0, "cityscapes", InputFile("camera", "cam.json", "0" * 64))
    seen = street_view(spec, W, H, VanishingPoint(500.0, 240.0, 1.0, 30, 40), CURB, CameraParams())
    assert (seen.horizon_v, seen.focal_px, seen.vanishing_u) == (240.0, 800.0, 500.0)
    assert seen.camera_height_m == pytest.approx(1.2 - CURB)  # above the sidewalk
    # no vanishing point: the given pitch (2 deg down) puts the horizon 800 tan(2 deg) above row 256
    pitched = street_view(spec, W, H, None, CURB, CameraParams())
    assert pitched.vanishing_u is None
    assert pitched.horizon_v == pytest.approx(256.0 - 800.0 * np.tan(np.radians(2.0)), abs=0.01)
    assert street_view(None, W, H, None, CURB, CameraParams()) is None
    # no camera: the default field of view (60 deg) and the typical height (1.5 m)
    default = street_view(None, W, H, VanishingPoint(500.0, 240.0, 1.0, 30, 40), CURB, CameraParams())
    assert default.focal_px == pytest.approx(512.0 / np.tan(np.radians(30.0)))
    assert default.camera_height_m == pytest.approx(1.5 - CURB)


def test_road_top_row_needs_the_fraction_of_the_width():
    road = np.zeros((100, 1000), dtype=bool)
    road[60:, :] = True
    road[40, :4] = True  # 4 px: below 0.5 % of 1000 px
    road[50, :5] = True  # 5 px: exactly 0.5 %
    assert road_top_row(road, SceneParams()) == 50.0
    assert road_top_row(road, SceneParams(road_top_min_fraction=0.01)) == 60.0
    assert road_top_row(road, SceneParams(road_top_min_fraction=0.001)) == 40.0
    assert road_top_row(None, SceneParams()) is None
    assert road_top_row(np.zeros((10, 10), dtype=bool), SceneParams()) is None


def test_road_top_row_floor_in_pixels_for_narrow_images():
    road = np.zeros((20, 100), dtype=bool)
    road[5, :1] = True  # 0.5 % of 100 px is 0.5 px: the 2 px floor applies
    road[8, :2] = True
    assert road_top_row(road, SceneParams()) == 8.0
    assert road_top_row(road, SceneParams(road_top_min_px=1)) == 5.0


def test_vanishing_yaw_known_answers():
    cam = PinholeCamera(W, H, K, 1.5)
    assert vanishing_yaw(None, cam) is None
    assert vanishing_yaw(VanishingPoint(512.0, 256.0, 1.0, 10, 10), cam) == pytest.approx(0.0, abs=1e-12)
    # 800 px right of the centre is 45 degrees to the right: yaw -pi/4 (world Y is left)
    assert vanishing_yaw(VanishingPoint(1312.0, 256.0, 1.0, 10, 10), cam) == pytest.approx(-np.pi / 4)
    turned = PinholeCamera(W, H, K, 1.5, yaw=0.3)
    assert vanishing_yaw(VanishingPoint(512.0, 256.0, 1.0, 10, 10), turned) == pytest.approx(0.3)


def _person(ref: int, **flags: bool) -> ImageObject:
    box = np.array([500, 200, 520, 300], dtype=np.int64)
    defaults = {"bottom_truncated": False, "bottom_occluded": False, "top_truncated": False}
    return ImageObject(
        "person", "person", ref, box, np.ones((100, 20), dtype=bool), np.array([510.0, 300.0]),
        **{**defaults, **flags}, ref=ref,
    )


def test_height_observations_keep_rigid_whole_objects_only():
    table = load_class_table()
    catalogue = AssetCatalogue({"person": AssetSizes({"": (0.5, 0.5, 1.7)}, "")})
    objects = [_person(1), _person(2, top_truncated=True), _person(3, bottom_occluded=True)]
    obs = height_observations(objects, catalogue, table, W)
    prior = table["person"]
    assert obs.u.tolist() == [510.0] and obs.v_bottom.tolist() == [300.0] and obs.v_top.tolist() == [200.0]
    assert (obs.height_m[0], obs.height_std_m[0]) == (prior.size_m[2], prior.height_std_m)
    # without measures: the nearest contact half the footprint ahead of the centre, the top
    # right above the centre, so 0.25 m beyond the contact (seen end on)
    assert (obs.top_near_m[0], obs.top_far_m[0]) == pytest.approx((0.25, 0.25))
    assert len(height_observations([], catalogue, table, W).u) == 0
