"""Fill in what the camera file did not say: intrinsics, height and pitch.

Objects of known class-height distribution constrain the camera height and the
horizon (Hoiem, Efros and Hebert 2006, "Putting Objects in Perspective"): an object
standing on the ground whose bottom is at row ``v_b`` and top at ``v_t`` has, for a
camera at height ``h`` pitched by ``theta``, a predicted top row that depends only on
``(h, theta)`` and its metric height. The posterior over ``(h, theta)`` combines robust
(Cauchy) image residuals of every usable object with Gaussian priors on the height and
pitch of a vehicle-mounted camera (or, when a road plane was given, on the plane's height and
pitch: :class:`PosePrior`); a coarse-to-fine grid search finds its mode, and the
estimate is the posterior mean (and spread) summed on a fine grid round it, which a few
objects' long valleys and the cusps of roofs at camera height do not throw off as they
do the mode (measured on the 10 KITTI frames: median depth error 4.5 % with the mode,
3.4 % with the mean). Far from the prior's mean the prior pulls the estimate by a few per cent. The top row of the road
region bounds the horizon from below when it is known, and the street's vanishing point
(:mod:`usdworld.geometry.vanishing`) is a robust (Cauchy) measurement of the horizon row.
The priors, noise levels and grids are fields of :class:`~usdworld.parameters.CameraParams`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from usdworld.errors import CalibrationError
from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.vanishing import VanishingPoint, horizon_measurement
from usdworld.parameters.camera import DEFAULT_CAMERA, CameraParams

if TYPE_CHECKING:  # the focal length, lane and roll modules are imported where a missing part is estimated
    from usdworld.geometry.focal import FocalEstimate
    from usdworld.geometry.lanes import LaneMarkings, LaneWidthCue
    from usdworld.geometry.roll import RollEstimate, RollMeasurement


@dataclass(frozen=True)
class HeightObservations:
    """Objects usable for calibration: upright, bottom and top visible.

    Attributes:
        u: (N,) float64 column of the object's centre, pixels.
        v_bottom: (N,) float64 row where the object meets the ground, pixels.
        v_top: (N,) float64 row of the object's top, pixels.
        height_m: (N,) float64 expected metric height of each object's class.
        height_std_m: (N,) float64 spread of that height.
        top_near_m: (N,) float64 how far beyond the contact point, along the view, the
            near edge of the object's top lies (metres; default 0: a flat object).
        top_far_m: (N,) float64 the same for the top's far edge. A car's box bottom is
            its nearest corner while its top row is the far edge of the roof (the top is
            below the camera); a person's top is the head above the feet (0, 0).
    """

    u: np.ndarray
    v_bottom: np.ndarray
    v_top: np.ndarray
    height_m: np.ndarray
    height_std_m: np.ndarray
    top_near_m: np.ndarray | None = None
    top_far_m: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.u)
        for name in ("top_near_m", "top_far_m"):
            if getattr(self, name) is None:
                object.__setattr__(self, name, np.zeros(n))
        for name in ("v_bottom", "v_top", "height_m", "height_std_m", "top_near_m", "top_far_m"):
            if len(getattr(self, name)) != n:
                raise CalibrationError(f"height observations: {name} has a different length than u")

    def __len__(self) -> int:
        return len(self.u)


@dataclass(frozen=True)
class HorizonEvidence:
    """What the image says about the horizon row, apart from the objects.

    Attributes:
        road_top_v: highest row of the road region (the horizon is above it), or None.
        vanishing_v: row of the street's vanishing point, or None.
        vanishing_sigma_px: its standard error, pixels (road slope included).
    """

    road_top_v: float | None = None
    vanishing_v: float | None = None
    vanishing_sigma_px: float = 1.0


@dataclass(frozen=True)
class PosePrior:
    """A measured camera pose with its uncertainty: a Gaussian prior on height and pitch.

    A road plane fitted round the car (a KITTI ``planes`` file) measures the road under the
    camera; the road under an object tens of metres away is not that plane, so the plane
    is fused with what the objects say instead of fixing the camera.

    Attributes:
        height_m: measured camera height above the road, metres.
        height_sigma_m: its standard deviation, metres (> 0).
        pitch: measured pitch, radians (positive looking down).
        pitch_sigma: its standard deviation, radians (> 0).
    """

    height_m: float
    height_sigma_m: float
    pitch: float
    pitch_sigma: float

    def __post_init__(self) -> None:
        if not (self.height_sigma_m > 0 and self.pitch_sigma > 0):
            raise CalibrationError(
                f"pose prior: sigmas must be > 0, got {self.height_sigma_m:g} m and {self.pitch_sigma:g} rad"
            )


@dataclass(frozen=True)
class CameraEstimate:
    """The camera used for the world, and how each part of it was obtained.

    Attributes:
        camera: the full camera.
        estimated: names of the parameters that were not given (``K``, ``height_m``,
            ``pitch``, ``roll``, ``yaw``).
        method: one line saying how the missing parameters were obtained.
        n_objects: objects that constrained the estimate.
        residual_px: median absolute top-row residual of those objects, pixels (0 without).
        sigma_height_m: standard deviation of the camera height (0 when it was given).
        sigma_pitch: standard deviation of the pitch, radians (0 when it was given).
        focal: how the focal length was estimated (its cues, fused), or None when K was given.
        lanes: the lane-line pairs that measured the camera height (their spacing), or None
            when no markings showed or the height was given.
        roll: how the roll was obtained (the vertical vanishing point fused with a level
            prior), or None when it was given.
    """

    camera: PinholeCamera
    estimated: tuple[str, ...]
    method: str
    n_objects: int
    residual_px: float
    sigma_height_m: float = 0.0
    sigma_pitch: float = 0.0
    focal: FocalEstimate | None = None
    lanes: LaneWidthCue | None = None
    roll: RollEstimate | None = None


#: (candidate, object) pairs evaluated at once by :func:`_object_cost`: 16k float64 = 128 KiB per
#: temporary, a few of which fit a core's L2 cache. Speed only; the values do not depend on it.
_BLOCK_ELEMENTS = 1 << 14


def intrinsics_from_focal(width: int, height: int, f_px: float) -> np.ndarray:
    """(3, 3) float64 K with square pixels of focal ``f_px`` and the principal point at the image centre."""
    from usdworld.geometry.focal import principal_point

    cx, cy = principal_point(width, height)
    return np.array([[f_px, 0.0, cx], [0.0, f_px, cy], [0.0, 0.0, 1.0]])


def predicted_top_rows(
    h: np.ndarray, pitch: np.ndarray, K: np.ndarray, obs: HeightObservations
) -> tuple[np.ndarray, np.ndarray]:
    """Top rows predicted for each object under each candidate (height, pitch); zero roll.

    The object's top is at ``height_m`` above the ground, from ``top_near_m`` to
    ``top_far_m`` beyond its contact point; its highest image row is the predicted top.

    Args:
        h: (G,) float64 candidate camera heights, metres.
        pitch: (G,) float64 candidate pitches, radians.
        K: (3, 3) float64 camera matrix.
        obs: the N objects.

    Returns:
        v_top: (G, N) float64 predicted top rows (NaN where the bottom is above the horizon).
        depth: (G, N) float64 depth of the object's top along the optical axis.
    """
    v_top, depth, _ = _top_rows(h, pitch, K, obs)
    return v_top, depth


def _top_rows(
    h: np.ndarray, pitch: np.ndarray, K: np.ndarray, obs: HeightObservations
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`predicted_top_rows`, and the top's pixels per metre of height spread,
    ``fy * height_std_m / max(depth, 0.1)`` ((G, N) float64, which the cost reuses).

    Temporaries are reused in place (``out=``) and the products that do not depend on the
    edge are made once: every value is the same float operation on the same operands.
    """
    fy, cy = K[1, 1], K[1, 2]
    b = ((obs.v_bottom - cy) / fy)[None, :]
    c, s = np.cos(pitch)[:, None], np.sin(pitch)[:, None]
    hh = h[:, None]
    denom = b * c
    np.add(s, denom, out=denom)  # s + b c
    with np.errstate(divide="ignore", invalid="ignore"):
        t = hh / denom
        t[~(denom > 1e-9)] = np.nan
        forward = b * s
        np.subtract(c, forward, out=forward)
        np.multiply(t, forward, out=forward)  # t (c - b s)
        dz = obs.height_m[None, :] - hh
        s_dz, c_dz = s * dz, c * dz
        rows, depths = [], []
        for offset in (obs.top_near_m, obs.top_far_m):
            ahead = forward + offset[None, :]
            z_cam = c * ahead
            np.subtract(z_cam, s_dz, out=z_cam)  # c ahead - s dz
            y_cam = s * ahead
            np.add(y_cam, c_dz, out=y_cam)
            np.negative(y_cam, out=y_cam)  # -(s ahead + c dz)
            row = np.multiply(fy, y_cam, out=y_cam)
            np.divide(row, z_cam, out=row)
            np.add(cy, row, out=row)  # cy + fy y_cam / z_cam
            row[~(z_cam > 0.1)] = np.nan
            rows.append(row)
            depths.append(z_cam)
    far_higher = rows[1] < rows[0]
    depth = np.where(far_higher, depths[1], depths[0])
    # Smooth minimum over the roof height's spread: real roofs are not all at the class
    # height, so the switch from the far edge to the near edge as the camera passes the
    # roof is gradual, not a kink in the cost. min(a, b) = (a + b - |a - b|) / 2 with |g|
    # replaced by g tanh(g / tau): exact when the edges coincide (a flat object) and when
    # they are far apart, smooth in between.
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        spread_px = fy * obs.height_std_m[None, :] / np.maximum(depth, 0.1)
        tau = np.maximum(spread_px, 1e-6)
        gap = rows[1] - rows[0]
        np.divide(gap, tau, out=tau)
        np.tanh(tau, out=tau)
        np.multiply(gap, tau, out=tau)  # gap tanh(gap / tau)
        v_top = rows[0] + rows[1]
        np.subtract(v_top, tau, out=v_top)
        np.multiply(0.5, v_top, out=v_top)
    return v_top, depth, spread_px


def _object_cost(
    h: np.ndarray, pitch: np.ndarray, K: np.ndarray, obs: HeightObservations, params: CameraParams
) -> np.ndarray:
    """Sum over the objects of their robust (Cauchy) top-row costs, per candidate; (G,) float64.

    Evaluated over blocks of candidates of about ``_BLOCK_ELEMENTS`` (candidate, object)
    pairs, so that each temporary of :func:`predicted_top_rows` stays in the processor's cache
    instead of a (G, N) array in memory (G is up to 161 x 161): every value, and each
    candidate's sum over its objects, is computed by the same operations as in one block.
    """
    out = np.empty(len(h))
    step = max(1, _BLOCK_ELEMENTS // len(obs))
    for a in range(0, len(h), step):
        v_top, _, spread_px = _top_rows(h[a : a + step], pitch[a : a + step], K, obs)
        # sqrt(spread^2 + noise^2), the top row's sigma, in place
        sigma = np.square(spread_px, out=spread_px)
        np.add(sigma, params.edge_noise_px**2, out=sigma)
        np.sqrt(sigma, out=sigma)
        r = np.subtract(v_top, obs.v_top[None, :], out=v_top)
        np.divide(r, sigma, out=r)
        finite = np.isfinite(r)
        cost = np.square(r, out=r)
        np.log1p(cost, out=cost)
        cost[~finite] = params.unprojectable_cost
        out[a : a + step] = cost.sum(axis=1)
    return out


def _cost(
    h: np.ndarray,
    pitch: np.ndarray,
    K: np.ndarray,
    obs: HeightObservations,
    evidence: HorizonEvidence,
    params: CameraParams,
    prior: PosePrior | None = None,
    lanes: LaneWidthCue | None = None,
) -> np.ndarray:
    """Negative log posterior (up to a constant) of each candidate; (G,) float64.

    The prior is ``prior`` when the pose was measured, else the vehicle-camera priors of ``params``;
    ``lanes`` adds the lane-line pairs' robust (Cauchy) height terms.
    """
    if prior is None:
        mean_h, std_h = params.height_prior_m
        cost = 0.5 * ((h - mean_h) / std_h) ** 2 + 0.5 * (np.degrees(pitch) / params.pitch_prior_std_deg) ** 2
    else:
        cost = 0.5 * ((h - prior.height_m) / prior.height_sigma_m) ** 2
        cost = cost + 0.5 * ((pitch - prior.pitch) / prior.pitch_sigma) ** 2
    if len(obs):
        cost = cost + _object_cost(h, pitch, K, obs, params)
    horizon = K[1, 2] - K[1, 1] * np.tan(pitch)
    if evidence.road_top_v is not None:
        excess = np.maximum(horizon - evidence.road_top_v, 0.0)
        cost = cost + 0.5 * (excess / params.road_top_sigma_px) ** 2
    if evidence.vanishing_v is not None:
        cost = cost + np.log1p(((horizon - evidence.vanishing_v) / evidence.vanishing_sigma_px) ** 2)
    if lanes is not None:
        cost = cost + lanes.cost(h, pitch)
    return cost


def _search(
    K: np.ndarray,
    obs: HeightObservations,
    evidence: HorizonEvidence,
    fixed_h: float | None,
    fixed_pitch: float | None,
    params: CameraParams,
    prior: PosePrior | None = None,
    lanes: LaneWidthCue | None = None,
) -> tuple[float, float]:
    """Coarse-to-fine grid search of the (height, pitch) posterior."""
    h_lo, h_hi = params.height_range_m
    p_lo, p_hi = np.radians(params.pitch_range_deg)
    h_step, p_step = params.search_step_height_m, np.radians(params.search_step_pitch_deg)
    best_h, best_p = fixed_h, fixed_pitch
    for _ in range(3):
        hs = np.array([fixed_h]) if fixed_h is not None else np.arange(h_lo, h_hi + 1e-9, h_step)
        ps = np.array([fixed_pitch]) if fixed_pitch is not None else np.arange(p_lo, p_hi + 1e-12, p_step)
        H, P = np.meshgrid(hs, ps, indexing="ij")
        cost = _cost(H.ravel(), P.ravel(), K, obs, evidence, params, prior, lanes)
        k = int(np.argmin(cost))
        best_h, best_p = float(H.ravel()[k]), float(P.ravel()[k])
        h_lo, h_hi = best_h - 2 * h_step, best_h + 2 * h_step
        p_lo, p_hi = best_p - 2 * p_step, best_p + 2 * p_step
        h_step, p_step = h_step / 10, p_step / 10
    assert best_h is not None and best_p is not None
    return best_h, best_p


def _posterior_moments(
    K: np.ndarray,
    obs: HeightObservations,
    evidence: HorizonEvidence,
    mode: tuple[float, float],
    free: tuple[bool, bool],
    params: CameraParams,
    prior: PosePrior | None = None,
    lanes: LaneWidthCue | None = None,
) -> tuple[float, float, float, float]:
    """Posterior mean and standard deviation of height and pitch, summed on a grid round the mode.

    The posterior is not a smooth bowl: where a car's roof crosses the camera height its
    top row switches from the roof's far edge to its near edge, which puts a cusp in the
    cost, and a few objects leave a long valley of height-pitch pairs. The mean and the
    spread over the grid are stable where the mode and the local curvature are not.

    Returns:
        (mean height, mean pitch, sigma height, sigma pitch); a fixed parameter keeps its
        value with sigma 0.
    """
    h0, p0 = mode
    h_lo, h_hi = params.height_range_m
    half_h, step_h = params.moment_half_height_m, params.moment_step_height_m
    if free[0]:
        hs = np.arange(max(h_lo, h0 - half_h), min(h_hi, h0 + half_h) + 1e-9, step_h)
    else:
        hs = np.array([h0])
    if free[1]:
        half, step = np.radians(params.moment_half_pitch_deg), np.radians(params.moment_step_pitch_deg)
        ps = np.arange(p0 - half, p0 + half + 1e-12, step)
    else:
        ps = np.array([p0])
    H, P = np.meshgrid(hs, ps, indexing="ij")
    cost = _cost(H.ravel(), P.ravel(), K, obs, evidence, params, prior, lanes)
    w = np.exp(-(cost - cost.min()))
    w /= w.sum()
    # Exactly rounded sums (math.fsum), not ``w @ x``: BLAS splits a long dot product over its
    # threads and the partial sums' order changes the last bits (the grid has ~26k points).
    mean_h, mean_p = math.fsum(w * H.ravel()), math.fsum(w * P.ravel())
    sigma_h = math.sqrt(math.fsum(w * (H.ravel() - mean_h) ** 2)) if free[0] else 0.0
    sigma_p = math.sqrt(math.fsum(w * (P.ravel() - mean_p) ** 2)) if free[1] else 0.0
    return mean_h, mean_p, sigma_h, sigma_p


def _fit_subset(obs: HeightObservations, max_objects: int) -> HeightObservations:
    """The objects the camera is fitted to: all of them up to ``max_objects``, else
    ``max_objects`` spread evenly over the contact rows (the objects sorted by ``v_bottom``,
    ties in input order, taken at evenly spaced ranks), kept in input order.

    Chosen by where they stand, never by their top rows: picking the tallest boxes would pick
    the cars taller than their class and bias the height. The posterior costs (grid points x
    objects), and its precision stops improving well before thousands of objects
    (:attr:`CameraParams.max_fit_objects`).
    """
    n = len(obs)
    if n <= max_objects:
        return obs
    by_row = np.argsort(obs.v_bottom, kind="stable")
    keep = np.sort(by_row[np.round(np.linspace(0, n - 1, max_objects)).astype(np.int64)])
    return HeightObservations(
        *(
            np.asarray(getattr(obs, name))[keep]
            for name in ("u", "v_bottom", "v_top", "height_m", "height_std_m", "top_near_m", "top_far_m")
        )
    )


def _derolled(
    obs: HeightObservations,
    vanishing: VanishingPoint | None,
    lanes: LaneMarkings | None,
    roll: float,
    K: np.ndarray,
    params: CameraParams,
) -> tuple[HeightObservations, VanishingPoint | None, LaneMarkings | None]:
    """The objects' contacts and tops, the street's vanishing point and the lane lines as the level
    camera sees them (turned back by ``roll`` about the principal point of ``K``)."""
    from usdworld.geometry.lanes import derolled_markings
    from usdworld.geometry.roll import deroll_points

    c = np.asarray(K)[:2, 2]
    bottom = deroll_points(np.column_stack([obs.u, obs.v_bottom]), roll, c)
    top = deroll_points(np.column_stack([obs.u, obs.v_top]), roll, c)
    obs = HeightObservations(
        bottom[:, 0], bottom[:, 1], top[:, 1], obs.height_m, obs.height_std_m, obs.top_near_m, obs.top_far_m
    )
    if vanishing is not None:
        (u, v), = deroll_points(np.array([[vanishing.u, vanishing.v]]), roll, c)
        vanishing = replace(vanishing, u=float(u), v=float(v))
    if lanes is not None:
        lanes = derolled_markings(lanes, roll, c, params)
    return obs, vanishing, lanes


def estimate_camera(
    width: int,
    height: int,
    K: np.ndarray | None,
    height_m: float | None,
    pitch: float | None,
    roll: float | None,
    yaw: float | None,
    observations: HeightObservations,
    road_top_v: float | None = None,
    vanishing: VanishingPoint | None = None,
    params: CameraParams = DEFAULT_CAMERA,
    focal: FocalEstimate | None = None,
    pose_prior: PosePrior | None = None,
    lanes: LaneMarkings | None = None,
    roll_measurement: RollMeasurement | None = None,
) -> CameraEstimate:
    """Complete a partially known camera.

    Args:
        width: image width in pixels.
        height: image height in pixels.
        K: (3, 3) float64 camera matrix, or None: then the focal length is ``focal`` (the
            photo's cues fused with the prior, :mod:`usdworld.geometry.focal`), or the prior
            alone, with the principal point at the image centre.
        height_m: camera height in metres, or None to estimate.
        pitch: radians (positive looking down), or None to estimate.
        roll: radians, or None: then ``roll_measurement`` fused with a level prior
            (:func:`usdworld.geometry.roll.fuse_roll`), 0 without one.
        yaw: radians, or None (then 0: the world's X axis is the camera's heading).
        observations: upright objects with visible bottom and top.
        road_top_v: highest image row (smallest v) of the road region, or None.
        vanishing: the street's vanishing point, or None.
        params: the priors, noise levels and search grids.
        focal: the fused focal length when ``K`` is None (ignored when K is given).
        pose_prior: a measured height and pitch with their uncertainty (a road plane), fused
            with the objects in place of the vehicle-camera priors; only with ``height_m``
            and ``pitch`` None.
        lanes: the photo's lane lines (:func:`usdworld.geometry.lanes.find_lane_markings`); their
            neighbouring pairs measure the camera height (:class:`~usdworld.geometry.lanes.LaneWidthCue`)
            when it is estimated.
        roll_measurement: the roll the vertical vanishing point measures, or None; used only
            when ``roll`` is None. The objects, the vanishing point and the lines are turned
            back by the fused roll (:func:`usdworld.geometry.roll.deroll_points`) before the
            level camera's height and pitch are fitted to them.

    Returns:
        The camera and a record of what was estimated and how.

    Raises:
        CalibrationError: ``pose_prior`` given together with a height or pitch.
    """
    if pose_prior is not None and (height_m is not None or pitch is not None):
        raise CalibrationError(
            "a pose prior is for a camera whose height and pitch are not given; pass one of the two"
        )
    estimated = []
    notes = []
    if K is None:
        if focal is None:
            from usdworld.geometry.focal import fuse_focal, prior_cue

            focal = fuse_focal([prior_cue(width, height, params)], params)
        K = intrinsics_from_focal(width, height, focal.f_px)
        estimated.append("K")
        notes.append(f"intrinsics estimated, centred principal point: {focal.describe()}")
    else:
        focal = None
    roll_estimate = None
    if roll is None:
        from usdworld.geometry.roll import fuse_roll

        estimated.append("roll")
        roll_estimate = fuse_roll(roll_measurement, params)
        notes.append(roll_estimate.describe())
        roll = roll_estimate.roll
        if roll != 0.0:
            observations, vanishing, lanes = _derolled(observations, vanishing, lanes, roll, np.asarray(K), params)
    if yaw is None:
        yaw = 0.0
    residual = 0.0
    n_used = 0
    sigma_h = sigma_p = 0.0
    lane_cue = None
    if height_m is None or pitch is None:
        if height_m is None:
            estimated.append("height_m")
        if pitch is None:
            estimated.append("pitch")
        usable = _fit_subset(observations, params.max_fit_objects)
        v_vp = horizon_measurement(vanishing, float(np.asarray(K)[1, 1]), params) if vanishing is not None else None
        evidence = HorizonEvidence(road_top_v, *(v_vp or (None, 1.0)))
        if height_m is None and lanes is not None:
            from usdworld.geometry.lanes import lane_width_cue

            lane_cue = lane_width_cue(lanes, np.asarray(K), params)
        mode = _search(np.asarray(K), usable, evidence, height_m, pitch, params, pose_prior, lane_cue)
        h_est, p_est, sigma_h, sigma_p = _posterior_moments(
            np.asarray(K), usable, evidence, mode, (height_m is None, pitch is None), params, pose_prior, lane_cue
        )
        n_used = len(usable)
        if pose_prior is not None:
            notes.append(
                f"road plane's height {pose_prior.height_m:.3f} m and pitch "
                f"{math.degrees(pose_prior.pitch):.2f} deg as a prior (+-{pose_prior.height_sigma_m:g} m, "
                f"+-{math.degrees(pose_prior.pitch_sigma):.2f} deg)"
            )
        if n_used:
            v_top, _ = predicted_top_rows(np.array([h_est]), np.array([p_est]), np.asarray(K), usable)
            res = np.abs(v_top[0] - usable.v_top)
            residual = float(np.nanmedian(res)) if np.isfinite(res).any() else 0.0
            notes.append(
                f"height/pitch fitted to {n_used} object(s) of known class height"
                + (f" (spread over the rows of {len(observations)})" if n_used < len(observations) else "")
                + (" and the road's top row" if road_top_v is not None else "")
                + (f", horizon near the vanishing row {vanishing.v:.1f}" if vanishing is not None else "")
                + f" (median residual {residual:.1f} px)"
            )
        elif vanishing is not None:
            notes.append(f"no usable objects: height from the prior, horizon near the vanishing row {vanishing.v:.1f}")
        elif road_top_v is not None:
            notes.append("no usable objects: height from the prior, pitch bounded by the road's top row")
        elif pose_prior is None:
            notes.append(
                f"nothing to go on: default camera height {params.height_prior_mean_m:g} m and level pitch"
            )
        if lane_cue is not None:
            implied = ", ".join(f"{x:.2f}" for x in lane_cue.heights_m(p_est))
            notes.append(
                f"height also from {len(lane_cue)} pair(s) of lane lines of {params.lane_width_m:g} +- "
                f"{params.lane_width_std_m:g} m spacing (implied {implied} m; "
                f"+-{100 * float(np.min(lane_cue.sigma_log)):.0f} % each)"
            )
        height_m, pitch = h_est, p_est
    method = "; ".join(notes) if notes else "all camera parameters given"
    camera = PinholeCamera(width, height, np.asarray(K), float(height_m), float(pitch), float(roll), float(yaw))
    return CameraEstimate(
        camera, tuple(estimated), method, n_used, residual, sigma_h, sigma_p, focal, lane_cue, roll_estimate
    )
