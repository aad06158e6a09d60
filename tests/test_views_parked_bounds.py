"""A drive's parked cars: frames placed by a depth bound join their car and do not pull it."""

from __future__ import annotations

import numpy as np
import pytest
from layout_support import ground_placement

from usdworld.layout.draft import DepthMethod
from usdworld.parameters.views import ViewsParams
from usdworld.views.drive import bounded_standing_position, track_drive
from usdworld.views.fusion import Observation, fuse

PARAMS = ViewsParams()
CAR = (40.0, 5.0)


def _car(k: int, along: float, method: DepthMethod, sigma_range: float) -> Observation:
    """Frame ``k``'s view (camera at the origin) of a car (4.5 x 1.8 m) placed ``along`` metres from the
    parked car at :data:`CAR` along its viewing ray."""
    p = np.array(CAR)
    xy = p + along * p / np.linalg.norm(p)
    placement = ground_placement("car", (float(xy[0]), float(xy[1])), (100, 40, 140, 70), (4.5, 1.8, 1.5), method)
    return Observation(k, f"f{k}", f"f{k}.png", placement, np.zeros(2), sigma_range, 0.3)


def _drive(bound_frames: range) -> list[Observation]:
    """30 frames at 0.1 s of a car parked 40 m away: its contact seen (readings 0.5 m off along
    the ray, spread 3 m) but in ``bound_frames``, where a nearer parked car hides its bottom and
    it is placed just behind that car, 12 m nearer (a bound from below, spread 3 m)."""
    return [
        _car(k, -12.0, DepthMethod.BEHIND, 3.0) if k in bound_frames
        else _car(k, 0.5 if k % 2 else -0.5, DepthMethod.CONTACT, 3.0)
        for k in range(30)
    ]


def test_frames_behind_a_nearer_car_join_the_parked_car_and_do_not_pull_it() -> None:
    """Frames 10-19 say only "at least 28 m": the track keeps that bound, so they are compared across
    the ray only and join the car, and its place counts them only on the side they bound: one
    standing car at 40 m. Compared in full (m2 about 14 of the 9.21 gate) they start a second,
    standing car 12 m nearer (main: 2 cars); read as positions they would pull the car to 36 m."""
    world = track_drive(_drive(range(10, 20)), [0.1 * k for k in range(30)], PARAMS)
    assert len(world) == 1
    (car,) = world
    assert not car.moving and len(car.times) == 30
    assert car.fused.placement.contact_world[:2] == pytest.approx(CAR, abs=0.3)


def test_bounds_at_the_end_of_a_track_do_not_make_a_parked_car_a_mover() -> None:
    """The bound frames last (20-29): read as positions they would move the track towards the camera
    at about 4 m/s; counted only where the track breaks them, the car stands at 40 m."""
    world = track_drive(_drive(range(20, 30)), [0.1 * k for k in range(30)], PARAMS)
    assert len(world) == 1
    (car,) = world
    assert not car.moving and len(car.times) == 30
    assert car.fused.placement.contact_world[:2] == pytest.approx(CAR, abs=0.3)


def test_the_bounded_standing_position_keeps_the_mean_without_bounds_or_readings() -> None:
    """No frame bounds, or every frame does: the information-weighted mean is kept as given."""
    times = [0.0, 0.1]
    for method in (DepthMethod.CONTACT, DepthMethod.BEHIND):
        items = fuse([_car(0, -1.0, method, 2.0)], PARAMS) + fuse([_car(1, 1.0, method, 2.0)], PARAMS)
        xy = np.array([1.0, 2.0])
        assert bounded_standing_position(times, items, xy).tolist() == [1.0, 2.0]


def test_a_broken_bound_still_pulls() -> None:
    """A bound the readings break (a frame "at most 35 m" of a car read at 40 m) counts as a reading
    at its bound: the place lies between, nearer than the readings' mean."""
    obs = [_car(0, 0.0, DepthMethod.CONTACT, 3.0), _car(1, -5.0, DepthMethod.CONTACT_PARTIAL, 3.0)]
    items = fuse([obs[0]], PARAMS) + fuse([obs[1]], PARAMS)
    xy = bounded_standing_position([0.0, 0.1], items, np.array(CAR))
    r = float(np.linalg.norm(xy))
    assert float(np.linalg.norm(CAR)) - 5.0 < r < float(np.linalg.norm(CAR)) - 1.0
