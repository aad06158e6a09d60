"""A drive's walkers: frames placed by a depth bound join their walker's track."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from layout_support import ground_placement

from usdworld.layout.draft import DepthMethod
from usdworld.parameters.views import ViewsParams
from usdworld.views.drive import bounded_m2, track_drive, walking_prior
from usdworld.views.fusion import Observation

PARAMS = ViewsParams()


def _obs(k: int, xy: np.ndarray, method: DepthMethod, sigma_range: float) -> Observation:
    """Frame ``k``'s view of a walker-sized person at ``xy`` placed by ``method`` (camera at the origin)."""
    box, size = (100, 40, 104, 160), (0.6, 0.6, 1.75)
    placement = ground_placement("person", (float(xy[0]), float(xy[1])), box, size, method)
    return Observation(k, f"f{k}", f"f{k}.png", placement, np.zeros(2), sigma_range, 0.2)


def test_bound_frames_join_the_walker_instead_of_starting_tracks() -> None:
    """A walker 30 m away crossing at 1.3 m/s, 20 frames at 0.1 s: its feet seen (readings 0.3 m
    off along the ray, spread 1 m) but in frames 6 and 13, where a parked car hides them and it is
    placed just behind the car, 9 m nearer (a bound from below, spread 2 m), and frame 10, where
    only its visible bottom places it, 20 m beyond (a bound from above, spread 8 m: legs too thin
    for the mask). Each bound is kept by the track, so the walker is one object; compared in full,
    as readings, they start a second object (main: 2 objects)."""
    times = [0.1 * k for k in range(20)]
    obs = []
    for k, t in enumerate(times):
        p = np.array([30.0, -1.0 + 1.3 * t])
        u = p / np.linalg.norm(p)
        if k in (6, 13):
            obs.append(_obs(k, p - 9.0 * u, DepthMethod.BEHIND, 2.0))
        elif k == 10:
            obs.append(_obs(k, p + 20.0 * u, DepthMethod.CONTACT_PARTIAL, 8.0))
        else:
            obs.append(_obs(k, p + (0.3 if k % 2 else -0.3) * u, DepthMethod.CONTACT, 1.0))
    world = track_drive(obs, times, PARAMS)
    assert len(world) == 1
    (walker,) = world
    assert walker.moving and len(walker.times) == 20


@settings(max_examples=60, deadline=None)
@given(
    st.floats(-20.0, 20.0),
    st.floats(-3.0, 3.0),
    st.floats(0.0, 2.0 * np.pi),
    st.floats(0.2, 5.0),
    st.floats(0.05, 1.0),
    st.sampled_from([-1, 1]),
)
def test_a_kept_bound_is_compared_across_its_ray_only(
    along: float, across: float, heading: float, sigma_along: float, sigma_across: float, side: int
) -> None:
    """A reading is compared in full; a bound the prediction keeps (beyond a lower bound, nearer than an
    upper one) only across its ray, never farther than in full; a broken bound in full."""
    u = np.array([np.cos(heading), np.sin(heading)])
    n = np.array([-u[1], u[0]])
    S = sigma_along**2 * np.outer(u, u) + sigma_across**2 * np.outer(n, n)
    d = along * u + across * n  # observation minus prediction
    full = float(d @ np.linalg.solve(S, d))
    assert bounded_m2(d, S) == full
    kept = side * along < 0.0  # a lower bound (+1) is kept by a prediction beyond it: d . u < 0
    m2 = bounded_m2(d, S, u, side)
    if kept:
        assert np.isclose(m2, across**2 / sigma_across**2)
        assert m2 <= full + 1e-9
    else:
        assert np.isclose(m2, full)


def _walker_along_its_rays(step: float) -> tuple[list[float], list[Observation], np.ndarray]:
    """A walker 45 m away walking at 1.3 m/s towards the camera and across (30 frames at 0.1 s), its
    depth read off a contact row that steps by ``step`` metres (the row's whole pixels: the depth
    holds, then jumps), stated spread ``step``, bearing exact."""
    times = [0.1 * k for k in range(30)]
    v = 1.3 * np.array([np.cos(np.deg2rad(150.0)), np.sin(np.deg2rad(150.0))])
    truth = np.array([np.array([45.0, 3.0]) + v * t for t in times])
    obs = []
    for k, p in enumerate(truth):
        r = float(np.linalg.norm(p))
        stepped = step * (np.floor(r / step) + 0.5)
        obs.append(_obs(k, p / r * stepped, DepthMethod.CONTACT, step))
    return times, obs, truth


def test_a_walker_seen_along_its_rays_walks_at_a_walkers_speed() -> None:
    """Its rows step by 3 m (about one pixel at 45 m), so its readings say little of its speed along
    the ray, and the zero-mean speed prior let the fit slow it to 0.8 m/s, 0.64 m off (median); with
    the walking-speed prior along its fitted direction it is placed 0.18 m off at 1.12 m/s. Rows
    0.05 m apart (a near walker) fix the speed, and the prior's 1.32 m/s moves it by under 0.05 m/s."""
    times, obs, truth = _walker_along_its_rays(3.0)
    (walker,) = track_drive(obs, times, PARAMS)
    assert walker.moving
    error = np.linalg.norm(walker.positions[:, :2] - truth, axis=1)
    assert float(np.median(error)) < 0.25
    assert abs(float(np.linalg.norm(walker.velocity)) - 1.3) < 0.25
    times, obs, _ = _walker_along_its_rays(0.05)
    (near,) = track_drive(obs, times, PARAMS)
    assert abs(float(np.linalg.norm(near.velocity)) - 1.3) < 0.05


@settings(max_examples=40, deadline=None)
@given(st.floats(0.05, 5.0), st.floats(0.0, 2.0 * np.pi), st.floats(0.5, 5.0))
def test_the_walking_prior_is_the_speed_along_the_fitted_direction(
    speed: float, heading: float, sigma: float
) -> None:
    """Mean: the walking speed along the velocity's direction, whatever its fitted speed; spread: the
    walking speed's along it, the zero-mean prior's across it."""
    u = np.array([np.cos(heading), np.sin(heading)])
    n = np.array([-u[1], u[0]])
    mean, info = walking_prior(speed * u, sigma, PARAMS)
    assert np.allclose(mean, PARAMS.person_walking_speed_mps * u)
    assert np.isclose(u @ info @ u, 1.0 / PARAMS.person_walking_speed_sd_mps**2)
    assert np.isclose(n @ info @ n, 1.0 / sigma**2)
    assert np.isclose(u @ info @ n, 0.0, atol=1e-9)
    assert walking_prior(np.zeros(2), sigma, PARAMS) is None
