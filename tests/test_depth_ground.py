"""Tests for usdworld.perception.depth.ground."""

from __future__ import annotations

import numpy as np
import pytest

from usdworld.errors import CalibrationError, InputError
from usdworld.geometry.camera import PinholeCamera
from usdworld.perception.depth import GroundDepthBackend, ground_plane_depth


def _camera(pitch: float = 0.0, w: int = 40, h: int = 30) -> PinholeCamera:
    K = np.array([[50.0, 0.0, w / 2], [0.0, 50.0, h / 2], [0.0, 0.0, 1.0]])
    return PinholeCamera(w, h, K, height_m=1.5, pitch=pitch)


def test_known_answer_level_camera() -> None:
    cam = _camera()
    depth, valid = ground_plane_depth(cam)
    # Row 29: pixel centre v = 29.5, 14.5 px below the horizon (cy = 15): d = f h / 14.5.
    np.testing.assert_allclose(depth[29], 50.0 * 1.5 / 14.5, rtol=1e-6)
    # Rows at or above the horizon (centre v <= 15) are invalid; row 15 (v = 15.5) is 150 m away.
    assert not valid[:15].any()
    np.testing.assert_allclose(depth[15, 0], 50 * 1.5 / 0.5, rtol=1e-6)
    assert valid[15:].all()
    assert (depth[~valid] == 0).all() and depth.dtype == np.float32


def test_max_depth_and_pitch() -> None:
    cam = _camera(pitch=0.05)
    depth, valid = ground_plane_depth(cam, max_depth_m=20.0)
    assert depth[valid].max() <= 20.0
    # Depth decreases monotonically down each column below the horizon.
    col = depth[:, 5][valid[:, 5]]
    assert np.all(np.diff(col) < 0)
    with pytest.raises(CalibrationError, match="max_depth_m must be > 0"):
        ground_plane_depth(cam, max_depth_m=0.0)


def test_backend_needs_camera_of_image_size() -> None:
    backend = GroundDepthBackend()
    rgb = np.zeros((30, 40, 3), np.uint8)
    pred = backend.predict(rgb, _camera())
    assert pred.kind == "metric" and pred.name == "ground" and pred.shape == (30, 40)
    with pytest.raises(CalibrationError, match="ground depth needs the camera"):
        backend.predict(rgb, None)
    with pytest.raises(InputError, match="ground: camera is for a 40x30 image, the photo is 41x30"):
        backend.predict(np.zeros((30, 41, 3), np.uint8), _camera())
    with pytest.raises(InputError, match=r"ground: image must be \(H, W, 3\) uint8 RGB"):
        backend.predict(np.zeros((30, 40), np.uint8), _camera())
