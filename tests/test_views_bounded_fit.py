"""A drive's moving track placed with frames that bound the depth (behind an occluder, a partial contact)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from layout_support import ground_placement

from usdworld.layout.draft import DepthMethod
from usdworld.layout.placement import Placement
from usdworld.parameters.views import ViewsParams
from usdworld.views.drive import fit_motion, fit_motion_bounded, track_drive
from usdworld.views.fusion import FusedObject, Observation
from usdworld.views.hidden_contact import depth_bound_side, surface_sigma

PARAMS = ViewsParams()
CAMERA_HEIGHT = 1.21
KERB = 0.15


def _placement(cls: str, xy: tuple[float, float], method: DepthMethod) -> Placement:
    """A walker-sized ``cls`` (0.6 x 0.6 x 1.75 m) at ``xy``, placed by ``method``."""
    return ground_placement(cls, xy, (100, 40, 104, 160), (0.6, 0.6, 1.75), method)


def _item(*methods: DepthMethod) -> FusedObject:
    obs = tuple(
        Observation(k, f"v{k}", f"v{k}.png", _placement("person", (20.0, 0.0), m), np.zeros(2), 1.0, 0.2)
        for k, m in enumerate(methods)
    )
    return FusedObject(obs[0].placement, obs, "single", np.eye(2))


def test_which_placements_bound_the_depth_and_from_which_side() -> None:
    """Behind an occluder: at least that far (+1); a visible bottom's ground point or a cut height:
    at most that far (-1); a frame one of whose views reads the depth is a reading (0)."""
    assert depth_bound_side(_item(DepthMethod.BEHIND)) == 1
    assert depth_bound_side(_item(DepthMethod.CONTACT_PARTIAL)) == -1
    assert depth_bound_side(_item(DepthMethod.HEIGHT_PARTIAL, DepthMethod.CONTACT_PARTIAL)) == -1
    assert depth_bound_side(_item(DepthMethod.BEHIND, DepthMethod.CONTACT)) == 0
    assert depth_bound_side(_item(DepthMethod.BEHIND, DepthMethod.CONTACT_PARTIAL)) == 0
    for m in (DepthMethod.CONTACT, DepthMethod.TOP_ROW, DepthMethod.FUSED, DepthMethod.CUT_OFF):
        assert depth_bound_side(_item(m)) == 0


def _one_sided_cost(
    fit_state: np.ndarray,
    t_ref: float,
    times: np.ndarray,
    z: np.ndarray,
    cov: np.ndarray,
    rays: np.ndarray,
    sides: np.ndarray,
    sigma_speed: float,
) -> float:
    """The cost :func:`fit_motion_bounded` minimises: Mahalanobis residuals, a kept bound's along-ray part 0,
    plus the velocity prior (``fit_state`` (4,), ``z`` (N, 2), ``cov`` (N, 2, 2), ``rays`` (N, 2))."""
    pred = fit_state[:2] + (times - t_ref)[:, None] * fit_state[2:]
    d = pred - z
    along = np.einsum("ni,ni->n", d, rays)
    d = d - np.where(sides * along > 0.0, along, 0.0)[:, None] * rays
    cost = float(np.einsum("ni,nij,nj->", d, np.linalg.inv(cov), d))
    return cost + float(fit_state[2:] @ fit_state[2:]) / sigma_speed**2


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(-8.0, 8.0), st.floats(-8.0, 8.0), st.sampled_from([-1, 0, 0, 1])),
        min_size=4,
        max_size=12,
    ),
    st.floats(0.3, 3.0),
    st.integers(0, 2**31 - 1),
)
def test_the_bounded_fit_minimises_the_one_sided_cost(
    frames: list[tuple[float, float, int]], sigma_along: float, seed: int
) -> None:
    """Walkers 20-40 m from cameras driving past: the bounded fit's cost (a kept bound costs nothing
    along its ray) is no higher than the plain fit's nor than that of any nearby state (the cost is
    convex, so a local minimum is the minimum); without bounds, or without a frame that reads the
    depth, it is the plain fit."""
    rng = np.random.default_rng(seed)
    n = len(frames)
    times = np.arange(n, dtype=np.float64) * 0.5
    truth = np.array([30.0, 5.0]) + times[:, None] * np.array([0.0, 1.3])
    cameras = np.c_[times * 8.0 - 10.0, np.zeros(n)]
    rays = truth - cameras
    rays = rays / np.linalg.norm(rays, axis=1, keepdims=True)
    normals = np.c_[-rays[:, 1], rays[:, 0]]
    along = np.array([f[0] for f in frames])
    across = 0.05 * np.array([f[1] for f in frames])
    sides = np.array([f[2] for f in frames])
    z = truth + along[:, None] * rays + across[:, None] * normals
    sig_across = 0.3
    cov = np.array(
        [sigma_along**2 * np.outer(u, u) + sig_across**2 * np.outer(m, m) for u, m in zip(rays, normals)]
    )
    plain = fit_motion(times, z, cov, 2.0)
    bounded = fit_motion_bounded(times, z, cov, 2.0, rays, sides)
    if np.all(sides != 0):  # no frame reads the depth: the bounds are read as positions
        assert np.array_equal(bounded.state, plain.state)
        return
    args = (bounded.t_ref, times, z, cov, rays, sides, 2.0)
    best = _one_sided_cost(bounded.state, *args)
    assert best <= _one_sided_cost(plain.state, *args) + 1e-6
    for _ in range(8):
        step = rng.normal(size=4) * np.array([0.05, 0.05, 0.02, 0.02])
        assert best <= _one_sided_cost(bounded.state + step, *args) + 1e-6
    readings = fit_motion_bounded(times, z, cov, 2.0, rays, np.zeros(n, dtype=int))
    assert np.array_equal(readings.state, plain.state)


def test_frames_behind_a_parked_car_do_not_pull_a_walkers_track_nearer() -> None:
    """A walker 40 m away crossing at 1.4 m/s, seen in 20 frames: every other frame sees its feet
    (placed 1 m off along the ray, alternately too near and too far, stated spread 2.5 m), the
    others only its head over a parked car, so it is placed just behind the car, 6 m nearer than
    it walks (a bound from below, with the stated and surface spreads of such a frame). Taken as
    bounds those frames keep the track where the seen feet put it (median 0.04 m off); read as
    positions, as the tracking's own fit reads them, they drag it 0.73 m towards the camera."""
    times = [0.5 * k for k in range(20)]
    truth = np.array([[40.0, -7.0 + 1.4 * t] for t in times])
    obs = []
    for k, (t, p) in enumerate(zip(times, truth)):
        r = float(np.linalg.norm(p))
        u = p / r
        if k % 2 == 0:
            seen = p + (1.0 if k % 4 == 0 else -1.0) * u
            placement = _placement("person", (seen[0], seen[1]), DepthMethod.CONTACT)
            obs.append(Observation(k, f"f{k}", f"f{k}.png", placement, np.zeros(2), 2.5, 0.2))
        else:
            near = p - 6.0 * u
            placement = _placement("person", (near[0], near[1]), DepthMethod.BEHIND)
            spread = surface_sigma(placement, r - 6.0, CAMERA_HEIGHT, KERB)
            obs.append(Observation(k, f"f{k}", f"f{k}.png", placement, np.zeros(2), 0.12 * r, 0.2, spread))
    (walker,) = track_drive(obs, times, PARAMS)
    assert walker.moving
    error = np.linalg.norm(walker.positions[:, :2] - truth, axis=1)
    assert float(np.median(error)) < 0.1
    pos = np.array([o.placement.contact_world[:2] for o in obs])
    rays = pos / np.linalg.norm(pos, axis=1, keepdims=True)
    cov = np.array([o.covariance() + o.surface_sigma_m**2 * np.outer(u, u) for o, u in zip(obs, rays)])
    plain = fit_motion(times, pos, cov, PARAMS.person_speed_max_mps)
    plain_error = np.linalg.norm(np.array([plain.predict(t)[0] for t in times]) - truth, axis=1)
    assert float(np.median(plain_error)) > 0.5


def test_a_partial_contact_far_beyond_does_not_pull_a_track_away() -> None:
    """Known answer, upper bound: a car 20 m ahead standing still (velocity fixed), three readings at
    20 m and one visible-bottom bound at 26 m (it is at most that far): the bound is kept, so the
    fit is the readings' 20 m; read as a position it would pull the fit to 21.5 m (equal spreads)."""
    times = [0.0, 0.1, 0.2, 0.3]
    z = np.array([[20.0, 0.0], [20.0, 0.0], [20.0, 0.0], [26.0, 0.0]])
    cov = np.array([np.diag([4.0, 0.04])] * 4)
    rays = np.array([[1.0, 0.0]] * 4)
    fit = fit_motion_bounded(times, z, cov, 0.0, rays, np.array([0, 0, 0, -1]))
    assert fit.state[:2] == pytest.approx([20.0, 0.0], abs=1e-3)
    assert fit_motion(times, z, cov, 0.0).state[:2] == pytest.approx([21.5, 0.0])
    broken = fit_motion_bounded(times, z, cov, 0.0, rays, np.array([0, 0, 0, 1]))
    assert broken.state[:2] == pytest.approx([21.5, 0.0])
