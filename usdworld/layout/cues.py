"""The depth of one object's front from its own evidence (step 1 of the paper, made robust).

Every cue to the depth of the object's front is computed (the ground contact through the
DLT homography ``ground_from_px``, the class-height prior by the silhouette, and a dense
depth map's robust mean when one is given) and fused by inverse-variance weighting
(:mod:`usdworld.perception.depth.fusion`); the contact cue is widened by the camera's own
uncertainty when the camera was estimated. When no cue is valid (the bottom is cut or
hidden) the front depth is a bound from above or the top-row estimate
(:func:`partial_front_depth`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usdworld.errors import LayoutError
from usdworld.geometry.homography import apply_homography
from usdworld.io.asset_catalogue import AssetSizes
from usdworld.io.class_table import ClassPrior
from usdworld.io.types import DepthMap
from usdworld.layout.boxes import object_yaw
from usdworld.layout.draft import (
    DepthMethod,
    Forced,
    PlacementContext,
    depth_of_ground_point,
    method_confidence,
    point_at_depth,
)
from usdworld.layout.silhouette import depth_from_silhouette, depth_from_top_row, top_offsets
from usdworld.perception.depth.fusion import DepthCue, fuse, object_depth_cues
from usdworld.perception.objects import ImageObject

#: Why a facade whose base is seen has no height cue.
FACADE_HEIGHT_NOTE = "not used: a facade's base is seen"


@dataclass(frozen=True)
class FrontDepth:
    """What an object's own evidence says about the depth of its front.

    Attributes:
        depth_m: front depth along the optical axis, metres (NaN: unplaceable).
        method: what decided it.
        confidence: the method's confidence (before the object's score).
        cues: every cue computed, as front depths.
    """

    depth_m: float
    method: DepthMethod
    confidence: float
    cues: tuple[DepthCue, ...]


def contact_depth(obj: ImageObject, ctx: PlacementContext) -> tuple[np.ndarray, bool, float]:
    """The object's contact pixel on the ground.

    Returns:
        ((2,) float64 ground point on the road plane, whether it lies ahead of the camera,
        its front depth in metres, NaN when not; on the kerb top for a sidewalk contact).
    """
    camera = ctx.camera
    contact_ground = apply_homography(ctx.ground_from_px, np.array([[float(x) for x in obj.contact_px]]))[0]
    contact_ok = (
        bool(np.all(np.isfinite(contact_ground))) and depth_of_ground_point(camera, contact_ground) > 0
    )
    front = depth_of_ground_point(camera, contact_ground) if contact_ok else float("nan")
    if contact_ok and ctx.sidewalk_lift and obj.standing_on == "sidewalk":
        # The homography maps to the road plane z = 0; the contact lies on the kerb top,
        # which the viewing ray meets (h - kerb) / h of the way to the road plane.
        front *= (camera.height_m - ctx.params.curb_height_m) / camera.height_m
    return contact_ground, contact_ok, front


def silhouette_depth(
    obj: ImageObject,
    prior: ClassPrior,
    sizes: AssetSizes,
    ctx: PlacementContext,
    contact_ground: np.ndarray,
    contact_ok: bool,
) -> float | None:
    """The silhouette height's depth, with the object's own depth extent (its roof's far edge
    is its top row when the roof is below the camera); yaw guessed at the contact point (or
    ``guess_depth_m`` along its ray), default variant at unit scale. None when not whole."""
    u, v = (float(x) for x in obj.contact_px)
    camera = ctx.camera
    guess = contact_ground if contact_ok else point_at_depth(camera, u, v, ctx.params.guess_depth_m)
    yaw = object_yaw(prior, guess, ctx.axis, obj, camera, ctx.params)[0]
    rel_yaw = yaw - float(np.arctan2(guess[1], guess[0]))
    dv = sizes.default_variant
    offsets = top_offsets(sizes.contact_half(dv), sizes.top_half(dv), sizes.footprint(dv), rel_yaw, obj.box_only)
    return depth_from_silhouette(camera, (u, v), obj.height_px, prior.size_m[2], offsets, ctx.params)


def object_cues(
    obj: ImageObject,
    prior: ClassPrior,
    sizes: AssetSizes,
    ctx: PlacementContext,
    contact_ground: np.ndarray,
    contact_ok: bool,
    front_contact: float,
) -> list[DepthCue]:
    """Cues for the depth of the object's front (its contact row / visible surface)."""
    camera = ctx.camera
    bottom_seen = not (obj.bottom_truncated or obj.bottom_occluded)
    whole = bottom_seen and not obj.top_truncated
    height_depth = None
    if whole and obj.height_px > 0:
        height_depth = silhouette_depth(obj, prior, sizes, ctx, contact_ground, contact_ok)
    cues = object_depth_cues(
        obj.mask,
        np.zeros_like(obj.mask),
        front_contact if (contact_ok and bottom_seen) else None,
        crop_depth(ctx.depth_map, obj) if ctx.depth_map is not None else None,
        prior.size_m[2],
        obj.height_px if whole and obj.height_px > 0 else None,
        camera.fy,
        camera_height_m=camera.height_m,
        class_height_std_m=prior.height_std_m,
        height_depth_m=height_depth,
        # A given camera height is independent of the class heights; an estimated one
        # was fitted to them, so the contact cue already carries their mean's error.
        class_mean_rel_sigma=ctx.perception.height_mean_rel_sigma if ctx.camera_sigma[0] == 0.0 else 0.0,
        params=ctx.perception,
    )
    cues = [with_camera_uncertainty(c, ctx) for c in cues]
    if ctx.classes.has(obj.class_name, "facade") and any(c.name == "contact" and c.available for c in cues):
        # Buildings are 3 to 30 m tall: where a facade's base is seen, its height only
        # drags a far one nearer (a tall building looks like a near one of usual height).
        cues = [DepthCue("height", None, None, FACADE_HEIGHT_NOTE) if c.name == "height" else c for c in cues]
    return cues


def front_depth(obj: ImageObject, ctx: PlacementContext, forced: Forced | None) -> FrontDepth:
    """The front depth, what decided it and every cue (``forced`` overrides the cues' verdict)."""
    prior, sizes = ctx.classes[obj.class_name], ctx.asset_sizes[obj.class_name]
    contact_ground, contact_ok, front_contact = contact_depth(obj, ctx)
    cues = tuple(object_cues(obj, prior, sizes, ctx, contact_ground, contact_ok, front_contact))
    if forced is not None:
        return FrontDepth(
            forced.front_depth_m, forced.method, method_confidence(forced.method, ctx.params), cues
        )
    try:
        fused = fuse(list(cues), ctx.perception)
    except LayoutError:
        if obj.bottom_truncated:
            cut = cut_off_front_depth(obj, prior, sizes, ctx, contact_ok, front_contact)
            if cut is not None:
                depth, method, cue = cut
                return FrontDepth(depth, method, method_confidence(method, ctx.params), (*cues, cue))
        depth, method = partial_front_depth(obj, prior, ctx, contact_ok, front_contact)
        return FrontDepth(depth, method, method_confidence(method, ctx.params), cues)
    method = DepthMethod(fused.method)
    return FrontDepth(fused.depth_m, method, method_confidence(method, ctx.params), cues)


def with_camera_uncertainty(cue: DepthCue, ctx: PlacementContext) -> DepthCue:
    """Widen the contact cue by the camera's own height and pitch uncertainty and by the
    road's unevenness.

    A height error scales every contact depth (``d * s_h / h``); a pitch error shifts the
    horizon, which moves a contact depth by ``d^2 * s_pitch / h``. The road under the object
    is not the camera's ground plane: a surface ``dz`` higher there meets the contact's ray
    ``d * dz / h`` nearer, so its spread :attr:`PlacementParams.ground_height_sigma_m`
    widens the cue by ``d * s_ground / h`` even when the camera (or its road plane) is given.
    """
    if cue.name != "contact" or not cue.available:
        return cue
    s_h, s_p = ctx.camera_sigma
    h = ctx.camera.height_m
    d = float(cue.depth_m)
    camera = float(np.hypot(d * s_h / h, d * d * s_p / h))
    ground = d * ctx.params.ground_height_sigma_m / h
    extra = float(np.hypot(camera, ground))
    if extra == 0:
        return cue
    notes = (["camera uncertainty"] if camera > 0 else []) + (["road unevenness"] if ground > 0 else [])
    return DepthCue(cue.name, d, float(np.hypot(cue.sigma_m, extra)), cue.note + f"; {' and '.join(notes)} included")


def crop_depth(depth_map: DepthMap, obj: ImageObject) -> DepthMap:
    """The depth map inside the object's box, aligned with its mask crop."""
    x0, y0, x1, y1 = (int(b) for b in obj.box_px)
    return DepthMap(depth_map.depth_m[y0:y1, x0:x1], depth_map.valid[y0:y1, x0:x1], depth_map.source)


def partial_front_depth(
    obj: ImageObject, prior: ClassPrior, ctx: PlacementContext, contact_ok: bool, front_contact: float
) -> tuple[float, DepthMethod]:
    """Front depth when no cue is valid (the bottom is cut or hidden).

    The visible bottom's ground point and the depth the cut height gives both
    over-estimate the depth (the visible bottom is above the true one; the visible
    height is below the true one), so the smaller of them bounds it from above. When
    the top is in view and the class's height stands well clear of the camera's (a
    person's head, a tree's crown), the top row places the object itself
    (:func:`usdworld.layout.silhouette.depth_from_top_row`, ``top_row``), within that
    bound; the occluder bounds it from below later (:mod:`usdworld.layout.occlusion`).

    Returns:
        (front depth in metres, NaN when nothing bounds it; the method).
    """
    camera = ctx.camera
    bounds: list[tuple[float, str]] = []
    if contact_ok:
        bounds.append((front_contact, DepthMethod.CONTACT_PARTIAL.value))
    if obj.is_thing and obj.height_px > 0:
        bounds.append((camera.fy * prior.size_m[2] / obj.height_px, DepthMethod.HEIGHT_PARTIAL.value))
    top = None
    if not obj.top_truncated:
        x0, y0, x1, _ = (float(b) for b in obj.edges_px)
        v_top = y0 if obj.box_only else y0 - 0.5
        top = depth_from_top_row(
            camera, 0.5 * (x0 + x1), v_top, prior.size_m[2], prior.height_std_m, ctx.params
        )
    if top is not None and (not bounds or top[0] <= min(bounds)[0]):
        return top[0], DepthMethod.TOP_ROW
    if bounds:
        depth, method = min(bounds)
        return depth, DepthMethod(method)
    return float("nan"), DepthMethod.UNPLACEABLE


# --- objects cut by the image border --------------------------------------------------------


def _top_row_line(obj: ImageObject, ctx: PlacementContext) -> tuple[float, float] | None:
    """Height above the road of the top row's viewing ray as a line in depth: ``z(d) = a + b d``.

    Returns:
        (a, b): a in metres (the camera height), b in metres per metre of optical depth;
        None when the ray does not go ahead of the camera.
    """
    camera = ctx.camera
    x0, y0, x1, _ = (float(b) for b in obj.edges_px)
    v_top = y0 if obj.box_only else y0 - 0.5
    ray = camera.rays_world(np.array([[0.5 * (x0 + x1), v_top]], dtype=np.float64))[0]
    along = float(ray @ camera.rotation_world_from_cam[:, 2])
    if along <= 1e-9:
        return None
    return float(camera.center_world[2]), float(ray[2] / along)


def _width_cue(
    obj: ImageObject, prior: ClassPrior, ctx: PlacementContext, guess_depth_m: float
) -> tuple[float, float] | None:
    """Depth from the box's width when both its sides are seen: a road-aligned class's
    footprint (length ``l``, width ``w``) at heading ``rel`` to the viewing ray spans
    ``l |sin rel| + w |cos rel|`` across it. Its spread is the class's relative size spread
    (its height spread over its height: one uniform scale, as ``scale_range`` assumes).

    Returns:
        (depth, sigma) in metres, or None (a side cut, a class not aligned with the road, or
        no width).
    """
    if obj.sides_cut or prior.yaw != "road" or obj.width_px <= 0:
        return None
    camera = ctx.camera
    x0, y0, x1, _ = (float(b) for b in obj.edges_px)
    u = 0.5 * (x0 + x1)
    v = y0
    guess = point_at_depth(camera, u, v, guess_depth_m)
    yaw = object_yaw(prior, guess, ctx.axis, obj, camera, ctx.params)[0]
    rel = yaw - float(np.arctan2(guess[1], guess[0]))
    span = prior.size_m[0] * abs(np.sin(rel)) + prior.size_m[1] * abs(np.cos(rel))
    depth = camera.fx * span / obj.width_px
    return depth, depth * prior.height_std_m / prior.size_m[2]


def truncated_normal_median(mean: float, sigma: float, lo: float, hi: float) -> float:
    """Median of a normal distribution (mean, sigma) restricted to ``[lo, hi]`` (lo < hi).

    Where the interval lies far in one tail (its probability underflows), the end nearer
    the mean.
    """
    from statistics import NormalDist  # with decimal and fractions: only for objects the image cuts off

    dist = NormalDist(mean, sigma)
    p_lo, p_hi = dist.cdf(lo), dist.cdf(hi)
    if p_hi - p_lo < 1e-12:
        return hi if mean > hi else lo
    return float(min(max(dist.inv_cdf(0.5 * (p_lo + p_hi)), lo), hi))


def cut_off_front_depth(
    obj: ImageObject,
    prior: ClassPrior,
    sizes: AssetSizes,
    ctx: PlacementContext,
    contact_ok: bool,
    front_contact: float,
) -> tuple[float, DepthMethod, DepthCue] | None:
    """Front depth of an object whose bottom is cut by the image border, from the cues still seen.

    A box cut by the border bounds the object from the cut side only: the visible bottom's
    ground point and the cut height's depth bound its depth from above (``hi``, the smaller).
    Within ``(near plane, hi]`` the cues still measured are multiplied as Gaussians in depth:

    * the top row (when the top is seen): the ray through it stands ``z(d) = a + b d`` above
      the road at depth ``d``; the class height ``H ~ N(mean, std)`` makes that
      ``d ~ N((mean - a) / b, std / |b|)``: broad for a car's roof near the camera's height,
      sharp for a person's head or a van's roof well clear of it;
    * the width across the image (when both sides are seen): :func:`_width_cue`.

    The depth is the median of that product restricted to the interval (a uniform prior in
    depth within the bounds). With no cue still seen (a box cut at its top and its sides as
    well) the uniform prior alone decides: the middle of the interval, not its upper end (a
    bound is the farthest the object can be, and taking it put a truck filling KITTI
    000019's left edge 78 % too far). A dense depth map, when given, is fused before this is
    reached (:func:`front_depth`).

    Returns:
        (front depth in metres, :attr:`DepthMethod.CUT_OFF`, a ``cut_off`` cue whose note
        names the cut sides, the cues used and the bounds), or None when nothing bounds it.
    """
    camera = ctx.camera
    bounds: list[tuple[float, str]] = []
    if contact_ok and np.isfinite(front_contact):
        bounds.append((front_contact, "contact"))
    if obj.is_thing and obj.height_px > 0:
        bounds.append((camera.fy * prior.size_m[2] / obj.height_px, "cut height"))
    if not bounds:
        return None
    hi, hi_name = min(bounds)
    lo = ctx.params.near_plane_m
    if not hi > lo:
        return None
    gaussians: list[tuple[float, float, str]] = []
    if not obj.top_truncated:
        line = _top_row_line(obj, ctx)
        if line is not None and abs(line[1]) > 1e-9:
            a, b = line
            gaussians.append(((prior.size_m[2] - a) / b, prior.height_std_m / abs(b), "top row"))
    width = _width_cue(obj, prior, ctx, 0.5 * (lo + hi))
    if width is not None:
        gaussians.append((width[0], width[1], "width"))
    if not gaussians:
        depth = 0.5 * (lo + hi)
        note = (
            f"cut at {', '.join(obj.cut_sides)}: no cue still seen; the middle of ({lo:g}, {hi:.2f}] m "
            f"(upper bound from the {hi_name})"
        )
        # The spread of a uniform distribution over the interval.
        return depth, DepthMethod.CUT_OFF, DepthCue("cut_off", depth, (hi - lo) / np.sqrt(12.0), note)
    weights = np.array([1.0 / s**2 for _, s, _ in gaussians])
    mean = float(np.sum(weights * np.array([m for m, _, _ in gaussians])) / weights.sum())
    sigma = float(1.0 / np.sqrt(weights.sum()))
    depth = truncated_normal_median(mean, sigma, lo, hi)
    used = " + ".join(name for _, _, name in gaussians)
    note = (
        f"cut at {', '.join(obj.cut_sides)}: {used} within ({lo:g}, {hi:.2f}] m "
        f"(upper bound from the {hi_name}); unbounded estimate {mean:.2f} +- {sigma:.2f} m"
    )
    return depth, DepthMethod.CUT_OFF, DepthCue("cut_off", depth, max(min(sigma, hi - lo), 1e-6), note)
