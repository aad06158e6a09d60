"""Metric placement of image objects: depth cues, position, scale, variant and yaw.

Position (step 2 of the paper): the ground-contact pixel goes through the DLT
homography ``ground_from_px`` to a ground point, which is then moved back along the
viewing ray by the object's half extent along that ray, so that the object's centre,
not its front face, is placed. With a dense depth map, the object's depth is the
robust mean over its mask instead, repaired by the paper's ordering rules.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.homography import apply_homography
from usdworld.io.types import DepthMap
from usdworld.layout.collision import footprint_half_extents, resolve_collisions
from usdworld.layout.ordering import apply_ordering_rules
from usdworld.layout.priors import ClassPrior, prior_for
from usdworld.layout.yaw import RoadAxis, choose_yaw
from usdworld.perception.objects import ImageObject

#: Height of the kerb: objects standing on the sidewalk are lifted by this much.
CURB_HEIGHT_M = 0.15
#: One pixel of contact-row error, in pixels, used for the contact cue's spread.
CONTACT_ROW_NOISE_PX = 1.0
#: Relative spread assumed for a dense depth map's per-object mean.
DEPTH_MAP_REL_STD = 0.1


@dataclass(frozen=True)
class DepthCue:
    """One estimate of an object's centre depth.

    Attributes:
        name: ``ground_contact``, ``height_prior`` or ``depth_map``.
        depth_m: centre depth along the optical axis, or NaN when unavailable.
        sigma_m: assumed standard deviation, or NaN when unavailable.
    """

    name: str
    depth_m: float
    sigma_m: float

    @property
    def available(self) -> bool:
        return bool(np.isfinite(self.depth_m) and self.depth_m > 0)


@dataclass(frozen=True)
class AssetSizes:
    """Sizes of the class assets, by variant, as recorded in the library.

    Attributes:
        by_variant: (l, w, h) metres for each variant name.
        default_variant: the asset's default variant.
    """

    by_variant: dict[str, tuple[float, float, float]]
    default_variant: str


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
        scale_measured: scale measured from the image before clamping (NaN if not measurable).
        size_m: (3,) float64 size after scaling (length, width, height).
        depth_m: centre depth along the optical axis, metres.
        depth_method: the cue that decided the depth (or ``depth_map+rule1`` ...).
        cues: every depth cue computed.
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
    scale_measured: float
    size_m: np.ndarray
    depth_m: float
    depth_method: str
    cues: tuple[DepthCue, ...]
    collision_displacement: np.ndarray = field(default_factory=lambda: np.zeros(2))
    confidence: float = 0.0


def _forward_half_extent(size_lw: np.ndarray, yaw: float, bearing: float) -> float:
    """Distance from a footprint's centre to its nearest edge point along a ray direction."""
    rel = yaw - bearing
    return float(0.5 * (size_lw[0] * abs(np.cos(rel)) + size_lw[1] * abs(np.sin(rel))))


def _depth_of_ground_point(camera: PinholeCamera, p_ground: np.ndarray) -> float:
    return float(camera.cam_from_world_points(np.array([[p_ground[0], p_ground[1], 0.0]]))[0, 2])


def _measured_height(obj: ImageObject, front_depth_m: float, camera: PinholeCamera) -> float:
    """Metric height of the object's visible extent at its front depth (NaN if cut)."""
    if obj.top_truncated or obj.bottom_truncated or obj.bottom_occluded or not front_depth_m > 0:
        return float("nan")
    return float(obj.height_px * front_depth_m / camera.fy)


def _choose_variant(sizes: AssetSizes, measured_h: float) -> str:
    if not np.isfinite(measured_h) or len(sizes.by_variant) < 2:
        return sizes.default_variant
    names = sorted(sizes.by_variant)
    errs = [abs(np.log(measured_h / sizes.by_variant[n][2])) for n in names]
    return names[int(np.argmin(errs))]


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
) -> tuple[list[Placement], list[str]]:
    """Place every object in the world frame, then resolve footprint collisions.

    Args:
        objects: image objects in canonical order (names follow this order per class).
        camera: the source camera.
        ground_from_px: (3, 3) float64 homography from pixels to ground metres (DLT).
        axis: the road axis, for yaw.
        asset_sizes: asset sizes of every class that occurs.
        depth_map: optional dense metric depth; when given, it decides the depth.
        sidewalk_lift: lift objects standing on the sidewalk to the kerb height.

    Returns:
        Placements in the same order as ``objects`` and the names of objects that
        could not be placed (stuff with no visible ground contact and no usable height).
        Names are given before skipping, so they stay stable.
    """
    counters: dict[str, int] = {}
    drafts = []
    skipped: list[str] = []
    for obj in objects:
        prior = prior_for(obj.class_name)
        sizes = asset_sizes[obj.class_name]
        counters[obj.class_name] = counters.get(obj.class_name, 0) + 1
        name = f"{obj.class_name}_{counters[obj.class_name]:04d}"
        draft = _draft(obj, name, prior, sizes, camera, ground_from_px, axis, depth_map)
        if draft is None:
            skipped.append(name)
        else:
            drafts.append(draft)

    if depth_map is not None and drafts:
        result = apply_ordering_rules(
            np.array([d["obj"].contact_px[1] for d in drafts]),
            np.array([d["depth_m"] for d in drafts]),
            np.array([d["obj"].box_px for d in drafts], dtype=np.float64),
        )
        for d, depth, rule in zip(drafts, result.depth_m, result.rule):
            if rule:
                d["depth_m"] = float(depth)
                d["depth_method"] += "+" + rule
                d["ground"] = _point_at_depth(camera, *d["obj"].contact_px, float(depth))

    placements: list[Placement] = []
    if not drafts:
        return placements, skipped
    centers = np.array([d["ground"] for d in drafts])
    half = footprint_half_extents(np.array([d["size"][:2] for d in drafts]), np.array([d["yaw"] for d in drafts]))
    priority = np.array([d["depth_m"] / max(d["confidence"], 1e-3) for d in drafts])
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


def _draft(  # noqa: PLR0913
    obj: ImageObject,
    name: str,
    prior: ClassPrior,
    sizes: AssetSizes,
    camera: PinholeCamera,
    ground_from_px: np.ndarray,
    axis: RoadAxis,
    depth_map: DepthMap | None,
) -> dict | None:
    """Everything about one object before ordering rules and collisions; None when it cannot be placed."""
    u, v = (float(x) for x in obj.contact_px)
    contact_ground = apply_homography(ground_from_px, np.array([[u, v]]))[0]
    contact_ok = bool(np.all(np.isfinite(contact_ground))) and _depth_of_ground_point(camera, contact_ground) > 0
    front_depth = _depth_of_ground_point(camera, contact_ground) if contact_ok else float("nan")

    # Scale and variant from the visible height at the front depth.
    measured_h = _measured_height(obj, front_depth, camera)
    variant = _choose_variant(sizes, measured_h)
    base = np.array(sizes.by_variant[variant], dtype=np.float64)
    scale_measured = float(measured_h / base[2]) if np.isfinite(measured_h) else float("nan")
    lo, hi = prior.scale_range
    scale = float(np.clip(scale_measured, lo, hi)) if np.isfinite(scale_measured) else 1.0
    size = base * scale

    # Yaw from the contact point (refined below once the centre is known).
    probe = contact_ground if contact_ok else np.array([10.0, 0.0])
    yaw, yaw_source = choose_yaw(prior.yaw, probe, axis)

    cues = []
    bearing = float(np.arctan2(probe[1], probe[0]))
    half_depth = _forward_half_extent(size[:2], yaw, bearing)
    ray = camera.rays_world(np.array([[u, v]]))[0]
    horiz = np.hypot(ray[0], ray[1])  # ground distance per metre of depth along this ray
    # Ground contact: move the contact point back along the ray by the half extent.
    if contact_ok and not obj.bottom_truncated and not obj.bottom_occluded:
        center_depth = front_depth + half_depth / max(horiz, 1e-9)
        sigma = center_depth**2 * CONTACT_ROW_NOISE_PX / (camera.fy * camera.height_m)
        cues.append(DepthCue("ground_contact", center_depth, sigma))
    else:
        cues.append(DepthCue("ground_contact", float("nan"), float("nan")))
    # Height prior: class height over pixel height.
    if not (obj.top_truncated or obj.bottom_truncated or obj.bottom_occluded) and obj.height_px > 0:
        d = camera.fy * prior.size_m[2] / obj.height_px + half_depth / max(horiz, 1e-9)
        cues.append(DepthCue("height_prior", d, d * prior.height_std_m / prior.size_m[2]))
    else:
        cues.append(DepthCue("height_prior", float("nan"), float("nan")))
    if depth_map is not None:
        cues.append(_depth_map_cue(obj, depth_map, half_depth / max(horiz, 1e-9)))

    depth, method, confidence = _decide(
        cues, obj, depth_map is not None, contact_ok, front_depth, half_depth, horiz, camera.fy
    )
    if not np.isfinite(depth):
        return None
    ground = _point_at_depth(camera, u, v, depth)
    yaw, yaw_source = choose_yaw(prior.yaw, ground, axis)
    return {
        "obj": obj,
        "name": name,
        "variant": variant,
        "ground": ground,
        "yaw": yaw,
        "yaw_source": yaw_source,
        "scale": scale,
        "scale_measured": scale_measured,
        "size": size,
        "depth_m": depth,
        "depth_method": method,
        "cues": tuple(cues),
        "confidence": confidence * float(obj.score),
    }


def _depth_map_cue(obj: ImageObject, depth_map: DepthMap, back_m: float) -> DepthCue:
    """Robust mean (median) of the depth map over the object's mask, moved to the centre."""
    x0, y0, x1, y1 = (int(b) for b in obj.box_px)
    crop = np.asarray(depth_map.depth_m)[y0:y1, x0:x1]
    valid = np.asarray(depth_map.valid)[y0:y1, x0:x1] & obj.mask
    if valid.sum() < 3:
        return DepthCue("depth_map", float("nan"), float("nan"))
    d = float(np.median(crop[valid])) + back_m
    return DepthCue("depth_map", d, DEPTH_MAP_REL_STD * d)


def _decide(
    cues: list[DepthCue],
    obj: ImageObject,
    prefer_map: bool,
    contact_ok: bool,
    front_depth: float,
    half_depth: float,
    horiz: float,
    camera_fy: float,
) -> tuple[float, str, float]:
    """Pick the depth: the depth map when given, else ground contact, else the height prior."""
    by_name = {c.name: c for c in cues}
    if prefer_map and by_name["depth_map"].available:
        return by_name["depth_map"].depth_m, "depth_map", 0.7
    if by_name["ground_contact"].available:
        return by_name["ground_contact"].depth_m, "ground_contact", 0.9
    if by_name["height_prior"].available:
        return by_name["height_prior"].depth_m, "height_prior", 0.6
    if contact_ok:
        # Cut or hidden bottom: the visible bottom is above the true one, so this
        # over-estimates the depth; it is the best we have.
        return front_depth + half_depth / max(horiz, 1e-9), "ground_contact_partial", 0.3
    if obj.is_thing and obj.height_px > 0:
        # No ground below the object and its extent is cut: the visible height is a
        # lower bound, so this over-estimates the depth too.
        prior = prior_for(obj.class_name)
        return camera_fy * prior.size_m[2] / obj.height_px + half_depth / max(horiz, 1e-9), "height_prior_partial", 0.2
    return float("nan"), "unplaceable", 0.0
