"""A car cut by the image's left or right border is placed from its seen edge and its contact row."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from usdworld.authoring.asset_library import library_dirs
from usdworld.authoring.asset_measures import asset_catalogue
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import load_class_table
from usdworld.layout.boxes import box_corners, lowest_row_inside, place_border_cut
from usdworld.layout.draft import PlacementContext
from usdworld.layout.drafting import draft_object
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.objects import ImageObject

TABLE = load_class_table()
PARAMS = PlacementParams()
FORWARD = RoadAxis(0.0, np.zeros(2), "camera_forward")
CAMERA = PinholeCamera(1242, 375, np.array([[721.0, 0.0, 621.0], [0.0, 721.0, 173.0], [0.0, 0.0, 1.0]]), 1.65)


def _seen(camera: PinholeCamera, centre: np.ndarray, yaw: float, size: np.ndarray) -> ImageObject | None:
    """A box-only detection of the car's part inside the image: its columns there, and its bottom
    at the lowest row its footprint reaches inside the image (None unless one side is cut)."""
    corners = box_corners(centre, yaw, size)
    px, _ = camera.project(corners)
    W = float(camera.width)
    x0, x1 = max(float(px[:, 0].min()), 0.0), min(float(px[:, 0].max()), W)
    if (x0 <= 0.0) == (x1 >= W) or x1 - x0 < 4.0:
        return None
    foot, _ = camera.project(corners[[0, 1, 3, 2]])  # the bottom four, round the rim
    bottom, top = lowest_row_inside(foot, W), max(float(px[:, 1].min()), 0.0)
    if not top < bottom < camera.height:
        return None
    edges = np.array([x0, top, x1, bottom])
    box = np.array([np.floor(x0), np.floor(top), np.ceil(x1), np.ceil(bottom)], dtype=np.int64)
    return ImageObject(
        class_name="car",
        source_label="car",
        instance_id=0,
        box_px=box,
        mask=np.ones((box[3] - box[1], box[2] - box[0]), dtype=bool),
        contact_px=np.array([0.5 * (x0 + x1), bottom]),
        bottom_truncated=False,
        bottom_occluded=False,
        top_truncated=False,
        left_truncated=x0 <= 0.0,
        right_truncated=x1 >= W,
        ref=0,
        box_only=True,
        box_edges_px=edges,
    )


def _drafted(camera: PinholeCamera, u: float, v: float) -> np.ndarray:
    """The contact pixel's ground point, (2,) float64."""
    ground, _ = camera.ground_points(np.array([[u, v]]))
    return ground[0, :2]


@settings(max_examples=100, deadline=None)
@given(
    x=st.floats(8.0, 30.0),
    across=st.floats(-1.2, 1.2),
    side=st.sampled_from([-1.0, 1.0]),
    yaw=st.sampled_from([0.0, np.pi]),
)
def test_the_solve_finds_the_centre_whose_seen_part_makes_the_box(x: float, across: float, side: float, yaw: float) -> None:
    # A parked car along the road straddling one border (``across`` metres from where the
    # border's ray meets its row): its inner edge and the lowest row of its footprint inside
    # the image fix its centre, whatever its contact's ray.
    y = side * (x * CAMERA.cx / CAMERA.fx + across)
    size = np.array(TABLE["car"].size_m, dtype=np.float64)
    truth = np.array([x, y])
    seen = _seen(CAMERA, truth, yaw, size)
    assume(seen is not None)
    start = _drafted(CAMERA, *seen.contact_px) + np.array([0.5 * size[0], 0.0])
    placed = place_border_cut(CAMERA, start, yaw, size, size[:2], seen, PARAMS)
    assert placed is not start
    assert np.linalg.norm(placed - truth) < 0.01


def test_a_car_cut_by_the_right_border_is_drafted_where_it_stands() -> None:
    # Parked 9 m ahead and 7 m right along the road; the right border cuts off its near end.
    # Its contact row is the footprint's lowest row at the border, not its nearest corner's: the
    # old draft (half a length beyond the contact along its ray) put it 0.58 m off.
    sizes = asset_catalogue(["car"], library_dirs(None))
    ctx = PlacementContext(CAMERA, np.linalg.inv(CAMERA.px_from_ground()), FORWARD, sizes, TABLE, PARAMS, None)
    truth = np.array([9.0, -7.0])
    # The draft's own size for this box (its variant from the height seen), found by drafting once.
    size = np.array(TABLE["car"].size_m, dtype=np.float64)
    for _ in range(3):
        seen = _seen(CAMERA, truth, 0.0, size)
        assert seen is not None and seen.right_truncated and not seen.left_truncated
        draft = draft_object(seen, "car_0000", ctx)
        size = np.asarray(draft.size, dtype=np.float64)
    assert np.linalg.norm(draft.ground[:2] - truth) < 0.05
    assert draft.depth_m == pytest.approx(float(CAMERA.cam_from_world_points(np.array([[*truth, 0.0]]))[0, 2]), abs=0.05)
