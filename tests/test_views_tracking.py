"""Tracking a drive's frames: one global assignment per frame, fragments of a standing object joined."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from layout_support import ground_placement

from usdworld.parameters.views import ViewsParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.views.drive import (
    DriveObject,
    footprint_reach_across,
    frame_scatter,
    merge_overlapping,
    one_object_cut_in_two,
    track_drive,
)
from usdworld.views.fusion import combine, fuse
from usdworld.views.fusion import Observation

PARAMS = ViewsParams()


def _obs(
    frame: int,
    xy: tuple[float, float],
    sigma_r: float,
    sigma_l: float,
    ref: int = 1,
    cls: str = "pole",
    footprint: float = 0.3,
) -> Observation:
    """A pole (or ``cls`` with a square ``footprint`` metres wide) seen in ``frame`` (one view per
    frame) from a camera at the origin."""
    x, y = xy
    r = float(np.hypot(x, y))
    cue = DepthCue("contact", r, sigma_r)
    size = (footprint, footprint, 6.0)
    placement = ground_placement(cls, xy, (100, 40, 104, 160), size, cues=(cue,), ref=ref)
    return Observation(frame, f"f{frame}", f"f{frame}.png", placement, np.zeros(2), sigma_r, sigma_l)


def _positions(objects: list[DriveObject]) -> list[list[float]]:
    return sorted(o.fused.placement.position_world[:2].tolist() for o in objects)


def test_a_frame_is_assigned_globally_not_nearest_first() -> None:
    """Two poles 4 m apart across a 40 m ray; the next frame places one 1.25 m from the first and
    one 3 m on the far side of it. Nearest first would give the first pole the 1.25 m one and leave
    the other outside every gate (a third pole); the assignment pairs each with a pole. (Traffic
    lights: they stand at their observations' weighted mean, where a pole, a trunk class, would be
    triangulated from bearings that a camera standing still does not give.)"""
    obs = [
        _obs(0, (40.0, 0.0), 1.0, 1.0, ref=1, cls="traffic_light"),
        _obs(0, (40.0, 4.0), 1.0, 1.0, ref=2, cls="traffic_light"),
        _obs(1, (40.0, 1.25), 1.0, 1.0, ref=1, cls="traffic_light"),
        _obs(1, (40.0, -3.0), 1.0, 1.0, ref=2, cls="traffic_light"),
    ]
    objects = track_drive(obs, [0.0, 0.1], PARAMS)
    assert len(objects) == 2
    by_frames = sorted(tuple(len(o.times) for o in objects))
    assert by_frames == [2, 2]
    assert _positions(objects) == [pytest.approx([40.0, -1.5]), pytest.approx([40.0, 2.625])]


def test_a_standing_object_broken_by_a_depth_jump_is_placed_once() -> None:
    """A pole 40 m down the ray placed 5 m long in three frames (sigma 2 m along the ray), then,
    nearer placements, 5 m nearer with sigma 1 m: the jump is beyond the track's gate and starts a
    second track, but the two fragments share no frame and agree within their floored covariances."""
    far = [_obs(k, (45.0, 0.0), 2.0, 0.3) for k in range(3)]
    obs = far + [_obs(k, (40.0, 0.0), 1.0, 0.3) for k in range(3, 6)]
    (pole,) = track_drive(obs, [0.1 * k for k in range(6)], PARAMS)
    assert len(pole.times) == 6 and not pole.moving
    # inverse-variance mean of all six: 3 x 45 / 4 + 3 x 40 / 1 over 3 / 4 + 3
    assert pole.fused.placement.position_world[:2] == pytest.approx([41.0, 0.0], abs=1e-9)

    # what stays apart: two poles 3 m apart seen together in every frame; two poles 8 m apart along
    # the ray, each sure to a metre, seen one after the other
    together = [_obs(k, (40.0, 0.0), 1.0, 0.3, ref=1) for k in range(4)] + [
        _obs(k, (40.0, 3.0), 1.0, 0.3, ref=2) for k in range(4)
    ]
    assert len(track_drive(together, [0.1 * k for k in range(4)], PARAMS)) == 2
    apart = [_obs(k, (48.0 if k < 3 else 40.0, 0.0), 1.0, 0.3) for k in range(6)]
    assert len(track_drive(apart, [0.1 * k for k in range(6)], PARAMS)) == 2


def test_fragments_whose_frames_scatter_more_than_stated_are_joined() -> None:
    """A pole 40-45 m down the ray, every frame stated sure to 1 m: frames 0-5 alternate 44 / 46 m,
    frames 6-11 alternate 39 / 41 m. The jump (45 -> 41 m) starts a second track; each fragment's
    frames scatter by 1.48 m (1.4826 MAD), more than the 1 m they state, so a frame's error is
    1.48^2 / (1 - 0.5) and the fragments, 5 m apart, agree (m2 = 25 / 4.73 = 5.3). With the stated
    1 m alone the floored covariances leave them 18.75 apart in squared sigmas: two poles. (Traffic
    lights, placed at their weighted mean: see test_a_frame_is_assigned_globally_not_nearest_first.)"""
    xs = [44.0, 46.0] * 3 + [39.0, 41.0] * 3
    obs = [_obs(k, (x, 0.0), 1.0, 0.3, cls="traffic_light") for k, x in enumerate(xs)]
    (pole,) = track_drive(obs, [0.1 * k for k in range(12)], PARAMS)
    assert len(pole.times) == 12 and not pole.moving
    assert pole.fused.placement.position_world[:2] == pytest.approx([42.5, 0.0], abs=1e-9)

    # the same 5 m jump between fragments whose frames agree with what they state stays two poles
    steady = [_obs(k, (45.0 if k < 6 else 40.0, 0.0), 1.0, 0.3, cls="traffic_light") for k in range(12)]
    assert len(track_drive(steady, [0.1 * k for k in range(12)], PARAMS)) == 2
    # and a fragment of fewer than scatter_min_frames frames uses what its surest frame states
    short = [
        _obs(k, x, 1.0, 0.3, cls="traffic_light")
        for k, x in enumerate([(44.0, 0.0), (46.0, 0.0), (39.0, 0.0), (41.0, 0.0)])
    ]
    assert len(track_drive(short, [0.1 * k for k in range(4)], PARAMS)) == 2


@given(
    spread=st.floats(0.1, 5.0),
    bearing=st.floats(-math.pi, math.pi),
    offset=st.floats(-3.0, 3.0),
)
def test_frame_scatter_measures_a_spread_along_the_ray(spread: float, bearing: float, offset: float) -> None:
    """Frames spread symmetrically along one ray from the camera: the along-ray standard deviation is
    1.4826 times their median absolute deviation, nothing across, whichever way the ray points."""
    u = np.array([math.cos(bearing), math.sin(bearing)])
    depths = 30.0 + offset + spread * np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
    S = frame_scatter(depths[:, None] * u[None, :], np.zeros((5, 2)))
    assert float(u @ S @ u) == pytest.approx((1.4826 * spread) ** 2, rel=1e-9)
    n = np.array([-u[1], u[0]])
    assert float(n @ S @ n) == pytest.approx(0.0, abs=1e-9)


def test_a_tree_its_view_cuts_in_two_is_placed_once() -> None:
    """Each of five frames places one tree (footprint 2.6 m) twice, 1.2 m apart across a 30 m ray
    and 0.8 m apart along it: the two share every frame, so no fragment join can make them one;
    their footprints overlap, so each frame's two are one tree. The camera stands still, so the
    halves' bearings disagree in every frame and the triangulation keeps one of them: the tree
    stands on a half's ray, within its footprint of where one frame's two combine."""
    obs = []
    for f in range(5):
        obs.append(_obs(f, (30.0, 0.0), 1.5, 0.3, ref=1, cls="tree", footprint=2.6))
        obs.append(_obs(f, (30.8, 1.2), 1.5, 0.3, ref=2, cls="tree", footprint=2.6))
    objects = track_drive(obs, [0.1 * f for f in range(5)], PARAMS)
    assert len(objects) == 1
    assert len(objects[0].fused.observations) == 10
    xy = combine(obs[:2])[0]
    assert 30.0 < xy[0] < 30.8 and 0.0 < xy[1] < 1.2
    placed = objects[0].fused.placement.position_world[:2]
    assert float(np.linalg.norm(placed - xy)) < 1.3
    bearings = [math.atan2(1.2, 30.8), 0.0]
    assert min(abs(math.atan2(placed[1], placed[0]) - b) for b in bearings) < 1e-3


def test_trees_one_behind_the_other_or_beside_it_stay_two() -> None:
    """Same bearing, 8 m apart along the ray with 1 m depth spreads: beyond the footprints by far
    more than half a spread of the difference; or side by side 3 m apart across the ray."""
    behind = fuse([_obs(0, (30.0, 0.0), 1.0, 0.3, 1, "tree", 2.6), _obs(0, (38.0, 0.0), 1.0, 0.3, 2, "tree", 2.6)], PARAMS)
    beside = fuse([_obs(0, (30.0, 0.0), 1.0, 0.3, 1, "tree", 2.6), _obs(0, (30.0, 3.0), 1.0, 0.3, 2, "tree", 2.6)], PARAMS)
    for pair in (behind, beside):
        assert not one_object_cut_in_two(pair[0], pair[1], PARAMS)
        assert len(merge_overlapping(pair, PARAMS)) == 2


def test_cars_are_not_merged_within_a_frame() -> None:
    """Only trunk classes are merged (vehicles and people are tracked): two cars (footprint 1.8 m)
    1 m apart overlap, yet stay two."""
    cars = fuse([_obs(0, (30.0, 0.0), 1.0, 0.3, 1, "car", 1.8), _obs(0, (30.0, 1.0), 1.0, 0.3, 2, "car", 1.8)], PARAMS)
    assert one_object_cut_in_two(cars[0], cars[1], PARAMS)
    assert len(merge_overlapping(cars, PARAMS)) == 2


@given(
    st.floats(0.0, 20.0),
    st.floats(-40.0, 40.0),
    st.floats(0.1, 3.0),
    st.floats(0.3, 4.0),
)
def test_objects_apart_across_the_ray_beyond_their_footprints_are_never_one(
    along: float, extra: float, sigma: float, footprint: float
) -> None:
    """Whatever the depths and their spreads, two placements whose contacts are farther apart across
    their mean ray (here the x axis) than their footprints reach stay two; at one place they are one."""
    across = footprint + abs(extra) + 1e-3
    pair = fuse(
        [
            _obs(0, (40.0 - along / 2, -across / 2), sigma, 0.3, 1, "tree", footprint),
            _obs(0, (40.0 + along / 2, across / 2), sigma, 0.3, 2, "tree", footprint),
        ],
        PARAMS,
    )
    assert not one_object_cut_in_two(pair[0], pair[1], PARAMS)
    same = fuse([_obs(0, (40.0, 0.0), sigma, 0.3, 1, "tree", footprint), _obs(0, (40.0, 0.0), sigma, 0.3, 2, "tree", footprint)], PARAMS)
    assert one_object_cut_in_two(same[0], same[1], PARAMS)


def test_footprint_reach_across_known_answers() -> None:
    """A lamp's 2.0 x 0.3 m footprint with its arm along y: seen along x the arm spans the view
    (1.0 m each side), seen along y only its width (0.15 m); at 30 degrees, 0.15 + 0.85 cos 30."""
    lamp = _obs(0, (30.0, 0.0), 1.0, 0.3).placement
    lamp = dataclasses.replace(lamp, size_m=np.array([2.0, 0.3, 8.0]), yaw=0.5 * math.pi)
    assert footprint_reach_across(lamp, np.array([1.0, 0.0])) == pytest.approx(1.0)
    assert footprint_reach_across(lamp, np.array([0.0, -1.0])) == pytest.approx(0.15)
    ray = np.array([math.cos(math.pi / 6), math.sin(math.pi / 6)])
    assert footprint_reach_across(lamp, ray) == pytest.approx(0.15 + 0.85 * math.cos(math.pi / 6))


@given(st.floats(0.1, 4.0), st.floats(0.1, 4.0), st.floats(-math.pi, math.pi), st.floats(-math.pi, math.pi))
def test_footprint_reach_across_lies_between_the_inscribed_disc_and_the_long_side(
    length: float, width: float, yaw: float, bearing: float
) -> None:
    """Whatever the yaw and the ray: at least the inscribed disc's radius, at most half the long
    side; a square footprint reaches exactly its disc's radius."""
    base = _obs(0, (30.0, 0.0), 1.0, 0.3).placement
    ray = np.array([math.cos(bearing), math.sin(bearing)])
    placement = dataclasses.replace(base, size_m=np.array([length, width, 6.0]), yaw=yaw)
    reach = footprint_reach_across(placement, ray)
    assert 0.5 * min(length, width) - 1e-9 <= reach <= 0.5 * max(length, width) + 1e-9
    square = dataclasses.replace(base, size_m=np.array([width, width, 6.0]), yaw=yaw)
    assert footprint_reach_across(square, ray) == pytest.approx(0.5 * width)


def test_a_street_lamps_mast_and_head_in_one_frame_are_one_lamp() -> None:
    """One frame places a street lamp (2.0 x 0.3 m, its arm across the ray) twice, 0.8 m apart
    across a 30 m ray at one depth: its mast and its head, which the arm holds up to 1 m to the
    side. One lamp; two plain poles (0.3 x 0.3 m) as far apart stay two."""

    def frame(length: float) -> list:
        pair = [_obs(0, (30.0, 0.0), 1.0, 0.3, 1), _obs(0, (30.0, 0.8), 1.0, 0.3, 2)]
        out = []
        for o in pair:
            size = np.array([length, 0.3, 8.0])
            placement = dataclasses.replace(o.placement, size_m=size, yaw=0.5 * math.pi)
            out.append(dataclasses.replace(o, placement=placement))
        return fuse(out, PARAMS)

    lamp = frame(2.0)
    assert one_object_cut_in_two(lamp[0], lamp[1], PARAMS)
    assert len(merge_overlapping(lamp, PARAMS)) == 1
    poles = frame(0.3)
    assert not one_object_cut_in_two(poles[0], poles[1], PARAMS)
    assert len(merge_overlapping(poles, PARAMS)) == 2
