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


def _well_conditioned(H: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """Points away from the line that H sends to infinity (noise there is amplified without bound)."""
    src = rng.uniform(-1, 1, size=(n, 2)) * 100
    w = src @ H[2, :2] + H[2, 2]
    return src[(w > 0.5) & (w < 2.0)]


@given(H=homographies(), seed=st.integers(0, 2**16))
def test_recovers_h_up_to_scale_exactly_without_noise(H, seed):
    src = _well_conditioned(H, np.random.default_rng(seed), 60)
    if len(src) < 8:
        return
    fit = estimate_homography(src, apply_homography(H, src))
    unit = H / np.linalg.norm(H)
    np.testing.assert_allclose(fit.dst_from_src, unit * np.sign(unit[2, 2]), atol=1e-8)


@given(H=homographies(), seed=st.integers(0, 2**16))
def test_recovers_h_from_noisy_points(H, seed):
    rng = np.random.default_rng(seed)
    src = _well_conditioned(H, rng, 60)
    held_out = _well_conditioned(H, rng, 60)
    if len(src) < 12 or len(held_out) < 1:
        return
    noisy = apply_homography(H, src) + rng.normal(0, 1e-3, size=(len(src), 2))
    fit = estimate_homography(src, noisy)
    # Under noise, H is identified by what it does: points it was not fitted on land
    # where the true H sends them, to within a few times the noise (1e-3).
    error = np.linalg.norm(apply_homography(fit.dst_from_src, held_out) - apply_homography(H, held_out), axis=1)
    assert np.median(error) < 5e-3 and fit.rms_dst < 5e-3


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
