"""Drafting one object: depth of its front, then size, then centre (step 1 and 2 of the paper).

Position (step 2): the object is placed on the viewing ray of its contact pixel, moved
back by the footprint's extent beyond its nearest contact along the camera's heading (a
ground point's image row depends only on how far ahead it is), so that the object's
centre, not its front face, is placed; things are then shifted sideways until their
projected box spans the image box's columns (:func:`usdworld.layout.boxes.align_box_columns`).
Every cue in the provenance is given at the centre too.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from usdworld.io.class_table import ClassPrior
from usdworld.io.asset_catalogue import AssetSizes
from usdworld.layout.asset_sizes import choose_variant
from usdworld.layout.boxes import align_box_columns, object_heading, object_yaw, place_border_cut
from usdworld.layout.cues import FrontDepth, front_depth
from usdworld.layout.draft import (
    DepthMethod,
    Draft,
    Forced,
    PlacementContext,
    depth_of_ground_point,
    point_at_depth,
)
from usdworld.layout.facades import facade_frontage, out_of_view_frontage, past_the_side
from usdworld.layout.silhouette import height_from_top_row
from usdworld.perception.depth.fusion import DepthCue
from usdworld.perception.objects import ImageObject
from usdworld.perception.shape import top_shape_ratio

#: Class yaw modes that turn an object for want of its real heading (to the camera, or along
#: the street either way): its footprint may lie at any heading, and no corner of it is known
#: to make a cut box's seen edge.
HEADING_STAND_INS = ("camera", "along_road")


@dataclass(frozen=True)
class _Size:
    """Variant and scale of one object (:func:`_size`)."""

    variant: str
    base: np.ndarray
    scale: float
    scale_measured: float
    stretch: np.ndarray
    size: np.ndarray


def draft_object(
    obj: ImageObject, name: str, ctx: PlacementContext, forced: Forced | None = None
) -> Draft | None:
    """Everything about one object before the row, occlusion and collision passes.

    Args:
        obj: the image evidence.
        name: its prim name.
        ctx: camera, ground, class table and thresholds.
        forced: the front depth and its method when the caller knows better (an object on
            its street row, or whose only clue is the object hiding it).

    Returns:
        The draft; None when nothing gives its depth, or its centre would lie behind the camera.
    """
    front = front_depth(obj, ctx, forced)
    if not np.isfinite(front.depth_m):
        return None
    prior, sizes = ctx.classes[obj.class_name], ctx.asset_sizes[obj.class_name]
    u, v = (float(x) for x in obj.contact_px)
    # Yaw at the front point; variant and scale from the visible height and aspect there.
    # A person's heading along the street is a tie-break, not a measurement: their
    # footprint is sized and centred as when facing the camera, so it moves no depth.
    front_ground = point_at_depth(ctx.camera, u, v, front.depth_m)
    centring = replace(prior, yaw="camera") if prior.yaw == "along_road" else prior
    yaw, _ = object_yaw(centring, front_ground, ctx.axis, obj, ctx.camera, ctx.params)
    sized = _size(obj, prior, sizes, ctx, front, front_ground, yaw)
    trunk = ctx.classes.has(obj.class_name, "trunk")
    ground, depth, back = _centre(obj, prior, sizes, ctx, front.depth_m, front_ground, yaw, sized, trunk)
    heading = object_heading(prior, ground, ctx.axis, obj, ctx.camera, ctx.params)
    yaw, yaw_source = heading.yaw, heading.source
    if obj.is_thing:
        heading_known = prior.yaw not in HEADING_STAND_INS
        ground = align_box_columns(ctx.camera, ground, yaw, sized.size, obj, ctx.params, heading_known)
        if prior.yaw == "road" and front.method is DepthMethod.CONTACT and not trunk:
            # Cut by the left or right border: its seen edge and contact row place it (its
            # contact is not its nearest corner, so the drafted centre overshoots along the ray).
            # A mask's lowest pixel is a tyre's, or, with no tyre in view, the body's bottom.
            placed = ground
            tyres = 2.0 * sizes.contact_half(sized.variant) * sized.scale
            for reach in ((sized.size[:2],) if obj.box_only else (tyres, sized.size[:2])):
                placed = place_border_cut(ctx.camera, ground, yaw, sized.size, reach, obj, ctx.params)
                if placed is not ground:
                    break
            if placed is not ground:
                ground = placed
                depth = depth_of_ground_point(ctx.camera, ground)
                back = depth - front.depth_m
    if not depth > 0:  # a wall seen at the image's bottom corner, a few decimetres ahead: centre behind the camera
        return None
    centre_cues = tuple(
        DepthCue(c.name, c.depth_m + back, c.sigma_m, c.note)
        if c.available and c.depth_m + back > 0
        else (DepthCue(c.name, None, None, f"{c.note}; centre behind the camera") if c.available else c)
        for c in front.cues
    )
    # Trees, poles and signs collide by their trunk or post: people stand under crowns,
    # lamp arms and sign plates. Their ground point is the trunk's, which need not be the
    # asset's origin (a street lamp's mast stands behind the middle of mast and arm).
    return Draft(
        obj=obj,
        name=name,
        variant=sized.variant,
        ground=ground,
        yaw=yaw,
        yaw_source=yaw_source,
        scale=sized.scale,
        stretch=sized.stretch,
        scale_measured=sized.scale_measured,
        size=sized.size,
        footprint=2.0 * sizes.contact_own_half(sized.variant) * sized.scale if trunk else sized.size[:2],
        depth_m=depth,
        method=front.method,
        cues=centre_cues,
        confidence=front.confidence * float(obj.score),
        front_depth_m=front.depth_m,
        back_m=back,
        # The visible bottom's ground point bounds a hidden or cut bottom's depth from above.
        upper_m=front.depth_m if front.method is DepthMethod.CONTACT_PARTIAL else float("inf"),
        behind=forced.behind if forced is not None else None,
        yaw_confidence=heading.confidence,
        contact_offset=(
            sizes.contact_offset(sized.variant) * sized.scale * sized.stretch[:2] if trunk else np.zeros(2)
        ),
    )


def _size(
    obj: ImageObject,
    prior: ClassPrior,
    sizes: AssetSizes,
    ctx: PlacementContext,
    front: FrontDepth,
    front_ground: np.ndarray,
    yaw: float,
) -> _Size:
    """Variant, scale and stretch from the visible height, aspect, top shape and frontage."""
    camera, params = ctx.camera, ctx.params
    facade = ctx.classes.has(obj.class_name, "facade")
    bottom_seen = not (obj.bottom_truncated or obj.bottom_occluded)
    whole = bottom_seen and not obj.top_truncated
    bearing = float(np.arctan2(front_ground[1], front_ground[0]))
    measured_h = float(obj.height_px * front.depth_m / camera.fy) if whole else float("nan")
    if front.method is DepthMethod.STREET_LINE and not obj.top_truncated:
        # Its row gives the depth of an object whose bottom is hidden: its top row there
        # gives its height above the ground.
        x0, y0, x1, _ = (float(b) for b in obj.edges_px)
        measured_h = height_from_top_row(
            camera, 0.5 * (x0 + x1), y0 if obj.box_only else y0 - 0.5, front.depth_m
        )
    sides_cut = obj.box_px[0] <= 0 or obj.box_px[2] >= camera.width
    # The silhouette's aspect tells stuff variants apart (a conifer from a broad tree); for
    # vehicles and people perspective dominates it, so only their height counts.
    use_aspect = whole and not sides_cut and not obj.is_thing and obj.height_px > 0
    aspect = obj.width_px / obj.height_px if use_aspect else float("nan")
    # Trees and poles (a lamp's arm turned over the road) show their variant in the shape
    # of their top, even when their bottom is hidden.
    turned_alike = prior.yaw == "none" or (prior.yaw == "face_road" and not facade)
    shape_seen = turned_alike and not obj.box_only and not obj.top_truncated and not sides_cut
    top_shape = top_shape_ratio(obj.mask) if shape_seen else None
    variant = choose_variant(sizes, measured_h, aspect, yaw - bearing, top_shape, params.top_shape_offset)
    base = np.array(sizes.by_variant[variant], dtype=np.float64)
    scale_measured = float(measured_h / base[2]) if np.isfinite(measured_h) else float("nan")
    one_side_cut = (obj.box_px[0] <= 0) != (obj.box_px[2] >= camera.width)
    frontage = float("nan")
    if facade and bottom_seen:
        frontage = facade_frontage(camera, obj, front_ground, yaw, params.wall_trace_step_px)
        if one_side_cut and prior.frontage_range_m is not None:
            frontage = out_of_view_frontage(frontage, prior.frontage_range_m)
    if not np.isfinite(scale_measured) and np.isfinite(frontage):
        # A facade cut by the image's top: its frontage sizes it, never below the height
        # in view (a lower bound on its height).
        seen_h = float(obj.height_px * front.depth_m / camera.fy) / base[2] if obj.height_px > 0 else 0.0
        scale_measured = max(frontage / base[1], seen_h)
    lo, hi = prior.scale_range
    scale = float(np.clip(scale_measured, lo, hi)) if np.isfinite(scale_measured) else 1.0
    stretch = np.ones(3)
    if facade and prior.facade_depth_m is not None:
        # A photo shows a facade's front only: the footprint behind it takes the class's
        # usual depth, not the uniform scale's (which makes a tall building as deep as tall).
        stretch[0] = prior.facade_depth_m / (base[0] * scale)
        if one_side_cut and np.isfinite(frontage):
            stretch[1] = frontage / (base[1] * scale)
    return _Size(variant, base, scale, scale_measured, stretch, base * scale * stretch)


def _forward_half_extent(size_lw: np.ndarray, yaw: float, direction: float) -> float:
    """Distance from a footprint's centre to its nearest corner, measured along a direction (yaw, radians)."""
    rel = yaw - direction
    return float(0.5 * (size_lw[0] * abs(np.cos(rel)) + size_lw[1] * abs(np.sin(rel))))


def _centre(
    obj: ImageObject,
    prior: ClassPrior,
    sizes: AssetSizes,
    ctx: PlacementContext,
    front: float,
    front_ground: np.ndarray,
    yaw: float,
    sized: _Size,
    trunk: bool,
) -> tuple[np.ndarray, float, float]:
    """The footprint centre behind the front: ((2,) ground point, its depth, depth minus front's), metres.

    A mask's lowest pixel is its nearest ground contact (tyres, feet); a detector's box
    bottom follows the projected 3D box, i.e. the footprint's nearest corner. "Nearest" is
    along the camera's heading, not the viewing ray: a ground point's image row depends
    only on how far ahead of the camera it is. The centre is that much further ahead
    (optical depth grows by cos(pitch) per metre ahead); its sideways offset from the
    contact's ray is the box alignment's job. A facade's centre is half its depth behind
    its front wall, away from the road.
    """
    camera = ctx.camera
    size, scale, variant = sized.size, sized.scale, sized.variant
    u, v = (float(x) for x in obj.contact_px)
    if ctx.classes.has(obj.class_name, "facade"):
        # A facade's contact lies on its front wall, which faces the road: the centre is
        # half the depth behind it, away from the road (not further along the ray).
        bottom_seen = not (obj.bottom_truncated or obj.bottom_occluded)
        step = ctx.params.wall_trace_step_px
        along = past_the_side(camera, obj, front_ground, yaw, float(size[1]), step) if bottom_seen else 0.0
        ground = (
            front_ground
            + along * np.array([-np.sin(yaw), np.cos(yaw)])
            - 0.5 * size[0] * np.array([np.cos(yaw), np.sin(yaw)])
        )
        depth = depth_of_ground_point(camera, ground)
        return ground, depth, depth - front
    contact_half = sizes.contact_own_half(variant) if trunk else sizes.contact_half(variant)
    reach = size[:2] if obj.box_only else 2.0 * contact_half * scale
    if prior.yaw in HEADING_STAND_INS and not obj.box_only:  # any heading may be the real one
        ahead = sizes.mean_reach(variant) * scale
    else:
        ahead = _forward_half_extent(reach, yaw, camera.yaw)
    back = ahead * float(np.cos(camera.pitch))
    depth = front + back
    return point_at_depth(camera, u, v, depth), depth, back
