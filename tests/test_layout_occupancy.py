"""The coarse raster that proves a disk of spots blocked: known answers, and a proof that holds."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.layout.occupancy import blocked_radius

TOL = 0.01


def _blocked(spots: np.ndarray, h: np.ndarray, centers: np.ndarray, half: np.ndarray, tol: float = TOL) -> np.ndarray:
    """(K,) bool: the exact test of collision resolution, each spot against every box."""
    gap = np.abs(spots[:, None, :] - centers[None, :, :]) - (h[None, None, :] + half[None, :, :])
    return np.any(np.all(gap < -tol, axis=2), axis=1)


def test_one_big_box_blocks_the_whole_disk():
    h = np.array([2.0, 1.0])
    assert blocked_radius(np.zeros(2), h, 5.0, np.array([[0.0, 0.0]]), np.array([[10.0, 10.0]]), TOL) == 5.0


def test_a_free_gap_bounds_the_radius():
    # Two boxes leave the spots x > 3 free (the box of half width 1 overlaps the right one
    # only when x < 0.5 + 1 + 1.5 - tol... here it is placed so that x in (3, 4) is free).
    h = np.array([1.0, 1.0])
    centers = np.array([[0.0, 0.0], [8.0, 0.0]])
    half = np.array([[2.0, 20.0], [3.0, 20.0]])
    # Blocked spots: |x| < 3 - tol and |x - 8| < 4 - tol; the free ones are 2.99 <= x <= 4.01.
    r = blocked_radius(np.zeros(2), h, 10.0, centers, half, TOL)
    assert 2.9 < r < 3.0 - TOL + 1e-9  # the proof reaches close to the gap and never past it
    assert blocked_radius(np.array([6.0, 0.0]), h, 1.0, centers, half, TOL) == 1.0  # x in [5, 7]: all blocked


def test_seam_of_two_overlapping_boxes_is_blocked():
    h = np.array([0.5, 0.5])
    centers = np.array([[-2.0, 0.0], [2.0, 0.0]])
    half = np.array([[2.5, 5.0], [2.5, 5.0]])  # they overlap on |x| < 0.5 (+ h on each side)
    assert blocked_radius(np.zeros(2), h, 3.0, centers, half, TOL) == 3.0


def test_nothing_to_prove():
    h = np.array([1.0, 1.0])
    assert blocked_radius(np.zeros(2), h, 3.0, np.zeros((0, 2)), np.zeros((0, 2)), TOL) == -math.inf
    far = np.array([[100.0, 100.0]])
    assert blocked_radius(np.zeros(2), h, 3.0, far, np.ones((1, 2)), TOL) == -math.inf
    huge = np.array([[1e9, 0.0]])  # past the coordinates the raster handles safely
    assert blocked_radius(np.array([1e9, 0.0]), h, 3.0, huge, np.full((1, 2), 1e3), TOL) == -math.inf


@settings(max_examples=150, deadline=None)
@given(
    st.integers(1, 30),
    st.floats(0.0, 12.0),
    st.sampled_from([1.0, 4.0, 12.0]),
    st.integers(0, 2**31 - 1),
)
def test_every_spot_within_the_radius_is_blocked(n, radius, spread, seed):
    # Random heaps of boxes: the exact test blocks every spot within the proved radius,
    # probed on a fine grid, on its rim and at random.
    rng = np.random.default_rng(seed)
    c0 = rng.uniform(-3, 3, 2)
    h = rng.uniform(0.3, 2.5, 2)
    centers = c0 + rng.uniform(-spread, spread, (n, 2))
    half = rng.uniform(0.2, 6.0, (n, 2))
    r = blocked_radius(c0, h, radius, centers, half, TOL)
    assert r <= radius
    if r < 0:
        return
    t = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    rim = c0 + r * np.column_stack([np.cos(t), np.sin(t)])
    g = np.linspace(-r, r, 121)
    grid = c0 + np.array(np.meshgrid(g, g, indexing="ij")).reshape(2, -1).T
    rnd = c0 + rng.uniform(-r, r, (4000, 2))
    spots = np.concatenate([rim, grid, rnd, c0[None, :]])
    spots = spots[np.linalg.norm(spots - c0, axis=1) <= r]
    assert _blocked(spots, h, centers, half).all()
