"""A box cut on one side (by the image border or by a nearer object) is aligned by its seen edge."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.geometry.camera import PinholeCamera
from usdworld.layout.boxes import align_box_columns, box_corners
from usdworld.parameters.perception import PerceptionParams
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.objects import ImageObject, hidden_sides

CAMERA = PinholeCamera(512, 256, np.array([[281.0, 0.0, 256.0], [0.0, 281.0, 128.0], [0.0, 0.0, 1.0]]), 1.3)
SIZE = np.array([4.5, 1.85, 1.5])


def _seen(left: float, right: float, **flags: bool) -> ImageObject:
    """A car's image evidence whose box spans columns [left, right) (sub-pixel edges)."""
    x0, x1 = int(np.floor(left)), int(np.ceil(right))
    return ImageObject(
        class_name="car",
        source_label="car",
        instance_id=26000,
        box_px=np.array([x0, 120, x1, 140]),
        mask=np.ones((20, x1 - x0), dtype=bool),
        contact_px=np.array([0.5 * (left + right), 139.5]),
        bottom_truncated=False,
        bottom_occluded=False,
        top_truncated=False,
        box_edges_px=np.array([left, 120.0, right, 140.0]),
        **flags,
    )


def _columns(centre: np.ndarray, yaw: float) -> tuple[float, float]:
    px, _ = CAMERA.project(box_corners(centre, yaw, SIZE))
    return float(px[:, 0].min()), float(px[:, 0].max())


def _start(centre: np.ndarray, left: float, right: float) -> np.ndarray:
    """The ground point on the ray of the seen box's centre column, as far ahead as the car."""
    ray = CAMERA.rays_world(np.array([[0.5 * (left + right), 139.5]]))[0]
    t = float(centre[0] / ray[0])
    return (CAMERA.center_world + ray * t)[:2]


def test_a_car_behind_another_in_a_parked_row_is_placed_by_its_seen_edge() -> None:
    # A parked car 40 m ahead, 2.5 m right, along the road: a nearer car hides its right
    # part, 3 px of its left side show. Its centre lies where its whole box's left edge is
    # the seen one; the seen sliver's centre column is 0.3 m off across the ray.
    truth = np.array([40.0, -2.5])
    u0, u1 = _columns(truth, 0.0)
    seen = _seen(u0, u0 + 3.0, right_hidden=True)
    start = _start(truth, u0, u0 + 3.0)
    placed = align_box_columns(CAMERA, start, 0.0, SIZE, seen, PlacementParams())
    assert np.linalg.norm(start - truth) > 0.25
    assert abs(placed[1] - truth[1]) < 0.02
    # Unhidden, the same sliver is a whole (narrow) object: centred on it.
    whole = align_box_columns(CAMERA, start, 0.0, SIZE, _seen(u0, u0 + 3.0), PlacementParams())
    assert abs(whole[1] - truth[1]) > 0.25


def test_a_car_cut_by_the_image_border_is_left_where_its_seen_part_is() -> None:
    # A car 12 m ahead, 9.5 m left: the left border cuts it. Its contact row is not its
    # nearest contact (that is out of view), so its seen edge alone is not used.
    truth = np.array([12.0, 9.5])
    u0, u1 = _columns(truth, 0.0)
    assert u0 < 0.0 < u1
    start = _start(truth, 0.0, u1)
    placed = align_box_columns(CAMERA, start, 0.0, SIZE, _seen(0.0, u1, left_truncated=True), PlacementParams())
    assert np.array_equal(placed, start)


@settings(max_examples=200, deadline=None)
@given(
    x=st.floats(8.0, 80.0),
    y=st.floats(-8.0, 8.0),
    yaw=st.floats(-0.3, 0.3),
    keep=st.floats(0.2, 0.8),
    side=st.sampled_from(["left", "right"]),
)
def test_the_seen_edge_is_matched_whichever_side_is_hidden(x: float, y: float, yaw: float, keep: float, side: str) -> None:
    truth = np.array([x, y])
    u0, u1 = _columns(truth, yaw)
    if not (1.0 < u0 and u1 < CAMERA.width - 1.0 and u1 - u0 > 2.0):
        return
    cut = u0 + keep * (u1 - u0)
    left, right = (u0, cut) if side == "left" else (cut, u1)
    seen = _seen(left, right, right_hidden=side == "left", left_hidden=side == "right")
    start = _start(truth, left, right)
    placed = align_box_columns(CAMERA, start, yaw, SIZE, seen, PlacementParams())
    p0, p1 = _columns(placed, yaw)
    assert abs((p0 - u0) if side == "left" else (p1 - u1)) < 0.25
    assert np.linalg.norm(placed - start) <= 0.5 * np.hypot(SIZE[0], SIZE[1]) + 1e-9


def test_a_side_is_hidden_by_an_object_standing_nearer_only() -> None:
    # Object 2 (a car behind) shows a sliver left of object 1 (nearer: its bottom is lower).
    owner = np.zeros((60, 80), dtype=np.int32)
    owner[20:50, 30:60] = 1
    owner[18:40, 26:30] = 2
    bottoms = np.array([-1, 49, 39])
    fraction = PerceptionParams().hidden_side_fraction
    far = owner[18:40, 26:30] == 2
    near = owner[20:50, 30:60] == 1
    assert hidden_sides(far, 26, 18, owner, 2, bottoms, fraction) == (False, True)
    # The nearer car's left side borders the farther one: that hides nothing of it.
    assert hidden_sides(near, 30, 20, owner, 1, bottoms, fraction) == (False, False)
    # A side at the image border is cut, not hidden.
    owner2 = np.zeros((60, 80), dtype=np.int32)
    owner2[20:50, 0:10] = 1
    assert hidden_sides(owner2[20:50, 0:10] == 1, 0, 20, owner2, 1, np.array([-1, 49]), fraction) == (False, False)


def test_without_a_heading_a_hidden_side_is_not_taken_as_cut() -> None:
    # A person turned to the camera for want of a heading: which corner makes the seen edge
    # is unknown, so the box is centred as if whole, and a border-cut one is left alone.
    truth = np.array([20.0, -2.0])
    size = np.array([0.6, 0.6, 1.75])
    px, _ = CAMERA.project(box_corners(truth, 0.0, size))
    u0, u1 = float(px[:, 0].min()), float(px[:, 0].max())
    start = _start(truth, u0, u1) + np.array([0.0, 0.2])
    hidden = _seen(u0, u1, right_hidden=True)
    params = PlacementParams()
    assert np.allclose(
        align_box_columns(CAMERA, start, 0.0, size, hidden, params, heading_known=False),
        align_box_columns(CAMERA, start, 0.0, size, _seen(u0, u1), params),
    )
    cut = _seen(0.0, u1, left_truncated=True)
    assert np.array_equal(align_box_columns(CAMERA, start, 0.0, size, cut, params, heading_known=False), start)
