"""Objects seen by several views placed once: association by class and distance within
the uncertainties, then fusion (layout level: pure numpy).

Each view places its objects as a single image would; :func:`observations` takes them
into the rig's world with their uncertainty as a ground-plane covariance: along the
viewing ray the spread of the object's depth cues, across it a small share of the range
(:class:`~usdworld.parameters.views.ViewsParams`), both widened for an object cut by
the image's border. :func:`fuse` merges, greedily and
nearest first, objects of one class from different views whose Mahalanobis distance is
inside the gate, and places each group at the information-weighted mean of its
observations. That one formula triangulates where the views' rays cross (the across-ray
spreads are small, so the rays pin the point) and falls back to inverse-variance fusion
of the depths where the rays are nearly parallel; the result says which of the two decided.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from usdworld.layout.placement import Placement
from usdworld.parameters.views import ViewsParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.views.hidden_contact import surface_sigma


@dataclass(frozen=True)
class ContactRow:
    """How one view's contact rows turn into depth: what :func:`gate_sigma` needs.

    Attributes:
        fy: the view camera's vertical focal length, pixels.
        camera_height_m: its height above the ground, metres.
        error_px: the contact row's standard deviation its placement used
            (:attr:`~usdworld.parameters.perception.PerceptionParams.contact_row_error_px`), pixels.
    """

    fy: float
    camera_height_m: float
    error_px: float


@dataclass(frozen=True)
class Observation:
    """One view's placement of an object, in the rig's world.

    Attributes:
        view: index of the view.
        view_name: the view's name.
        image_name: the view's photo.
        placement: the placement with its position and yaw in the world frame.
        camera_ground: (2,) float64 the view camera's centre on the ground (x, y), metres.
        sigma_range_m: standard deviation along the viewing ray, metres.
        sigma_lateral_m: standard deviation across it, metres.
        surface_sigma_m: along-ray standard deviation of a hidden contact's unknown surface,
            metres (:func:`usdworld.views.hidden_contact.surface_sigma`; 0 when the contact is
            seen). Not part of :meth:`covariance`: only a drive's motion fit adds it.
    """

    view: int
    view_name: str
    image_name: str
    placement: Placement
    camera_ground: np.ndarray
    sigma_range_m: float
    sigma_lateral_m: float
    surface_sigma_m: float = 0.0

    def covariance(self) -> np.ndarray:
        """(2, 2) float64 ground-plane covariance of the position, metres squared."""
        d = self.placement.contact_world[:2] - self.camera_ground
        d = d / max(float(np.linalg.norm(d)), 1e-9)
        n = np.array([-d[1], d[0]])
        return self.sigma_range_m**2 * np.outer(d, d) + self.sigma_lateral_m**2 * np.outer(n, n)


@dataclass(frozen=True)
class FusedObject:
    """One object of the rig's world and the observations that placed it.

    Attributes:
        placement: the fused placement (world frame), named ``<class>_<NNNN>``.
        observations: the views' placements, the primary one (smallest depth spread) first.
        method: ``single`` (one view), ``triangulated`` (the rays decided), ``fused`` (the depths
            decided) or, for a moving object of a drive, ``tracked`` (:mod:`usdworld.views.drive`).
        covariance: (2, 2) float64 ground-plane covariance of the position, metres squared.
    """

    placement: Placement
    observations: tuple[Observation, ...]
    method: str
    covariance: np.ndarray


def gate_sigma(cue: DepthCue, row: ContactRow | None, params: ViewsParams) -> float:
    """A cue's spread as the views' gates take it (metres): a contact cue's row error widened
    from the single view's ``row.error_px`` to ``gate_contact_row_error_px``.

    The row's part of a contact cue's variance is ``(e_v d^2 / (f h))^2`` beside its other
    parts (camera, road, relative floor), so the difference of the two row errors' squares
    is added to it; ``d`` is the cue's depth (the footprint centre's, a little beyond the
    contact's: slightly wider). Other cues, or no row given, keep their spread.
    """
    sigma = float(cue.sigma_m)  # type: ignore[arg-type]
    if cue.name != "contact" or row is None or cue.depth_m is None:
        return sigma
    extra_px2 = params.gate_contact_row_error_px**2 - row.error_px**2
    if extra_px2 <= 0:
        return sigma
    d = float(cue.depth_m)
    metres_per_px = d * d / (row.fy * row.camera_height_m)
    return math.sqrt(sigma**2 + extra_px2 * metres_per_px**2)


def depth_sigma(placement: Placement, params: ViewsParams, row: ContactRow | None = None) -> float:
    """Standard deviation of a placement's depth: its cues' spreads (a contact cue's as
    :func:`gate_sigma` widens it, when ``row`` is given) fused by inverse variance.

    Cues without a depth or a spread are left out; with none left,
    ``fallback_depth_rel_sigma`` times the depth.
    """
    weights = [
        1.0 / gate_sigma(c, row, params) ** 2
        for c in placement.cues
        if c.depth_m is not None and c.sigma_m is not None and math.isfinite(c.sigma_m) and c.sigma_m > 0
    ]
    if not weights:
        return params.fallback_depth_rel_sigma * float(placement.depth_m)
    return 1.0 / math.sqrt(sum(weights))


def to_world(placement: Placement, world_from_ground: np.ndarray) -> Placement:
    """A view's placement moved from its ground frame into the world (a turn about Z and a shift)."""
    p = world_from_ground[:3, :3] @ placement.position_world + world_from_ground[:3, 3]
    turn = math.atan2(world_from_ground[1, 0], world_from_ground[0, 0])
    yaw = math.remainder(placement.yaw + turn, 2.0 * math.pi)
    return dataclasses.replace(placement, position_world=p, yaw=yaw)


def observations(
    view: int,
    view_name: str,
    image_name: str,
    placements: Sequence[Placement],
    world_from_ground: np.ndarray,
    params: ViewsParams,
    row: ContactRow | None = None,
    curb_height_m: float = 0.0,
) -> list[Observation]:
    """The placements of one view as observations in the world.

    Args:
        view: the view's index.
        view_name: its name.
        image_name: its photo's file name.
        placements: its placements, in its ground frame.
        world_from_ground: (4, 4) float64 its ground frame in the world (:func:`usdworld.views.rig.world_from_ground`).
        params: the fusion's thresholds.
        row: the view's contact rows (:func:`gate_sigma`); None keeps the cues' spreads.
        curb_height_m: the kerb's height, metres, for a hidden contact's surface spread
            (:func:`~usdworld.views.hidden_contact.surface_sigma`; needs ``row``'s camera height).
    """
    camera = world_from_ground[:2, 3].copy()
    out = []
    for p in placements:
        moved = to_world(p, world_from_ground)
        rng = float(np.linalg.norm(moved.contact_world[:2] - camera))
        cut = params.cut_sigma_share * float(max(p.size_m[0], p.size_m[1])) if p.obj.cut_sides else 0.0
        lateral = max(params.lateral_sigma_min_m, params.lateral_sigma_rel * rng) + cut
        surface = 0.0 if row is None else surface_sigma(p, rng, row.camera_height_m, curb_height_m)
        out.append(
            Observation(
                view, view_name, image_name, moved, camera, depth_sigma(p, params, row) + cut, lateral, surface
            )
        )
    return out


def combine(group: Sequence[Observation]) -> tuple[np.ndarray, np.ndarray]:
    """Information-weighted mean (2,) and covariance (2, 2) of a group's ground contacts
    (:attr:`~usdworld.layout.placement.Placement.contact_world`: what each view measured,
    whichever variant it chose)."""
    info = np.zeros((2, 2))
    vec = np.zeros(2)
    for o in group:
        inv = np.linalg.inv(o.covariance())
        info += inv
        vec += inv @ o.placement.contact_world[:2]
    cov = np.linalg.inv(info)
    return cov @ vec, cov


def sized_by_a_whole_view(primary: Placement, members: Sequence[Observation]) -> Placement:
    """``primary`` with the variant and size of the most precise member that measured them.

    A view that cuts an object's top or hides its bottom measures neither its height nor
    its variant: its placement keeps the class's default variant at the clamped or unit
    scale (the nearest views of a street lamp cut its head). The first member, in order of
    precision, whose scale was measured (``scale_measured`` finite) gives the variant, scale,
    stretch, size and contact offset; the primary keeps the rest (yaw, evidence, cues).

    Args:
        primary: the most precise member's placement.
        members: the object's observations, most precise first.
    """
    for o in members:
        p = o.placement
        if math.isfinite(p.scale_measured):
            return dataclasses.replace(
                primary,
                variant=p.variant,
                scale=p.scale,
                stretch=p.stretch,
                scale_measured=p.scale_measured,
                size_m=p.size_m,
                contact_offset=p.contact_offset,
            )
    return primary


def fusion_method(group: Sequence[Observation], cov: np.ndarray, params: ViewsParams) -> str:
    if len(group) == 1:
        return "single"
    depth_only = 1.0 / sum(1.0 / o.sigma_range_m**2 for o in group)
    return (
        "triangulated"
        if float(np.linalg.eigvalsh(cov)[-1]) < params.triangulated_ratio * depth_only
        else "fused"
    )


def associate(obs: Sequence[Observation], params: ViewsParams) -> list[list[int]]:
    """Groups of observations that are one object (indices into ``obs``).

    Greedy and nearest first: the two groups of one class, with no view in common, whose
    fused positions are closest in squared Mahalanobis distance (covariances summed) are
    merged while that distance is within ``association_gate_chi2``. A view never merges
    two of its own objects (its own placement already tells them apart).

    Returns:
        The groups, each sorted, ordered by their first index.
    """
    groups = [[i] for i in range(len(obs))]
    fused = [combine([o]) for o in obs]
    views = [{o.view} for o in obs]
    classes = [o.placement.obj.class_name for o in obs]
    while True:
        best: tuple[float, int, int] | None = None
        for a in range(len(groups)):
            for b in range(a + 1, len(groups)):
                if classes[a] != classes[b] or views[a] & views[b]:
                    continue
                diff = fused[a][0] - fused[b][0]
                m2 = float(diff @ np.linalg.solve(fused[a][1] + fused[b][1], diff))
                if m2 <= params.association_gate_chi2 and (best is None or m2 < best[0]):
                    best = (m2, a, b)
        if best is None:
            break
        _, a, b = best
        groups[a] = sorted(groups[a] + groups[b])
        views[a] |= views[b]
        fused[a] = combine([obs[i] for i in groups[a]])
        for items in (groups, views, classes, fused):
            del items[b]
    return sorted(groups, key=lambda g: g[0])


def fuse(obs: Sequence[Observation], params: ViewsParams) -> list[FusedObject]:
    """Associate the views' observations and place each object once.

    The fused placement is the primary observation's (its class, asset variant, yaw, scale
    and image evidence) at the fused ground position, keeping its height above the ground;
    objects are renamed ``<class>_<NNNN>``, numbered per class in the order of their first
    observation (views in order, each view's placements in order).

    Args:
        obs: every view's observations, views in order.
        params: the fusion's thresholds.

    Returns:
        The objects, in the order of their first observation.
    """
    out = []
    counters: dict[str, int] = {}
    for group in associate(obs, params):
        members = sorted((obs[i] for i in group), key=lambda o: (o.sigma_range_m, o.view))
        primary = members[0].placement
        xy, cov = combine(members)
        cls = primary.obj.class_name
        counters[cls] = counters.get(cls, 0) + 1
        contact = np.array([xy[0], xy[1], primary.position_world[2]])
        sized = sized_by_a_whole_view(primary, members)
        placement = dataclasses.replace(sized, name=f"{cls}_{counters[cls]:04d}").with_contact_at(contact)
        out.append(FusedObject(placement, tuple(members), fusion_method(members, cov, params), cov))
    return out
