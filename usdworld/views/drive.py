"""A drive's frames placed into one world: standing objects once, moving ones as tracks (layout level: pure numpy).

A view set is a *drive* when all its views carry timestamps and they fall into two or
more *frames*: in time order, a view within ``frame_gap_s`` of the one before is of the
same frame (a rig's cameras fire a few milliseconds apart: a nuScenes sample is one
frame), a longer gap starts the next one. A frame's time is its first timestamp. Fusing
every observation of a drive at once (:func:`usdworld.views.fusion.fuse`) would compare
each with all others, and would average a moving car's positions into one; instead the
frames are tracked in time order, so the work grows with the number of frames:

1. Within a frame the cameras' observations are fused as a rig's are (:func:`fuse`), and
   two objects of a trunk class (trees, poles, signs) whose footprints overlap are made one
   (:func:`merge_overlapping`): two trunks cannot stand in one place, so they are one
   object the single view cut in two (a tree's crown split by what stands in front of it).
   Across the viewing ray, where a bearing is precise, the footprints must overlap (a
   street lamp's by its arm's width across the ray: a view may see its head apart); along
   it, where a depth is not, within ``split_depth_sigmas`` of the depth difference's spread.
2. Each track of one class predicts its ground position at the frame's time with a
   constant-velocity fit of its observations (information form, each weighted by its
   ground covariance). Classes that cannot move (everything but vehicles and people)
   have velocity 0; vehicles and people have a zero-mean velocity prior of standard
   deviation ``vehicle_speed_max_mps`` / ``person_speed_max_mps``, which is what lets a
   track follow a car before its own observations fix its speed.
   A frame that places a walker from the top of its head (its feet hidden) weighs in with
   the spread of the surface it may stand on, road or kerb, added along its ray
   (:func:`usdworld.views.hidden_contact.fit_covariance`): frames that see the feet fix it.
3. The frame's objects join tracks by one global assignment (Hungarian) that maximises
   the summed ``association_gate_chi2 - m2`` of the pairs it makes, ``m2`` a pair's
   squared Mahalanobis distance (prediction and observation covariances summed), so only
   pairs within the gate are made; the rest start tracks. A person's or a vehicle's frame placed
   by a bound (:func:`usdworld.views.hidden_contact.depth_bound_side`: just behind what hides its
   bottom, or its visible bottom) is compared only across its ray where the track keeps the bound
   (:func:`bounded_m2`), so it joins its object instead of starting a track of its own; and a
   vehicle track's moving fit counts such a frame only where it breaks the bound
   (:func:`fit_motion_bounded`, as the placed fit below), so a frame that only says "at least this
   far" does not pull the track nearer and make a parked car a mover. A
   track not seen for longer than ``track_gap_s`` is closed. A vehicle's track predicts under two hypotheses,
   standing (velocity 0) and moving (the velocity prior), weighted by the prior
   ``vehicle_standing_share`` times each one's evidence in the track's frames
   (:func:`standing_weight`); its ``m2`` is the mixture's (:func:`association_m2`). A
   track of one frame is a parked car until its frames say otherwise: under the speed
   prior alone its gate would reach about 21 m half a second after that frame and take
   another parked car of the row; as a mixture the moving hypothesis pays for its weight
   and reaches 0.59 of that.
4. Standing tracks that are fragments of one object are joined (:func:`merge_fragments`):
   a single-view placement error that jumps between frames starts a second track, and
   both then keep catching the object's observations. Two standing tracks of one class
   that share no frame are one object when their positions agree within the gate, each
   position's covariance floored at ``frame_error_correlation`` times one frame's error
   covariance (the share of a frame's error that the object's other frames repeat does
   not average away). A frame's error is the larger of what the surest frame states and
   what the fragment's own frames measure: their robust scatter about their median, along
   and across their mean viewing ray, divided by ``1 - frame_error_correlation`` (the
   scatter shows only the part the frames do not share). Stated spreads understate the
   single-view depth error of far objects, and a fragment whose frames scatter by metres
   is not known to a fraction of a metre. A trunk class's fragment (tree, pole, sign) is
   compared at its bearing triangulation (below).
   Moving tracks that are fragments of one mover are joined too (:func:`merge_moving_fragments`):
   a walker's frames that the association split between two tracks open at once (a frame whose
   depth jumped by a contact row started the second) leave two movers where there is one. Two
   moving tracks of one class that share no frame are one mover when their constant-velocity
   fits, each predicted to where the two meet (the midpoint between their time spans, or between
   their mean times where the spans interleave), agree within the gate, their covariances summed,
   and their frames together still move.
5. Standing tracks of one trunk class whose triangulated positions are nearer than their
   footprints' inscribed radii summed are one object (:func:`merge_standing_trunks`),
   whether or not they share frames: two trunks cannot stand in one place. Two that share
   frames and agree only within their depths' spread are one when every shared frame sees
   them overlap across its ray and, for a footprint without an arm, they share no more of the
   shorter one's frames than a crown cut in half the frames gives by chance (:func:`cut_tail`,
   at the gate's 1 %: a crown is cut in two only where something stands in front of it; two
   trees of a row are two in every frame that sees both); a shared frame in which either
   track holds an observation whose ray misses that track's footprint (another object's,
   :func:`ray_through_own_footprint`) is left out of the overlap test. A trunk track
   shorter than ``scatter_min_frames`` whose every ray passes through a longer one's
   footprint is that object seen with a failed depth (:func:`absorb_short_fragments`): it
   joins it with its bearings, its depths dropped.
6. Standing vehicle tracks of one class whose placed positions are nearer than their
   footprints' inscribed radii summed (half their widths summed) are one vehicle
   (:func:`merge_standing_vehicles`), whether or not they share frames: two parked cars
   cannot stand in one place, whatever their headings. A view that places a parked car a
   metre or more off its other frames (a hidden side it did not see) starts a fragment that
   then holds a neighbour's frame in some frame the car's own track holds too, so step 4,
   which joins fragments that share no frame, leaves it as a second car.

**Trunks are triangulated.** A standing tree, pole or sign seen from a moving camera is
where its frames' rays cross (:func:`bearing_triangulation`): its single-view depth errs
by a share that all its frames repeat (its size or contact misjudged once for all), its
bearing (the column of its trunk's base) does not. The depth cues enter once, as a prior
along the mean viewing ray with the standing estimate's floored variance, so a far object
seen over a short baseline keeps its depth; frames whose bearing is to another point (a
crown cut by what stands in front) get little weight. Vehicles stay at their
information-weighted mean: their visible face, and so their bearing's point, turns with
the view, and a parked car with a depth error looks like a slow mover.

**Moving or standing.** A vehicle's or person's track is *moving* when it spans at least
``moving_min_frames`` frames and its fitted velocity disagrees with standing still beyond
its uncertainty: ``v^T C_v^-1 v > association_gate_chi2`` (the chi-square 99 % quantile, 2
degrees of freedom) and ``|v| >= moving_speed_min_mps`` (a slower drift is what a depth
error that grows with range makes of a parked car the camera drives past). A vehicle's
``C_v`` splits its frames' errors (:func:`standing_chi2`): ``frame_error_correlation`` of each
frame's variance is one relative depth error all of them repeat, which fakes a velocity of
that error times the camera's for a standing car, and only the rest scatters from frame to
frame (a far car followed at one range, every frame repeating one depth, moves). A track that a
standing join made of fragments (steps 4 and 6) adds what each fragment's own shared error makes of
its velocity (:func:`_parts_velocity_covariance`): the join took the fragments for one object within
those errors, so their step is no evidence of motion. Everything
else stands: it is placed once, at the information-weighted mean of all its observations
(as :func:`fuse` places an object several cameras see), or a trunk class at its bearing
triangulation; a standing vehicle whose frames mix readings and bounds is placed where its
bounds count only on the side they bound (:func:`bounded_standing_position`).

**What a moving object gets.** Its placement (the default, un-timed value) is its fitted
position at its first frame; per frame where it is seen, a time sample of its position
*on the constant-velocity fit* (not the raw observation: single-view depth noise would
make it jitter) and of its heading, the velocity's direction. A moving vehicle's frames are
first placed with its own height (:func:`track_height_factor`: the contact cues of its near
frames measure it) in place of its class prior's in their height cues (:func:`with_height_factor`):
a car taller than the prior reads nearer by the same share in every frame that leans on its
height, the far ones most, which tilts the fitted velocity. That fit is the tracking's
with one difference: a frame placed by a bound (just behind what hides its bottom, or by a
visible bottom or cut height: :func:`usdworld.views.hidden_contact.depth_bound_side`) only
says on which side along its ray the object is, so it counts only where the track would
cross it (:func:`fit_motion_bounded`); and a person's speed along the fitted direction has
the published walking-speed prior instead of the zero-mean one (:func:`walking_prior`): a
walker seen along its viewing rays, where a far contact row steps by metres, gets its speed
from how fast people walk. Between and outside those
frames USD interpolates the samples linearly and holds the first and last; the world
shows the object only from the first frame it is seen in to the last (its ``visibility``
is time-sampled: :func:`usdworld.authoring.rig.visibility_samples`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from usdworld.geometry.rotation import turned
from usdworld.io.class_table import load_class_table
from usdworld.layout.draft import DepthMethod
from usdworld.layout.placement import Placement
from usdworld.parameters.views import ViewsParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.perception.depth.fusion import fuse as fuse_cues
from usdworld.views.bearings import bearing_sigmas, bearing_triangulation
from usdworld.views.fusion import (
    FusedObject,
    Observation,
    combine,
    fuse,
    fusion_method,
    sized_by_a_whole_view,
)
from usdworld.views.hidden_contact import depth_bound_side, fit_covariance

#: Classes that can move in a drive, with the parameter that bounds their speed.
VEHICLE_CLASSES = ("car", "truck", "bus", "motorcycle", "bicycle")
PEOPLE_CLASSES = ("person", "rider")


def speed_prior(class_name: str, params: ViewsParams) -> float:
    """Standard deviation of the velocity prior of a class, m/s (0: the class stands still)."""
    if class_name in VEHICLE_CLASSES:
        return params.vehicle_speed_max_mps
    if class_name in PEOPLE_CLASSES:
        return params.person_speed_max_mps
    return 0.0


def standing_prior(class_name: str, params: ViewsParams) -> float:
    """Prior probability that a track of a class stands rather than moves (0: no standing hypothesis is kept).

    Vehicles: ``vehicle_standing_share``. People are tracked under their speed prior alone,
    and classes that cannot move stand by their fit.
    """
    return params.vehicle_standing_share if class_name in VEHICLE_CLASSES else 0.0


@dataclass(frozen=True)
class MotionFit:
    """A constant-velocity fit of a track's ground positions.

    Attributes:
        t_ref: the reference time, seconds.
        state: (4,) float64 position (x, y) at ``t_ref`` and velocity (vx, vy), metres and m/s.
        covariance: (4, 4) float64 its covariance.
    """

    t_ref: float
    state: np.ndarray
    covariance: np.ndarray

    def predict(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(2,) position and (2, 2) covariance at time ``t``."""
        H = np.hstack([np.eye(2), (t - self.t_ref) * np.eye(2)])
        return H @ self.state, H @ self.covariance @ H.T

    @property
    def velocity(self) -> np.ndarray:
        """(2,) float64 m/s."""
        return self.state[2:]

    def speed_chi2(self) -> float:
        """Squared Mahalanobis distance of the velocity from standing still."""
        v = self.velocity
        C = self.covariance[2:, 2:]
        if not np.all(np.isfinite(C)) or np.linalg.det(C) <= 0:
            return 0.0
        return float(v @ np.linalg.solve(C, v))


def fit_motion(
    times: Sequence[float], positions: np.ndarray, covariances: np.ndarray, sigma_speed: float
) -> MotionFit:
    """Fit ``x(t) = p + v (t - t_ref)`` to ground positions, ``t_ref`` the last time.

    Args:
        times: (N,) seconds.
        positions: (N, 2) float64 ground positions, metres.
        covariances: (N, 2, 2) float64 their covariances, metres squared.
        sigma_speed: standard deviation of the zero-mean prior on each velocity component,
            m/s; 0 fixes the velocity at 0 (a class that cannot move).

    Returns:
        The fit (velocity exactly 0 with zero covariance when ``sigma_speed`` is 0).
    """
    inv = np.linalg.inv(np.asarray(covariances, dtype=np.float64))
    return _fit_information(times, np.asarray(positions, dtype=np.float64), inv, sigma_speed)


#: A prior on a track's velocity: (2,) mean, m/s, and (2, 2) information (inverse covariance), (s/m)^2.
VelocityPrior = tuple[np.ndarray, np.ndarray]


def _fit_information(
    times: Sequence[float],
    z: np.ndarray,
    inv: np.ndarray,
    sigma_speed: float,
    prior: VelocityPrior | None = None,
) -> MotionFit:
    """:func:`fit_motion` from (N, 2) positions and their (N, 2, 2) information matrices (inverse
    covariances).

    ``prior`` replaces the zero-mean velocity prior of spread ``sigma_speed`` (which must then be > 0).
    """
    t = np.asarray(times, dtype=np.float64)
    t_ref = float(t[-1])
    if sigma_speed <= 0:
        info = inv.sum(axis=0)
        cov = np.linalg.inv(info)
        p = cov @ np.einsum("nij,nj->i", inv, z)
        C = np.zeros((4, 4))
        C[:2, :2] = cov
        return MotionFit(t_ref, np.array([p[0], p[1], 0.0, 0.0]), C)
    dt = t - t_ref
    info = np.zeros((4, 4))
    info[:2, :2] = inv.sum(axis=0)
    cross = np.einsum("n,nij->ij", dt, inv)
    info[:2, 2:] = cross
    info[2:, :2] = cross.T
    mean, prior_info = prior if prior is not None else (np.zeros(2), np.eye(2) / sigma_speed**2)
    info[2:, 2:] = np.einsum("n,nij->ij", dt * dt, inv) + prior_info
    rhs = np.concatenate(
        [np.einsum("nij,nj->i", inv, z), np.einsum("n,nij,nj->i", dt, inv, z) + prior_info @ mean]
    )
    C = np.linalg.inv(info)
    return MotionFit(t_ref, C @ rhs, C)


#: Most active sets :func:`fit_motion_bounded` tries (each is one refit; it usually settles in two or three).
_BOUND_MAX_REFITS = 50
#: Relative change of the bounds' across-ray widening below which :func:`fit_motion_bounded` counts it settled.
_WIDEN_RTOL = 1e-3


def fit_motion_bounded(
    times: Sequence[float],
    positions: np.ndarray,
    covariances: np.ndarray,
    sigma_speed: float,
    rays: np.ndarray,
    sides: np.ndarray,
    prior: VelocityPrior | None = None,
    ranges: np.ndarray | None = None,
) -> MotionFit:
    """:func:`fit_motion` where some positions bound the depth along their viewing ray instead of reading it.

    A bound from below (``side`` +1: the object is at or beyond the position along ``ray``) or
    from above (-1: at or nearer) costs nothing along its ray where the track keeps it and its
    along-ray spread where the track breaks it; across the ray (the bearing) it counts as a
    reading (its across-ray variance, the along-ray position left free). The cost is convex and
    piecewise quadratic; the fit finds its minimum by active sets: the bounds the current track
    keeps lose their along-ray information, the broken ones are readings at the bound, the track is
    fitted again, until the kept set (and the widening below) repeats (the lowest cost seen is
    returned if it never does). Without bounds, or with no frame that reads the depth (the bounds are then all
    that is known along the rays), it is :func:`fit_motion`'s. The covariance is the last
    refit's.

    A bound's across-ray spread is stated where the bound places it; its bearing is an angle
    (``lateral_sigma_rel`` of the range), so where ``ranges`` are given a kept bound from below
    is compared across its ray with that spread scaled to the track's range along the ray
    (``(range at the track / range of the bound)^2`` on the variance, the scale taken from the
    previous fit): a car only known to be "behind this, or farther", placed 10 m short, does not
    hold the track to its bearing as if it were seen 10 m nearer. The spread is never narrowed
    (the bounds from above keep theirs: its floor is metric).

    Args:
        times: (N,) seconds.
        positions: (N, 2) float64 ground positions (a bound's: the bound itself), metres.
        covariances: (N, 2, 2) float64 their covariances, metres squared.
        sigma_speed: the velocity prior (:func:`fit_motion`).
        rays: (N, 2) float64 unit viewing directions on the ground, from the camera to the position.
        sides: (N,) int 0 for a reading, +1 for a bound from below, -1 for one from above.
        prior: a velocity prior (mean, information) in place of the zero-mean one of spread
            ``sigma_speed`` (> 0), or None.
        ranges: (N,) float64 each position's distance from its camera, metres (:func:`frame_ranges`),
            or None to compare bounds across their rays with their stated spreads.

    Returns:
        The fit.

    Example:
        A walker at 10 m whose second frame is only known to be beyond 9 m: the bound is kept, so
        that frame does not pull; read as a position it would.

        >>> at = np.array([[10.0, 0.0], [9.0, 0.0]]); cov = np.array([np.eye(2)] * 2)
        >>> rays = np.array([[1.0, 0.0]] * 2)
        >>> fit_motion_bounded([0.0, 1.0], at, cov, 0.0, rays, np.array([0, 1])).state[:2].round(3).tolist()
        [10.0, 0.0]
        >>> fit_motion([0.0, 1.0], at, cov, 0.0).state[:2].round(3).tolist()
        [9.5, 0.0]
    """
    z = np.asarray(positions, dtype=np.float64)
    rays = np.asarray(rays, dtype=np.float64)
    sides = np.asarray(sides)
    cov = np.asarray(covariances, dtype=np.float64)
    inv = np.linalg.inv(cov)
    fit = _fit_information(times, z, inv, sigma_speed, prior)
    if not np.any(sides != 0) or np.all(sides != 0):
        return fit
    t = np.asarray(times, dtype=np.float64)
    normals = np.c_[-rays[:, 1], rays[:, 0]]
    across_var = np.einsum("ni,nij,nj->n", normals, cov, normals)
    across_only = np.einsum("ni,nj->nij", normals, normals) / across_var[:, None, None]

    def widen(f: MotionFit) -> np.ndarray:
        """(N,) the factor on each frame's across-ray variance at the track's range (1 without ranges)."""
        if ranges is None:
            return np.ones(len(z))
        d = f.state[:2] + (t - f.t_ref)[:, None] * f.state[2:] - z
        return np.maximum(1.0, 1.0 + np.einsum("ni,ni->n", d, rays) / ranges) ** 2

    def kept_and_cost(f: MotionFit) -> tuple[np.ndarray, float]:
        d = f.state[:2] + (t - f.t_ref)[:, None] * f.state[2:] - z
        kept = sides * np.einsum("ni,ni->n", d, rays) > 0.0
        full = np.einsum("ni,nij,nj->n", d, inv, d)
        across = np.einsum("ni,ni->n", d, normals) ** 2 / (across_var * widen(f))
        cost = float(np.where(kept, across, full).sum())
        if prior is not None:
            dv = f.state[2:] - prior[0]
            return kept, cost + float(dv @ prior[1] @ dv)
        return kept, cost + float(f.state[2:] @ f.state[2:]) / sigma_speed**2 if sigma_speed > 0 else cost

    kept, cost = kept_and_cost(fit)
    best = (cost, fit)
    seen: list[tuple[np.ndarray, np.ndarray]] = []
    for _ in range(_BOUND_MAX_REFITS):
        w = widen(fit)
        if any(np.array_equal(kept, k) and np.allclose(w, wk, rtol=_WIDEN_RTOL) for k, wk in seen):
            break
        seen.append((kept, w))
        info = np.where(kept[:, None, None], across_only / w[:, None, None], inv)
        fit = _fit_information(times, z, info, sigma_speed, prior)
        kept, cost = kept_and_cost(fit)
        if cost < best[0]:
            best = (cost, fit)
    return best[1]


#: Added to every score inside the gate, so a pair exactly at the gate still scores above no pair.
_TIE = 1e-9


def standing_weight(fit: MotionFit, sigma_speed: float, prior: float) -> float:
    """Posterior probability that a track stands, given its moving fit.

    The Bayes factor of standing against moving is the Savage-Dickey density ratio: the moving
    fit's posterior density of the velocity at 0 over its prior density there,
    ``sigma^2 / sqrt(det C_v) exp(-v^T C_v^-1 v / 2)``. A track of one frame has learnt nothing
    of its velocity (the ratio is 1) and keeps the prior; frames that agree with standing
    still raise the weight, a fitted speed beyond its spread lowers it.

    Args:
        fit: the track's constant-velocity fit under the zero-mean velocity prior.
        sigma_speed: that prior's standard deviation per component, m/s (> 0).
        prior: the prior probability of standing, in [0, 1].

    Example:
        >>> one_frame = fit_motion([0.0], np.zeros((1, 2)), np.eye(2)[None], 14.0)
        >>> round(standing_weight(one_frame, 14.0, 0.95), 6)
        0.95
    """
    if prior <= 0.0 or prior >= 1.0:
        return float(min(max(prior, 0.0), 1.0))
    det = float(np.linalg.det(fit.covariance[2:, 2:]))
    if not math.isfinite(det) or det <= 0.0:
        return prior
    log_bf = -0.5 * fit.speed_chi2() + 0.5 * math.log(sigma_speed**4 / det)
    log_odds = math.log(prior / (1.0 - prior)) + log_bf
    return 1.0 / (1.0 + math.exp(-log_odds)) if log_odds > -700.0 else 0.0


#: The standing fragments a track was joined from: each one's frame times and the (2, 2) covariance, metres
#: squared, of the error its frames share.
Fragments = tuple[tuple[tuple[float, ...], np.ndarray], ...]


@dataclass
class _Track:
    class_name: str
    sigma_speed: float
    times: list[float] = field(default_factory=list)
    items: list[FusedObject] = field(default_factory=list)
    fit: MotionFit | None = None
    standing_share: float = 0.0
    still: MotionFit | None = None
    #: The standing fragments a standing join made this track of: each one's frame times and the (2, 2)
    #: covariance of the error its frames share (:func:`_shared_error`); empty for a track never joined.
    parts: Fragments = ()

    def add(self, t: float, item: FusedObject) -> None:
        self.times.append(t)
        self.items.append(item)
        self.refit()

    def refit(self) -> None:
        """Fit the motion of the frames held now; standing too where the class keeps it.

        A vehicle's moving fit is :func:`fit_motion_bounded` (a frame placed by a depth bound
        counts along its ray only where the track breaks it); other classes' and the standing
        hypothesis are :func:`fit_motion`."""
        pos = np.array([o.placement.contact_world[:2] for o in self.items])
        cov = np.array([fit_covariance(o) for o in self.items])
        if self.class_name in VEHICLE_CLASSES:
            rays, sides = frame_rays_and_sides(self.items)
            ranges = frame_ranges(self.items)
            self.fit = fit_motion_bounded(self.times, pos, cov, self.sigma_speed, rays, sides, ranges=ranges)
        else:
            self.fit = fit_motion(self.times, pos, cov, self.sigma_speed)
        if self.sigma_speed > 0 and self.standing_share > 0:
            self.still = fit_motion(self.times, pos, cov, 0.0)

    def placed_fit(self, params: ViewsParams) -> MotionFit:
        """The fit that places a moving track: :func:`fit_motion_bounded`, each frame's bound
        side from :func:`~usdworld.views.hidden_contact.depth_bound_side` along its primary
        view's ray (the tracking's own fit, :meth:`refit`, does so only for a vehicle and takes a
        person's every frame as a reading).

        A person's speed along its fitted direction has the walking prior
        (:func:`walking_prior`), the direction refitted until it settles."""
        pos = np.array([o.placement.contact_world[:2] for o in self.items])
        cov = np.array([fit_covariance(o) for o in self.items])
        rays, sides = frame_rays_and_sides(self.items)
        ranges = frame_ranges(self.items)
        fit = fit_motion_bounded(self.times, pos, cov, self.sigma_speed, rays, sides, ranges=ranges)
        if self.class_name not in PEOPLE_CLASSES or self.sigma_speed <= 0:
            return fit
        for _ in range(_WALK_MAX_REFITS):
            prior = walking_prior(fit.velocity, self.sigma_speed, params)
            if prior is None:
                return fit
            before = fit.velocity
            fit = fit_motion_bounded(self.times, pos, cov, self.sigma_speed, rays, sides, prior, ranges)
            v = fit.velocity
            turn = abs(math.atan2(before[0] * v[1] - before[1] * v[0], float(before @ v)))
            if turn < _WALK_TURN_RAD:
                break
        return fit


def frame_ranges(items: Sequence[FusedObject]) -> np.ndarray:
    """(N,) float64 each frame's placement's distance on the ground from its primary camera, metres."""
    d = np.array([o.placement.contact_world[:2] - o.observations[0].camera_ground for o in items])
    return np.maximum(np.linalg.norm(d, axis=1), 1e-3)


def frame_rays_and_sides(items: Sequence[FusedObject]) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2) unit viewing directions (each frame's primary camera to its placement) and (N,) bound
    sides (:func:`~usdworld.views.hidden_contact.depth_bound_side`) of a track's frames."""
    rays = np.array([o.placement.contact_world[:2] - o.observations[0].camera_ground for o in items])
    rays = rays / np.maximum(np.linalg.norm(rays, axis=1, keepdims=True), 1e-9)
    return rays, np.array([depth_bound_side(o) for o in items], dtype=np.int64)


def bounded_standing_position(times: Sequence[float], items: Sequence[FusedObject], xy: np.ndarray) -> np.ndarray:
    """(2,) where a standing vehicle stands when some of its frames bound its depth instead of reading it.

    The standing fit (velocity 0) of :func:`fit_motion_bounded` over the frames' positions and
    stated covariances: a bound counts along its ray only where the position breaks it (a car
    seen "at least this far" behind what hides it, "at most this far" by its cut bottom, does
    not pull the position to the bound), across its ray as a reading. Where no frame bounds,
    or every frame does (the bounds are then all that is known), ``xy`` (the information-weighted
    mean) is kept.

    Args:
        times: (N,) the frames' times, seconds.
        items: the frames' objects.
        xy: (2,) float64 the information-weighted mean of the observations, metres.

    Example:
        Two readings at 10 m and a frame that only says "beyond 8 m": the bound is kept, so it
        does not pull.

        >>> from types import SimpleNamespace as NS
        >>> from usdworld.layout.draft import DepthMethod
        >>> def item(x, method):
        ...     p = NS(contact_world=np.array([x, 0.0, 0.0]), method=method)
        ...     return NS(placement=p, covariance=np.eye(2), observations=(NS(placement=p, camera_ground=np.zeros(2)),))
        >>> items = [item(10.0, DepthMethod.CONTACT), item(10.0, DepthMethod.CONTACT), item(8.0, DepthMethod.BEHIND)]
        >>> bounded_standing_position([0.0, 1.0, 2.0], items, np.array([9.33, 0.0])).round(2).tolist()
        [10.0, 0.0]
    """
    rays, sides = frame_rays_and_sides(items)
    if not np.any(sides != 0) or np.all(sides != 0):
        return xy
    pos = np.array([o.placement.contact_world[:2] for o in items])
    cov = np.array([o.covariance for o in items])
    return fit_motion_bounded(times, pos, cov, 0.0, rays, sides, ranges=frame_ranges(items)).state[:2]


#: Most refits of a walker's direction under :func:`walking_prior`, and the turn that counts as settled,
#: radians.
_WALK_MAX_REFITS = 20
_WALK_TURN_RAD = 1e-4


def walking_prior(velocity: np.ndarray, sigma_speed: float, params: ViewsParams) -> VelocityPrior | None:
    """The walking-speed prior on a moving person's velocity, linearised at a fitted direction.

    People walk at ``person_walking_speed_mps`` +- ``person_walking_speed_sd_mps`` (observed
    street pedestrians' speeds), whichever way they go: a ring in the velocity plane. At the
    direction ``u`` of a fitted velocity the ring is, to first order, a Gaussian of that mean
    and spread along ``u`` and flat across it, where the zero-mean prior of spread
    ``sigma_speed`` is kept. A track moving along its viewing rays, where a single view's depth
    errs by metres, gets its speed from the prior rather than from a row's whole-pixel steps.

    Args:
        velocity: (2,) float64 the fitted velocity, m/s.
        sigma_speed: the zero-mean prior's spread per component, m/s (> 0).
        params: the walking speed and its spread.

    Returns:
        (mean (2,), information (2, 2)), or None for a velocity of no direction (0).

    Example:
        >>> mean, info = walking_prior(np.array([0.3, 0.0]), 2.6, ViewsParams())
        >>> mean.round(2).tolist(), round(float(info[0, 0]), 1), round(float(info[1, 1]), 3)
        ([1.32, 0.0], 10.4, 0.148)
    """
    speed = float(np.linalg.norm(velocity))
    if speed <= 0.0 or not math.isfinite(speed):
        return None
    u = velocity / speed
    n = np.array([-u[1], u[0]])
    info = np.outer(u, u) / params.person_walking_speed_sd_mps**2 + np.outer(n, n) / sigma_speed**2
    return params.person_walking_speed_mps * u, info


def bounded_m2(d: np.ndarray, S: np.ndarray, ray: np.ndarray | None = None, side: int = 0) -> float:
    """Squared Mahalanobis distance of an observation from a prediction, the observation maybe a depth bound.

    A reading (``side`` 0) is compared in full: ``d^T S^-1 d``. A bound (``side`` +1: the object
    is at or beyond the observed position along its viewing ray, -1: at or nearer;
    :func:`~usdworld.views.hidden_contact.depth_bound_side`) says nothing along its ray where the
    prediction keeps it, so only the distance across the ray counts there, ``(d . n)^2 / (n^T S n)``
    (as :func:`fit_motion_bounded` costs a kept bound); where the prediction breaks it, in full.

    Args:
        d: (2,) float64 observation minus prediction, metres.
        S: (2, 2) float64 the prediction's and the observation's covariances summed, metres squared.
        ray: (2,) float64 unit viewing direction from the camera to the observation (needed when
            ``side`` is not 0).
        side: 0 for a reading, +1 for a bound from below, -1 for one from above.

    Example:
        A walker predicted 6 m beyond a frame that only says "behind this parked car, or farther":

        >>> d, S, ray = np.array([-6.0, 0.1]), np.eye(2), np.array([1.0, 0.0])
        >>> [round(bounded_m2(d, S, ray, side), 2) for side in (0, 1, -1)]
        [36.01, 0.01, 36.01]
    """
    m2 = float(d @ np.linalg.solve(S, d))
    if side == 0 or ray is None or side * float(d @ ray) >= 0.0:
        return m2
    n = np.array([-ray[1], ray[0]])
    return float(d @ n) ** 2 / float(n @ S @ n)


@dataclass(frozen=True)
class TrackPrediction:
    """A track's prediction at one frame's time, as the association reads it (the same for every
    observation of the frame: worked out once per track and frame).

    Attributes:
        x: (2,) float64 the track's fit's predicted position, metres.
        P: (2, 2) float64 its covariance, metres squared.
        still: the standing hypothesis' (position, covariance) where the track keeps one, else None.
        w: the standing hypothesis' weight (:func:`standing_weight`; 0 without one).
    """

    x: np.ndarray
    P: np.ndarray
    still: tuple[np.ndarray, np.ndarray] | None = None
    w: float = 0.0


def predict_track(tr: _Track, t: float) -> TrackPrediction | None:
    """``tr``'s :class:`TrackPrediction` at time ``t``, seconds (None while it has no fit)."""
    if tr.fit is None:
        return None
    x, P = tr.fit.predict(t)
    if tr.still is None:
        return TrackPrediction(x, P)
    w = standing_weight(tr.fit, tr.sigma_speed, tr.standing_share)
    return TrackPrediction(x, P, tr.still.predict(t), w)


def association_m2(
    pred: TrackPrediction | None, z: np.ndarray, R: np.ndarray, ray: np.ndarray | None = None, side: int = 0
) -> float:
    """Squared distance of an observation from a track's prediction, as the gate and the assignment read it.

    One hypothesis (the track's fit): the squared Mahalanobis distance ``m2``, the prediction's
    and the observation's covariances summed. A track that keeps a standing hypothesis (a
    vehicle's, :func:`standing_prior`) predicts standing with weight ``w``
    (:func:`standing_weight`) and moving with ``1 - w``; its distance is
    ``-2 ln(w exp(-m2_s / 2) + (1 - w) exp(-m2_m / 2))``, each hypothesis' likelihood taken
    relative to its own peak as the gate takes one hypothesis' (the single hypothesis' own
    ``m2`` when ``w`` is 0 or 1). It lies between the nearer hypothesis' ``m2`` and that plus
    ``-2 ln`` of its weight: an observation that only the moving hypothesis reaches pays for
    that hypothesis' small weight (with the 0.95 prior of a one-frame track, 6.0 of the 9.21
    gate, so the 14 m/s prior's spread reaches 0.59 of what it reached alone).

    Args:
        pred: the track's prediction at the frame's time (:func:`predict_track`; None, a track
            with no fit yet: infinite).
        z: (2,) float64 the observation's ground position, metres.
        R: (2, 2) float64 its covariance, metres squared.
        ray: (2,) float64 unit viewing direction to the observation, for a bound.
        side: whether the observation bounds its depth (:func:`bounded_m2`; 0: a reading).
    """
    if pred is None:
        return math.inf
    m2 = bounded_m2(z - pred.x, pred.P + R, ray, side)
    if pred.still is None:
        return m2
    w = pred.w
    xs, Ps = pred.still
    m2s = bounded_m2(z - xs, Ps + R, ray, side)
    terms = [math.log(weight) - 0.5 * dist for weight, dist in ((w, m2s), (1.0 - w, m2)) if weight > 0.0]
    top = max(terms)
    return -2.0 * (top + math.log(sum(math.exp(v - top) for v in terms)))


@dataclass(frozen=True)
class DriveObject:
    """One object of a drive's world.

    Attributes:
        fused: the object as a rig's world holds it (placement, every observation of every
            frame, primary first; method; covariance of the placed position).
        moving: whether it moves (see the module docstring).
        times: (T,) float64 the frames where it is seen, seconds.
        positions: (T, 3) float64 its positions at those times (on the fit when moving;
            the placed position repeated when standing), metres.
        yaws: (T,) float64 its headings at those times, radians.
        velocity: (2,) float64 its fitted ground velocity, m/s (0 for a class that cannot move).
    """

    fused: FusedObject
    moving: bool
    times: np.ndarray
    positions: np.ndarray
    yaws: np.ndarray
    velocity: np.ndarray


def frame_times(timestamps: Sequence[float | None], params: ViewsParams) -> list[float] | None:
    """Each view's frame time when the views are a drive (see the module docstring), else None.

    Args:
        timestamps: (V,) each view's timestamp, seconds, or None.
        params: ``frame_gap_s``.

    Returns:
        (V,) the time of each view's frame (its first timestamp), or None when a timestamp
        is missing or all views are one frame.

    Example:
        >>> frame_times([0.0, 0.01, 0.1, 0.11], ViewsParams())
        [0.0, 0.0, 0.1, 0.1]
    """
    if not timestamps or any(t is None for t in timestamps):
        return None
    values = [float(t) for t in timestamps if t is not None]
    order = sorted(range(len(values)), key=lambda i: values[i])
    out = [0.0] * len(values)
    start = previous = values[order[0]]
    frames = 1
    for i in order:
        if values[i] - previous > params.frame_gap_s:
            start = values[i]
            frames += 1
        out[i] = start
        previous = values[i]
    return out if frames >= 2 else None


def _footprint_radius(placement: Placement) -> float:
    """Radius of the disc inscribed in a placement's footprint, metres."""
    return 0.5 * float(min(placement.size_m[0], placement.size_m[1]))


def footprint_reach_across(placement: Placement, ray: np.ndarray) -> float:
    """Half the width across a viewing ray of a placement's footprint taken as a capsule, metres.

    The capsule is the disc inscribed in the footprint swept along its long side: a tree's or a
    plain pole's square footprint is its disc (the reach is the disc's radius whatever the ray),
    a street lamp's long one (its arm) reaches ``0.5 (long - short) |sin a|`` farther, ``a`` the
    angle between its long side and the ray. One view's mask of a part of the object (a lamp's
    head and arm cut from its mast by what stands in front) places that part's column anywhere
    across that width.

    Args:
        placement: the placement (``size_m`` length along its yaw, then width; ``yaw``).
        ray: (2,) float64 the unit viewing direction on the ground.

    Example:
        >>> from types import SimpleNamespace
        >>> lamp = SimpleNamespace(size_m=np.array([2.0, 0.3, 8.0]), yaw=math.pi / 2)
        >>> [round(footprint_reach_across(lamp, np.array(ray)), 3) for ray in ([1.0, 0.0], [0.0, 1.0])]
        [1.0, 0.15]
    """
    length, width = float(placement.size_m[0]), float(placement.size_m[1])
    yaw = placement.yaw if length >= width else placement.yaw + 0.5 * math.pi
    sin = abs(math.cos(yaw) * float(ray[1]) - math.sin(yaw) * float(ray[0]))
    return 0.5 * min(length, width) + 0.5 * abs(length - width) * sin


def one_object_cut_in_two(a: FusedObject, b: FusedObject, params: ViewsParams) -> bool:
    """Whether two standing objects of one frame overlap: one object its single view cut in two.

    Across the viewing ray (a bearing is precise) their contacts are nearer than the sum of
    their footprints' reaches across it (:func:`footprint_reach_across`: a square footprint's
    inscribed radius, more for a lamp's arm across the ray); along it (a depth is not) their
    distance exceeds the sum ``f`` of the radii of the discs inscribed in their footprints by at
    most ``split_depth_sigmas`` standard deviations of their depth difference (their
    covariances summed, along the ray).

    Args:
        a: one object of the frame.
        b: another object of the frame, of the same class.
        params: ``split_depth_sigmas``.
    """
    za = a.placement.contact_world[:2]
    zb = b.placement.contact_world[:2]
    u = 0.5 * (za + zb) - a.observations[0].camera_ground
    u = u / max(float(np.linalg.norm(u)), 1e-9)
    d = za - zb
    reach = _footprint_radius(a.placement) + _footprint_radius(b.placement)
    wide = footprint_reach_across(a.placement, u) + footprint_reach_across(b.placement, u)
    sigma = math.sqrt(float(u @ (a.covariance + b.covariance) @ u))
    across = abs(float(d @ np.array([-u[1], u[0]])))
    return across < wide and abs(float(d @ u)) - reach <= params.split_depth_sigmas * sigma


def merge_overlapping(items: list[FusedObject], params: ViewsParams) -> list[FusedObject]:
    """One frame's objects, trunk objects of one class that overlap made one.

    Two trunks cannot stand in one place: two placements of a class that stands on a trunk or
    post (the class table's ``trunk`` role: trees, poles, signs) that overlap
    (:func:`one_object_cut_in_two`) are one object its single view cut in two (a tree's crown
    split by what stands in front of it). Vehicles and people are tracked instead, and
    facades, which a single view cuts along a street on purpose, are left as they are.
    Greedy, nearest pair first; a merged object is placed as :func:`fuse` places one (the
    information-weighted mean of its observations, the most precise one primary).

    Args:
        items: the frame's objects (:func:`usdworld.views.fusion.fuse`).
        params: ``split_depth_sigmas`` and the fusion's method threshold.

    Returns:
        The objects, a merged one in the place of the first of its two.
    """
    trunks = load_class_table().with_role("trunk")
    items = list(items)
    while True:
        best: tuple[float, int, int] | None = None
        for a in range(len(items)):
            pa = items[a].placement
            if pa.obj.class_name not in trunks:
                continue
            for b in range(a + 1, len(items)):
                pb = items[b].placement
                if pb.obj.class_name != pa.obj.class_name or not one_object_cut_in_two(items[a], items[b], params):
                    continue
                d = float(np.linalg.norm(pa.contact_world[:2] - pb.contact_world[:2]))
                if best is None or d < best[0]:
                    best = (d, a, b)
        if best is None:
            return items
        _, a, b = best
        items[a] = _merged_item(items[a], items[b], params)
        del items[b]


def _merged_item(a: FusedObject, b: FusedObject, params: ViewsParams) -> FusedObject:
    """One frame's two objects made one, placed as :func:`fuse` places one (named as ``a``)."""
    members = sorted((*a.observations, *b.observations), key=lambda o: (o.sigma_range_m, o.view))
    xy, cov = combine(members)
    primary = sized_by_a_whole_view(members[0].placement, members)
    contact = np.array([xy[0], xy[1], primary.position_world[2]])
    placement = dataclasses.replace(primary, name=a.placement.name).with_contact_at(contact)
    return FusedObject(placement, tuple(members), fusion_method(members, cov, params), cov)


def _associate(tracks: list[_Track], t: float, items: list[FusedObject], params: ViewsParams) -> list[int | None]:
    """The track index each item joins, or None: one global assignment per frame.

    Each pair of one class within ``association_gate_chi2`` scores ``gate - m2``
    (:func:`association_m2`: its squared Mahalanobis distance, prediction and observation
    covariances summed, of the standing-or-moving mixture for a vehicle's track; across the ray
    only for a person's or a vehicle's bound the track keeps, :func:`bounded_m2`); the
    assignment (Hungarian) maximises the summed score, so a pair is made only where it is
    inside the gate, and one near pair never takes the track that two others need.
    """
    from scipy.optimize import linear_sum_assignment  # lazy: only drives need it

    gate = params.association_gate_chi2
    score = np.zeros((len(items), len(tracks)))
    predicted = [predict_track(tr, t) for tr in tracks]
    for j, item in enumerate(items):
        cls = item.placement.obj.class_name
        z = item.placement.contact_world[:2]
        side = depth_bound_side(item) if cls in PEOPLE_CLASSES or cls in VEHICLE_CLASSES else 0
        ray = z - item.observations[0].camera_ground
        ray = ray / max(float(np.linalg.norm(ray)), 1e-9)
        for k, tr in enumerate(tracks):
            if tr.class_name != cls or tr.fit is None:
                continue
            m2 = association_m2(predicted[k], z, item.covariance, ray, side)
            if m2 <= gate:
                score[j, k] = gate - m2 + _TIE
    out: list[int | None] = [None] * len(items)
    if score.size:
        for j, k in zip(*linear_sum_assignment(score, maximize=True)):
            if score[j, k] > 0:
                out[int(j)] = int(k)
    return out


def _yaw_of(velocity: np.ndarray, fallback: float, params: ViewsParams) -> float:
    if float(np.linalg.norm(velocity)) >= params.moving_speed_min_mps:
        return math.atan2(float(velocity[1]), float(velocity[0]))
    return fallback


def track_drive(
    obs: Sequence[Observation], view_times: Sequence[float], params: ViewsParams
) -> list[DriveObject]:
    """Place a drive's observations: standing objects once, moving ones with their track.

    Args:
        obs: every view's observations in the world, views in order.
        view_times: (V,) each view's frame time (:func:`frame_times`), seconds.
        params: the thresholds.

    Returns:
        The objects, in the order of their first observation (frames in time order),
        named ``<class>_<NNNN>`` per class in that order.
    """
    by_frame: dict[float, list[Observation]] = {}
    for o in obs:
        by_frame.setdefault(float(view_times[o.view]), []).append(o)
    open_tracks: list[_Track] = []
    done: list[_Track] = []
    for t in sorted(by_frame):
        still = []
        for tr in open_tracks:
            (still if t - tr.times[-1] <= params.track_gap_s else done).append(tr)
        open_tracks = still
        items = merge_overlapping(fuse(by_frame[t], params), params)
        joins = _associate(open_tracks, t, items, params)
        for item, k in zip(items, joins):
            if k is None:
                cls = item.placement.obj.class_name
                tr = _Track(cls, speed_prior(cls, params), standing_share=standing_prior(cls, params))
                open_tracks.append(tr)
                tr.add(t, item)
            else:
                open_tracks[k].add(t, item)
    done.extend(open_tracks)
    done = merge_fragments([tr for tr in done if tr.fit is not None], params)
    done = merge_moving_fragments(done, params)
    done = merge_standing_trunks(done, params)
    done = merge_standing_vehicles(done, params)
    index = {(o.view, o.placement.name): i for i, o in enumerate(obs)}  # a view names each object once

    def first_seen(tr: _Track) -> tuple[float, int]:
        return tr.times[0], min(index[o.view, o.placement.name] for o in tr.items[0].observations)

    done.sort(key=first_seen)
    counters: dict[str, int] = {}
    return [_drive_object(tr, tr.fit, params, counters) for tr in done if tr.fit is not None]


def _is_moving(tr: _Track, fit: MotionFit, params: ViewsParams) -> bool:
    """Whether a track moves (the module docstring's test; a vehicle's significance is :func:`standing_chi2`)."""
    if tr.sigma_speed <= 0 or len(tr.times) < params.moving_min_frames:
        return False
    if float(np.linalg.norm(fit.velocity)) < params.moving_speed_min_mps:
        return False
    chi2 = standing_chi2(tr, params) if tr.class_name in VEHICLE_CLASSES else fit.speed_chi2()
    return chi2 > params.association_gate_chi2


def standing_chi2(tr: _Track, params: ViewsParams) -> float:
    """Squared Mahalanobis distance of a track's fitted velocity from standing still, frame errors split.

    ``frame_error_correlation`` (rho) of each frame's error variance is common to the track's frames
    (:func:`_shared_error`): one relative depth error ``e`` that all of them repeat (a size or contact
    misjudged once for all), each frame's position off by ``e`` times its offset from its camera.
    Such an error moves every frame along its own ray by a share of its range, so it leaves a
    standing object's frames on a straight line: their fitted velocity is ``e`` times the object's
    velocity relative to the camera, ``-e`` times the camera's own velocity ``w`` for an object that
    stands. Only the rest, ``1 - rho`` of each frame's variance, scatters from frame to frame. So the
    velocity is fitted as the tracking fits it (:meth:`_Track.refit`, except that a bound keeps its
    stated across-ray spread, not its bearing's at the track's range) with each frame's covariance
    scaled by ``1 - rho``, and tested against standing with the shared error's apparent velocity
    added to its covariance: ``rho s^2 w w^T``, ``s^2`` the median over the frames of the along-ray
    variance over the squared range (a frame's relative depth variance). A parked car the camera
    drives towards may drift by the shared error times the camera's speed; a far car the camera
    follows at one range, every frame of which repeats one depth, is not taken for a parked one
    because each frame's stated spread is large.

    Args:
        tr: a vehicle's track, with its frames.
        params: ``frame_error_correlation``.

    Returns:
        ``v^T C^-1 v`` (0 where the covariance is singular).
    """
    rho = params.frame_error_correlation
    pos = np.array([o.placement.contact_world[:2] for o in tr.items])
    cov = np.array([fit_covariance(o) for o in tr.items])
    cams = np.array([o.observations[0].camera_ground for o in tr.items])
    rays, sides = frame_rays_and_sides(tr.items)
    fit = fit_motion_bounded(tr.times, pos, (1.0 - rho) * cov, tr.sigma_speed, rays, sides)
    t = np.asarray(tr.times, dtype=np.float64)
    dt = t - t.mean()
    w = dt @ (cams - cams.mean(axis=0)) / float(dt @ dt) if float(dt @ dt) > 0 else np.zeros(2)
    ranges2 = np.maximum(np.einsum("ni,ni->n", pos - cams, pos - cams), 1e-9)
    relative = float(np.median(np.einsum("ni,nij,nj->n", rays, cov, rays) / ranges2))
    C = fit.covariance[2:, 2:] + rho * relative * np.outer(w, w)
    C = C + _parts_velocity_covariance(tr, pos, (1.0 - rho) * cov, rays, sides, fit)
    v = fit.velocity
    if not np.all(np.isfinite(C)) or np.linalg.det(C) <= 0:
        return 0.0
    return float(v @ np.linalg.solve(C, v))


def _parts_velocity_covariance(
    tr: _Track, pos: np.ndarray, cov: np.ndarray, rays: np.ndarray, sides: np.ndarray, fit: MotionFit
) -> np.ndarray:
    """(2, 2) covariance that a joined track's fragments' own shared errors add to its fitted velocity.

    A standing join (:func:`merge_fragments`, :func:`merge_standing_vehicles`) takes two fragments
    for one object when they agree within their positions' covariances, each floored by the error
    its own frames share (:func:`_shared_error`): the fragments may differ by those errors. The
    joined track's moving test must allow the same: fragment ``k``'s frames all off by one offset
    ``b_k ~ N(0, S_k)`` move the fitted velocity, so the velocity's covariance under standing gains
    what those offsets make of it. Each fragment's frames are moved together by one standard
    deviation along each principal axis of ``S_k`` (a frame two fragments both hold by half), the
    track refitted, and the velocity's changes ``dv`` summed as ``dv dv^T`` (exact for a linear fit,
    the secant over the error's own scale where a bound's side changes). It is 0 for a track of one
    fragment: an offset of all its frames leaves the velocity as it is.

    Args:
        tr: the track, with :attr:`_Track.parts`.
        pos: (N, 2) its frames' positions; ``cov``: (N, 2, 2) the covariances its moving fit uses.
        rays: (N, 2) unit viewing rays; ``sides``: (N,) bound sides (:func:`fit_motion_bounded`).
        fit: that fit of ``pos``.
    """
    out = np.zeros((2, 2))
    if len(tr.parts) < 2:
        return out
    index = {t: i for i, t in enumerate(tr.times)}
    holders = np.zeros(len(tr.times))
    for times, _ in tr.parts:
        holders[[index[t] for t in times if t in index]] += 1.0
    for times, shared in tr.parts:
        share = np.zeros(len(tr.times))
        at = [index[t] for t in times if t in index]
        share[at] = 1.0 / holders[at]
        variances, axes = np.linalg.eigh(shared)
        for var, axis in zip(variances, axes.T):
            if var <= 0.0:
                continue
            moved = pos + math.sqrt(float(var)) * share[:, None] * axis
            dv = fit_motion_bounded(tr.times, moved, cov, tr.sigma_speed, rays, sides).velocity - fit.velocity
            out += np.outer(dv, dv)
    return out


def joined_parts(a: _Track, b: _Track, params: ViewsParams) -> Fragments:
    """The fragments of a standing join of ``a`` and ``b`` (:attr:`_Track.parts`).

    Each track's own parts where a join made it, else the track itself with its :func:`_shared_error`.
    """
    return tuple(p for tr in (a, b) for p in (tr.parts or ((tuple(tr.times), _shared_error(tr, params)),)))


#: Ratio of a normal distribution's standard deviation to its median absolute deviation (1 / Phi^-1(3/4)).
_MAD_TO_SIGMA = 1.4826


def frame_scatter(positions: np.ndarray, cameras: np.ndarray) -> np.ndarray:
    """(2, 2) robust covariance of a track's per-frame positions, along and across their mean viewing ray.

    The median absolute deviations about the median, taken along the mean of the frames'
    unit viewing rays and across it, scaled to standard deviations (``1.4826 MAD``, the
    normal consistency factor): a frame whose depth cue failed does not set the spread.

    Args:
        positions: (N, 2) float64 the frames' ground positions, metres.
        cameras: (N, 2) float64 the ground points of the cameras that placed them, metres.

    Returns:
        (2, 2) float64 metres squared.

    Example:
        >>> frame_scatter(np.array([[9.0, 0.0], [10.0, 0.0], [11.0, 0.0]]), np.zeros((3, 2))).round(4).tolist()
        [[2.1981, 0.0], [0.0, 0.0]]
    """
    rays = positions - cameras
    u = (rays / np.maximum(np.linalg.norm(rays, axis=1, keepdims=True), 1e-9)).mean(axis=0)
    u = u / max(float(np.linalg.norm(u)), 1e-9)
    n = np.array([-u[1], u[0]])
    d = positions - np.median(positions, axis=0)
    along, across = (_MAD_TO_SIGMA * float(np.median(np.abs(v - np.median(v)))) for v in (d @ u, d @ n))
    return along**2 * np.outer(u, u) + across**2 * np.outer(n, n)


def _standing_estimate(tr: _Track, params: ViewsParams) -> tuple[np.ndarray, np.ndarray]:
    """(2,) position and (2, 2) covariance of a standing track, floored for correlated frame errors.

    The information-weighted mean of its observations (a vehicle's with its depth bounds counted
    on their side only, :func:`bounded_standing_position`), whose covariance assumes independent
    frames, plus :func:`_shared_error` (what the frames share does not average away).
    """
    xy, cov = _standing_position(tr, [o for item in tr.items for o in item.observations])
    return xy, cov + _shared_error(tr, params)


def _standing_position(tr: _Track, members: Sequence[Observation]) -> tuple[np.ndarray, np.ndarray]:
    """(2,) where a standing track stands and (2, 2) the covariance of its observations taken as independent.

    The information-weighted mean of ``members`` (:func:`~usdworld.views.fusion.combine`); a
    vehicle's depth bounds count on their side only (:func:`bounded_standing_position`).
    """
    xy, cov = combine(members)
    if tr.class_name in VEHICLE_CLASSES:
        xy = bounded_standing_position(tr.times, tr.items, xy)
    return xy, cov


def _shared_error(tr: _Track, params: ViewsParams) -> np.ndarray:
    """(2, 2) covariance of the error that a standing track's frames share, metres squared.

    ``frame_error_correlation`` (rho) times one frame's error covariance. A frame's error
    covariance is its surest frame's stated one or, when larger (trace) and the track has
    ``scatter_min_frames`` frames, the measured :func:`frame_scatter` divided by ``1 - rho``
    (the frames scatter by their unshared part only).
    """
    frame = min((item.covariance for item in tr.items), key=lambda c: float(np.trace(c)))
    rho = params.frame_error_correlation
    if len(tr.items) >= params.scatter_min_frames and rho < 1.0:
        positions = np.array([item.placement.contact_world[:2] for item in tr.items])
        cameras = np.array([item.observations[0].camera_ground for item in tr.items])
        measured = frame_scatter(positions, cameras) / (1.0 - rho)
        if float(np.trace(measured)) > float(np.trace(frame)):
            frame = measured
    return rho * frame


def track_bearings(items: Sequence[FusedObject], params: ViewsParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A standing track's bearings: (N, 2) contacts, (N, 2) cameras and (N,) spreads.

    One per observation of each of its frames, each from the camera that made it, with its
    :func:`bearing_sigmas` spread: the two halves of a tree that a frame made one keep their
    own bearings, of which the triangulation's weights keep the one that agrees with the
    other frames (the mean of the halves would be the trunk of neither).
    """
    members = [o for item in items for o in item.observations]
    contacts = np.array([o.placement.contact_world[:2] for o in members], dtype=np.float64)
    cameras = np.array([o.camera_ground for o in members], dtype=np.float64)
    return contacts, cameras, bearing_sigmas(members, params)


def _merge_estimate(tr: _Track, params: ViewsParams) -> tuple[np.ndarray, np.ndarray]:
    """(2,) position and (2, 2) covariance of a standing track as fragments are compared.

    A trunk class's track is placed by its bearings (:func:`bearing_triangulation`, its
    :func:`_standing_estimate` the depth prior), with the triangulation's covariance plus
    :func:`_shared_error`: the bearings pin the point, but two fragments of one object still
    differ by what each one's frames share (which part of a crown they saw, a depth error
    the prior carries). Other classes' is the standing estimate.
    """
    prior = _standing_estimate(tr, params)
    if tr.class_name not in load_class_table().with_role("trunk"):
        return prior
    xy, cov = bearing_triangulation(*track_bearings(tr.items, params), *prior, params)
    return xy, cov + _shared_error(tr, params)


def merge_fragments(tracks: list[_Track], params: ViewsParams) -> list[_Track]:
    """Join standing tracks that are one object broken into fragments.

    Two standing tracks of one class that share no frame (one frame never holds one object
    twice) are one object when their positions (:func:`_standing_estimate`, covariances
    summed) are within ``association_gate_chi2``, and, for a class whose association keeps a
    standing hypothesis (vehicles, :func:`standing_prior`), their frames together still stand
    (:func:`_is_moving` of the joined track is false: two parked fragments that together move
    are two cars, or a parked car and a mover's stray frames; a slow walker, whose fragments
    each stand, is found by joining them); greedy, nearest first, as
    :func:`usdworld.views.fusion.associate` joins views. Moving tracks are kept as they are.

    Args:
        tracks: the drive's tracks, each with its fit.
        params: the gate and the correlation floor.

    Returns:
        The tracks, merged ones with their frames in time order and their fit redone.
    """
    moving = [tr.fit is not None and _is_moving(tr, tr.fit, params) for tr in tracks]
    keep = [tr for tr, m in zip(tracks, moving) if m]
    frags = [tr for tr, m in zip(tracks, moving) if not m and tr.fit is not None]
    if len(frags) < 2:
        return tracks
    frames = {t: i for i, t in enumerate(sorted({t for tr in frags for t in tr.times}))}
    seen = np.zeros((len(frags), len(frames)), dtype=np.int32)
    for i, tr in enumerate(frags):
        seen[i, [frames[t] for t in tr.times]] = 1
    estimates = [_merge_estimate(tr, params) for tr in frags]
    pos = np.array([e[0] for e in estimates])
    cov = np.array([e[1] for e in estimates])
    cls = np.array([tr.class_name for tr in frags])
    alive = np.ones(len(frags), dtype=bool)
    upper = np.triu(np.ones((len(frags), len(frags)), dtype=bool), 1)
    while True:
        m2 = _pair_mahalanobis2(pos, cov)
        ok = upper & (cls[:, None] == cls[None, :]) & alive[:, None] & alive[None, :]
        ok &= (seen @ seen.T == 0) & (m2 <= params.association_gate_chi2)
        if not ok.any():
            return keep + [tr for tr, on in zip(frags, alive) if on]
        a, b = np.unravel_index(int(np.argmin(np.where(ok, m2, np.inf))), m2.shape)
        joined = _joined(frags[a], frags[b])
        joined.parts = joined_parts(frags[a], frags[b], params)
        if joined.standing_share > 0 and joined.fit is not None and _is_moving(joined, joined.fit, params):
            upper[a, b] = False  # two parked fragments whose frames together move are not one parked vehicle
            continue
        frags[a] = joined
        seen[a] |= seen[b]
        alive[b] = False
        pos[a], cov[a] = _merge_estimate(frags[a], params)



def fragments_agree(a: _Track, b: _Track) -> float | None:
    """Squared Mahalanobis distance of two tracks' fits where they meet, or None where they cannot be one.

    Two tracks of one class that share no frame meet at the midpoint ``t`` between the nearer ends of
    their frames' time spans (between their mean times where the spans interleave); each fit predicts
    its position there (:meth:`MotionFit.predict`), the covariances summed.

    Args:
        a: one track, with its fit.
        b: another.
    """
    if a.class_name != b.class_name or set(a.times) & set(b.times) or a.fit is None or b.fit is None:
        return None
    if a.times[-1] < b.times[0]:
        t = 0.5 * (a.times[-1] + b.times[0])
    elif b.times[-1] < a.times[0]:
        t = 0.5 * (b.times[-1] + a.times[0])
    else:
        t = 0.5 * (float(np.mean(a.times)) + float(np.mean(b.times)))
    xa, Pa = a.fit.predict(t)
    xb, Pb = b.fit.predict(t)
    d = xa - xb
    return float(d @ np.linalg.solve(Pa + Pb, d))


class _Refusals:
    """Pairs of tracks a greedy join has refused, by identity.

    The pairs are held, not only their ``id()``: a track a later join replaces would otherwise be
    freed, and a new track could take its id and inherit its refusal.
    """

    def __init__(self) -> None:
        self._pairs: dict[tuple[int, int], tuple[_Track, _Track]] = {}

    def add(self, a: _Track, b: _Track) -> None:
        """Refuse joining ``a`` with ``b`` (in this order)."""
        self._pairs[id(a), id(b)] = (a, b)

    def __contains__(self, pair: tuple[_Track, _Track]) -> bool:
        return (id(pair[0]), id(pair[1])) in self._pairs


def merge_moving_fragments(tracks: list[_Track], params: ViewsParams) -> list[_Track]:
    """Join moving tracks that are one mover broken into fragments.

    Two moving tracks of one class that share no frame (one frame never holds one object twice)
    are one mover when their constant-velocity fits agree where they meet
    (:func:`fragments_agree`, within ``association_gate_chi2``: each fit's covariance already
    carries its velocity's spread, so fragments far apart in time must agree in speed too) and
    their frames together still move (:func:`_is_moving`); greedy, nearest first, as
    :func:`merge_fragments` joins standing ones. Standing tracks are left to the other joins.

    Args:
        tracks: the drive's tracks, each with its fit.
        params: the gate and the moving test's thresholds.

    Returns:
        The tracks, joined ones with their frames in time order and their fit redone.
    """
    moving = [tr for tr in tracks if tr.fit is not None and _is_moving(tr, tr.fit, params)]
    rest = [tr for tr in tracks if not any(tr is m for m in moving)]
    refused = _Refusals()
    while True:
        best: tuple[float, int, int] | None = None
        for a in range(len(moving)):
            for b in range(a + 1, len(moving)):
                if (moving[a], moving[b]) in refused:
                    continue
                m2 = fragments_agree(moving[a], moving[b])
                if m2 is not None and m2 <= params.association_gate_chi2 and (best is None or m2 < best[0]):
                    best = (m2, a, b)
        if best is None:
            return rest + moving
        _, a, b = best
        joined = _joined(moving[a], moving[b])
        if joined.fit is None or not _is_moving(joined, joined.fit, params):
            refused.add(moving[a], moving[b])
            continue
        moving[a] = joined
        del moving[b]


def merge_standing_trunks(tracks: list[_Track], params: ViewsParams) -> list[_Track]:
    """Join standing tracks of one trunk class whose triangulated footprints overlap.

    Two trunks cannot stand in one place (:func:`merge_overlapping`). Once each standing
    track of a trunk class is placed by its bearings (:func:`_merge_estimate`), two of one
    class whose positions are nearer than the sum of the radii of the discs inscribed in
    their footprints (each track's median over its frames) are one object, whether or not
    they share frames (the two halves of a tree cut by what stands in front of it are seen
    together), or when they share frames and :func:`seen_as_one_trunk` (their triangulations
    agree within their covariances, every shared frame sees them overlap across the ray and,
    without an arm, the frames they share are as few as a crown cut now and then gives).
    Greedy, nearest pair first; a frame both saw keeps one object, the two placements made one
    as :func:`merge_overlapping` makes them.

    Args:
        tracks: the drive's tracks, each with its fit.
        params: the bearing triangulation's parameters and the correlation floor.

    Returns:
        The tracks, joined ones with their frames in time order and their fit redone.
    """
    trunks = load_class_table().with_role("trunk")
    keep, cand = [], []
    for tr in tracks:
        standing = tr.fit is not None and not _is_moving(tr, tr.fit, params)
        (cand if standing and tr.class_name in trunks else keep).append(tr)
    est = [_merge_estimate(tr, params) for tr in cand]
    radius = [float(np.median([_footprint_radius(item.placement) for item in tr.items])) for tr in cand]
    while True:
        best: tuple[float, int, int] | None = None
        for a in range(len(cand)):
            for b in range(a + 1, len(cand)):
                if cand[a].class_name != cand[b].class_name:
                    continue
                d = float(np.linalg.norm(est[a][0] - est[b][0]))
                if best is not None and d >= best[0]:
                    continue
                if d < radius[a] + radius[b] or seen_as_one_trunk(cand[a], cand[b], est[a], est[b], params):
                    best = (d, a, b)
        if best is None:
            return keep + absorb_short_fragments(cand, est, params)
        _, a, b = best
        cand[a] = _joined_overlapping(cand[a], cand[b], params)
        est[a] = _merge_estimate(cand[a], params)
        radius[a] = float(np.median([_footprint_radius(item.placement) for item in cand[a].items]))
        del cand[b], est[b], radius[b]


def merge_standing_vehicles(tracks: list[_Track], params: ViewsParams) -> list[_Track]:
    """Join standing vehicle tracks of one class whose footprints must overlap.

    Two parked vehicles cannot stand in one place: two standing tracks of one vehicle class
    whose placed positions (:func:`_standing_estimate`) are nearer than the sum of the radii
    of the discs inscribed in their footprints (each track's median over its frames: half a
    car's width) overlap whatever their headings, so they are one vehicle, whether or not
    they share frames (one of them holds, in some frame, what the view saw of a neighbour,
    or the view cut the vehicle in two). As :func:`merge_fragments` joins vehicle fragments,
    two whose frames together would move are not joined. Greedy, nearest pair first; a frame
    both hold keeps one object, the two placements made one (:func:`merge_overlapping`).
    Unlike a trunk's, a vehicle's position is not triangulated, so the test uses only the
    disc that lies inside the footprint for every heading: two vehicles side by side, or
    one behind the other, are farther apart than that.

    Args:
        tracks: the drive's tracks, each with its fit.
        params: the moving test's and the standing estimate's parameters.

    Returns:
        The tracks, joined ones with their frames in time order and their fit redone.
    """
    keep, cand = [], []
    for tr in tracks:
        standing = tr.fit is not None and not _is_moving(tr, tr.fit, params)
        (cand if standing and tr.class_name in VEHICLE_CLASSES else keep).append(tr)
    pos = [_standing_estimate(tr, params)[0] for tr in cand]
    radius = [float(np.median([_footprint_radius(item.placement) for item in tr.items])) for tr in cand]
    refused = _Refusals()
    while True:
        best: tuple[float, int, int] | None = None
        for a in range(len(cand)):
            for b in range(a + 1, len(cand)):
                if cand[a].class_name != cand[b].class_name or (cand[a], cand[b]) in refused:
                    continue
                d = float(np.linalg.norm(pos[a] - pos[b]))
                if d < radius[a] + radius[b] and (best is None or d < best[0]):
                    best = (d, a, b)
        if best is None:
            return keep + cand
        _, a, b = best
        joined = _joined_overlapping(cand[a], cand[b], params)
        joined.parts = joined_parts(cand[a], cand[b], params)
        if joined.fit is not None and _is_moving(joined, joined.fit, params):
            refused.add(cand[a], cand[b])  # two standing tracks whose frames together move
            continue
        cand[a] = joined
        pos[a] = _standing_estimate(joined, params)[0]
        radius[a] = float(np.median([_footprint_radius(item.placement) for item in joined.items]))
        del cand[b], pos[b], radius[b]


def on_bearing_of(fragment: _Track, track: _Track, xy: np.ndarray) -> float | None:
    """How far a short fragment's rays pass a standing trunk track's footprint, or None where one misses it.

    For each observation of ``fragment``: the distance of ``xy`` (the track's triangulated
    position) from the observation's ray, less the two footprints' reaches across that ray
    (:func:`footprint_reach_across`; the track's the median over its frames). The fragment's
    rays all pass through the track's footprint when every value is negative (the two
    footprints overlap across each ray, ``xy`` ahead of the camera); the result is then the
    largest value (nearer 0: the worst ray's margin), else None.

    Args:
        fragment: a standing track of a trunk class.
        track: another of the same class.
        xy: (2,) float64 ``track``'s triangulated position, metres.
    """
    worst = -math.inf
    for item in fragment.items:
        for o in item.observations:
            ray = o.placement.contact_world[:2] - o.camera_ground
            ray = ray / max(float(np.linalg.norm(ray)), 1e-9)
            d = xy - o.camera_ground
            if float(d @ ray) <= 0.0:
                return None
            across = abs(float(d @ np.array([-ray[1], ray[0]])))
            reach = float(np.median([footprint_reach_across(i.placement, ray) for i in track.items]))
            margin = across - reach - footprint_reach_across(o.placement, ray)
            if margin >= 0.0:
                return None
            worst = max(worst, margin)
    return worst


def absorb_short_fragments(
    tracks: list[_Track], est: list[tuple[np.ndarray, np.ndarray]], params: ViewsParams
) -> list[_Track]:
    """Standing trunk tracks of fewer than ``scatter_min_frames`` frames joined to the track on their bearing.

    A tree's, pole's or sign's single-view depth fails where its view cuts it (the image's
    border, a crown cut by what stands in front: its size, and so its depth, is a guess),
    while its bearing stays the trunk's. Such a frame starts a track of a frame or two placed
    metres along the ray from the object, and the association never reaches it. A track too
    short for its frames to measure their own scatter (``scatter_min_frames``) whose every ray
    passes through the footprint of a longer standing track of its class (:func:`on_bearing_of`)
    is that object: it joins the one its rays pass most nearly, its bearings kept and its failed
    depths dropped (:func:`depth_from`: each contact moved along its own ray to the track's
    depth). A short track that no longer one's footprint explains is kept (a trunk seen only at
    the drive's start or end).

    Args:
        tracks: the drive's standing trunk tracks after :func:`merge_standing_trunks`' joins.
        est: (2,) position and (2, 2) covariance of each (:func:`_merge_estimate`).
        params: ``scatter_min_frames``.

    Returns:
        The tracks, each short one that joined another gone, the one it joined with its frames.
    """
    short = params.scatter_min_frames
    long_ = [k for k, tr in enumerate(tracks) if len(tr.times) >= short]
    joins: dict[int, list[int]] = {}
    for j, frag in enumerate(tracks):
        if len(frag.times) >= short:
            continue
        best: tuple[float, int] | None = None
        for k in long_:
            if tracks[k].class_name != frag.class_name:
                continue
            margin = on_bearing_of(frag, tracks[k], est[k][0])
            if margin is not None and (best is None or margin < best[0]):
                best = (margin, k)
        if best is not None:
            joins.setdefault(best[1], []).append(j)
    gone = {j for js in joins.values() for j in js}
    out = []
    for k, tr in enumerate(tracks):
        if k in gone:
            continue
        for j in joins.get(k, []):
            frag = tracks[j]
            prior = _standing_estimate(tr, params)[0]
            items = [depth_from(i, prior) for i in frag.items]
            moved = _Track(frag.class_name, frag.sigma_speed, list(frag.times), items)
            tr = _joined_overlapping(tr, moved, params)
        out.append(tr)
    return out


def depth_from(item: FusedObject, xy: np.ndarray) -> FusedObject:
    """One frame's object with each observation's contact moved along its own ray to the point nearest ``xy``.

    Its bearings (camera to contact) are kept; its depths become those of ``xy`` along each ray,
    so the object's failed single-view depth no longer counts. The frame's placement is the
    moved contacts' :func:`~usdworld.views.fusion.combine`.

    Args:
        item: the frame's object.
        xy: (2,) float64 the point whose depth it takes, metres.
    """
    moved = []
    for o in item.observations:
        contact = o.placement.contact_world
        ray = contact[:2] - o.camera_ground
        ray = ray / max(float(np.linalg.norm(ray)), 1e-9)
        at = o.camera_ground + max(float((xy - o.camera_ground) @ ray), 0.0) * ray
        placement = o.placement.with_contact_at(np.array([at[0], at[1], contact[2]]))
        moved.append(dataclasses.replace(o, placement=placement))
    placed, _ = combine(moved)
    contact = item.placement.contact_world
    placement = item.placement.with_contact_at(np.array([placed[0], placed[1], contact[2]]))
    return dataclasses.replace(item, placement=placement, observations=tuple(moved))


def arm_across(items: Sequence[FusedObject], ray: np.ndarray) -> float:
    """How far a track's footprint reaches across a viewing ray beyond its inscribed disc, metres.

    The median over its frames of :func:`footprint_reach_across` less the disc's radius: 0 for a
    square footprint (a tree, a plain pole), for a street lamp the share of its arm across the
    ray, so the most a view of its head alone can place its contact beside the mast.

    Args:
        items: the track's frames' objects.
        ray: (2,) float64 the unit viewing direction on the ground.
    """
    return float(
        np.median([footprint_reach_across(o.placement, ray) - _footprint_radius(o.placement) for o in items])
    )


def seen_as_one_trunk(
    a: _Track,
    b: _Track,
    est_a: tuple[np.ndarray, np.ndarray],
    est_b: tuple[np.ndarray, np.ndarray],
    params: ViewsParams,
) -> bool:
    """Whether two standing trunk tracks that share frames are one object by their triangulations.

    Their triangulated positions (:func:`_merge_estimate`) agree within
    ``association_gate_chi2`` (covariances summed) once their distance across the pair's mean
    viewing ray is shortened by the longer arm of the two (:func:`arm_across`: a track of a
    lamp's head triangulates to a point under the head, beside the mast), and in every frame
    that saw both the two placements overlap across the viewing ray (nearer than the sum of
    their footprints' reaches across it, :func:`footprint_reach_across`): the halves of one
    crown cut by what stands in front of it share their bearing, and so do a lamp's mast and
    its head over the road; two trunks seen side by side do not. Their depths in such a frame
    are not compared (a half's contact can lie metres off along the ray); the triangulations
    compare them. A shared frame in which either track holds what its own footprint does not
    explain (:func:`ray_through_own_footprint`: the observation's ray misses the track's
    triangulated footprint, so it saw another object, as a far frame of a row does) says nothing
    about whether the two are one, and is left out of that test. Pairs that share no frame are
    :func:`merge_fragments`' to join.

    Where neither track has an arm (:func:`arm_across` 0: a tree's or plain pole's square
    footprint), the share of the shorter track's frames that the other also holds must be one
    that a crown cut in two in half the frames or fewer gives by chance: :func:`cut_tail` of
    the shared count at least the gate's tail, ``exp(-association_gate_chi2 / 2)`` (0.01). A
    view cuts one crown in two only in the frames where something stands in front of it; two
    trees of a row that a far view sees on one bearing (their footprints overlap across every
    ray and their depths are metres apart, within the depth cues' spread) are two objects in
    every frame that sees both, so their tracks share nearly all of the shorter one's frames.
    A lamp's head and mast are seen apart in every frame by design, so an arm keeps the old test.

    Args:
        a: one standing track of a trunk class.
        b: another of the same class.
        est_a: (2,) position and (2, 2) covariance of ``a`` (:func:`_merge_estimate`).
        est_b: the same of ``b``.
        params: ``association_gate_chi2``.
    """
    shared = set(a.times) & set(b.times)
    if not shared:
        return False
    d = est_a[0] - est_b[0]
    cameras = np.array([item.observations[0].camera_ground for tr in (a, b) for item in tr.items])
    rays = 0.5 * (est_a[0] + est_b[0]) - cameras
    u = (rays / np.maximum(np.linalg.norm(rays, axis=1, keepdims=True), 1e-9)).mean(axis=0)
    u = u / max(float(np.linalg.norm(u)), 1e-9)
    n = np.array([-u[1], u[0]])
    across = float(d @ n)
    arm = max(arm_across(a.items, u), arm_across(b.items, u))
    shorter = min(len(a.times), len(b.times))
    if arm <= 0.0 and cut_tail(len(shared), shorter) < math.exp(-0.5 * params.association_gate_chi2):
        return False
    d = d - math.copysign(min(abs(across), arm), across) * n
    if float(d @ np.linalg.solve(est_a[1] + est_b[1], d)) > params.association_gate_chi2:
        return False
    items_b = dict(zip(b.times, b.items))
    for t, ia in zip(a.times, a.items):
        ib = items_b.get(t)
        if ib is None:
            continue
        if not (ray_through_own_footprint(ia, a, est_a[0]) and ray_through_own_footprint(ib, b, est_b[0])):
            continue  # a frame of another object in one of the tracks
        za, zb = ia.placement.contact_world[:2], ib.placement.contact_world[:2]
        u = 0.5 * (za + zb) - ia.observations[0].camera_ground
        u = u / max(float(np.linalg.norm(u)), 1e-9)
        across = abs(float((za - zb) @ np.array([-u[1], u[0]])))
        if across >= footprint_reach_across(ia.placement, u) + footprint_reach_across(ib.placement, u):
            return False
    return True


def ray_through_own_footprint(item: FusedObject, track: _Track, xy: np.ndarray) -> bool:
    """Whether a frame's object of a standing trunk track is that track's object by its bearing.

    Its primary observation's ray (camera to contact) passes ``xy``, the track's triangulated
    position, nearer than the two footprints reach across that ray (:func:`footprint_reach_across`;
    the track's the median over its frames): the footprints overlap across the ray, as
    :func:`on_bearing_of` asks of a short fragment's rays. A ray that misses it saw another object
    (a far frame of a row of trees joins the neighbour's track: its depth spread spans both).

    Args:
        item: one frame's object of ``track``.
        track: a standing track of a trunk class.
        xy: (2,) float64 ``track``'s triangulated position, metres.

    Example:
        >>> from types import SimpleNamespace as NS
        >>> def tree(x, y):
        ...     placement = NS(contact_world=np.array([x, y, 0.0]), size_m=np.array([2.0, 2.0, 5.0]), yaw=0.0)
        ...     return NS(placement=placement, observations=(NS(camera_ground=np.zeros(2)),))
        >>> track = NS(items=[tree(20.0, 5.0)])
        >>> ray_through_own_footprint(tree(40.0, 10.0), track, np.array([20.0, 5.0]))
        True
        >>> ray_through_own_footprint(tree(40.0, 5.0), track, np.array([20.0, 5.0]))
        False
    """
    o = item.observations[0]
    ray = item.placement.contact_world[:2] - o.camera_ground
    ray = ray / max(float(np.linalg.norm(ray)), 1e-9)
    across = abs(float((xy - o.camera_ground) @ np.array([-ray[1], ray[0]])))
    reach = float(np.median([footprint_reach_across(i.placement, ray) for i in track.items]))
    return across < reach + footprint_reach_across(item.placement, ray)


def cut_tail(shared: int, frames: int) -> float:
    """Chance that a crown cut in two with probability 1/2 per frame is cut in ``shared`` or more of ``frames``.

    The binomial tail ``P(X >= shared)``, ``X ~ Bin(frames, 1/2)``: a half is the most that
    "cut now and then, by what stands in front" allows, so the tail bounds how likely a track of
    ``frames`` frames, ``shared`` of them also holding another track's observation, is one
    object's fragment (:func:`seen_as_one_trunk`).

    Args:
        shared: frames the two tracks share (>= 0).
        frames: frames of the shorter track (>= shared).

    Example:
        >>> [round(cut_tail(s, 4), 4) for s in (2, 4)], round(cut_tail(10, 10), 4)
        ([0.6875, 0.0625], 0.001)
    """
    return sum(math.comb(frames, k) for k in range(shared, frames + 1)) / 2.0**frames


def _joined_overlapping(a: _Track, b: _Track, params: ViewsParams) -> _Track:
    """One track of two standing ones: a frame both saw keeps one object (:func:`_merged_item`)."""
    by_time: dict[float, FusedObject] = dict(zip(a.times, a.items))
    for t, item in zip(b.times, b.items):
        by_time[t] = _merged_item(by_time[t], item, params) if t in by_time else item
    times = sorted(by_time)
    items = [by_time[t] for t in times]
    out = _Track(a.class_name, a.sigma_speed, times, items, standing_share=a.standing_share)
    out.refit()
    return out


def _pair_mahalanobis2(pos: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """(N, N) squared Mahalanobis distances of (N, 2) positions with (N, 2, 2) covariances summed per pair."""
    d = pos[:, None, :] - pos[None, :, :]
    S = cov[:, None] + cov[None, :]
    det = S[..., 0, 0] * S[..., 1, 1] - S[..., 0, 1] * S[..., 1, 0]
    dx, dy = d[..., 0], d[..., 1]
    return (S[..., 1, 1] * dx * dx - 2.0 * S[..., 0, 1] * dx * dy + S[..., 0, 0] * dy * dy) / det


def _joined(a: _Track, b: _Track) -> _Track:
    """One track of two that share no frame: their frames in time order, the fit redone."""
    pairs = sorted(zip(a.times + b.times, a.items + b.items), key=lambda p: p[0])
    times, items = [t for t, _ in pairs], [item for _, item in pairs]
    out = _Track(a.class_name, a.sigma_speed, times, items, standing_share=a.standing_share)
    out.refit()
    return out


def variant_of_most_frames(members: Sequence[Observation]) -> list[Observation]:
    """A standing trunk object's observations, those of the variant its frames' evidence favours first.

    Each frame that measured the object's scale also chose its variant (a street lamp or a
    plain pole) from its own view. The object's variant is the one with the most evidence:
    each such observation counts with its weight in the fusion (``1 / sigma_range^2``, as
    :func:`~usdworld.views.fusion.combine` weighs it), not the single most precise frame's
    choice, which is one draw (a plain pole's top and a lamp's head differ by a few pixels).
    :func:`~usdworld.views.fusion.sized_by_a_whole_view` then sizes the object by the most
    precise member of that variant.

    Args:
        members: the object's observations, most precise first.

    Returns:
        ``members`` reordered: those that measured the chosen variant first (in their order),
        then the rest.

    Example:
        >>> from types import SimpleNamespace as NS
        >>> seen = [NS(placement=NS(variant=v, scale_measured=1.0), sigma_range_m=s)
        ...         for v, s in (("street_lamp", 1.0), ("plain", 1.2), ("plain", 1.2))]
        >>> [o.placement.variant for o in variant_of_most_frames(seen)]
        ['plain', 'plain', 'street_lamp']
    """
    weights: dict[str, float] = {}
    for o in members:
        if math.isfinite(o.placement.scale_measured):
            weights[o.placement.variant] = weights.get(o.placement.variant, 0.0) + 1.0 / o.sigma_range_m**2
    if not weights:
        return list(members)
    chosen = max(weights, key=lambda v: weights[v])  # a tie: the variant of the more precise member
    first = [
        o for o in members if o.placement.variant == chosen and math.isfinite(o.placement.scale_measured)
    ]
    return first + [o for o in members if not any(o is f for f in first)]


def _cue_depth(cues: Sequence[DepthCue], height_factor: float) -> float | None:
    """The depth :func:`~usdworld.perception.depth.fusion.fuse` (a single view's cue fusion) gives a placement's contact and height
    cues with the height cue's depth and spread times ``height_factor``; None unless both cues are
    available and they are its only ones."""
    avail = [c for c in cues if c.available]
    if {c.name for c in avail} != {"contact", "height"}:
        return None
    scaled = [
        dataclasses.replace(c, depth_m=c.depth_m * height_factor, sigma_m=c.sigma_m * height_factor)
        if c.name == "height"
        else c
        for c in avail
    ]
    return fuse_cues(scaled).depth_m


def track_height_factor(items: Sequence[FusedObject]) -> float:
    """A vehicle track's height over its class prior's, measured by its frames' contact cues.

    Each observation whose placement has both a ground-contact cue and a class-height cue says
    how much taller than the prior the object is: the contact depth over the height depth,
    ``k_i = d_c / d_h`` (the height cue's depth is the prior height times the focal length over
    the silhouette's pixels, so the object's height is the prior's times ``k_i`` where the
    contact's depth is right), known to ``sigma_c / d_h``. The frames' estimates are averaged by
    inverse variance with the prior ``k = 1`` of the height cue's own relative spread (the
    class's height spread and the silhouette's pixels): a track whose contact cues say little
    (seen only far away, where a row spans metres) leans on the prior.

    Args:
        items: the track's frames' objects.

    Returns:
        The factor (1 where no observation has both cues).
    """
    num = den = 0.0
    prior = []
    for item in items:
        for o in item.observations:
            by_name = {c.name: c for c in o.placement.cues if c.available}
            c, h = by_name.get("contact"), by_name.get("height")
            if c is None or h is None:
                continue
            d_c, s_c, d_h, s_h = float(c.depth_m), float(c.sigma_m), float(h.depth_m), float(h.sigma_m)
            var = (s_c / d_h) ** 2
            num += (d_c / d_h) / var
            den += 1.0 / var
            prior.append((s_h / d_h) ** 2)
    if not prior:
        return 1.0
    var0 = float(np.median(prior))
    return (1.0 / var0 + num) / (1.0 / var0 + den)


def with_height_factor(item: FusedObject, factor: float) -> FusedObject:
    """One frame's object with each observation's height cue scaled by ``factor`` and its contact moved
    along its ray by the change of its contact-and-height depth (:func:`track_height_factor`).

    An observation placed by another method, or whose depth is not its two cues' fusion, is kept.
    The contact moves by the depth change times the observation's range over its depth (the ray's
    ground length per metre of depth); the frame's placement is the moved observations'
    :func:`~usdworld.views.fusion.combine`, its covariance kept (as :func:`depth_from` does).

    Args:
        item: one frame's object of a vehicle track.
        factor: the track's height over its class prior's (:func:`track_height_factor`).

    Returns:
        The object with its observations moved (``item`` itself when none moved).
    """
    moved = []
    changed = False
    for o in item.observations:
        before, after = _cue_depth(o.placement.cues, 1.0), _cue_depth(o.placement.cues, factor)
        if (
            o.placement.method is not DepthMethod.CONTACT
            or before is None
            or after is None
            or abs(before - o.placement.depth_m) > 1e-6 * max(1.0, abs(before))
        ):
            moved.append(o)
            continue
        contact = o.placement.contact_world
        offset = contact[:2] - o.camera_ground
        scale = float(np.linalg.norm(offset)) / max(o.placement.depth_m, 1e-9)
        u = offset / max(float(np.linalg.norm(offset)), 1e-9)
        at = contact[:2] + u * (after - before) * scale
        placement = o.placement.with_contact_at(np.array([at[0], at[1], contact[2]]))
        moved.append(dataclasses.replace(o, placement=placement))
        changed = True
    if not changed:
        return item
    placed, _ = combine(moved)
    contact = item.placement.contact_world
    placement = item.placement.with_contact_at(np.array([placed[0], placed[1], contact[2]]))
    return dataclasses.replace(item, placement=placement, observations=tuple(moved))


def _drive_object(tr: _Track, fit: MotionFit, params: ViewsParams, counters: dict[str, int]) -> DriveObject:
    members = sorted(
        (o for item in tr.items for o in item.observations), key=lambda o: (o.sigma_range_m, o.view)
    )
    primary = members[0].placement
    cls = tr.class_name
    counters[cls] = counters.get(cls, 0) + 1
    name = f"{cls}_{counters[cls]:04d}"
    times = np.array(tr.times)
    moving = _is_moving(tr, fit, params)
    z = float(primary.position_world[2])
    if moving:
        if cls in VEHICLE_CLASSES:
            factor = track_height_factor(tr.items)
            tr = _Track(cls, tr.sigma_speed, list(tr.times), [with_height_factor(i, factor) for i in tr.items])
        fit = tr.placed_fit(params)
        xy = np.array([fit.predict(float(t))[0] for t in times])
        positions = np.c_[xy, np.full(len(times), z)]
        yaw = _yaw_of(fit.velocity, primary.yaw, params)
        placement = dataclasses.replace(primary, name=name).with_contact_at(positions[0], yaw)
        positions = positions - np.array([*turned(primary.contact_offset, yaw), 0.0])  # contacts -> origins
        cov = fit.predict(float(times[0]))[1]
        fused = FusedObject(placement, tuple(members), "tracked", cov)
        return DriveObject(fused, True, times, positions, np.full(len(times), yaw), fit.velocity.copy())
    if cls in load_class_table().with_role("trunk"):
        xy, cov = bearing_triangulation(*track_bearings(tr.items, params), *_standing_estimate(tr, params), params)
        sized = sized_by_a_whole_view(primary, variant_of_most_frames(members))
    else:
        xy, cov = _standing_position(tr, members)
        sized = sized_by_a_whole_view(primary, members)
    placement = dataclasses.replace(sized, name=name).with_contact_at(np.array([xy[0], xy[1], z]))
    position = placement.position_world
    fused = FusedObject(placement, tuple(members), fusion_method(members, cov, params), cov)
    velocity = fit.velocity.copy()
    return DriveObject(
        fused, False, times, np.tile(position, (len(times), 1)), np.full(len(times), primary.yaw), velocity
    )
