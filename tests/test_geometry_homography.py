"""Normalised DLT: known answers, recovery from noisy points, degenerate sets."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from usdworld.errors import CalibrationError
from usdworld.geometry.homography import apply_homography, estimate_homography


def _normalised(H):
    return H / H[2, 2]


def test_identity_known_answer():
    src = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], dtype=float)
    fit = estimate_homography(src, src)
    np.testing.assert_allclose(_normalised(fit.dst_from_src), np.eye(3), atol=1e-12)
    assert np.linalg.norm(fit.dst_from_src) == pytest.approx(1.0)
    assert fit.rms_dst < 1e-12


def test_hand_computed_translation_scale():
    # x' = 2x + 3, y' = 0.5y - 1: points chosen by hand.
    src = np.array([[0, 0], [2, 0], [0, 4], [2, 4], [1, 1]], dtype=float)
    dst = np.array([[3, -1], [7, -1], [3, 1], [7, 1], [5, -0.5]], dtype=float)
    fit = estimate_homography(src, dst)
    np.testing.assert_allclose(_normalised(fit.dst_from_src), [[2, 0, 3], [0, 0.5, -1], [0, 0, 1]], atol=1e-10)


@st.composite
def homographies(draw):
    a = np.array(draw(st.lists(st.floats(-0.3, 0.3), min_size=8, max_size=8)))
    H = np.eye(3).ravel()
    H[:8] += a
    H = H.reshape(3, 3)
    H[2, :2] *= 0.1
    return H


@given(H=homographies(), seed=st.integers(0, 2**16))
def test_recovers_h_up_to_scale_from_noisy_points(H, seed):
    rng = np.random.default_rng(seed)
    src = rng.uniform(-1, 1, size=(30, 2)) * 100
    dst = apply_homography(H, src)
    if not np.isfinite(dst).all() or np.abs(dst).max() > 1e4:
        return
    noisy = dst + rng.normal(0, 1e-3, size=dst.shape)
    fit = estimate_homography(src, noisy)
    est = _normalised(fit.dst_from_src)
    mapped = apply_homography(est, src)
    # Transfer error stays near the noise level (amplified where points approach the
    # line at infinity) and H matches up to scale.
    assert np.sqrt(np.mean(np.sum((mapped - dst) ** 2, axis=1))) < 1e-4 * np.abs(dst).max() + 0.01
    np.testing.assert_allclose(est, _normalised(H), atol=1e-3 * max(1, np.abs(_normalised(H)).max()))


def test_too_few_points():
    with pytest.raises(CalibrationError, match="at least 4"):
        estimate_homography(np.zeros((3, 2)), np.zeros((3, 2)))


def test_collinear_points():
    src = np.array([[0, 0], [1, 1], [2, 2], [3, 3], [4, 4]], dtype=float)
    with pytest.raises(CalibrationError, match="collinear"):
        estimate_homography(src, src + [1, 0])


def test_three_collinear_of_four_is_degenerate():
    src = np.array([[0, 0], [1, 0], [2, 0], [0, 1]], dtype=float)
    dst = np.array([[0, 0], [1, 0], [2, 0], [0, 1]], dtype=float)
    with pytest.raises(CalibrationError):
        estimate_homography(src, dst)


def test_mismatched_counts_and_nan():
    with pytest.raises(CalibrationError, match="pair them up"):
        estimate_homography(np.random.default_rng(0).random((5, 2)), np.random.default_rng(1).random((6, 2)))
    bad = np.random.default_rng(0).random((5, 2))
    bad[0, 0] = np.nan
    with pytest.raises(CalibrationError, match="NaN"):
        estimate_homography(bad, bad)
