"""A moving vehicle's height measured by its track's own frames, in place of its class prior."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from layout_support import ground_placement

from usdworld.layout.draft import DepthMethod
from usdworld.perception.depth.fusion import DepthCue
from usdworld.views.drive import track_height_factor, with_height_factor
from usdworld.views.fusion import FusedObject, Observation


def _frame(
    range_m: float, cues: tuple[DepthCue, ...], bearing: float = 0.0, method: DepthMethod = DepthMethod.CONTACT
) -> FusedObject:
    """A car's frame placed at the inverse-variance depth of ``cues`` along ``bearing`` from a camera at the origin."""
    avail = [c for c in cues if c.sigma_m is not None and c.depth_m is not None]
    w = [1.0 / c.sigma_m**2 for c in avail]
    depth = sum(wi * c.depth_m for wi, c in zip(w, avail)) / sum(w) if method is DepthMethod.CONTACT else range_m
    xy = (depth * math.cos(bearing), depth * math.sin(bearing))
    placement = dataclasses.replace(
        ground_placement("car", xy, (100, 120, 140, 140), (4.2, 1.8, 1.5), method=method, cues=cues), depth_m=depth
    )
    o = Observation(0, "f", "f.png", placement, np.zeros(2), 0.05 * depth, 0.02 * depth)
    return FusedObject(placement, (o,), "single", o.covariance())


def _cues(range_m: float, factor: float, row_px: float = 0.3) -> tuple[DepthCue, ...]:
    """A contact cue at the true depth (its spread a row's ``row_px`` at a 350 px focal length and a 1.4 m
    high camera) and the height cue of a car ``factor`` times as tall as the prior (13 % spread)."""
    d_h = range_m / factor
    return (
        DepthCue("contact", range_m, row_px * range_m**2 / (350.0 * 1.4)),
        DepthCue("height", d_h, 0.13 * d_h),
    )


def test_a_tall_cars_height_is_measured_by_its_near_frames() -> None:
    """A 1.73 m car (1.15 times the 1.5 m prior) seen from 60 m down to 10 m: its near frames' contact
    cues fix its height; a car of the prior's height keeps factor 1."""
    ranges = np.linspace(60.0, 10.0, 40)
    tall = [_frame(r, _cues(r, 1.15)) for r in ranges]
    assert abs(track_height_factor(tall) - 1.15) < 0.005
    usual = [_frame(r, _cues(r, 1.0)) for r in ranges]
    assert abs(track_height_factor(usual) - 1.0) < 0.005


def test_a_frame_without_both_cues_leaves_the_prior() -> None:
    """No observation with both a contact and a height cue: the factor is the prior's, 1."""
    only_height = _frame(50.0, (DepthCue("height", 50.0, 6.0), DepthCue("contact", None, None, "cut")))
    assert track_height_factor([only_height]) == 1.0


def test_the_measured_height_moves_a_far_frame_along_its_ray() -> None:
    """A frame at 50 m on a 30 degree bearing whose height cue reads 43.5 m (a car 1.15 times the prior):
    with the measured factor its two cues agree at 50 m, so its contact moves out along its own ray to
    50 m; a frame placed by a bound (behind what hides it) is kept as it is."""
    bearing = math.radians(30.0)
    item = _frame(50.0, _cues(50.0, 1.15, row_px=3.0), bearing)
    assert np.linalg.norm(item.placement.contact_world[:2]) < 49.0
    moved = with_height_factor(item, 1.15)
    xy = moved.placement.contact_world[:2]
    assert abs(float(np.linalg.norm(xy)) - 50.0) < 1e-6
    assert abs(math.atan2(xy[1], xy[0]) - bearing) < 1e-9
    behind = _frame(50.0, _cues(50.0, 1.15), bearing, DepthMethod.BEHIND)
    assert with_height_factor(behind, 1.15) is behind
