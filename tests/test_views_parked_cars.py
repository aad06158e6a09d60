"""A drive's vehicle tracks as a standing-or-moving mixture: one-frame parked cars keep apart."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from layout_support import ground_placement

from usdworld.parameters.views import ViewsParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.views.drive import (
    _Track,
    association_m2,
    fit_motion,
    predict_track,
    standing_weight,
    track_drive,
)
from usdworld.views.fusion import Observation, fuse

PARAMS = ViewsParams()


def _car(frame: int, xy: tuple[float, float], sigma_r: float, sigma_l: float, ref: int) -> Observation:
    """A car (4.5 x 1.8 m) seen in ``frame`` (one view per frame) from a camera at the origin."""
    x, y = xy
    r = float(np.hypot(x, y))
    cue = DepthCue("contact", r, sigma_r)
    placement = ground_placement("car", xy, (100, 40, 140, 70), (4.5, 1.8, 1.5), cues=(cue,), ref=ref)
    return Observation(frame, f"f{frame}", f"f{frame}.png", placement, np.zeros(2), sigma_r, sigma_l)


def test_two_parked_cars_seen_one_after_the_other_are_not_one_mover() -> None:
    """Two parked cars on either side of a lane, 7 m apart across a 20 m ray (bearings sure to
    0.5 m): car A is seen in frame 0 only, car B from frame 2 on (A hidden by then); a car drives
    past at 10 m/s, seen in frames 0-5. Under the 14 m/s speed prior alone, A's one-frame track
    predicts 0.2 s later with a 2.9 m spread and takes B (m2 5.9 of the 9.21 gate): one track of
    both cars, judged moving across the ray. Parked with prior 0.95, only the moving
    hypothesis reaches B, and it pays -2 ln 0.05 = 6.0 for its weight (m2 11.9): two standing cars,
    one mover."""
    obs = [_car(0, (20.0, 3.5), 1.0, 0.5, ref=1)]
    obs += [_car(k, (20.0, -3.5), 1.0, 0.5, ref=2) for k in (2, 3, 4)]
    obs += [_car(k, (25.0 + 1.0 * k, -10.0), 1.0, 0.5, ref=3) for k in range(6)]
    objects = track_drive(obs, [0.1 * k for k in range(6)], PARAMS)
    movers = [o for o in objects if o.moving]
    standing = sorted((o for o in objects if not o.moving), key=lambda o: -o.fused.placement.contact_world[1])
    assert len(movers) == 1 and len(movers[0].times) == 6
    assert movers[0].velocity == pytest.approx([10.0, 0.0], abs=0.5)
    assert [len(o.times) for o in standing] == [1, 3]
    assert standing[0].fused.placement.contact_world[:2] == pytest.approx([20.0, 3.5])
    assert standing[1].fused.placement.contact_world[:2] == pytest.approx([20.0, -3.5])


def test_parked_fragments_apart_beyond_their_own_errors_stay_two_cars() -> None:
    """Two parked cars 9 m apart along a 30 m ray (each frame sure to 2 m along it): A seen in frames
    0-19, B in frames 31-50 (A's track closed in between). Each fragment's position is known no better
    than the error its own frames share (half a frame's variance), and 9 m is 4.3 of those summed
    spreads: two parked cars, not one car driving off. (With frames sure only to 4 m the step is
    within the two fragments' own errors, m2 4.6: the join takes them for one car, and the joined
    track's moving test, which allows each fragment its own error, agrees.)"""
    obs = [_car(k, (30.0, 0.0), 2.0, 0.3, ref=1) for k in range(20)]
    obs += [_car(k, (39.0, 0.0), 2.0, 0.3, ref=2) for k in range(31, 51)]
    objects = track_drive(obs, [0.1 * k for k in range(51)], PARAMS)
    assert not any(o.moving for o in objects)
    assert sorted(len(o.times) for o in objects) == [20, 20]
    xs = sorted(o.fused.placement.contact_world[0] for o in objects)
    assert xs == [pytest.approx(30.0), pytest.approx(39.0)]


def _track(times: list[float], xy: np.ndarray, share: float) -> _Track:
    tr = _Track("car", PARAMS.vehicle_speed_max_mps, standing_share=share)
    for k, t in enumerate(times):
        tr.add(t, fuse([_car(k, (float(xy[k, 0]), float(xy[k, 1])), 1.5, 0.4, ref=1)], PARAMS)[0])
    return tr


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 6),
    speed=st.floats(0.0, 15.0),
    dz=st.tuples(st.floats(-15.0, 15.0), st.floats(-15.0, 15.0)),
    gap=st.integers(1, 10),
    share=st.sampled_from([0.0, 0.5, 0.95]),
)
def test_the_mixture_distance_lies_between_its_hypotheses(
    n: int, speed: float, dz: tuple[float, float], gap: int, share: float
) -> None:
    """The mixture's m2 is -2 ln(w exp(-m2_s / 2) + (1 - w) exp(-m2_m / 2)): never below the nearer
    hypothesis' m2, never above either hypothesis' m2 less twice the log of its weight; without a
    standing share it is the moving fit's."""
    times = [0.1 * k for k in range(n)]
    xy = np.array([[30.0 + speed * t, 5.0] for t in times])
    tr = _track(times, xy, share)
    t = times[-1] + 0.1 * gap
    z = np.array([30.0 + speed * t + dz[0], 5.0 + dz[1]])
    R = np.diag([2.0, 0.3])
    x, P = tr.fit.predict(t)
    m2_moving = float((z - x) @ np.linalg.solve(P + R, z - x))
    got = association_m2(predict_track(tr, t), z, R)
    if share == 0.0:
        assert tr.still is None and got == pytest.approx(m2_moving, rel=1e-12)
        return
    xs, Ps = tr.still.predict(t)
    m2_standing = float((z - xs) @ np.linalg.solve(Ps + R, z - xs))
    w = standing_weight(tr.fit, tr.sigma_speed, share)
    assert got >= min(m2_standing, m2_moving) - 1e-9
    for weight, m2 in ((w, m2_standing), (1.0 - w, m2_moving)):
        if weight > 0.0:
            assert got <= m2 - 2.0 * math.log(weight) + 1e-9


def test_the_standing_weight_follows_the_frames() -> None:
    """One frame keeps the prior; ten frames standing still raise it; ten frames at 10 m/s
    (sure to a metre) drop it to nothing; the Savage-Dickey ratio in closed form for two frames."""
    sigma = PARAMS.vehicle_speed_max_mps
    cov = np.array([np.eye(2)] * 10)
    still = fit_motion([0.1 * k for k in range(10)], np.tile([20.0, 0.0], (10, 1)), cov, sigma)
    assert standing_weight(still, sigma, 0.95) > 0.99
    driving = np.array([[20.0 + k, 0.0] for k in range(10)])
    moving = fit_motion([0.1 * k for k in range(10)], driving, cov, sigma)
    assert standing_weight(moving, sigma, 0.95) < 1e-6
    two = fit_motion([0.0, 1.0], np.array([[0.0, 0.0], [1.0, 0.0]]), cov[:2], sigma)
    Cv = two.covariance[2:, 2:]
    v = two.velocity
    bf = sigma**2 / math.sqrt(np.linalg.det(Cv)) * math.exp(-0.5 * float(v @ np.linalg.solve(Cv, v)))
    assert standing_weight(two, sigma, 0.5) == pytest.approx(bf / (1.0 + bf), rel=1e-12)
    assert standing_weight(two, sigma, 0.0) == 0.0 and standing_weight(two, sigma, 1.0) == 1.0
