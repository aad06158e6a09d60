"""A view's known pose -> its camera's height, pitch and roll, and its ground frame in the world."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from views_support import K, world_from_cam

from usdworld.errors import CalibrationError
from usdworld.geometry.camera import PinholeCamera
from usdworld.views.rig import ground_pose, heading, world_from_ground


def test_a_level_camera_has_its_height_and_no_tilt() -> None:
    h, pitch, roll = ground_pose(world_from_cam((3.0, -2.0, 1.6), 70.0))
    assert (h, pitch, roll) == pytest.approx((1.6, 0.0, 0.0), abs=1e-12)


def test_a_camera_looking_down_has_positive_pitch() -> None:
    pose = world_from_cam((0.0, 0.0, 2.0), 0.0)
    a = math.radians(5.0)  # turn the camera about its x axis so that it looks 5 degrees down
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(a), math.sin(a)], [0.0, -math.sin(a), math.cos(a)]])
    pose[:3, :3] = pose[:3, :3] @ tilt
    assert pose[2, 2] == pytest.approx(-math.sin(a))  # the optical axis dips
    h, pitch, roll = ground_pose(pose)
    assert (h, math.degrees(pitch), roll) == pytest.approx((2.0, 5.0, 0.0), abs=1e-9)


@given(
    x=st.floats(-50, 50),
    y=st.floats(-50, 50),
    h=st.floats(0.3, 4.0),
    heading_deg=st.floats(-180, 180),
    pitch_deg=st.floats(-20, 20),
    roll_deg=st.floats(-20, 20),
)
def test_the_ground_frame_maps_the_view_camera_onto_its_pose(
    x: float, y: float, h: float, heading_deg: float, pitch_deg: float, roll_deg: float
) -> None:
    """Build a pose from a camera at (x, y) turned ``heading``; the ground frame recovers both."""
    level = PinholeCamera(800, 450, K, h, math.radians(pitch_deg), math.radians(roll_deg), 0.0)
    psi = math.radians(heading_deg)
    turn = np.eye(4)
    turn[:2, :2] = [[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]]
    turn[:2, 3] = (x, y)
    pose = turn @ level.world_from_cam()
    got_h, got_pitch, got_roll = ground_pose(pose)
    assert (got_h, got_pitch, got_roll) == pytest.approx((h, level.pitch, level.roll), abs=1e-9)
    view = PinholeCamera(800, 450, K, got_h, got_pitch, got_roll, 0.0)
    W = world_from_ground(pose, view.world_from_cam())
    assert W @ view.world_from_cam() == pytest.approx(pose, abs=1e-9)
    assert W[2, 3] == 0.0 and W[:3, 2] == pytest.approx([0.0, 0.0, 1.0])
    assert math.remainder(heading(W) - psi, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)


def test_poses_that_differ_by_more_than_a_turn_are_refused() -> None:
    view = PinholeCamera(800, 450, K, 1.5, 0.0, 0.0, 0.0)
    other = PinholeCamera(800, 450, K, 1.5, math.radians(3.0), 0.0, 0.0)
    with pytest.raises(CalibrationError, match="differs from its pose by more than a turn about Z"):
        world_from_ground(other.world_from_cam(), view.world_from_cam())
