"""``layout/surfaces``: which placed objects hide ground, the fill behind them, surface samples."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import load_class_table
from usdworld.layout.surfaces import fill_hidden_ground, ground_occluders, surface_points
from usdworld.parameters import SceneParams

W, H = 1024, 512
K = np.array([[800.0, 0.0, 512.0], [0.0, 800.0, 256.0], [0.0, 0.0, 1.0]])
CAM = PinholeCamera(W, H, K, 1.5)


def _placed(name: str, is_thing: bool, depth_m: float, size_m: tuple, box=(400, 300, 600, 400)):
    x0, y0, x1, y1 = box
    obj = SimpleNamespace(
        class_name=name, is_thing=is_thing, box_px=np.array(box), mask=np.ones((y1 - y0, x1 - x0), dtype=bool)
    )
    return SimpleNamespace(obj=obj, depth_m=depth_m, size_m=np.array(size_m, dtype=float))


def test_ground_occluders_are_things_and_thin_occluders_with_their_front_depth():
    table = load_class_table()
    car = _placed("car", True, 10.0, (4.0, 3.0, 1.5))
    pole = _placed("pole", False, 6.0, (0.3, 0.4, 6.0))
    building = _placed("building", False, 20.0, (10.0, 8.0, 12.0))
    near_car = _placed("car", True, 1.0, (4.0, 3.0, 1.5))
    out = ground_occluders([car, pole, building, near_car], table, 0.5)
    assert [o[2] for o in out] == [pytest.approx(7.5), pytest.approx(5.75), 0.5]  # front = centre - half diagonal
    assert out[0][0] is car.obj.box_px and out[0][1] is car.obj.mask
    assert ground_occluders([near_car], table, 0.2)[0][2] == 0.2


def test_fill_hidden_ground_continues_the_road_behind_a_car_within_the_reach():
    labels = np.full((H, W), 7, dtype=np.uint8)  # road
    labels[:256] = 23  # sky above the horizon
    car = _placed("car", True, 12.0, (4.0, 2.0, 1.5), box=(450, 330, 574, 356))
    labels[330:356, 450:574] = 26  # the car's pixels
    table = load_class_table()
    near = fill_hidden_ground(labels, [car], CAM, 0.0, table, SceneParams(fill_reach_m=1.0))
    front = 12.0 - np.hypot(4.0, 2.0) / 2.0
    v_far = 256.0 + (356.0 - 256.0) * front / (front + 1.0)  # the row 1 m behind its front (346.7)
    rows = np.nonzero((near[330:356, 450:574] == 7).all(axis=1))[0] + 330
    assert (rows.min(), rows.max()) == (int(np.ceil(v_far)), 355)
    assert (near[330 : int(np.ceil(v_far)), 450:574] == 26).all()  # beyond the reach: still the car
    whole = fill_hidden_ground(labels, [car], CAM, 0.0, table, SceneParams())  # 8 m reach: all of it
    assert (whole[330:356, 450:574] == 7).all()
    assert (whole[:330] == labels[:330]).all()


def test_surface_points_sample_cell_centres_within_range():
    mask = np.zeros((H, W), dtype=bool)
    mask[400:408, 508:516] = True  # 2 x 2 cells of 4 px
    pts = surface_points(mask, _ground_from_px(), CAM, 80.0, 4)
    expected, _ = CAM.ground_points(np.array([[510.0, 402.0], [514.0, 402.0], [510.0, 406.0], [514.0, 406.0]]))
    assert pts == pytest.approx(expected, abs=1e-6)
    assert surface_points(mask, _ground_from_px(), CAM, 5.0, 4).shape == (0, 2)  # all beyond 5 m (8 m away)
    assert surface_points(np.zeros((H, W), dtype=bool), _ground_from_px(), CAM, 80.0, 4) is None


def _ground_from_px() -> np.ndarray:
    """The ground homography of the level camera (DLT from its generated correspondences)."""
    from usdworld.geometry.camera import ground_correspondences
    from usdworld.geometry.homography import estimate_homography

    px, ground = ground_correspondences(CAM)
    return estimate_homography(px, ground).dst_from_src
