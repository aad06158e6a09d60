"""Known-answer tests of the contact-to-position chain (layout.cues, layout.drafting).

A car of the class's mean size is put in the world, its 3D box is projected with the
true camera the way KITTI draws its 2D labels (the rectangle round the eight projected
corners, so the box bottom is the footprint's nearest corner, not its centre), and the
box alone is placed with that camera: it must land at its true depth.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from usdworld.authoring.asset_library import library_dirs
from usdworld.authoring.asset_measures import asset_catalogue
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import load_class_table
from usdworld.layout.boxes import box_corners
from usdworld.layout.cues import with_camera_uncertainty
from usdworld.layout.draft import PlacementContext
from usdworld.layout.placement import place_objects
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.perception.objects import ImageObject

# KITTI camera 2 (frame 000000's P2) at its rig height, pitched 1 degree down, rolled 0.5.
K = np.array([[707.0493, 0.0, 604.0814], [0.0, 707.0493, 180.5066], [0.0, 0.0, 1.0]])
CAM = PinholeCamera(1242, 375, K, 1.65, math.radians(1.0), math.radians(0.5))


def _kitti_box(centre_xy: tuple[float, float], yaw: float, size_lwh: np.ndarray) -> ImageObject:
    """The 2D label KITTI would give: the rectangle round the projected 3D box."""
    px, depth = CAM.project(box_corners(np.array(centre_xy), yaw, size_lwh))
    assert np.all(depth > 0)
    x0, y0 = px.min(axis=0)
    x1, y1 = px.max(axis=0)
    assert 0 < x0 < x1 < CAM.width and 0 < y0 < y1 < CAM.height
    box = np.array([np.floor(x0), np.floor(y0), np.ceil(x1), np.ceil(y1)], dtype=np.int64)
    return ImageObject(
        class_name="car",
        source_label="Car",
        instance_id=0,
        box_px=box,
        mask=np.ones((box[3] - box[1], box[2] - box[0]), dtype=bool),
        contact_px=np.array([(x0 + x1) / 2.0, y1]),
        bottom_truncated=False,
        bottom_occluded=False,
        top_truncated=False,
        ref=0,
        box_only=True,
    )


@pytest.mark.parametrize(
    ("centre_xy", "yaw_deg"),
    [
        ((12.0, 0.0), 0.0),  # end on, straight ahead
        ((25.0, 3.5), 0.0),  # one lane to the left, driving away
        ((40.0, -3.5), 180.0),  # oncoming, one lane to the right
        ((18.0, 6.0), 30.0),  # turning across
    ],
)
def test_projected_kitti_car_is_placed_at_its_true_depth(centre_xy: tuple[float, float], yaw_deg: float) -> None:
    table = load_class_table()
    size = np.array(table["car"].size_m, dtype=np.float64)
    obj = _kitti_box(centre_xy, math.radians(yaw_deg), size)
    placements, _ = place_objects(
        [obj],
        CAM,
        np.linalg.inv(CAM.px_from_ground()),
        RoadAxis(0.0, np.zeros(2), "camera_forward"),
        asset_catalogue(["car"], library_dirs(None)),
        table,
        PlacementParams(),
    )
    (placed,) = placements
    true_depth = float(CAM.cam_from_world_points(np.array([[*centre_xy, 0.0]]))[0, 2])
    # Asset variants differ from the class's mean box by a few per cent in length and
    # height, which moves the centre behind the nearest corner by up to ~0.2 m and the
    # class-height cue by a few per cent: 4 % is that, not a bias of the chain.
    assert placed.depth_m == pytest.approx(true_depth, rel=0.04)


def test_road_unevenness_widens_the_contact_cue_of_a_given_camera() -> None:
    """A ground dz higher under the object moves its contact depth by d dz / h: with the
    camera given (no camera sigma) the cue is widened by that much alone."""
    params = PlacementParams(ground_height_sigma_m=0.14)
    ctx = PlacementContext(
        CAM, np.eye(3), RoadAxis(0.0, np.zeros(2), "camera_forward"), {}, load_class_table(), params
    )
    cue = with_camera_uncertainty(DepthCue("contact", 30.0, 0.3, "ground contact row"), ctx)
    ground = 30.0 * params.ground_height_sigma_m / CAM.height_m
    assert cue.sigma_m == pytest.approx(math.hypot(0.3, ground))
    assert "road unevenness included" in cue.note
    # The geometry behind it: the ray that meets the plane at depth d meets a ground raised
    # by dz at d (h - dz) / h (level camera).
    level = CAM.replace(pitch=0.0, roll=0.0)
    v = level.cy + level.fy * level.height_m / 30.0
    ray = level.rays_world(np.array([[level.cx, v]]))[0]
    dz = 0.1
    t = (level.height_m - dz) / -ray[2]
    assert t * ray[0] == pytest.approx(30.0 * (level.height_m - dz) / level.height_m)
