"""The ground's height where objects stand, from their contact and class-height depths, and its spread."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.geometry.camera import PinholeCamera
from usdworld.views.unevenness import (
    GroundHeights,
    contact_height_offset,
    ground_height_spread,
)

K = np.array([[1266.0, 0.0, 816.0], [0.0, 1266.0, 491.0], [0.0, 0.0, 1.0]])


@settings(max_examples=60, deadline=None)
@given(
    height_m=st.floats(1.2, 2.0),
    pitch_deg=st.floats(-1.0, 3.0),
    x=st.floats(8.0, 70.0),
    y=st.floats(-6.0, 6.0),
    dz=st.floats(-0.4, 0.9),
)
def test_the_contact_ray_passes_the_objects_depth_at_its_grounds_height(
    height_m: float, pitch_deg: float, x: float, y: float, dz: float
) -> None:
    """An object standing on ground ``dz`` above the camera's plane: its contact pixel's ray meets the
    plane at ``d_c``; with its true depth (what a right class height gives) the offset is ``dz``."""
    camera = PinholeCamera(1632, 982, K, height_m, math.radians(pitch_deg))
    px, (depth,) = camera.project(np.array([[x, y, dz]]))
    _, (contact_depth,) = camera.ground_points(px)
    assert contact_depth > 0
    offset, variance = contact_height_offset(float(contact_depth), 0.0, float(depth), 0.0, height_m)
    assert offset == pytest.approx(dz, abs=1e-6)
    assert variance == 0.0


def test_the_offsets_variance_follows_from_both_cues() -> None:
    """d dz / d d_h = -h / d_c and d dz / d d_c = h d_h / d_c^2: at d_c 60 m, d_h 40 m, h 1.5 m,
    sigmas 4 m and 1 m give (0.025 * 4)^2 + (0.01667 * 1)^2."""
    offset, variance = contact_height_offset(60.0, 1.0, 40.0, 4.0, 1.5)
    assert offset == pytest.approx(0.5)
    assert variance == pytest.approx((1.5 / 60 * 4.0) ** 2 + (1.5 * 40 / 3600 * 1.0) ** 2)


@settings(max_examples=60, deadline=None)
@given(
    dz=st.lists(st.floats(-2.0, 2.0), min_size=1, max_size=30),
    variance=st.floats(1e-4, 1.0),
)
def test_with_equal_variances_the_spread_is_the_excess_mean_square(dz: list[float], variance: float) -> None:
    """Equal variances v: the likelihood's maximum is s^2 = mean(dz^2) - v, or 0 when that is negative."""
    a = np.array(dz)
    s = ground_height_spread(GroundHeights(a, np.full(len(a), variance)))
    expected = math.sqrt(max(0.0, float(np.mean(a**2)) - variance))
    assert s == pytest.approx(expected, abs=1e-6)


def test_a_known_spread_is_recovered_from_unequal_variances() -> None:
    """4000 grounds drawn 0.4 m about the plane, each measured with its own error (0.05-0.5 m): 0.4 m back."""
    rng = np.random.default_rng(7)
    sd = rng.uniform(0.05, 0.5, 4000)
    dz = rng.normal(0.0, 0.4, 4000) + rng.normal(0.0, sd)
    assert ground_height_spread(GroundHeights(dz, sd**2)) == pytest.approx(0.4, abs=0.02)


def test_a_flat_ground_measured_within_its_errors_has_no_spread() -> None:
    rng = np.random.default_rng(3)
    sd = rng.uniform(0.05, 0.5, 2000)
    dz = rng.normal(0.0, sd) * 0.9  # a little tighter than the errors say
    assert ground_height_spread(GroundHeights(dz, sd**2)) == 0.0
    assert ground_height_spread(GroundHeights(np.zeros(0), np.zeros(0))) == 0.0
