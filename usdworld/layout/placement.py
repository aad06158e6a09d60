"""Metric placement of image objects: a short list of named passes over frozen drafts.

1. :func:`draft_all` drafts every object from its own evidence: the depth of its front
   from fused cues (:mod:`usdworld.layout.cues`), then variant, scale and centre
   (:mod:`usdworld.layout.drafting`).
2. :func:`~usdworld.layout.occlusion.move_behind_occluders`: a hidden bottom's bound moves
   behind the object hiding it.
3. :func:`~usdworld.layout.rows.onto_street_rows`: members of a street row whose foot is
   hidden, cut or off the row stand in it (:mod:`usdworld.layout.rows`); then
   :func:`~usdworld.layout.occlusion.behind_bordered_things`: stuff inferred around a
   detection box that would hide the thing from the camera stands behind it.
4. :func:`~usdworld.layout.occlusion.drop_unbounded`: bounds beyond the world's range and
   slivers behind an occluder are dropped.
5. :func:`~usdworld.layout.occlusion.place_behind_occluders`: objects with no cue go right
   behind their occluder.
6. :func:`apply_ordering`: with a depth map, the paper's ordering rules repair the depths
   the map decided alone (depths carried by the contact already follow the ground lines
   the rules assume, and applying the rules to them was measured to make them worse:
   tools/eval_depth_fusion.py).
7. :func:`resolve_footprints`: footprint collisions are resolved, things before stuff.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import ClassTable
from usdworld.io.types import DepthMap
from usdworld.io.asset_catalogue import AssetSizes
from usdworld.layout.collision import Admissible, footprint_half_extents, resolve_collisions
from usdworld.layout.draft import (
    DEFAULT_COLLISION,
    DepthMethod,
    Draft,
    PlacementContext,
    depth_method_label,
    depth_of_ground_point,
    point_at_depth,
    turned,
)
from usdworld.layout.drafting import draft_object
from usdworld.layout.occlusion import (
    behind_bordered_things,
    drop_unbounded,
    move_behind_occluders,
    place_behind_occluders,
)
from usdworld.layout.ordering import apply_ordering_rules
from usdworld.layout.rows import onto_street_rows
from usdworld.layout.traffic_sides import face_the_traffic
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.collision import CollisionParams
from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams
from usdworld.parameters.placement import PlacementParams
from usdworld.parameters.scene import SceneParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.perception.objects import ImageObject

#: The scene defaults (the range beyond which partial placements are dropped, unless given).
DEFAULT_SCENE = SceneParams()

__all__ = ["AssetSizes", "DepthMethod", "Placement", "SkipReason", "Skipped", "place_objects", "skip_warnings"]


class SkipReason(Enum):
    """Why an object was not placed."""

    #: Nothing gives its depth: no visible ground contact and no usable height, or only an
    #: upper bound beyond the world's range (and no occluder or street row to stand behind),
    #: or what is seen of it is smaller there than the smallest of its class.
    NO_DEPTH = "no_depth"
    #: It would have to move further than ``CollisionParams.max_displacement_m``, or search
    #: more than ``max_candidates`` spots, to clear the objects already placed (a pile).
    PILED = "piled"
    #: Every free spot clear of the objects already placed lies where the photo contradicts
    #: it: off the rays through its pixels, or nearer or farther than its depth cues allow.
    NO_ROOM = "no_room"


@dataclass(frozen=True)
class Skipped:
    """An object not placed.

    Attributes:
        name: its prim name, as it would have been placed.
        reason: why it was not.
    """

    name: str
    reason: SkipReason


@dataclass(frozen=True)
class Placement:
    """One object placed in the world.

    Attributes:
        name: prim name ``<class>_<NNNN>``, stable for the same input.
        obj: the image evidence.
        variant: asset variant chosen.
        position_world: (3,) float64 footprint centre (z = 0, or the kerb height).
        yaw: rotation about Z, radians.
        yaw_source: how the yaw was chosen.
        scale: uniform scale applied to the asset.
        stretch: (3,) float64 factors on the uniform scale along the asset's axes (1 but
            for a facade's unseen depth and the frontage of one cut by the image's side).
        scale_measured: scale measured from the image before clamping (NaN if not measurable).
        size_m: (3,) float64 size after scaling (length, width, height).
        depth_m: centre depth along the optical axis, metres.
        method: what decided the depth (:class:`~usdworld.layout.draft.DepthMethod`).
        cues: every depth cue computed, as centre depths (unavailable ones have None).
        collision_displacement: (2,) float64 displacement applied by collision resolution.
        confidence: in [0, 1].
        behind: the occluder's name when ``method`` is ``BEHIND``.
        rule: ``''`` or the ordering rule(s) that changed the depth.
        yaw_confidence: how sure the yaw's facing direction is, in [0, 1].
        contact_offset: (2,) float64 the centre of its ground contact from its origin, in the
            asset's frame at its scale, metres (a street lamp's mast; zero for most classes):
            what the photos measure is :attr:`contact_world`.
    """

    name: str
    obj: ImageObject
    variant: str
    position_world: np.ndarray
    yaw: float
    yaw_source: str
    scale: float
    stretch: np.ndarray
    scale_measured: float
    size_m: np.ndarray
    depth_m: float
    method: DepthMethod
    cues: tuple[DepthCue, ...]
    collision_displacement: np.ndarray = field(default_factory=lambda: np.zeros(2))
    confidence: float = 0.0
    behind: str | None = None
    rule: str = ""
    yaw_confidence: float = 1.0
    contact_offset: np.ndarray = field(default_factory=lambda: np.zeros(2))

    @property
    def contact_world(self) -> np.ndarray:
        """(3,) float64 the centre of its ground contact (its origin but for trunks standing
        off-centre in their asset, like a street lamp's mast), metres."""
        offset = turned(self.contact_offset, self.yaw)
        return np.asarray(self.position_world, dtype=np.float64) + np.array([offset[0], offset[1], 0.0])

    def with_contact_at(self, contact_world: np.ndarray, yaw: float | None = None) -> Placement:
        """This placement moved (turned to ``yaw`` when given) so its contact stands at ``contact_world``.

        Args:
            contact_world: (3,) float64 where its contact's centre goes, metres.
            yaw: its new rotation about Z, radians (None: keep its own).
        """
        yaw = self.yaw if yaw is None else yaw
        p = np.asarray(contact_world, dtype=np.float64).copy()
        p[:2] -= turned(self.contact_offset, yaw)
        return replace(self, position_world=p, yaw=yaw)

    @property
    def depth_method(self) -> str:
        """What decided the depth as written to USD and ``report.json``: ``contact``, ``cnn``,
        ``height`` (the cue holding >= 80 % of the weight), ``fused``, ``contact_partial`` /
        ``height_partial`` / ``top_row`` (cut or hidden objects), ``street_line``,
        ``behind_<occluder>``, with ``+rule1`` / ``+rule2`` when the ordering rules changed it."""
        return depth_method_label(self.method, self.behind, self.rule)


def place_objects(
    objects: list[ImageObject],
    camera: PinholeCamera,
    ground_from_px: np.ndarray,
    axis: RoadAxis,
    asset_sizes: dict[str, AssetSizes],
    classes: ClassTable,
    params: PlacementParams,
    depth_map: DepthMap | None = None,
    sidewalk_lift: bool = True,
    camera_sigma: tuple[float, float] = (0.0, 0.0),
    max_partial_depth_m: float = DEFAULT_SCENE.max_range_m,
    sidewalk_ground: np.ndarray | None = None,
    collision: CollisionParams = DEFAULT_COLLISION,
    perception: PerceptionParams = DEFAULT_PERCEPTION,
) -> tuple[list[Placement], list[str]]:
    """Place every object in the world frame, then resolve footprint collisions.

    Args:
        objects: image objects in canonical order (names follow this order per class).
        camera: the source camera.
        ground_from_px: (3, 3) float64 homography from pixels to ground metres (DLT).
        axis: the road axis, for yaw.
        asset_sizes: asset sizes of every class that occurs.
        classes: the class table (priors and roles).
        params: the placement thresholds.
        depth_map: optional dense metric depth; when given, it adds the ``cnn`` cue and
            the paper's ordering rules repair the depths the map decided alone.
        sidewalk_lift: lift objects standing on the sidewalk to the kerb height.
        camera_sigma: standard deviations of the camera height (m) and pitch (rad),
            which widen the ground-contact cue when the camera was estimated.
        max_partial_depth_m: objects whose depth is only an upper bound (cut or hidden
            bottom) are dropped beyond this depth (the world's range; the default is the meshed ground's).
        sidewalk_ground: (N, 2) float64 ground points of sidewalk pixels, or None; they
            give the rows (:mod:`usdworld.layout.street_lines`) no object measured.
        collision: the footprint collision thresholds.
        perception: the depth cues' error model and fusion.

    Returns:
        Placements in the same order as ``objects`` and the objects that could not be
        placed, each once with its reason (stuff with no visible ground contact and no
        usable height first, then objects piled beyond ``CollisionParams.max_displacement_m``).
        Names are given before skipping, so they stay stable.
    """
    ctx = PlacementContext(
        camera,
        ground_from_px,
        axis,
        asset_sizes,
        classes,
        params,
        depth_map,
        camera_sigma,
        sidewalk_lift,
        collision,
        perception,
    )
    drafts, unplaced = draft_all(objects, ctx)
    drafts = move_behind_occluders(drafts, ctx)
    drafts, unplaced = onto_street_rows(drafts, unplaced, ctx, sidewalk_ground)
    drafts, cut = behind_bordered_things(drafts, ctx)
    unplaced = [*unplaced, *cut]
    drafts, unplaced = drop_unbounded(drafts, unplaced, ctx, max_partial_depth_m)
    drafts, no_depth = place_behind_occluders(drafts, unplaced, ctx)
    drafts = apply_ordering(drafts, ctx)
    drafts = face_the_traffic(drafts, ctx)
    placements, piled, no_room = resolve_footprints(drafts, ctx)
    skipped = (
        [Skipped(n, SkipReason.NO_DEPTH) for n in no_depth]
        + [Skipped(n, SkipReason.PILED) for n in piled]
        + [Skipped(n, SkipReason.NO_ROOM) for n in no_room]
    )
    return placements, skipped


#: Names a warning lists before it only counts the rest (a detector's raw output can pile
#: hundreds of boxes; a warning stays one readable line).
MAX_NAMED = 20


def _named(names: list[str]) -> str:
    """``a, b, c`` or, past :data:`MAX_NAMED`, the first ones and ``and N more``."""
    if len(names) <= MAX_NAMED:
        return ", ".join(names)
    return ", ".join(names[:MAX_NAMED]) + f" and {len(names) - MAX_NAMED} more"


def skip_warnings(skipped: list[Skipped], max_partial_depth_m: float, collision: CollisionParams) -> list[str]:
    """One warning per reason, naming the objects skipped for it (in the order given; past
    :data:`MAX_NAMED` names, how many more).

    Args:
        skipped: what :func:`place_objects` did not place.
        max_partial_depth_m: the range it was given, metres.
        collision: the collision thresholds it was given.
    """
    no_depth = [s.name for s in skipped if s.reason is SkipReason.NO_DEPTH]
    piled = [s.name for s in skipped if s.reason is SkipReason.PILED]
    no_room = [s.name for s in skipped if s.reason is SkipReason.NO_ROOM]
    warnings = []
    if no_depth:
        warnings.append(
            f"not placed (no visible ground contact, only a bound beyond {max_partial_depth_m:g} m, "
            "or smaller there than the smallest of its class): "
            + _named(no_depth)
        )
    if piled:
        warnings.append(
            f"{len(piled)} objects not placed: each would have to move more than {collision.max_displacement_m:g} m, "
            f"or past {collision.max_candidates} candidate spots, to clear the objects already placed "
            "(a pile of contradictory boxes): " + _named(piled)
        )
    if no_room:
        warnings.append(
            f"{len(no_room)} objects not placed: no spot clear of the objects already placed is as near as "
            f"{collision.depth_sigmas:g} sigma of their depth cues allow and no farther than their visible "
            "bottom: " + _named(no_room)
        )
    return warnings


def draft_all(
    objects: list[ImageObject], ctx: PlacementContext
) -> tuple[list[Draft], list[tuple[ImageObject, str]]]:
    """Pass: name every object (``<class>_<NNNN>`` in input order) and draft it.

    Returns:
        (the drafts, the objects and names nothing placed), both in input order.
    """
    counters: dict[str, int] = {}
    drafts: list[Draft] = []
    unplaced: list[tuple[ImageObject, str]] = []
    for obj in objects:
        counters[obj.class_name] = counters.get(obj.class_name, 0) + 1
        name = f"{obj.class_name}_{counters[obj.class_name]:04d}"
        draft = draft_object(obj, name, ctx)
        if draft is None:
            unplaced.append((obj, name))
        else:
            drafts.append(draft)
    return drafts, unplaced


def apply_ordering(drafts: list[Draft], ctx: PlacementContext) -> list[Draft]:
    """Pass: with a depth map, the paper's ordering rules (:mod:`usdworld.layout.ordering`)
    change the depths the map decided (:attr:`DepthMethod.is_ordered`); a depth decided by
    the ground contact or the height prior already obeys the ground lines and is kept."""
    if ctx.depth_map is None or not drafts:
        return drafts
    result = apply_ordering_rules(
        np.array([d.obj.contact_px[1] for d in drafts]),
        np.array([d.depth_m for d in drafts]),
        np.array([d.obj.box_px for d in drafts], dtype=np.float64),
        delta_m=ctx.params.ordering_delta_m,
        similar_rows_px=ctx.params.ordering_similar_rows_px,
    )
    out = []
    for d, depth, rule in zip(drafts, result.depth_m, result.rule):
        if rule and d.method.is_ordered:
            ground = point_at_depth(ctx.camera, *d.obj.contact_px, float(depth))
            d = replace(d, depth_m=float(depth), rule=str(rule), ground=ground)
        out.append(d)
    return out


def admissible_region(drafts: list[Draft], ctx: PlacementContext) -> Admissible:
    """How near and how far each draft's centre may be moved: no nearer than
    ``CollisionParams.depth_sigmas`` times its fused cues' sigma before its drafted depth
    (its drafted depth when no cue has a sigma), and no farther than the bound a hidden or
    cut bottom's visible contact gives (``Draft.upper_m``; none otherwise: farther along its
    rays an object hides nothing that the photo shows in front of it).

    Args:
        drafts: the drafts, in the order given to the collision resolution.
        ctx: the camera and the collision parameters.
    """
    camera = ctx.camera
    ground = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    z = camera.cam_from_world_points(ground)[:, 2]
    depths = np.empty((len(drafts), 2))
    k = ctx.collision.depth_sigmas
    for n, d in enumerate(drafts):
        weights = [1.0 / c.sigma_m**2 for c in d.cues if c.available and c.sigma_m is not None]
        sigma = 1.0 / np.sqrt(sum(weights)) if weights else 0.0
        depths[n] = (d.depth_m - k * sigma, max(d.upper_m + d.back_m, d.depth_m))
    eye = np.asarray(camera.center_world[:2], dtype=np.float64)
    return Admissible(eye, np.array([z[1] - z[0], z[2] - z[0]]), float(z[0]), depths)


def resolve_footprints(
    drafts: list[Draft], ctx: PlacementContext
) -> tuple[list[Placement], list[str], list[str]]:
    """Pass: resolve footprint collisions and make the placements.

    Things (vehicles, people) settle first: they are the photo's sharpest evidence, and a
    stuff region (a hedge, a facade chunk) should make way for them, not push them. Among
    each kind, the nearer and more confident settle first. An object is moved no nearer
    and no farther than the photo allows (:func:`admissible_region`). An object with no free spot within
    ``CollisionParams.max_displacement_m`` (a pile of contradictory boxes), or with none
    the photo allows, is not placed (:func:`skip_warnings` says how many and why).

    Returns:
        The placements, in draft order, the names of the objects piled and of those
        with no allowed spot.
    """
    if not drafts:
        return [], [], []
    params = ctx.params
    centers = np.array([d.ground for d in drafts])
    half = footprint_half_extents(np.array([d.footprint for d in drafts]), np.array([d.yaw for d in drafts]))
    priority = np.array(
        [
            d.depth_m / max(d.confidence, params.priority_confidence_floor)
            + (0.0 if d.obj.is_thing else params.stuff_priority_offset)
            for d in drafts
        ]
    )
    resolved = resolve_collisions(
        centers, half, priority, params=ctx.collision, admissible=admissible_region(drafts, ctx)
    )
    contradicted = resolved.contradicted if resolved.contradicted is not None else np.zeros(len(drafts), bool)
    no_room = [d.name for d, ok, c in zip(drafts, resolved.placed, contradicted) if not ok and c]
    piled = [d.name for d, ok, c in zip(drafts, resolved.placed, contradicted) if not ok and not c]
    placements = []
    for d, disp, center, ok in zip(drafts, resolved.displacement, resolved.centers, resolved.placed):
        depth = depth_of_ground_point(ctx.camera, center) if np.any(disp) else d.depth_m
        if not ok or not depth > 0:  # pushed behind the camera to clear the others: as good as piled
            if ok:
                piled.append(d.name)
            continue
        obj = d.obj
        z = params.curb_height_m if (ctx.sidewalk_lift and obj.standing_on == "sidewalk") else 0.0
        placements.append(
            Placement(
                name=d.name,
                obj=obj,
                variant=d.variant,
                position_world=np.array([*d.origin(center, d.yaw), z]),
                yaw=d.yaw,
                yaw_source=d.yaw_source,
                yaw_confidence=d.yaw_confidence,
                scale=d.scale,
                stretch=d.stretch,
                scale_measured=d.scale_measured,
                size_m=d.size,
                depth_m=depth,
                method=d.method,
                cues=d.cues,
                collision_displacement=disp,
                confidence=d.confidence,
                behind=d.behind,
                rule=d.rule,
                contact_offset=d.contact_offset,
            )
        )
    return placements, piled, no_room
