"""Depth from an object's image height with its own depth extent (layout.silhouette)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.geometry.camera import PinholeCamera
from usdworld.layout.silhouette import depth_from_silhouette, depth_from_top_row, silhouette_rows, top_offsets
from usdworld.parameters.placement import PlacementParams

PARAMS = PlacementParams()

K = np.array([[721.5, 0.0, 609.6], [0.0, 721.5, 172.9], [0.0, 0.0, 1.0]])
CAM = PinholeCamera(1242, 375, K, 1.65, pitch=np.radians(0.5))


def _projected_box(
    centre_xy: np.ndarray, yaw: float, lwh: tuple[float, float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """Image box of a 3D box standing on the ground, and its nearest-corner pixel."""
    l, w, h = lwh
    c, s = np.cos(yaw), np.sin(yaw)
    local = np.array([[sx * l / 2, sy * w / 2] for sx in (-1, 1) for sy in (-1, 1)])
    foot = centre_xy + local @ np.array([[c, s], [-s, c]])
    pts = np.vstack([np.column_stack([foot, np.zeros(4)]), np.column_stack([foot, np.full(4, h)])])
    px, depth = CAM.project(pts)
    box = np.array([px[:, 0].min(), px[:, 1].min(), px[:, 0].max(), px[:, 1].max()])
    nearest = int(np.argmax(px[:4, 1]))
    return box, np.array([0.5 * (box[0] + box[2]), box[3], depth[nearest]])


def test_flat_object_is_f_h_over_h():
    level = PinholeCamera(1242, 375, K, 1.65)
    d = depth_from_silhouette(level, (609.6, 300.0), 50.0, 1.5, (0.0, 0.0), PARAMS)
    assert d == pytest.approx(721.5 * 1.5 / 50.0, rel=1e-3)


@settings(max_examples=40, deadline=None)
@given(
    depth=st.floats(6.0, 70.0),
    lateral=st.floats(-6.0, 6.0),
    rel_yaw_deg=st.floats(-30.0, 30.0),
)
def test_projected_box_depth_recovered(depth: float, lateral: float, rel_yaw_deg: float):
    lwh = (3.9, 1.6, 1.5)
    bearing = np.arctan2(lateral, depth)
    yaw = bearing + np.radians(rel_yaw_deg)
    box, (u, v, near_depth) = _projected_box(np.array([depth, lateral]), yaw, lwh)
    offsets = top_offsets(np.zeros(2), np.zeros(2), np.array(lwh[:2]), np.radians(rel_yaw_deg), box_only=True)
    d = depth_from_silhouette(CAM, (u, v), box[3] - box[1], lwh[2], offsets, PARAMS)
    # The nearest corner is not on the box's centre column; within 3 % all the same.
    assert d == pytest.approx(near_depth, rel=0.03)


def test_flat_model_puts_a_car_too_close_and_the_box_model_does_not():
    lwh = (3.9, 1.6, 1.5)
    box, (u, v, near_depth) = _projected_box(np.array([22.0, 0.0]), 0.0, lwh)
    h_px = box[3] - box[1]
    flat = depth_from_silhouette(CAM, (u, v), h_px, lwh[2], (0.0, 0.0), PARAMS)
    boxed = depth_from_silhouette(
        CAM, (u, v), h_px, lwh[2], top_offsets(np.zeros(2), np.zeros(2), np.array(lwh[:2]), 0.0, True), PARAMS
    )
    assert flat < 0.985 * near_depth  # about 2 % short at 20 m
    assert boxed == pytest.approx(near_depth, rel=0.005)


def test_top_offsets_known_answers():
    # Mask evidence: lowest point at the near tyres (1.4 m ahead of the centre), roof 1.0 m.
    near, far = top_offsets(np.array([1.4, 0.9]), np.array([1.0, 0.6]), np.array([4.2, 1.8]), 0.0, False)
    assert (near, far) == pytest.approx((0.4, 2.4))
    # Seen from the side the widths count.
    near, far = top_offsets(
        np.array([1.4, 0.9]), np.array([1.0, 0.6]), np.array([4.2, 1.8]), np.pi / 2, False
    )
    assert (near, far) == pytest.approx((0.3, 1.5))
    assert top_offsets(np.zeros(2), np.zeros(2), np.array([4.0, 2.0]), 0.0, True) == pytest.approx((0.0, 4.0))


def test_no_depth_fits_returns_none():
    assert depth_from_silhouette(CAM, (609.6, 300.0), 1e6, 1.5, (0.0, 0.0), PARAMS) is None
    assert depth_from_silhouette(CAM, (609.6, 300.0), 1e-4, 1.5, (0.0, 0.0), PARAMS) is None


def test_rows_fall_with_depth():
    h = silhouette_rows(
        CAM, (609.6, 250.0), np.array([5.0, 10.0, 20.0, 40.0]), 1.5, (0.0, 3.9), PARAMS.near_plane_m
    )
    assert np.all(np.diff(h) < 0)


def test_top_row_places_a_person_and_refuses_a_car_roof():
    level = PinholeCamera(1242, 375, K, 1.3)
    v_top = 172.9 + 721.5 * (1.3 - 1.75) / 20.0
    found = depth_from_top_row(level, 609.6, v_top, 1.75, 0.1, PARAMS)
    assert found is not None
    d, sigma = found
    assert d == pytest.approx(20.0, rel=1e-3)
    assert sigma == pytest.approx(20.0 * np.hypot(0.1 / 0.45, 20.0 / (721.5 * 0.45)), rel=1e-3)
    # A car's roof (1.5 m) is too close to the camera height for its row to place it.
    assert depth_from_top_row(level, 609.6, 180.0, 1.5, 0.12, PARAMS) is None
