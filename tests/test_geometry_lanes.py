"""Lane markings and the camera height their spacing measures (geometry.lanes)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.estimate import HeightObservations, estimate_camera
from usdworld.geometry.lanes import (
    NO_MARKINGS,
    LaneLine,
    LaneMarkings,
    LanePair,
    find_lane_markings,
    lane_pairs,
    lane_width_cue,
)
from usdworld.geometry.vanishing import VanishingPoint
from usdworld.parameters.camera import DEFAULT_CAMERA

W_IMG, H_IMG = 1242, 375
K = np.array([[721.5, 0.0, 621.0], [0.0, 721.5, 187.5], [0.0, 0.0, 1.0]])
LANE = DEFAULT_CAMERA.lane_width_m


def _road_photo(
    camera: PinholeCamera,
    line_offsets_m: list[float],
    marking_m: float = 0.15,
    kerb_m: float | None = None,
    seed: int = 0,
) -> np.ndarray:
    """(H, W, 3) uint8 photo of a flat grey road with white lines along the world X axis at the
    given lateral offsets (Y, metres), 4x supersampled across each row; a bright pavement left of
    Y = ``kerb_m`` when given; sky above the horizon; a little sensor noise."""
    sub = 4
    u = (np.arange(W_IMG * sub) + 0.5) / sub - 0.5
    img = np.full((H_IMG, W_IMG), 200.0)
    for v in range(H_IMG):
        px = np.column_stack([u, np.full_like(u, float(v))])
        ground, _ = camera.ground_points(px)
        y = ground[:, 1]
        val = np.full(len(u), 200.0)
        on_ground = np.isfinite(y)
        val[on_ground] = 90.0
        for off in line_offsets_m:
            val[on_ground & (np.abs(y - off) <= marking_m / 2) & (ground[:, 0] < 80)] = 230.0
        if kerb_m is not None:
            val[on_ground & (y > kerb_m)] = 170.0
        img[v] = val.reshape(W_IMG, sub).mean(axis=1)
    img += np.random.default_rng(seed).normal(0.0, 3.0, img.shape)
    return np.repeat(np.clip(img, 0, 255).astype(np.uint8)[..., None], 3, axis=2)


def _street_vp(camera: PinholeCamera) -> VanishingPoint:
    u, v = camera.vanishing_point(np.array([1.0, 0.0, 0.0]))
    return VanishingPoint(u, v, 0.5, 20, 20)


CAMERA = PinholeCamera(W_IMG, H_IMG, K, 1.65, math.radians(0.5), 0.0, 0.0)


@pytest.fixture(scope="module")
def three_lanes() -> tuple[np.ndarray, LaneMarkings]:
    rgb = _road_photo(CAMERA, [-1.5 * LANE - 0.2, -0.5 * LANE - 0.2, 0.5 * LANE - 0.2, 1.5 * LANE - 0.2])
    return rgb, find_lane_markings(rgb, _street_vp(CAMERA), np.zeros((0, 4)))


def test_painted_lanes_of_known_width_give_the_camera_height(three_lanes):
    _, markings = three_lanes
    assert len(markings.lines) == 4
    assert len(markings.pairs) == 3
    cue = lane_width_cue(markings, K)
    assert cue is not None
    # lanes exactly lane_width_m apart: each pair implies the true height (fit error only)
    assert cue.heights_m(CAMERA.pitch) == pytest.approx([1.65] * 3, rel=0.03)


def test_the_cue_pulls_the_joint_fit_to_the_lanes_height(three_lanes):
    _, markings = three_lanes
    none = HeightObservations(*(np.zeros(0) for _ in range(5)))
    with_lanes = estimate_camera(W_IMG, H_IMG, K, None, CAMERA.pitch, 0.0, 0.0, none, lanes=markings)
    alone = estimate_camera(W_IMG, H_IMG, K, None, CAMERA.pitch, 0.0, 0.0, none)
    assert alone.camera.height_m == pytest.approx(DEFAULT_CAMERA.height_prior_mean_m, abs=0.01)
    # the lane width's spread (9 %) against the prior's (20 %): most of the way to 1.65
    assert 1.60 < with_lanes.camera.height_m < 1.66
    assert with_lanes.lanes is not None and len(with_lanes.lanes) == 3
    assert "3 pair(s) of lane lines" in with_lanes.method


def test_a_road_without_markings_gives_no_cue():
    rgb = _road_photo(CAMERA, [], kerb_m=4.0)  # plain asphalt and a pavement's wide step
    markings = find_lane_markings(rgb, _street_vp(CAMERA), np.zeros((0, 4)))
    assert markings.pairs == ()
    assert lane_width_cue(markings, K) is None


def test_without_a_vanishing_point_no_lines_are_looked_for(three_lanes):
    rgb, _ = three_lanes
    assert find_lane_markings(rgb, None, np.zeros((0, 4))) is NO_MARKINGS


def test_lines_under_an_object_box_are_not_paint(three_lanes):
    rgb, found = three_lanes
    # a box over the whole road below the horizon hides every line
    markings = find_lane_markings(rgb, _street_vp(CAMERA), np.array([[0.0, 190.0, W_IMG, H_IMG]]))
    assert len(found.lines) == 4 and markings.lines == ()


def _line(b: float) -> LaneLine:
    return LaneLine(600.0 - 180.0 * b, b, 0.002, 200.0, 375.0, 150)


def test_a_lone_pair_is_not_taken_for_a_lane():
    k = LANE / 1.65
    assert lane_pairs([_line(0.0), _line(k)]) == ()
    three = lane_pairs([_line(-k), _line(0.0), _line(k)])
    assert [round(p.k, 9) for p in three] == [round(k, 9)] * 2


def test_a_wrong_pairing_does_not_move_the_fit():
    k = LANE / 1.65  # lanes seen from 1.65 m
    good = [_line(-k), _line(0.0), _line(k), _line(2 * k)]
    # a kerb 2 m beyond the last line (a parking strip): a pair 0.6x a lane, which agrees with no other
    wrong = good + [_line(2 * k + k * 2.0 / LANE)]
    hs = np.linspace(1.2, 2.4, 1201)
    pitch = np.zeros_like(hs)
    best = []
    for lines in (good, wrong):
        cue = lane_width_cue(LaneMarkings(tuple(lines), lane_pairs(lines), 621.0), K)
        best.append(hs[int(np.argmin(cue.cost(hs, pitch)))])
    assert best[0] == pytest.approx(1.65, abs=0.02)
    assert best[1] == pytest.approx(best[0], abs=0.01)


def test_an_outlier_pair_that_passes_the_pairing_costs_a_near_constant():
    k = LANE / 1.65
    pairs = tuple(LanePair(_line(0.0), _line(x), x, 0.002) for x in (k, k, k))
    liar = pairs + (LanePair(_line(0.0), _line(k / 1.8), k / 1.8, 0.002),)  # a bus lane 1.8x narrower
    hs = np.linspace(1.2, 3.5, 2301)
    fits = []
    for ps in (pairs, liar):
        cue = lane_width_cue(LaneMarkings((), ps, 621.0), K)
        fits.append(hs[int(np.argmin(cue.cost(hs, np.zeros_like(hs))))])
    assert fits[1] == pytest.approx(fits[0], abs=0.02)


@settings(max_examples=25, deadline=None)
@given(h=st.floats(0.8, 3.0), pitch_deg=st.floats(-4.0, 4.0), psi_deg=st.floats(-15.0, 15.0))
def test_the_spacing_slope_of_two_ground_lines_is_w_cos_p_over_h_cos_psi(h, pitch_deg, psi_deg):
    """Two ground lines one lane apart, projected by PinholeCamera: ``dw/dv`` is the cue's prediction."""
    cam = PinholeCamera(W_IMG, H_IMG, K, h, math.radians(pitch_deg), 0.0, 0.0)
    psi = math.radians(psi_deg)
    d = np.array([math.cos(psi), math.sin(psi), 0.0])
    n = np.array([-math.sin(psi), math.cos(psi), 0.0])
    slopes = []
    for off in (0.3, 0.3 + LANE):
        pts = np.array([off * n + t * d for t in (15.0, 40.0)])
        px, _ = cam.project(pts)
        slopes.append((px[1, 0] - px[0, 0]) / (px[1, 1] - px[0, 1]))
    u_vp, _ = cam.vanishing_point(d)
    pair = LanePair(_line(slopes[1]), _line(slopes[0]), abs(slopes[1] - slopes[0]), 1e-4)
    cue = lane_width_cue(LaneMarkings((), (pair,), u_vp), K)
    assert cue.heights_m(math.radians(pitch_deg))[0] == pytest.approx(h, rel=1e-6)
