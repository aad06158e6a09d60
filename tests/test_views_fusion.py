"""Association and fusion of objects across views: rays crossing, depths averaging, what never merges."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from layout_support import ground_placement

from usdworld.layout.placement import Placement
from usdworld.parameters.views import ViewsParams
from usdworld.parameters.perception import DEFAULT_PERCEPTION
from usdworld.perception.depth.fusion import DepthCue, contact_sigma_m
from usdworld.views.fusion import (
    ContactRow,
    Observation,
    associate,
    depth_sigma,
    fuse,
    gate_sigma,
    observations,
)

PARAMS = ViewsParams()


def _placement(cls: str, x: float, y: float, sigma: float | None = 1.0, ref: int = 1) -> Placement:
    r = float(np.hypot(x, y))
    cue = DepthCue("contact", r if sigma is not None else None, sigma)
    return ground_placement(cls, (x, y), (100, 100, 140, 160), (4.2, 1.8, 1.5), cues=(cue,), ref=ref)


def _obs(
    view: int, cls: str, xy: tuple[float, float], camera: tuple[float, float], sigma_r: float, ref: int = 1
) -> Observation:
    return Observation(
        view, f"v{view}", f"v{view}.png", _placement(cls, *xy, ref=ref), np.array(camera), sigma_r, 0.1
    )


def test_crossing_rays_triangulate_the_point_their_depths_miss() -> None:
    """Two views 20 m apart see a car at (10, 10) along perpendicular rays; each depth is 2 m off
    along its own ray, but the rays pin the point: the fused car is near (10, 10), not between the guesses."""
    a = _obs(
        0, "car", (12.0, 12.0), (0.0, 0.0), sigma_r=3.0
    )  # ray (1, 1)/sqrt2 from the origin, 2.8 m too far
    b = _obs(
        1, "car", (8.5, 11.5), (20.0, 0.0), sigma_r=3.0
    )  # ray (-1, 1)/sqrt2 from (20, 0), 2.1 m too near
    (obj,) = fuse([a, b], PARAMS)
    assert obj.placement.position_world[:2] == pytest.approx([10.0, 10.0], abs=0.1)
    assert obj.method == "triangulated"
    assert [o.view for o in obj.observations] == [0, 1]


def test_parallel_rays_average_the_depths_by_inverse_variance() -> None:
    a = _obs(0, "car", (30.0, 0.0), (0.0, 0.0), sigma_r=1.0)
    b = _obs(1, "car", (33.0, 0.0), (0.0, 0.5), sigma_r=2.0)
    (obj,) = fuse([a, b], PARAMS)
    assert obj.placement.position_world[0] == pytest.approx((30.0 / 1 + 33.0 / 4) / (1 + 1 / 4), abs=0.05)
    assert obj.method == "fused"
    assert obj.observations[0].view == 0  # the primary observation is the surer one


def test_what_never_merges() -> None:
    same_view = [
        _obs(0, "car", (20.0, 0.0), (0.0, 0.0), 1.0, ref=1),
        _obs(0, "car", (20.5, 0.0), (0.0, 0.0), 1.0, ref=2),
    ]
    other_class = [
        _obs(0, "car", (20.0, 0.0), (0.0, 0.0), 1.0),
        _obs(1, "person", (20.0, 0.0), (0.0, 0.5), 1.0),
    ]
    far_apart = [_obs(0, "car", (20.0, 0.0), (0.0, 0.0), 0.5), _obs(1, "car", (20.0, 5.0), (0.0, 0.5), 0.5)]
    for obs in (same_view, other_class, far_apart):
        assert associate(obs, PARAMS) == [[0], [1]]


def test_association_ignores_the_order_of_the_observations() -> None:
    obs = [
        _obs(0, "car", (20.0, 0.0), (0.0, 0.0), 1.0, ref=1),
        _obs(1, "car", (20.6, 0.2), (0.0, 0.5), 1.0, ref=1),
        _obs(2, "car", (19.7, -0.3), (0.5, 0.0), 1.0, ref=1),
        _obs(0, "car", (40.0, 3.0), (0.0, 0.0), 2.0, ref=2),
        _obs(1, "car", (41.0, 3.0), (0.0, 0.5), 2.0, ref=2),
    ]
    # 0 and 1 are nearest (squared Mahalanobis 2.3); once fused, their tighter estimate leaves 2 outside the gate
    # (2 alone is 4.6 from 0, inside it): greedy nearest-first, whatever the input order
    expected = {frozenset({0, 1}), frozenset({2}), frozenset({3, 4})}
    for order in itertools.permutations(range(len(obs))):
        groups = associate([obs[i] for i in order], PARAMS)
        assert {frozenset(order[i] for i in g) for g in groups} == expected


def test_observations_move_placements_into_the_world_with_their_uncertainty() -> None:
    turn = math.radians(90.0)
    W = np.eye(4)
    W[:2, :2] = [[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]]
    W[:2, 3] = (1.0, 2.0)
    (o,) = observations(3, "side", "side.png", [_placement("car", 10.0, 0.0, sigma=0.8)], W, PARAMS)
    assert o.placement.position_world == pytest.approx([1.0, 12.0, 0.0])
    assert o.placement.yaw == pytest.approx(turn)
    assert o.sigma_range_m == pytest.approx(0.8)
    assert o.sigma_lateral_m == pytest.approx(
        max(PARAMS.lateral_sigma_min_m, PARAMS.lateral_sigma_rel * 10.0)
    )
    cov = o.covariance()
    assert cov[1, 1] == pytest.approx(0.8**2) and cov[0, 0] == pytest.approx(o.sigma_lateral_m**2)


def test_depth_sigma_fuses_the_cues_and_falls_back_without_them() -> None:
    p = _placement("car", 20.0, 0.0, sigma=None)
    assert depth_sigma(p, PARAMS) == pytest.approx(PARAMS.fallback_depth_rel_sigma * 20.0)
    two = Placement(
        **{
            **p.__dict__,
            "cues": (
                DepthCue("contact", 20.0, 1.0),
                DepthCue("height", 21.0, 1.0),
                DepthCue("cnn", None, None),
            ),
        }
    )
    assert depth_sigma(two, PARAMS) == pytest.approx(1.0 / math.sqrt(2.0))


def test_views_of_a_lamp_that_chose_different_variants_fuse_its_mast_not_their_origins() -> None:
    """Two views see one lamp's mast at (20, -5): the nearer chose the street lamp (mast 0.875 m
    behind its origin, arm turned over the road, +Y), the farther a plain pole. Fused, the mast
    stays at (20, -5) and the origin follows the chosen variant, not the mean of the two origins."""
    offset = np.array([-0.875, 0.0])
    lamp = dataclasses.replace(
        _placement("pole", 20.0, -4.0), variant="street_lamp", yaw=math.pi / 2, contact_offset=offset
    ).with_contact_at(np.array([20.0, -5.0, 0.0]))
    plain = _placement("pole", 20.0, -5.0, ref=2)
    assert lamp.position_world[:2] == pytest.approx([20.0, -5.0 + 0.875])  # the arm's side of the mast
    near = Observation(0, "v0", "v0.png", lamp, np.array([10.0, -5.0]), 0.5, 0.1)
    far = Observation(1, "v1", "v1.png", plain, np.array([0.0, -5.0]), 2.0, 0.1)
    (obj,) = fuse([near, far], PARAMS)
    assert obj.placement.variant == "street_lamp"
    assert obj.placement.contact_world[:2] == pytest.approx([20.0, -5.0], abs=1e-9)
    assert obj.placement.position_world[:2] == pytest.approx([20.0, -4.125], abs=1e-9)


def test_the_variant_and_size_come_from_the_nearest_view_that_measured_them() -> None:
    """The nearest view of a lamp cuts its head (no height: default variant at unit scale);
    a farther view saw all of it and chose the street lamp at scale 1.1. The fused lamp is
    that street lamp, its mast where the views put it, its yaw and evidence the nearest view's."""
    offset = np.array([-0.875, 0.0]) * 1.1
    cut = dataclasses.replace(
        _placement("pole", 20.0, -5.0), variant="plain", yaw=math.pi / 2, scale_measured=math.nan
    )
    whole = dataclasses.replace(
        _placement("pole", 20.0, -5.0, ref=2),
        variant="street_lamp",
        yaw=math.pi / 2,
        scale=1.1,
        scale_measured=1.1,
        size_m=np.array([2.05, 0.3, 7.96]) * 1.1,
        contact_offset=offset,
    ).with_contact_at(np.array([20.0, -5.0, 0.0]))
    near = Observation(0, "v0", "v0.png", cut, np.array([10.0, -5.0]), 0.5, 0.1)
    far = Observation(1, "v1", "v1.png", whole, np.array([0.0, -5.0]), 2.0, 0.1)
    (obj,) = fuse([near, far], PARAMS)
    p = obj.placement
    assert (p.variant, p.scale, p.obj.ref) == ("street_lamp", 1.1, 1)
    assert p.size_m == pytest.approx([2.255, 0.33, 8.756])
    assert p.contact_world[:2] == pytest.approx([20.0, -5.0], abs=1e-9)
    assert p.position_world[:2] == pytest.approx([20.0, -5.0 + 0.9625], abs=1e-9)


def test_gate_sigma_gives_a_contact_cue_back_its_whole_pixel_of_row() -> None:
    """A view weighs its contact cue with the row's quantisation spread (1/sqrt(12) px); the views'
    gates see the cue as a whole pixel of row would have made it, known answer for the cue alone,
    and no other cue (nor a view without its row) changes."""
    fy, h, d = 500.0, 1.5, 40.0
    quantised = DEFAULT_PERCEPTION.contact_row_error_px
    assert quantised == pytest.approx(1.0 / math.sqrt(12.0))
    cue = DepthCue("contact", d, contact_sigma_m(d, fy, h))
    whole = contact_sigma_m(d, fy, h, dataclasses.replace(DEFAULT_PERCEPTION, contact_row_error_px=1.0))
    row = ContactRow(fy, h, quantised)
    assert gate_sigma(cue, row, PARAMS) == pytest.approx(whole)
    assert gate_sigma(cue, None, PARAMS) == pytest.approx(cue.sigma_m)
    height = DepthCue("height", d, 6.0)
    assert gate_sigma(height, row, PARAMS) == 6.0
    p = dataclasses.replace(_placement("car", d, 0.0), cues=(cue, height))
    assert depth_sigma(p, PARAMS, row) == pytest.approx(1.0 / math.sqrt(whole**-2 + 6.0**-2))
    (o,) = observations(0, "v0", "v0.png", [p], np.eye(4), PARAMS, row)
    assert o.sigma_range_m == pytest.approx(depth_sigma(p, PARAMS, row))
