"""Camera completion from objects of known height (Hoiem et al. 2006)."""

from __future__ import annotations

import numpy as np
import pytest

from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.estimate import HeightObservations, estimate_camera
from usdworld.parameters import CameraParams

K = np.array([[720.0, 0.0, 620.0], [0.0, 720.0, 187.0], [0.0, 0.0, 1.0]])


def _observe(cam: PinholeCamera, feet: np.ndarray, heights: np.ndarray) -> HeightObservations:
    bottom, _ = cam.project(np.column_stack([feet, np.zeros(len(feet))]))
    top, _ = cam.project(np.column_stack([feet, heights]))
    return HeightObservations(bottom[:, 0], bottom[:, 1], top[:, 1], heights.copy(), np.full(len(feet), 0.1))


# Far from the height prior's mean (1.5 m) the prior pulls the posterior mean a little
# (class heights spread by 0.1 m make each object a weak constraint on its own).
@pytest.mark.parametrize("height_m, pitch_deg, tol_m", [(1.65, 1.0, 0.02), (1.2, -1.5, 0.06), (2.2, 3.0, 0.15)])
def test_recovers_height_and_pitch_from_exact_objects(height_m, pitch_deg, tol_m):
    true = PinholeCamera(1240, 375, K, height_m, pitch=np.radians(pitch_deg))
    feet = np.array([[8.0, 2.0], [15.0, -3.0], [25.0, 4.0], [40.0, -1.0], [12.0, 6.0]])
    heights = np.array([1.5, 1.5, 1.75, 1.5, 1.75])
    est = estimate_camera(1240, 375, K, None, None, 0.0, 0.0, _observe(true, feet, heights))
    assert est.camera.height_m == pytest.approx(height_m, abs=tol_m)
    assert est.camera.pitch == pytest.approx(np.radians(pitch_deg), abs=np.radians(0.35))
    assert set(est.estimated) == {"height_m", "pitch"}
    assert est.n_objects == 5 and est.residual_px < 1.5


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
    assert est.camera.fx == pytest.approx(CameraParams().focal_prior_diag_ratio * np.hypot(1000, 500))
    assert est.focal is not None and est.focal.sources == ("prior",)
    assert est.camera.height_m == pytest.approx(CameraParams().height_prior_m[0], abs=0.01)
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


def _car_boxes(cam: PinholeCamera, centres: np.ndarray, lwh: tuple[float, float, float]) -> HeightObservations:
    """Image boxes of cars seen along their length (bottom: near corner, top: far roof edge)."""
    l, w, h = lwh
    rows = []
    for x, y in centres:
        foot = np.array([[x + sx * l / 2, y + sy * w / 2] for sx in (-1, 1) for sy in (-1, 1)])
        px, _ = cam.project(np.vstack([np.column_stack([foot, np.zeros(4)]), np.column_stack([foot, np.full(4, h)])]))
        rows.append((px[:, 0].mean(), px[:, 1].max(), px[:, 1].min()))
    r = np.array(rows)
    n = len(r)
    return HeightObservations(r[:, 0], r[:, 1], r[:, 2], np.full(n, h), np.full(n, 0.1), np.zeros(n), np.full(n, l))


def test_cars_with_depth_extent_give_the_true_camera_height():
    true = PinholeCamera(1240, 375, K, 1.65, pitch=np.radians(0.3))
    centres = np.array([[12.0, -3.0], [20.0, 2.5], [30.0, -3.0], [45.0, 3.0], [16.0, 6.0]])
    obs = _car_boxes(true, centres, (3.9, 1.6, 1.5))
    est = estimate_camera(1240, 375, K, None, None, 0.0, 0.0, obs)
    assert est.camera.height_m == pytest.approx(1.65, abs=0.03)
    # Treating the same boxes as flat boards underestimates the height (and so every depth).
    flat = HeightObservations(obs.u, obs.v_bottom, obs.v_top, obs.height_m, obs.height_std_m)
    assert estimate_camera(1240, 375, K, None, None, 0.0, 0.0, flat).camera.height_m < 1.61


def test_vanishing_point_fixes_the_pitch_of_a_single_object():
    from usdworld.geometry.vanishing import VanishingPoint

    true = PinholeCamera(1240, 375, K, 1.65, pitch=np.radians(-1.5))
    obs = _observe(true, np.array([[14.0, 1.0]]), np.array([1.75]))
    horizon = true.horizon_v()
    vp = VanishingPoint(600.0, horizon, 0.5, 20, 40)
    with_vp = estimate_camera(1240, 375, K, None, None, 0.0, 0.0, obs, vanishing=vp)
    without = estimate_camera(1240, 375, K, None, None, 0.0, 0.0, obs)
    assert with_vp.camera.pitch == pytest.approx(np.radians(-1.5), abs=np.radians(0.1))
    assert abs(with_vp.camera.height_m - 1.65) < abs(without.camera.height_m - 1.65)
    assert "vanishing row" in with_vp.method


def _random_cars(n: int, seed: int = 0) -> tuple[PinholeCamera, HeightObservations]:
    """n cars 5-40 m ahead of a 1.65 m camera, their heights spread round the class's 1.5 m by 0.12 m."""
    rng = np.random.default_rng(seed)
    true = PinholeCamera(1240, 375, K, 1.65, pitch=np.radians(0.5))
    feet = np.column_stack([rng.uniform(5.0, 40.0, n), rng.uniform(-8.0, 8.0, n)])
    heights = rng.normal(1.5, 0.12, n)
    obs = _observe(true, feet, heights)
    return true, HeightObservations(obs.u, obs.v_bottom, obs.v_top, np.full(n, 1.5), np.full(n, 0.12))


def test_object_cost_in_blocks_is_bit_identical_to_one_block():
    from usdworld.geometry import estimate

    _, obs = _random_cars(37)
    params = CameraParams()
    H, P = np.meshgrid(np.arange(0.5, 4.0, 0.05), np.radians(np.arange(-15.0, 15.0, 0.25)), indexing="ij")
    h, p = H.ravel(), P.ravel()
    v_top, z = estimate.predicted_top_rows(h, p, K, obs)
    sigma = np.sqrt((K[1, 1] * obs.height_std_m[None, :] / np.maximum(z, 0.1)) ** 2 + params.edge_noise_px**2)
    r = (v_top - obs.v_top[None, :]) / sigma
    whole = np.where(np.isfinite(r), np.log1p(r**2), params.unprojectable_cost).sum(axis=1)
    assert len(h) * len(obs) > 4 * estimate._BLOCK_ELEMENTS  # several blocks, the last one partial
    assert estimate._object_cost(h, p, K, obs, params).tobytes() == whole.tobytes()


def test_many_objects_fit_a_subset_spread_over_the_rows_without_bias():
    params = CameraParams()
    true, obs = _random_cars(1000)
    est = estimate_camera(1240, 375, K, None, None, 0.0, 0.0, obs, params=params)
    assert est.n_objects == params.max_fit_objects
    assert f"spread over the rows of {len(obs)}" in est.method
    # Within two of its own sigmas of the truth: a subset picked by box height (the tallest
    # cars) lands near 1.8 m here.
    assert abs(est.camera.height_m - true.height_m) < 2 * est.sigma_height_m
    assert abs(est.camera.pitch - true.pitch) < 2 * est.sigma_pitch + np.radians(0.05)


def test_up_to_the_cap_every_object_is_used_unchanged():
    from usdworld.geometry.estimate import _fit_subset

    _, obs = _random_cars(20)
    assert _fit_subset(obs, 20) is obs
    sub = _fit_subset(obs, 7)
    keep = [int(np.nonzero(obs.u == u)[0][0]) for u in sub.u]
    assert len(sub) == 7 and keep == sorted(keep)
    # The nearest and the farthest object are both in: the subset spans the rows.
    assert sub.v_bottom.max() == obs.v_bottom.max() and sub.v_bottom.min() == obs.v_bottom.min()


def test_a_measured_pose_is_a_prior_the_objects_correct():
    """A road plane's height and pitch are fused with the objects, not fixed: objects of a
    camera 1.65 m up and pitched 1 deg pull a plane's 1.85 m / 1.6 deg towards them."""
    from usdworld.geometry.estimate import PosePrior

    true = PinholeCamera(1240, 375, K, 1.65, pitch=np.radians(1.0))
    centres = np.array([[x, y] for x in (8.0, 12.0, 16.0, 20.0, 25.0, 30.0, 38.0, 45.0) for y in (-3.0, 3.0)])
    obs = _car_boxes(true, centres, (3.9, 1.6, 1.5))
    prior = PosePrior(1.85, 0.14, np.radians(1.6), np.radians(0.573))
    est = estimate_camera(1240, 375, K, None, None, 0.0, 0.0, obs, pose_prior=prior)
    assert abs(est.camera.height_m - 1.65) < 0.25 * (1.85 - 1.65)
    assert abs(est.camera.pitch - np.radians(1.0)) < 0.25 * np.radians(0.6)
    assert 0 < est.sigma_height_m < 0.14 and 0 < est.sigma_pitch < np.radians(0.573)
    assert "road plane" in est.method
    # Without objects the prior is the answer, with its own spread.
    empty = HeightObservations(*(np.zeros(0) for _ in range(5)))
    alone = estimate_camera(1240, 375, K, None, None, 0.0, 0.0, empty, pose_prior=prior)
    assert alone.camera.height_m == pytest.approx(1.85, abs=0.005)
    assert alone.camera.pitch == pytest.approx(np.radians(1.6), abs=np.radians(0.01))
    assert alone.sigma_height_m == pytest.approx(0.14, rel=0.05)
    assert "nothing to go on" not in alone.method


def test_a_pose_prior_needs_a_free_height_and_pitch_and_positive_spreads():
    from usdworld.errors import CalibrationError
    from usdworld.geometry.estimate import PosePrior

    empty = HeightObservations(*(np.zeros(0) for _ in range(5)))
    prior = PosePrior(1.65, 0.14, 0.01, 0.01)
    with pytest.raises(CalibrationError, match="pose prior"):
        estimate_camera(1240, 375, K, 1.65, None, 0.0, 0.0, empty, pose_prior=prior)
    with pytest.raises(CalibrationError, match="sigmas must be > 0"):
        PosePrior(1.65, 0.0, 0.01, 0.01)
