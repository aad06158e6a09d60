"""Metric placement of image objects: depth cues, position, scale, variant and yaw.

Depth (step 1 of the paper, made robust): every cue to the depth of the object's front
is computed (the ground contact through the DLT homography ``ground_from_px``, the
class-height prior, and a dense depth map's robust mean when one is given) and fused
by inverse-variance weighting (:mod:`usdworld.perception.depth.fusion`); the contact
cue is widened by the camera's own uncertainty when the camera was estimated. With a
depth map, the paper's ordering rules then repair the depths the map decided alone
(objects with no ground contact or height cue); depths carried by the contact already
follow the ground lines the rules assume, and applying the rules to them was measured to
make them worse (tools/eval_depth_fusion.py).

Position (step 2): the object is placed on the viewing ray of its contact pixel, moved
back by the footprint's extent beyond its nearest contact along the camera's heading (a
ground point's image row depends only on how far ahead it is), so that the object's
centre, not its front face, is placed; things are then shifted sideways until their
projected box spans the image box's columns. Every cue in the provenance is given at
the centre too.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from usdworld.errors import LayoutError
from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.homography import apply_homography
from usdworld.io.asset_catalogue import AssetSizes  # the input placement receives, defined with the catalogue
from usdworld.io.types import DepthMap
from usdworld.layout.boxes import align_box_columns, box_aspect_usable, fit_view_angle
from usdworld.layout.collision import footprint_half_extents, resolve_collisions
from usdworld.layout.ordering import apply_ordering_rules
from usdworld.layout.priors import ClassPrior, prior_for
from usdworld.layout.silhouette import (
    depth_from_silhouette,
    depth_from_top_row,
    height_from_top_row,
    top_offsets,
)
from usdworld.layout.street_lines import (
    LINE_CLASSES,
    StreetLine,
    fit_street_lines,
    lateral_offsets,
    line_for,
    lone_rows_agreeing,
    parked_car_lines,
    sidewalk_lines,
    unmeasured,
)
from usdworld.layout.yaw import RoadAxis, choose_yaw, yaw_from_view_angle
from usdworld.perception.depth.fusion import HEIGHT_MEAN_REL_SIGMA, DepthCue, fuse, object_depth_cues
from usdworld.perception.objects import CROWN_CLASSES, TRUNK_CLASSES, ImageObject
from usdworld.perception.shape import top_shape_ratio

#: Why a facade whose base is seen has no height cue.
FACADE_HEIGHT_NOTE = "not used: a facade's base is seen"
#: Depth methods the paper's ordering rules may change (those decided by the dense map).
ORDERED_METHODS = ("cnn", "contact_partial", "height_partial", "top_row")
#: Depth methods of objects whose bottom is cut or hidden (an upper bound, or the weak
#: top-row estimate): never a lower bound for others, dropped beyond the world's range.
PARTIAL_METHODS = ("contact_partial", "height_partial", "top_row")
#: Added to a stuff object's collision priority so that every thing settles before it.
STUFF_PRIORITY_OFFSET = 1e6
#: Height of the kerb: objects standing on the sidewalk are lifted by this much.
CURB_HEIGHT_M = 0.15


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
        depth_method: ``contact``, ``cnn``, ``height`` (the cue holding >= 80 % of the
            weight), ``fused``, ``contact_partial`` / ``height_partial`` / ``top_row`` (cut or hidden
            objects), with ``+rule1`` / ``+rule2`` when the ordering rules changed it.
        cues: every depth cue computed, as centre depths (unavailable ones have None).
        collision_displacement: (2,) float64 displacement applied by collision resolution.
        confidence: in [0, 1].
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
    depth_method: str
    cues: tuple[DepthCue, ...]
    collision_displacement: np.ndarray = field(default_factory=lambda: np.zeros(2))
    confidence: float = 0.0


def _forward_half_extent(size_lw: np.ndarray, yaw: float, direction: float) -> float:
    """Distance from a footprint's centre to its nearest corner, measured along a direction (yaw, radians)."""
    rel = yaw - direction
    return float(0.5 * (size_lw[0] * abs(np.cos(rel)) + size_lw[1] * abs(np.sin(rel))))


def _wall_positions(
    camera: PinholeCamera, v: float, front_ground: np.ndarray, yaw: float, columns: tuple[float, ...]
) -> list[float] | None:
    """Where image columns meet a facade, metres along it from ``front_ground`` (None when
    a column's trace runs parallel to it).

    The facade is the vertical wall through ``front_ground`` whose front faces ``yaw``; each
    image column sees the ground along a line (its vertical plane's trace, taken at row ``v``),
    which crosses the wall's foot at one point.
    """
    along = np.array([-np.sin(yaw), np.cos(yaw)])
    out = []
    for u in columns:
        trace, _ = camera.ground_points(np.array([[u, v], [u, v + 20.0]]))
        d = trace[1] - trace[0]
        # front_ground + t * along = trace[0] + r * d
        m = np.column_stack([along, -d])
        if not np.all(np.isfinite(m)) or abs(np.linalg.det(m)) < 1e-9:
            return None
        t, _ = np.linalg.solve(m, trace[0] - front_ground)
        out.append(float(t))
    return out


def _facade_frontage(camera: PinholeCamera, obj: ImageObject, front_ground: np.ndarray, yaw: float) -> float:
    """Metres of facade between an object's first and last columns (NaN when not measurable)."""
    ends = _wall_positions(
        camera, float(obj.contact_px[1]), front_ground, yaw, (obj.box_px[0], obj.box_px[2])
    )
    return float("nan") if ends is None else abs(ends[1] - ends[0])


def out_of_view_frontage(seen_m: float, frontage_range_m: tuple[float, float]) -> float:
    """The frontage to expect of a building that runs out of the image at one side, of
    which ``seen_m`` metres are in view.

    A long building is more likely than a short one to cover the column where the image
    ends (in proportion to its frontage), and its seen end lies anywhere along it (with
    density one over its frontage): the two cancel, so of the usual frontages
    (``frontage_range_m``, taken as uniform) every one at least ``seen_m`` long is equally
    likely. The middle of those; ``seen_m`` itself when it is longer than the usual ones.
    NaN stays NaN.

    Example:
        >>> out_of_view_frontage(5.0, (8.0, 25.0)), out_of_view_frontage(15.0, (8.0, 25.0))
        (16.5, 20.0)
        >>> out_of_view_frontage(30.0, (8.0, 25.0))
        30.0
    """
    lo, hi = frontage_range_m
    if not np.isfinite(seen_m) or seen_m >= hi:
        return float(seen_m)
    return 0.5 * (max(seen_m, lo) + hi)


def _past_the_side(
    camera: PinholeCamera, obj: ImageObject, front_ground: np.ndarray, yaw: float, frontage: float
) -> float:
    """How far along its wall (metres) a facade cut by one side of the image moves so that
    its seen end stays put and the rest of its frontage runs on out of view (0 when
    neither or both sides are cut, or when what is seen is longer than ``frontage``).

    The seen part of such a facade is its far end: the building goes on beyond the edge,
    by as much as a building of its size needs.
    """
    x0, x1 = float(obj.box_px[0]), float(obj.box_px[2])
    cut_left, cut_right = x0 <= 0, x1 >= camera.width
    if cut_left == cut_right:
        return 0.0
    ends = _wall_positions(camera, float(obj.contact_px[1]), front_ground, yaw, (x0, x1))
    if ends is None:
        return 0.0
    seen_end, cut_end = (ends[1], ends[0]) if cut_left else (ends[0], ends[1])
    seen = abs(cut_end - seen_end)
    if seen >= frontage:
        return 0.0
    return float(seen_end + np.sign(cut_end - seen_end) * 0.5 * frontage)


def _depth_of_ground_point(camera: PinholeCamera, p_ground: np.ndarray) -> float:
    return float(camera.cam_from_world_points(np.array([[p_ground[0], p_ground[1], 0.0]]))[0, 2])


def _choose_variant(
    sizes: AssetSizes, measured_h: float, aspect: float, yaw_to_ray: float, top_shape: float | None = None
) -> str:
    """The variant whose height, silhouette aspect and top shape best match the image.

    Args:
        sizes: the class's variants.
        measured_h: metric height seen in the image (NaN when cut).
        aspect: the mask's width / height in pixels (NaN when cut).
        yaw_to_ray: object yaw minus the viewing ray's bearing, radians.
        top_shape: the mask's :func:`usdworld.perception.shape.top_shape_ratio` (None when
            not usable); compared with the variants' side views.
    """
    shape_usable = top_shape is not None and len(sizes.top_shape_by_variant) == len(sizes.by_variant)
    if len(sizes.by_variant) < 2 or not (np.isfinite(measured_h) or np.isfinite(aspect) or shape_usable):
        return sizes.default_variant
    names = sorted(sizes.by_variant)
    errs = []
    for n in names:
        l, w, h = sizes.by_variant[n]
        err = abs(np.log(measured_h / h)) if np.isfinite(measured_h) else 0.0
        if np.isfinite(aspect) and aspect > 0:
            across = abs(l * np.sin(yaw_to_ray)) + abs(w * np.cos(yaw_to_ray))
            err += abs(np.log(aspect / (across / h)))
        if shape_usable:
            # Offset so that near-zero ratios (round tops) compare on a sane scale.
            err += abs(
                np.log((top_shape + TOP_SHAPE_OFFSET) / (sizes.top_shape_by_variant[n] + TOP_SHAPE_OFFSET))
            )
        errs.append(err)
    return names[int(np.argmin(errs))]


#: Added to top-shape ratios before comparing them in log space.
TOP_SHAPE_OFFSET = 0.1


def _point_at_depth(camera: PinholeCamera, u: float, v: float, depth: float) -> np.ndarray:
    """Ground point below the point at ``depth`` on the ray of pixel (u, v); (2,) float64."""
    ray = camera.rays_world(np.array([[u, v]]))[0]
    p = camera.center_world + ray * depth
    return p[:2]


def place_objects(
    objects: list[ImageObject],
    camera: PinholeCamera,
    ground_from_px: np.ndarray,
    axis: RoadAxis,
    asset_sizes: dict[str, AssetSizes],
    depth_map: DepthMap | None = None,
    sidewalk_lift: bool = True,
    camera_sigma: tuple[float, float] = (0.0, 0.0),
    max_partial_depth_m: float = 80.0,
    sidewalk_ground: np.ndarray | None = None,
) -> tuple[list[Placement], list[str]]:
    """Place every object in the world frame, then resolve footprint collisions.

    Args:
        objects: image objects in canonical order (names follow this order per class).
        camera: the source camera.
        ground_from_px: (3, 3) float64 homography from pixels to ground metres (DLT).
        axis: the road axis, for yaw.
        asset_sizes: asset sizes of every class that occurs.
        depth_map: optional dense metric depth; when given, it adds the ``cnn`` cue and
            the paper's ordering rules repair the depths the map decided alone.
        sidewalk_lift: lift objects standing on the sidewalk to the kerb height.
        camera_sigma: standard deviations of the camera height (m) and pitch (rad),
            which widen the ground-contact cue when the camera was estimated.
        max_partial_depth_m: objects whose depth is only an upper bound (cut or hidden
            bottom) are dropped beyond this depth.
        sidewalk_ground: (N, 2) float64 ground points of sidewalk pixels, or None; they
            give the rows (:mod:`usdworld.layout.street_lines`) no object measured.

    Returns:
        Placements in the same order as ``objects`` and the names of objects that
        could not be placed (stuff with no visible ground contact and no usable height).
        Names are given before skipping, so they stay stable.
    """

    def draft_of(obj: ImageObject, name: str, forced: tuple[float, str] | None = None) -> dict | None:
        prior, sizes = prior_for(obj.class_name), asset_sizes[obj.class_name]
        return _draft(
            obj,
            name,
            prior,
            sizes,
            camera,
            ground_from_px,
            axis,
            depth_map,
            camera_sigma,
            forced,
            sidewalk_lift,
        )

    counters: dict[str, int] = {}
    drafts = []
    unplaced: list[tuple[ImageObject, str]] = []
    for obj in objects:
        counters[obj.class_name] = counters.get(obj.class_name, 0) + 1
        name = f"{obj.class_name}_{counters[obj.class_name]:04d}"
        draft = draft_of(obj, name)
        if draft is None:
            unplaced.append((obj, name))
        else:
            drafts.append(draft)

    _move_behind_occluders(drafts, camera)
    # Rows along the street (building lines, tree and lamp rows) place the members whose
    # own contact is hidden or cut where their ray meets the row.
    walk = sidewalk_lines(sidewalk_ground, axis)
    lines = lone_rows_agreeing(_street_lines(drafts, camera, axis), walk)
    lines += unmeasured(walk, lines)
    lines += _parked_car_lines(drafts, axis, camera, lines)
    if lines:
        by_ref = {d["obj"].ref: d for d in drafts if d["obj"].ref >= 0}
        for k, d in enumerate(drafts):
            if d["depth_method"] in PARTIAL_METHODS or d["depth_method"].startswith("behind_"):
                moved = _onto_street_line(d["obj"], d["name"], d, by_ref, lines, camera, axis, draft_of)
                if moved is not None:
                    drafts[k] = moved
            elif _off_its_row(d, lines, camera, axis):
                # Its "contact" is ground seen under its crown or arm, behind its hidden foot:
                # an upper bound, and the row it belongs to is nearer.
                bounded = {**d, "upper_m": d["front_depth_m"]}
                moved = _onto_street_line(d["obj"], d["name"], bounded, by_ref, lines, camera, axis, draft_of)
                if moved is not None:
                    drafts[k] = moved
        remaining = []
        for obj, name in unplaced:
            moved = _onto_street_line(obj, name, None, by_ref, lines, camera, axis, draft_of)
            if moved is None:
                remaining.append((obj, name))
            else:
                drafts.append(moved)
        unplaced = remaining
    # A depth known only as an upper bound (a cut or hidden bottom) that lies beyond the
    # world's range says nothing useful, nor does "just behind" a near occluder for a
    # sliver of stuff too small to be the whole object there: neither is placed.
    far = [
        d
        for d in drafts
        if (d["depth_method"] in PARTIAL_METHODS and d["depth_m"] > max_partial_depth_m)
        or _sliver_behind(d, camera)
    ]
    drafts = [d for d in drafts if not any(d is f for f in far)]
    unplaced.extend((d["obj"], d["name"]) for d in far)
    # Objects with no cue at all but a placed occluder go right behind it.
    by_ref = {d["obj"].ref: d for d in drafts if d["obj"].ref >= 0}
    skipped: list[str] = []
    for obj, name in unplaced:
        occ = _occluder(by_ref, obj) if obj.class_name not in NOT_BOUNDING_OCCLUDERS else None
        if occ is None:
            skipped.append(name)
            continue
        behind = occ["depth_m"] + occ["back_m"] + BEHIND_GAP_M
        forced = draft_of(obj, name, (behind, f"behind_{occ['name']}"))
        if forced is None or _sliver_behind(forced, camera):
            skipped.append(name)
        else:
            drafts.append(forced)

    if depth_map is not None and drafts:
        result = apply_ordering_rules(
            np.array([d["obj"].contact_px[1] for d in drafts]),
            np.array([d["depth_m"] for d in drafts]),
            np.array([d["obj"].box_px for d in drafts], dtype=np.float64),
        )
        for d, depth, rule in zip(drafts, result.depth_m, result.rule):
            # The rules repair what a depth map gets wrong; a depth decided by the ground
            # contact or the height prior already obeys the ground lines and is kept.
            if rule and d["depth_method"] in ORDERED_METHODS:
                d["depth_m"] = float(depth)
                d["depth_method"] += "+" + rule
                d["ground"] = _point_at_depth(camera, *d["obj"].contact_px, float(depth))

    placements: list[Placement] = []
    if not drafts:
        return placements, skipped
    centers = np.array([d["ground"] for d in drafts])
    half = footprint_half_extents(
        np.array([d["footprint"] for d in drafts]), np.array([d["yaw"] for d in drafts])
    )
    # Things (vehicles, people) settle first: they are the photo's sharpest evidence, and a
    # stuff region (a hedge, a facade chunk) should make way for them, not push them.
    priority = np.array(
        [
            d["depth_m"] / max(d["confidence"], 1e-3) + (0.0 if d["obj"].is_thing else STUFF_PRIORITY_OFFSET)
            for d in drafts
        ]
    )
    resolved = resolve_collisions(centers, half, priority)
    for d, disp, center in zip(drafts, resolved.displacement, resolved.centers):
        obj = d["obj"]
        z = CURB_HEIGHT_M if (sidewalk_lift and obj.standing_on == "sidewalk") else 0.0
        placements.append(
            Placement(
                name=d["name"],
                obj=obj,
                variant=d["variant"],
                position_world=np.array([center[0], center[1], z]),
                yaw=d["yaw"],
                yaw_source=d["yaw_source"],
                scale=d["scale"],
                stretch=d["stretch"],
                scale_measured=d["scale_measured"],
                size_m=d["size"],
                depth_m=_depth_of_ground_point(camera, center) if np.any(disp) else d["depth_m"],
                depth_method=d["depth_method"],
                cues=d["cues"],
                collision_displacement=disp,
                confidence=d["confidence"],
            )
        )
    return placements, skipped


#: Gap left between an occluded object and the object hiding it, metres.
BEHIND_GAP_M = 0.3
#: Depth methods of a seen ground contact: the objects that measure a street line.
SEEN_CONTACT_METHODS = ("contact", "fused")
#: A street line's depth may exceed an object's own upper bound (its visible bottom's
#: ground point) by this fraction plus :data:`LINE_BOUND_SLACK_M`, and fall short of its
#: occluder's front by the slack, before the two are taken to disagree.
LINE_BOUND_SLACK = 0.1
LINE_BOUND_SLACK_M = 1.0


def _street_lines(drafts: list[dict], camera: PinholeCamera, axis: RoadAxis) -> list[StreetLine]:
    """Rows formed by the objects whose ground contact was seen (front points on the ground)."""
    seen = [
        d
        for d in drafts
        if d["obj"].class_name in LINE_CLASSES
        and d["depth_method"] in SEEN_CONTACT_METHODS
        and not (d["obj"].bottom_truncated or d["obj"].bottom_occluded)
    ]
    if not seen:
        return []
    fronts = np.array([_point_at_depth(camera, *d["obj"].contact_px, d["front_depth_m"]) for d in seen])
    return fit_street_lines([d["obj"].class_name for d in seen], fronts, axis)


def _parked_car_lines(
    drafts: list[dict], axis: RoadAxis, camera: PinholeCamera, lines: list[StreetLine]
) -> list[StreetLine]:
    """Kerb rows from the cars placed by their seen contact (:func:`parked_car_lines`)."""
    cars = [d for d in drafts if d["obj"].class_name == "car" and d["depth_method"] in SEEN_CONTACT_METHODS]
    return parked_car_lines(
        np.array([d["ground"][:2] for d in cars], dtype=np.float64).reshape(-1, 2),
        np.array([d["yaw"] for d in cars], dtype=np.float64),
        np.array([d["size"][1] for d in cars], dtype=np.float64),
        axis,
        camera.center_world[:2],
        lines,
    )


#: A tree or pole whose seen contact lies further than this (metres) across the street
#: from the row its class forms on that side is taken to stand in the row: twice the
#: spread a row's members may have (``street_lines.MAX_SPREAD_M``).
ROW_OUTLIER_M = 1.5
#: Classes found on their row below their contact's column, not their box's middle.
POST_CONTACT_CLASSES = frozenset({"pole"})


def _off_its_row(d: dict, lines: list[StreetLine], camera: PinholeCamera, axis: RoadAxis) -> bool:
    """True for a tree or pole placed by a seen contact that lies off its class's row on its
    side of the street by more than :data:`ROW_OUTLIER_M`, beyond the row (the contact
    is then ground seen past a crown's hem or a lamp's arm, not the foot)."""
    obj = d["obj"]
    if obj.class_name not in TRUNK_CLASSES or d["depth_method"] not in SEEN_CONTACT_METHODS:
        return False
    front = _point_at_depth(camera, *obj.contact_px, d["front_depth_m"])[:2]
    offset = float(lateral_offsets(front[None, :], axis)[0])
    rows = [ln for ln in lines if ln.class_name == obj.class_name and ln.side == np.sign(offset)]
    return any(abs(offset) - abs(ln.offset_m) > ROW_OUTLIER_M for ln in rows)


def _line_pixel(obj: ImageObject, width: int) -> np.ndarray:
    """Pixel whose ray finds an object on its row: a trunk or post stands below the middle
    of its crown or sign when its own foot is hidden (unless the image's side cuts it); a
    facade, and a pole (its lowest columns are its post, not the lamp's arm beside it),
    keep their contact pixel."""
    u, v = (float(x) for x in obj.contact_px)
    middle = prior_for(obj.class_name).yaw != "face_road" and obj.class_name not in POST_CONTACT_CLASSES
    if middle and obj.box_px[0] > 0 and obj.box_px[2] < width:
        u = 0.5 * float(obj.box_px[0] + obj.box_px[2])
    return np.array([u, v])


def _row_over_tree(obj: ImageObject, occ: dict) -> bool:
    """True for a facade whose base a street tree hides: the facades' row, measured by many
    points, is trusted over that one tree's depth (street trees stand in front of the
    facades, so a row that puts the facade in front of the tree means the tree is placed
    too far: its contact was ground seen past its crown)."""
    return prior_for(obj.class_name).yaw == "face_road" and occ["obj"].class_name in CROWN_CLASSES


def _onto_street_line(
    obj: ImageObject,
    name: str,
    draft: dict | None,
    by_ref: dict[int, dict],
    lines: list[StreetLine],
    camera: PinholeCamera,
    axis: RoadAxis,
    draft_of: Callable[[ImageObject, str, tuple[float, str]], dict | None],
) -> dict | None:
    """The draft of an object whose contact is hidden or cut, placed on its class's row.

    The row's depth must agree with what the object's own evidence bounds: no nearer than
    the front of the object hiding its bottom (unless that one's depth is itself only a
    bound from above, or it is a street tree in front of a facade: :func:`_row_over_tree`),
    no farther than its visible bottom's ground point (:data:`LINE_BOUND_SLACK`). None
    when there is no such row or they disagree.
    """
    if obj.class_name not in LINE_CLASSES:
        return None
    pixel = _line_pixel(obj, camera.width)
    hit = line_for(lines, obj.class_name, camera, (float(pixel[0]), float(pixel[1])), axis)
    if hit is None:
        return None
    line, front = hit
    upper = draft["upper_m"] if draft is not None else float("inf")
    if front > upper * (1.0 + LINE_BOUND_SLACK) + LINE_BOUND_SLACK_M:
        return None
    occ = _bounding_occluder(by_ref, obj)
    in_front_of_occluder = occ is not None and front < occ["depth_m"] - occ["back_m"] - LINE_BOUND_SLACK_M
    if in_front_of_occluder and not _row_over_tree(obj, occ):
        return None
    moved = draft_of(replace(obj, contact_px=pixel), name, (front, "street_line"))
    if moved is None:
        return None
    # How far off the row's depth may be: its spread across the street, seen at the
    # ray's angle to the row (a ray nearly along the row magnifies it).
    lateral = abs(float(line.offset_m)) + 1.0
    sigma = max(line.spread_m, 0.25) * max(front / lateral, 1.0)
    side = "left" if line.side > 0 else "right"
    what = {
        "objects": f"row of {line.support} {obj.class_name}s",
        "sidewalk": f"{obj.class_name} row from the sidewalk",
        "parked_cars": f"{obj.class_name} row behind the kerb the parked cars line",
    }[line.source]
    cue = DepthCue(
        "street_line",
        front + moved["back_m"],
        sigma,
        f"{what} {abs(line.offset_m):.2f} m {side} of the road axis (spread {line.spread_m:.2f} m)",
    )
    moved["cues"] = (*moved["cues"], cue)
    return moved


#: Classes never used as an occluder's lower bound (a facade's bottom edge hides ground
#: and things far behind it, so "just behind the building" says little), and never
#: placed by that bound alone (a sliver of facade seen past a tree could be anywhere).
NOT_BOUNDING_OCCLUDERS = ("building",)


def _occluder(by_ref: dict[int, dict], obj: ImageObject) -> dict | None:
    """The placed draft of the object hiding ``obj``'s bottom, when it can bound its depth."""
    occ = by_ref.get(obj.occluded_by) if obj.occluded_by >= 0 else None
    if occ is None or occ["obj"].class_name in NOT_BOUNDING_OCCLUDERS:
        return None
    return occ


def _bounding_occluder(by_ref: dict[int, dict], obj: ImageObject) -> dict | None:
    """:func:`_occluder`, when its own depth can bound ``obj``'s from below: not when that
    depth is itself only a bound from above (its bottom hidden or cut, :data:`PARTIAL_METHODS`)."""
    occ = _occluder(by_ref, obj)
    return None if occ is None or occ["depth_method"] in PARTIAL_METHODS else occ


def _sliver_behind(draft: dict, camera: PinholeCamera) -> bool:
    """True for stuff placed just behind its occluder whose visible part, at that depth, is
    smaller in both width and height than the smallest allowed scale of its class: a
    piece of a far tree or pole seen past a near car, which the occluder does not bound."""
    obj = draft["obj"]
    if obj.is_thing or not draft["depth_method"].startswith("behind_"):
        return False
    base = draft["size"] / (draft["scale"] * draft["stretch"])
    metres_per_px = draft["front_depth_m"] / camera.fy
    seen = max(obj.width_px * metres_per_px / base[1], obj.height_px * metres_per_px / base[2])
    return seen < prior_for(obj.class_name).scale_range[0]


def _move_behind_occluders(drafts: list[dict], camera: PinholeCamera) -> None:
    """Use the object hiding an object's bottom as a lower bound of its depth.

    A hidden bottom leaves upper bounds, the visible bottom's ground point
    (``contact_partial``, usually close) or the cut height (``height_partial``, poor),
    and perhaps the top-row estimate (``top_row``). The occluder's depth bounds it from
    below. A contact bound or top-row estimate short of the occluder moves the object
    just behind it; a height-only bound is replaced by that position.
    """
    by_ref = {d["obj"].ref: d for d in drafts if d["obj"].ref >= 0}
    for d in drafts:
        occ = _bounding_occluder(by_ref, d["obj"])
        method = d["depth_method"]
        if occ is None or method not in PARTIAL_METHODS:
            continue
        behind = occ["depth_m"] + occ["back_m"] + BEHIND_GAP_M
        if method in ("contact_partial", "top_row") and d["front_depth_m"] >= behind:
            continue
        d["front_depth_m"] = behind
        d["depth_m"] = behind + d["back_m"]
        d["depth_method"] = f"behind_{occ['name']}"
        d["confidence"] = _CONFIDENCE["behind"] * float(d["obj"].score)
        d["ground"] = _point_at_depth(camera, *d["obj"].contact_px, d["depth_m"])


def _draft(  # noqa: PLR0913
    obj: ImageObject,
    name: str,
    prior: ClassPrior,
    sizes: AssetSizes,
    camera: PinholeCamera,
    ground_from_px: np.ndarray,
    axis: RoadAxis,
    depth_map: DepthMap | None,
    camera_sigma: tuple[float, float],
    forced: tuple[float, str] | None = None,
    sidewalk_lift: bool = True,
) -> dict | None:
    """Everything about one object before ordering rules and collisions; None when it cannot be placed.

    ``forced`` gives the front depth and its method when the caller knows better (an
    object whose only clue is the object hiding it).
    """
    u, v = (float(x) for x in obj.contact_px)
    contact_ground = apply_homography(ground_from_px, np.array([[u, v]]))[0]
    contact_ok = (
        bool(np.all(np.isfinite(contact_ground))) and _depth_of_ground_point(camera, contact_ground) > 0
    )
    front_contact = _depth_of_ground_point(camera, contact_ground) if contact_ok else float("nan")
    if contact_ok and sidewalk_lift and obj.standing_on == "sidewalk":
        # The homography maps to the road plane z = 0; the contact lies on the kerb top,
        # which the viewing ray meets (h - kerb) / h of the way to the road plane.
        front_contact *= (camera.height_m - CURB_HEIGHT_M) / camera.height_m
    bottom_seen = not (obj.bottom_truncated or obj.bottom_occluded)
    whole = bottom_seen and not obj.top_truncated
    height_depth = None
    if whole and obj.height_px > 0:
        # The silhouette's height, with the object's own depth extent (its roof's far
        # edge is its top row when the roof is below the camera); yaw guessed at the
        # contact point, default variant at unit scale.
        guess = contact_ground if contact_ok else _point_at_depth(camera, u, v, 10.0)
        rel_yaw = _object_yaw(prior, guess, axis, obj, camera)[0] - float(np.arctan2(guess[1], guess[0]))
        dv = sizes.default_variant
        offsets = top_offsets(sizes.contact_half(dv), sizes.top_half(dv), sizes.footprint(dv), rel_yaw, obj.box_only)
        height_depth = depth_from_silhouette(camera, (u, v), obj.height_px, prior.size_m[2], offsets)

    # Cues for the depth of the object's front (its contact row / visible surface).
    cues = object_depth_cues(
        obj.mask,
        np.zeros_like(obj.mask),
        front_contact if (contact_ok and bottom_seen) else None,
        _crop_depth(depth_map, obj) if depth_map is not None else None,
        prior.size_m[2],
        obj.height_px if whole and obj.height_px > 0 else None,
        camera.fy,
        camera_height_m=camera.height_m,
        class_height_std_m=prior.height_std_m,
        height_depth_m=height_depth,
        # A given camera height is independent of the class heights; an estimated one
        # was fitted to them, so the contact cue already carries their mean's error.
        class_mean_rel_sigma=HEIGHT_MEAN_REL_SIGMA if camera_sigma[0] == 0.0 else 0.0,
    )
    cues = [_with_camera_uncertainty(c, camera, camera_sigma) for c in cues]
    if prior.yaw == "face_road" and any(c.name == "contact" and c.available for c in cues):
        # Buildings are 3 to 30 m tall: where a facade's base is seen, its height only
        # drags a far one nearer (a tall building looks like a near one of usual height).
        cues = [DepthCue("height", None, None, FACADE_HEIGHT_NOTE) if c.name == "height" else c for c in cues]
    if forced is not None:
        front, method = forced
        confidence = _CONFIDENCE["street_line" if method == "street_line" else "behind"]
    else:
        try:
            fused = fuse(cues)
            front, method, confidence = fused.depth_m, fused.method, _CONFIDENCE.get(fused.method, 0.8)
        except LayoutError:
            front, method, confidence = _partial_front_depth(obj, prior, camera, contact_ok, front_contact)
    if not np.isfinite(front):
        return None

    # Yaw at the front point; variant and scale from the visible height and aspect there.
    front_ground = _point_at_depth(camera, u, v, front)
    yaw, _ = _object_yaw(prior, front_ground, axis, obj, camera)
    bearing = float(np.arctan2(front_ground[1], front_ground[0]))
    measured_h = float(obj.height_px * front / camera.fy) if whole else float("nan")
    if method == "street_line" and not obj.top_truncated:
        # Its row gives the depth of an object whose bottom is hidden: its top row there
        # gives its height above the ground.
        x0, y0, x1, _ = (float(b) for b in obj.box_px)
        measured_h = height_from_top_row(camera, 0.5 * (x0 + x1), y0 if obj.box_only else y0 - 0.5, front)
    sides_cut = obj.box_px[0] <= 0 or obj.box_px[2] >= camera.width
    # The silhouette's aspect tells stuff variants apart (a conifer from a broad tree); for
    # vehicles and people perspective dominates it, so only their height counts.
    use_aspect = whole and not sides_cut and not obj.is_thing and obj.height_px > 0
    aspect = obj.width_px / obj.height_px if use_aspect else float("nan")
    # Objects that look the same from every side (trees, poles) show their variant in the
    # shape of their top, even when their bottom is hidden.
    shape_seen = prior.yaw == "none" and not obj.box_only and not obj.top_truncated and not sides_cut
    variant = _choose_variant(
        sizes, measured_h, aspect, yaw - bearing, top_shape_ratio(obj.mask) if shape_seen else None
    )
    base = np.array(sizes.by_variant[variant], dtype=np.float64)
    scale_measured = float(measured_h / base[2]) if np.isfinite(measured_h) else float("nan")
    one_side_cut = (obj.box_px[0] <= 0) != (obj.box_px[2] >= camera.width)
    frontage = float("nan")
    if prior.yaw == "face_road" and bottom_seen:
        frontage = _facade_frontage(camera, obj, front_ground, yaw)
        if one_side_cut and prior.frontage_range_m is not None:
            frontage = out_of_view_frontage(frontage, prior.frontage_range_m)
    if not np.isfinite(scale_measured) and np.isfinite(frontage):
        # A facade cut by the image's top: its frontage sizes it, never below the height
        # in view (a lower bound on its height).
        seen_h = float(obj.height_px * front / camera.fy) / base[2] if obj.height_px > 0 else 0.0
        scale_measured = max(frontage / base[1], seen_h)
    lo, hi = prior.scale_range
    scale = float(np.clip(scale_measured, lo, hi)) if np.isfinite(scale_measured) else 1.0
    stretch = np.ones(3)
    if prior.yaw == "face_road" and prior.facade_depth_m is not None:
        # A photo shows a facade's front only: the footprint behind it takes the class's
        # usual depth, not the uniform scale's (which makes a tall building as deep as tall).
        stretch[0] = prior.facade_depth_m / (base[0] * scale)
        if one_side_cut and np.isfinite(frontage):
            stretch[1] = frontage / (base[1] * scale)
    size = base * scale * stretch

    # Move back by the footprint's extent. A mask's lowest pixel is its nearest ground
    # contact (tyres, feet); a detector's box bottom follows the projected 3D box, i.e. the
    # footprint's nearest corner. "Nearest" is along the camera's heading, not the viewing
    # ray: a ground point's image row depends only on how far ahead of the camera it is.
    # The centre is that much further ahead (optical depth grows by cos(pitch) per metre
    # ahead); its sideways offset from the contact's ray is the box alignment's job.
    reach = size[:2] if obj.box_only else 2.0 * sizes.contact_half(variant) * scale
    if prior.yaw == "camera" and not obj.box_only:
        # Turned to face the camera only for want of its real heading: expect any heading.
        ahead = sizes.mean_reach(variant) * scale
    else:
        ahead = _forward_half_extent(reach, yaw, camera.yaw)
    if prior.yaw == "face_road":
        # A facade's contact lies on its front wall, which faces the road: the centre is
        # half the depth behind it, away from the road (not further along the ray).
        along = _past_the_side(camera, obj, front_ground, yaw, float(size[1])) if bottom_seen else 0.0
        ground = (
            front_ground
            + along * np.array([-np.sin(yaw), np.cos(yaw)])
            - 0.5 * size[0] * np.array([np.cos(yaw), np.sin(yaw)])
        )
        depth = _depth_of_ground_point(camera, ground)
        back = depth - front
    else:
        back = ahead * float(np.cos(camera.pitch))
        depth = front + back
        ground = _point_at_depth(camera, u, v, depth)
    yaw, yaw_source = _object_yaw(prior, ground, axis, obj, camera)
    if obj.is_thing:
        ground = align_box_columns(camera, ground, yaw, size, obj)
    centre_cues = tuple(
        DepthCue(c.name, c.depth_m + back, c.sigma_m, c.note) if c.available else c for c in cues
    )
    return {
        "obj": obj,
        "name": name,
        "variant": variant,
        "ground": ground,
        "yaw": yaw,
        "yaw_source": yaw_source,
        "scale": scale,
        "stretch": stretch,
        "scale_measured": scale_measured,
        "size": size,
        # Trees, poles and signs collide by their trunk or post: people stand under crowns,
        # lamp arms and sign plates.
        "footprint": 2.0 * sizes.contact_half(variant) * scale if obj.class_name in TRUNK_CLASSES else size[:2],
        "depth_m": depth,
        "depth_method": method,
        "cues": centre_cues,
        "confidence": confidence * float(obj.score),
        "front_depth_m": front,
        "back_m": back,
        # The visible bottom's ground point bounds a hidden or cut bottom's depth from above.
        "upper_m": front if method == "contact_partial" else float("inf"),
    }


def _object_yaw(
    prior: ClassPrior, point: np.ndarray, axis: RoadAxis, obj: ImageObject, camera: PinholeCamera
) -> tuple[float, str]:
    """The class's yaw rule at ``point``, turned to match a whole box's aspect when there is one
    (:mod:`usdworld.layout.boxes`)."""
    yaw, source = choose_yaw(prior.yaw, point, axis)
    if not box_aspect_usable(obj, prior, camera.width):
        return yaw, source
    angle = fit_view_angle(camera, point, prior.size_m, obj)
    bearing = float(np.arctan2(point[1], point[0]))
    return yaw_from_view_angle(angle, bearing, yaw), f"box_aspect_{source}"


#: Confidence of a placement by the cue that decided its depth.
_CONFIDENCE = {
    "contact": 0.9,
    "fused": 0.8,
    "cnn": 0.7,
    "height": 0.6,
    "contact_partial": 0.3,
    "street_line": 0.5,
    "top_row": 0.3,
    "behind": 0.25,
    "height_partial": 0.2,
}


def _with_camera_uncertainty(
    cue: DepthCue, camera: PinholeCamera, camera_sigma: tuple[float, float]
) -> DepthCue:
    """Widen the contact cue by the camera's own height and pitch uncertainty.

    A height error scales every contact depth (``d * s_h / h``); a pitch error shifts the
    horizon, which moves a contact depth by ``d^2 * s_pitch / h``.
    """
    if cue.name != "contact" or not cue.available:
        return cue
    s_h, s_p = camera_sigma
    d = float(cue.depth_m)
    extra = np.hypot(d * s_h / camera.height_m, d * d * s_p / camera.height_m)
    if extra == 0:
        return cue
    return DepthCue(
        cue.name, d, float(np.hypot(cue.sigma_m, extra)), cue.note + "; camera uncertainty included"
    )


def _crop_depth(depth_map: DepthMap, obj: ImageObject) -> DepthMap:
    """The depth map inside the object's box, aligned with its mask crop."""
    x0, y0, x1, y1 = (int(b) for b in obj.box_px)
    return DepthMap(depth_map.depth_m[y0:y1, x0:x1], depth_map.valid[y0:y1, x0:x1], depth_map.source)


def _partial_front_depth(
    obj: ImageObject, prior: ClassPrior, camera: PinholeCamera, contact_ok: bool, front_contact: float
) -> tuple[float, str, float]:
    """Front depth when no cue is valid (the bottom is cut or hidden).

    The visible bottom's ground point and the depth the cut height gives both
    over-estimate the depth (the visible bottom is above the true one; the visible
    height is below the true one), so the smaller of them bounds it from above. When
    the top is in view and the class's height stands well clear of the camera's (a
    person's head, a tree's crown), the top row places the object itself
    (:func:`usdworld.layout.silhouette.depth_from_top_row`, ``top_row``), within that
    bound; the occluder bounds it from below later (:func:`_move_behind_occluders`).
    """
    bounds = []
    if contact_ok:
        bounds.append((front_contact, "contact_partial"))
    if obj.is_thing and obj.height_px > 0:
        bounds.append((camera.fy * prior.size_m[2] / obj.height_px, "height_partial"))
    top = None
    if not obj.top_truncated:
        x0, y0, x1, _ = (float(b) for b in obj.box_px)
        v_top = y0 if obj.box_only else y0 - 0.5
        top = depth_from_top_row(camera, 0.5 * (x0 + x1), v_top, prior.size_m[2], prior.height_std_m)
    if top is not None and (not bounds or top[0] <= min(bounds)[0]):
        return top[0], "top_row", _CONFIDENCE["top_row"]
    if bounds:
        depth, method = min(bounds)
        return depth, method, _CONFIDENCE[method]
    return float("nan"), "unplaceable", 0.0
