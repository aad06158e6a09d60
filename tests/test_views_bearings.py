"""A drive's standing trunks triangulated from their bearings: a depth error their frames share is removed."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from layout_support import box_object

from usdworld.layout.draft import DepthMethod
from usdworld.layout.placement import Placement
from usdworld.parameters.views import ViewsParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.views.bearings import bearing_triangulation
from usdworld.views.drive import track_drive
from usdworld.views.fusion import Observation, combine

PARAMS = ViewsParams()


def _seen(
    frame: int,
    camera: tuple[float, float],
    point: tuple[float, float],
    scale: float,
    cls: str = "pole",
    footprint: float = 0.3,
    ref: int = 1,
) -> Observation:
    """``point`` seen from ``camera`` (one view per frame) with a relative depth error ``scale``:
    placed at ``camera + (1 + scale) (point - camera)``, its depth stated sure to 10 % of the range."""
    c = np.array(camera)
    z = c + (1.0 + scale) * (np.array(point) - c)
    rng = float(np.linalg.norm(z - c))
    placement = Placement(
        name=f"{cls}_{ref:04d}",
        obj=box_object(cls, (100, 40, 104, 160), ref),
        variant="default",
        position_world=np.array([z[0], z[1], 0.0]),
        yaw=0.0,
        yaw_source="road",
        scale=1.0,
        stretch=np.ones(3),
        scale_measured=1.0,
        size_m=np.array([footprint, footprint, 6.0]),
        depth_m=rng,
        method=DepthMethod.CONTACT,
        cues=(DepthCue("contact", rng, 0.1 * rng),),
    )
    return Observation(frame, f"f{frame}", f"f{frame}.png", placement, c, 0.1 * rng, max(0.25, 0.02 * rng))


def _drive(point: tuple[float, float], scale: float, frames: int = 21, step: float = 1.0, **kw) -> list[Observation]:
    """A camera driving along +x from the origin, ``step`` metres a frame, seeing ``point``."""
    return [_seen(k, (k * step, 0.0), point, scale, **kw) for k in range(frames)]


@settings(deadline=None, max_examples=40)
@given(
    scale=st.floats(-0.2, 0.2),
    x=st.floats(15.0, 40.0),
    y=st.floats(4.0, 12.0),
)
def test_a_pole_with_a_depth_error_its_frames_share_is_placed_by_its_bearings(scale: float, x: float, y: float) -> None:
    """A pole beside a 20 m drive, every frame's depth off by the same share (up to 20 %): the frames'
    weighted mean keeps the shared error (about ``scale`` times the range); the rays from the moving
    camera cross at the pole, so it stands within a tenth of that error of it (the depth prior,
    counted once, pulls a little where the rays cross at narrow angles) and 5 cm."""
    obs = _drive((x, y), scale)
    (pole,) = track_drive(obs, [0.1 * k for k in range(len(obs))], PARAMS)
    assert not pole.moving
    truth = np.array([x, y])
    mean_error = float(np.linalg.norm(combine(obs)[0] - truth))
    assert float(np.linalg.norm(pole.fused.placement.position_world[:2] - truth)) <= 0.1 * mean_error + 0.05


def test_a_near_pole_is_placed_to_a_centimetre() -> None:
    """15 % too far in every frame at 20 m: the weighted mean errs by half a metre, the bearings by
    under 1 cm. A parked car there keeps its weighted mean: its bearing is to its visible face,
    which turns with the view (2 % too far, as 15 % would make it a mover)."""
    obs = _drive((20.0, 8.0), 0.15)
    (pole,) = track_drive(obs, [0.1 * k for k in range(len(obs))], PARAMS)
    assert float(np.linalg.norm(combine(obs)[0] - np.array([20.0, 8.0]))) > 0.4
    assert pole.fused.placement.position_world[:2] == pytest.approx([20.0, 8.0], abs=0.01)
    cars = _drive((20.0, 8.0), 0.02, cls="car", footprint=1.8)
    (car,) = track_drive(cars, [0.1 * k for k in range(len(cars))], PARAMS)
    assert not car.moving
    assert car.fused.placement.contact_world[:2] == pytest.approx(combine(cars)[0], abs=1e-9)


def _rays(point: np.ndarray, cameras: np.ndarray, noise: np.ndarray) -> np.ndarray:
    """Contacts on the rays from ``cameras`` to ``point``, each turned by ``noise`` radians about its camera."""
    out = []
    for c, a in zip(cameras, noise):
        d = point - c
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        out.append(c + rot @ d)
    return np.array(out)


def test_a_far_object_over_a_short_baseline_keeps_its_depth_prior() -> None:
    """A point 80 m ahead and 3 m aside, seen over 1 m of driving with bearings that err by up to
    0.1 degrees: the rays fix almost nothing along them, so the prior's depth stays (to a tenth of
    its spread) and so does its variance along the ray; over a 20 m baseline at 20 m the rays
    decide, and the variance along them falls far below the prior's."""
    rng = np.random.default_rng(5)
    prior_cov = np.diag([4.0, 0.25])  # 2 m along x (the ray), 0.5 m across
    point = np.array([80.0, 3.0])
    cams = np.c_[np.linspace(0.0, 1.0, 11), np.zeros(11)]
    contacts = _rays(point, cams, rng.uniform(-1.7e-3, 1.7e-3, 11))
    sigmas = np.full(11, PARAMS.bearing_sigma_rad * 80.0)
    prior = point + np.array([2.0, 0.0])  # the depth cue 2 m long
    xy, cov = bearing_triangulation(contacts, cams, sigmas, prior, prior_cov, PARAMS)
    u = point / np.linalg.norm(point)
    assert abs(float((xy - prior) @ u)) < 0.2
    assert float(u @ cov @ u) > 0.9 * float(u @ prior_cov @ u)

    near = np.array([20.0, 8.0])
    cams = np.c_[np.linspace(0.0, 20.0, 21), np.zeros(21)]
    contacts = _rays(near, cams, np.zeros(21))
    sigmas = np.full(21, PARAMS.bearing_sigma_rad * 15.0)
    xy, cov = bearing_triangulation(contacts, cams, sigmas, near + np.array([2.0, 0.8]), prior_cov, PARAMS)
    assert xy == pytest.approx(near, abs=0.01)
    u = (near - cams.mean(axis=0)) / np.linalg.norm(near - cams.mean(axis=0))
    assert float(u @ cov @ u) < 0.01 * float(u @ prior_cov @ u)


def test_a_frame_whose_bearing_is_to_another_point_counts_for_little() -> None:
    """Twenty rays to the pole and four to a point 1 m beside it (a crown's half cut by what stands
    in front): the pole stays within 2 cm of where the twenty cross."""
    point = np.array([25.0, 6.0])
    cams = np.c_[np.linspace(0.0, 23.0, 24), np.zeros(24)]
    targets = np.tile(point, (24, 1))
    targets[::6] += np.array([1.0, 0.0])
    contacts = np.array([_rays(t, c[None, :], np.zeros(1))[0] for t, c in zip(targets, cams)])
    sigmas = np.full(24, PARAMS.bearing_sigma_rad * 15.0)
    xy, _ = bearing_triangulation(contacts, cams, sigmas, point + np.array([1.5, 0.0]), np.diag([4.0, 4.0]), PARAMS)
    assert xy == pytest.approx(point, abs=0.02)


def test_two_halves_of_a_tree_seen_together_are_one_tree_and_two_trees_stay_two() -> None:
    """Each frame places a tree (footprint 2.6 m) twice on the same bearing, once 15 % too far and
    once 15 % too near: metres apart along the ray, beyond what one frame merges, and together in
    every frame, so no fragment join can make them one. Triangulated, both stand at the tree: one
    tree. Two trees 6 m apart seen the same way stay two."""
    tree = (30.0, 7.0)
    obs = []
    for k in range(21):
        obs.append(_seen(k, (k * 1.0, 0.0), tree, 0.15, cls="tree", footprint=2.6, ref=1))
        obs.append(_seen(k, (k * 1.0, 0.0), tree, -0.15, cls="tree", footprint=2.6, ref=2))
    times = [0.1 * k for k in range(21)]
    (one,) = track_drive(obs, times, PARAMS)
    assert len(one.fused.observations) == 42 and len(one.times) == 21
    assert float(np.linalg.norm(one.fused.placement.position_world[:2] - np.array(tree))) < 0.1

    two = [_seen(k, (k * 1.0, 0.0), (30.0, 7.0), 0.0, cls="tree", footprint=2.6, ref=1) for k in range(21)]
    two += [_seen(k, (k * 1.0, 0.0), (36.0, 7.0), 0.0, cls="tree", footprint=2.6, ref=2) for k in range(21)]
    assert len(track_drive(two, times, PARAMS)) == 2


def test_a_crown_fragment_seen_beside_its_tree_joins_it_when_the_triangulations_agree() -> None:
    """A tree (footprint 2.2 m) at (30, 8) seen exactly from 22 frames along +x; in the last four
    also a second box, the part of its crown that what stands in front leaves, whose contact lies
    4 m farther along the ray of frame 19.5 (13.6 m away, depths sure to 1.4 m): beyond what one
    frame merges (4 m - 2.2 m > half a spread of the depth difference), so it starts a track of its
    own that shares four frames with the tree's. Its bearings span 3 m of baseline, so its depth is
    mostly its prior's and the two triangulations, 4 m apart, agree within their covariances
    (m2 7.2 < 9.21), and in each shared frame the two boxes are under 0.3 m apart across the ray:
    one tree,
    placed on its own frames' point. The same fragment 3 m beside the tree across the ray (apart
    across beyond the footprints in every shared frame) stays a tree of its own."""
    tree = np.array([30.0, 8.0])
    cam_mid = np.array([19.5, 0.0])
    u = (tree - cam_mid) / np.linalg.norm(tree - cam_mid)
    times = [0.1 * k for k in range(22)]

    def drive(fragment: np.ndarray) -> list[Observation]:
        def seen(k: int, point: np.ndarray, ref: int) -> Observation:
            return _seen(k, (float(k), 0.0), tuple(point), 0.0, cls="tree", footprint=2.2, ref=ref)

        return [seen(k, tree, 1) for k in range(22)] + [seen(k, fragment, 2) for k in range(18, 22)]

    (one,) = track_drive(drive(tree + 4.0 * u), times, PARAMS)
    assert len(one.fused.observations) == 26 and len(one.times) == 22
    assert float(np.linalg.norm(one.fused.placement.position_world[:2] - tree)) < 0.5

    beside = tree + 3.0 * np.array([-u[1], u[0]])
    assert len(track_drive(drive(beside), times, PARAMS)) == 2


def test_poles_one_behind_the_other_that_the_end_frames_see_apart_stay_two() -> None:
    """Two poles (footprint 0.3 m) 50 and 58 m down one ray, seen together from 11 frames over a
    10 m baseline across it. Their triangulations agree within their covariances (the depth error
    the frames share, 5 m along the ray, is not triangulated away: m2 2.1), and the middle
    frame sees them on one bearing; but the end frames see them 0.8 m apart across the ray, more
    than their footprints reach: two poles, each on its own point."""
    obs = []
    for k in range(11):
        camera = (0.0, float(k) - 5.0)
        obs.append(_seen(k, camera, (50.0, 0.0), 0.0, ref=1))
        obs.append(_seen(k, camera, (58.0, 0.0), 0.0, ref=2))
    objects = track_drive(obs, [0.1 * k for k in range(11)], PARAMS)
    assert len(objects) == 2
    placed = sorted(o.fused.placement.position_world[:2].tolist() for o in objects)
    assert placed == [pytest.approx([50.0, 0.0], abs=0.05), pytest.approx([58.0, 0.0], abs=0.05)]


def test_a_street_lamps_head_seen_beside_its_mast_joins_it_a_plain_poles_does_not() -> None:
    """A street lamp (footprint 2.0 x 0.3 m, its arm across the road: yaw -90 degrees) at (30, 8)
    seen from 22 frames along +x; the last frame also has a box of its head alone, whose contact
    lies 2 m farther along that frame's ray and 0.8 m across it. The two are apart along the ray
    beyond what one frame merges, so the head starts a track that shares that frame with the
    mast's; across the ray the arm spans 1.57 m of that view on each side (0.15 + 0.85 |sin|),
    more than the 0.8 m, so the head is the lamp's: one lamp, at its mast. A plain pole
    (0.3 x 0.3 m) whose second box lies as far across reaches 0.15 m: two poles."""
    lamp = np.array([30.0, 8.0])
    camera = np.array([21.0, 0.0])
    u = (lamp - camera) / np.linalg.norm(lamp - camera)
    head = lamp + 2.0 * u + 0.8 * np.array([-u[1], u[0]])
    times = [0.1 * k for k in range(22)]

    def drive(length: float) -> list[Observation]:
        def seen(k: int, point: np.ndarray, ref: int) -> Observation:
            o = _seen(k, (float(k), 0.0), (float(point[0]), float(point[1])), 0.0, ref=ref)
            size = np.array([length, 0.3, 8.0])
            placement = dataclasses.replace(o.placement, size_m=size, yaw=-0.5 * math.pi)
            return dataclasses.replace(o, placement=placement)

        return [seen(k, lamp, 1) for k in range(22)] + [seen(21, head, 2)]

    (one,) = track_drive(drive(2.0), times, PARAMS)
    assert len(one.fused.observations) == 23
    assert float(np.linalg.norm(one.fused.placement.contact_world[:2] - lamp)) < 0.05
    assert len(track_drive(drive(0.3), times, PARAMS)) == 2


def test_a_track_of_a_street_lamps_head_joins_its_mast_though_its_bearings_are_to_the_head() -> None:
    """A street lamp (2.0 x 0.3 m, its arm across the road: yaw -90 degrees) at (30, 8) seen from 22
    frames along +x; the last eight also see its head alone, 1.5 m out along the arm, placed 20 %
    too far along their rays (beyond what one frame merges). The head's track triangulates to the
    point under the head: its bearings consistently pass 1.5 m (about 1.2 m across the ray) from
    the mast, far beyond their spreads, so the two triangulations disagree unless the arm's reach
    across the ray is allowed for (arm_across): one lamp, at its mast. A plain pole (0.3 x 0.3 m)
    has no arm: two poles."""
    lamp = np.array([30.0, 8.0])
    head = lamp + np.array([0.0, -1.5])
    times = [0.1 * k for k in range(22)]

    def drive(length: float) -> list[Observation]:
        def seen(k: int, point: np.ndarray, ref: int, scale: float) -> Observation:
            o = _seen(k, (float(k), 0.0), (float(point[0]), float(point[1])), scale, ref=ref)
            size = np.array([length, 0.3, 8.0])
            placement = dataclasses.replace(o.placement, size_m=size, yaw=-0.5 * math.pi)
            return dataclasses.replace(o, placement=placement)

        return [seen(k, lamp, 1, 0.0) for k in range(22)] + [seen(k, head, 2, 0.2) for k in range(14, 22)]

    (one,) = track_drive(drive(2.0), times, PARAMS)
    assert len(one.fused.observations) == 30
    assert float(np.linalg.norm(one.fused.placement.contact_world[:2] - lamp)) < 0.05
    assert len(track_drive(drive(0.3), times, PARAMS)) == 2
