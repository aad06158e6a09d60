"""A drive's vehicle moving test: frame errors split into the part the frames share and the part they do not."""

from __future__ import annotations

import numpy as np
from layout_support import ground_placement

from usdworld.parameters.views import ViewsParams
from usdworld.views.drive import (
    _is_moving,
    _joined,
    _Track,
    fit_motion,
    joined_parts,
    merge_fragments,
    speed_prior,
    standing_chi2,
    standing_prior,
)
from usdworld.views.hidden_contact import fit_covariance
from usdworld.views.fusion import FusedObject, Observation

PARAMS = ViewsParams()
EGO = np.array([8.0, 0.0])  # m/s, the camera's velocity


def _frame(t: float, xy: np.ndarray, sigma_range: float, sigma_lateral: float) -> FusedObject:
    """A car's frame at ``xy`` seen from the camera where it is at time ``t``."""
    camera = EGO * t
    placement = ground_placement("car", (float(xy[0]), float(xy[1])), (100, 120, 104, 123), (4.2, 1.8, 1.5))
    o = Observation(int(round(10 * t)), "f", "f.png", placement, camera, sigma_range, sigma_lateral)
    return FusedObject(placement, (o,), "single", o.covariance())


def _track(frames: list[FusedObject], times: list[float]) -> _Track:
    tr = _Track("car", speed_prior("car", PARAMS), standing_share=standing_prior("car", PARAMS))
    for t, item in zip(times, frames):
        tr.add(t, item)
    return tr


def _parked_car_short_by_a_tenth(spread_share: float) -> tuple[list[float], _Track]:
    """Five seconds of a car parked 60 m ahead, every frame 10 % of its range too near, its along-ray spread
    ``spread_share`` of the range (across: 2 %)."""
    times = [0.1 * k for k in range(50)]
    car = np.array([60.0, 3.0])
    frames = []
    for t in times:
        rng = float(np.linalg.norm(car - EGO * t))
        frames.append(_frame(t, car - 0.10 * (car - EGO * t), spread_share * rng, 0.02 * rng))
    return times, _track(frames, times)


def test_a_far_car_followed_at_one_range_moves() -> None:
    """A car 141 m ahead that keeps its range from a camera driving at 8 m/s, every frame repeating one
    depth (a car three pixels tall changes no pixel in 5.6 s) stated at 36 m: a parked car would have
    come 45 m nearer, and a shared depth error fakes no speed at one range, so the car moves. Its
    frames' stated spreads taken as independent (the old test) leave 8 m/s below the gate."""
    times = [0.1 * k for k in range(57)]
    frames = [_frame(t, EGO * t + np.array([141.0, 0.5]), 36.0, 2.8) for t in times]
    tr = _track(frames, times)
    assert tr.fit.speed_chi2() < PARAMS.association_gate_chi2  # independent frames: standing
    assert standing_chi2(tr, PARAMS) > PARAMS.association_gate_chi2
    assert _is_moving(tr, tr.fit, PARAMS)
    assert np.allclose(tr.fit.velocity, EGO, atol=1.0)


def test_a_parked_car_with_a_shared_depth_error_stands() -> None:
    """A parked car 60 m ahead that the camera drives towards, every frame 10 % too near (one height
    misjudged for all frames; stated spread 8 % of the range): its frames drift away at 0.8 m/s on a
    straight line. Taking the shared part out of each frame's variance alone would make that drift
    significant; the apparent velocity a shared error gives (``rho s^2 w w^T``) keeps it standing."""
    times, tr = _parked_car_short_by_a_tenth(0.08)
    assert np.allclose(tr.fit.velocity, [0.8, 0.0], atol=0.05)
    pos = np.array([o.placement.contact_world[:2] for o in tr.items])
    cov = np.array([fit_covariance(o) for o in tr.items])
    indep = fit_motion(times, pos, (1.0 - PARAMS.frame_error_correlation) * cov, tr.sigma_speed)
    v = indep.velocity
    assert v @ np.linalg.solve(indep.covariance[2:, 2:], v) > PARAMS.association_gate_chi2
    assert standing_chi2(tr, PARAMS) < PARAMS.association_gate_chi2
    assert not _is_moving(tr, tr.fit, PARAMS)


def test_a_parked_car_whose_shared_error_fakes_a_drift_stands() -> None:
    """The same car with a stated spread of 5 % of the range: the frames taken as independent (the old
    test) find its 0.8 m/s drift significant and make it a mover; as one shared error it stands."""
    times, tr = _parked_car_short_by_a_tenth(0.05)
    assert tr.fit.speed_chi2() > PARAMS.association_gate_chi2
    assert not _is_moving(tr, tr.fit, PARAMS)


def _parked_fragments(offset: float) -> tuple[_Track, _Track]:
    """A parked car 30 m ahead seen for 12 frames, then a 4-frame fragment whose frames all read it
    ``offset`` metres nearer along their rays (one hidden side misjudged for those frames); stated
    spread 5 % of the range along the ray, 1 % across."""
    car = np.array([30.0, 6.0])

    def frame(t: float, d: float) -> FusedObject:
        rng = float(np.linalg.norm(car - EGO * t))
        return _frame(t, car - d * (car - EGO * t) / rng, 0.05 * rng, 0.01 * rng)

    ta = [0.1 * k for k in range(12)]
    tb = [0.1 * k for k in range(13, 17)]
    return _track([frame(t, 0.0) for t in ta], ta), _track([frame(t, offset) for t in tb], tb)


def test_a_fragment_within_its_own_shared_error_joins_its_parked_car() -> None:
    """The fragment 2 m nearer agrees with the car within the join's gate (each position floored by
    the error its own frames share), so the joined track's moving test must allow the fragments to
    differ by those errors too: taken as one shared error for all 16 frames, the 2 m step between them
    reads as 1.6 m/s and the join was refused (the car placed twice)."""
    a, b = _parked_fragments(2.0)
    joined = _joined(a, b)
    assert standing_chi2(joined, PARAMS) > PARAMS.association_gate_chi2  # one shared error: moves
    joined.parts = joined_parts(a, b, PARAMS)
    assert standing_chi2(joined, PARAMS) < PARAMS.association_gate_chi2
    (one,) = merge_fragments([a, b], PARAMS)
    assert len(one.times) == 16 and not _is_moving(one, one.fit, PARAMS)


def test_a_fragment_beyond_its_own_shared_error_stays_apart() -> None:
    """4 m off, the fragment is outside the join's gate: two cars, as before."""
    a, b = _parked_fragments(4.0)
    assert len(merge_fragments([a, b], PARAMS)) == 2


def test_fragments_add_nothing_to_a_track_of_one_part() -> None:
    """A track whose frames all belong to one fragment keeps the plain split test: an offset of all its
    frames leaves the fitted velocity as it is."""
    a, _ = _parked_fragments(2.0)
    plain = standing_chi2(a, PARAMS)
    a.parts = ((tuple(a.times), np.eye(2)),)
    assert standing_chi2(a, PARAMS) == plain


def test_a_mover_joined_from_standing_looking_fragments_still_moves() -> None:
    """A car driving at 5 m/s across 16 frames, its frames held as two fragments: their own shared
    errors (a few decimetres) do not explain 8 m of travel."""
    car = np.array([30.0, 6.0])
    times = [0.1 * k for k in range(16)]
    frames = []
    for t in times:
        xy = car + np.array([5.0, 0.0]) * t
        rng = float(np.linalg.norm(xy - EGO * t))
        frames.append(_frame(t, xy, 0.05 * rng, 0.01 * rng))
    a, b = _track(frames[:12], times[:12]), _track(frames[12:], times[12:])
    joined = _joined(a, b)
    joined.parts = joined_parts(a, b, PARAMS)
    assert _is_moving(joined, joined.fit, PARAMS)
