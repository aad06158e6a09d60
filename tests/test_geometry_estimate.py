"""Camera completion from objects of known height (Hoiem et al. 2006)."""

from __future__ import annotations

import numpy as np
import pytest

from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.estimate import CAMERA_HEIGHT_PRIOR_M, DEFAULT_HFOV_DEG, HeightObservations, estimate_camera

K = np.array([[720.0, 0.0, 620.0], [0.0, 720.0, 187.0], [0.0, 0.0, 1.0]])


def _observe(cam: PinholeCamera, feet: np.ndarray, heights: np.ndarray) -> HeightObservations:
    bottom, _ = cam.project(np.column_stack([feet, np.zeros(len(feet))]))
    top, _ = cam.project(np.column_stack([feet, heights]))
    return HeightObservations(bottom[:, 0], bottom[:, 1], top[:, 1], heights.copy(), np.full(len(feet), 0.1))


# Far from the height prior's mean (1.5 m) the prior pulls the MAP estimate a little.
@pytest.mark.parametrize("height_m, pitch_deg, tol_m", [(1.65, 1.0, 0.02), (1.2, -1.5, 0.03), (2.2, 3.0, 0.1)])
def test_recovers_height_and_pitch_from_exact_objects(height_m, pitch_deg, tol_m):
    true = PinholeCamera(1240, 375, K, height_m, pitch=np.radians(pitch_deg))
    feet = np.array([[8.0, 2.0], [15.0, -3.0], [25.0, 4.0], [40.0, -1.0], [12.0, 6.0]])
    heights = np.array([1.5, 1.5, 1.75, 1.5, 1.75])
    est = estimate_camera(1240, 375, K, None, None, 0.0, 0.0, _observe(true, feet, heights))
    assert est.camera.height_m == pytest.approx(height_m, abs=tol_m)
    assert est.camera.pitch == pytest.approx(np.radians(pitch_deg), abs=np.radians(0.25))
    assert set(est.estimated) == {"height_m", "pitch"}
    assert est.n_objects == 5 and est.residual_px < 1.0


def test_one_outlier_does_not_drag_the_fit():
    true = PinholeCamera(1240, 375, K, 1.65, pitch=np.radians(0.5))
    feet = np.array([[8.0, 2.0], [15.0, -3.0], [25.0, 4.0], [40.0, -1.0], [12.0, 6.0], [20.0, 0.0]])
    heights = np.array([1.5, 1.5, 1.5, 1.5, 1.5, 1.5])
    obs = _observe(true, feet, heights)
    v_top = obs.v_top.copy()
    v_top[0] -= 60.0  # a box twice too tall
    obs = HeightObservations(obs.u, obs.v_bottom, v_top, obs.height_m, obs.height_std_m)
    est = estimate_camera(1240, 375, K, None, None, 0.0, 0.0, obs)
    assert est.camera.height_m == pytest.approx(1.65, abs=0.08)


def test_nothing_to_go_on_gives_documented_defaults():
    empty = HeightObservations(*(np.zeros(0) for _ in range(5)))
    est = estimate_camera(1000, 500, None, None, None, None, None, empty)
    assert est.camera.fx == pytest.approx(500.0 / np.tan(np.radians(DEFAULT_HFOV_DEG / 2)))
    assert est.camera.height_m == pytest.approx(CAMERA_HEIGHT_PRIOR_M[0], abs=0.01)
    assert est.camera.pitch == pytest.approx(0.0, abs=1e-3)
    assert "K" in est.estimated and "nothing to go on" in est.method


def test_given_values_are_kept():
    empty = HeightObservations(*(np.zeros(0) for _ in range(5)))
    est = estimate_camera(1240, 375, K, 1.7, 0.02, 0.0, 0.0, empty)
    assert (est.camera.height_m, est.camera.pitch) == (1.7, 0.02)
    assert est.estimated == ()


def test_road_top_row_bounds_the_horizon():
    empty = HeightObservations(*(np.zeros(0) for _ in range(5)))
    # The road reaches up to row 150, so the horizon must lie at or above it (pitch up).
    est = estimate_camera(1240, 375, K, 1.6, None, 0.0, 0.0, empty, road_top_v=150.0)
    assert est.camera.horizon_v() <= 150.0 + 3.0
