"""Evaluate a world against its inputs: layout IoU, photo SSIM, per-object colour error and 3D object errors.

Example:
    >>> stage = open_world("world/world.usda")                                 # doctest: +SKIP
    >>> result = evaluate_world(stage, labels=read_label_ids("x_gtFine_labelIds.png"))  # doctest: +SKIP
    >>> result.miou, result.per_class_iou["car"]                               # doctest: +SKIP
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from pxr import Usd

from usdworld.errors import InputError
from usdworld.evaluation.colour_errors import object_colour_errors, summarise_colour
from usdworld.evaluation.ground_truth import GroundTruth
from usdworld.evaluation.objects import match_errors, match_objects, summarise, truth_in_world
from usdworld.evaluation.scene_check import scene_disagreements
from usdworld.evaluation.segmentation import class_counts, ignored_mask, mean_iou, placeable_label_ids
from usdworld.evaluation.ssim import ssim
from usdworld.evaluation.world_objects import world_objects
from usdworld.io.label_table import label_table
from usdworld.render.outputs import view_camera, world_facts, world_image_size
from usdworld.render.renderer import Renderer
from usdworld.render.scene import RenderScene
from usdworld.render.world_lights import lighting_from_stage
from usdworld.world_files import LIGHTS_PATH

log = logging.getLogger(__name__)


def class_name(label_id: int) -> str:
    """Cityscapes name of a label id (``"id<N>"`` for ids outside the table)."""
    for row in label_table():
        if row.id == label_id:
            return row.name
    return f"id{label_id}"


def read_label_ids(path: str | Path) -> np.ndarray:
    """(H, W) uint8 Cityscapes label ids from an 8-bit ``*_labelIds.png``.

    Raises:
        InputError: missing file, not a PNG, or not single-channel 8-bit.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such label image; pass --labels with a Cityscapes *_gtFine_labelIds.png")
    img = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputError(f"{p}: not a readable PNG; pass a Cityscapes *_gtFine_labelIds.png")
    if img.ndim != 2 or img.dtype != np.uint8:
        raise InputError(
            f"{p}: {img.dtype} image with shape {img.shape}; labels must be 8-bit single-channel label ids (*_gtFine_labelIds.png)"
        )
    return img


def world_input_names(stage: Usd.Stage) -> dict[str, str]:
    """Input file names the world was built from, by role (``image``, ``labels`` ...)."""
    out: dict[str, str] = {}
    for item in world_facts(stage).get("usdworld:inputFiles", []) or []:
        role, _, name = str(item).partition("=")
        if name:
            out.setdefault(role, name)
    return out


def ids_match_world(stage: Usd.Stage, gt: GroundTruth) -> bool:
    """Whether the ground truth's instance ids are the ones the world was built with.

    Synth: the world's instance map is ``<prefix>_gtFine_instanceIds.png`` of the same
    frame as ``<prefix>_gt.json``. KITTI: the label file itself (same SHA-256) was the
    world's detections input. nuScenes boxes carry no such ids.
    """
    facts = world_facts(stage)
    if gt.kind == "synth" and gt.file_name.endswith("_gt.json"):
        prefix = gt.file_name[: -len("_gt.json")]
        return world_input_names(stage).get("instances") == f"{prefix}_gtFine_instanceIds.png"
    if gt.kind == "kitti":
        return gt.sha256 in [str(h) for h in (facts.get("usdworld:inputHashes", []) or [])]
    return False


@dataclass(frozen=True)
class Evaluation:
    """Everything ``usdworld evaluate`` reports.

    Attributes:
        size: (width, height) of the evaluation render.
        classes: Cityscapes label ids the IoU is computed over.
        per_class_iou: Cityscapes class name -> IoU (NaN: in neither map).
        intersections: class name -> pixels in both maps.
        unions: class name -> pixels in either map.
        miou: mean of the finite IoUs (NaN without labels).
        ssim: SSIM between photo and render (None without a photo).
        objects: summary of the 3D errors (None without ground truth).
        object_rows: one row per ground-truth object.
        ground_truth: ``kind`` and file name of the ground truth, or None.
        rendered_class_ids: (H, W) int32 rendered class map, kept for further analysis.
        scene_warnings: why the ground truth looks like another scene's (empty when nothing
            says so; see :mod:`usdworld.evaluation.scene_check`).
        colour: median CIE76 and CIEDE2000 colour error per object, photo vs render (None
            without a photo; see :mod:`usdworld.evaluation.colour_errors`).
        colour_rows: one row per object compared.
        light: the world's sun against the true one (None without a true sun or without
            authored lights; :func:`light_errors`).
    """

    size: tuple[int, int]
    classes: tuple[int, ...]
    per_class_iou: dict[str, float]
    intersections: dict[str, int]
    unions: dict[str, int]
    miou: float
    ssim: float | None
    objects: dict[str, Any] | None
    object_rows: list[dict[str, Any]]
    ground_truth: dict[str, str] | None
    rendered_class_ids: np.ndarray = field(repr=False)
    scene_warnings: tuple[str, ...] = ()
    colour: dict[str, Any] | None = None
    colour_rows: list[dict[str, Any]] = field(default_factory=list)
    light: dict[str, Any] | None = None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dictionary (NaN written as null)."""

        def num(x: float | None) -> float | None:
            return None if x is None or not np.isfinite(x) else round(float(x), 6)

        out: dict[str, Any] = {
            "size": list(self.size),
            "classes": [class_name(c) for c in self.classes],
            "miou": num(self.miou),
            "per_class_iou": {k: num(v) for k, v in self.per_class_iou.items()},
            "ssim": num(self.ssim),
        }
        if self.colour is not None:
            out["colour"] = self.colour
            out["colour_rows"] = self.colour_rows
        if self.objects is not None:
            out["ground_truth"] = self.ground_truth
            out["median_position_error_m"] = num(self.objects["median_position_error_m"])
            out["objects"] = self.objects
            out["object_rows"] = self.object_rows
            out["scene_warnings"] = list(self.scene_warnings)
        if self.light is not None:
            out["light"] = self.light
        return out


def evaluate_world(
    stage: Usd.Stage,
    labels: np.ndarray | None = None,
    photo: np.ndarray | None = None,
    gt: GroundTruth | None = None,
    classes: Sequence[int] | None = None,
    size: tuple[int, int] | None = None,
    renderer: Renderer | None = None,
    ids_match: bool | None = None,
) -> Evaluation:
    """Render the world from its source camera and compare it with its inputs.

    Args:
        stage: the composed world.
        labels: (H, W) Cityscapes label ids of the source image, or None.
        photo: (H', W', 3) uint8 RGB source photo, or None (no SSIM).
        gt: 3D ground truth, or None (no object errors).
        classes: label ids to compute IoU over; default the classes the world places
            (every class id its meshes carry).
        size: (width, height) of the render; default the labels' size, else the world's image size.
        renderer: a renderer of that size to reuse (else one is created, lit by the world's
            authored lights, and closed).
        ids_match: whether ground-truth instance ids are the world's (default :func:`ids_match_world`).

    Raises:
        InputError: labels of another aspect ratio than the world's image.
        RenderError: no usable OpenGL.
    """
    if size is None:
        size = (labels.shape[1], labels.shape[0]) if labels is not None else world_image_size(stage)
    width, height = size
    if labels is not None and labels.shape != (height, width):
        raise InputError(f"labels are {labels.shape[1]}x{labels.shape[0]} but the render is {width}x{height}")
    ws, hs = world_image_size(stage)
    if abs(width / height - ws / hs) > 0.02 * ws / hs:
        raise InputError(
            f"the render size {width}x{height} does not have the world's image aspect ratio ({ws}x{hs}); pass labels of the source image"
        )
    camera = view_camera(stage, width, height)
    scene = RenderScene.from_stage(stage)
    own = renderer is None
    r = renderer if renderer is not None else Renderer(width, height, lighting=lighting_from_stage(stage))
    try:
        class_ids, _, object_ids, _ = r.render_labels(scene, camera.K, camera.world_from_cam)
        rgb = r.render_rgb(scene, camera.K, camera.world_from_cam) if photo is not None else None
    finally:
        if own:
            r.close()
    if classes is None:
        classes = [c for c in scene.label_ids_present() if c != 0]
    per_class: dict[str, float] = {}
    inter: dict[str, int] = {}
    union: dict[str, int] = {}
    miou = float("nan")
    if labels is not None:
        counts = class_counts(class_ids, placeable_label_ids(labels), classes, ignored_mask(labels))
        for c, k in counts.items():
            per_class[class_name(c)] = k.iou
            inter[class_name(c)] = k.intersection
            union[class_name(c)] = k.union
        miou = mean_iou(per_class)
    ssim_value = None
    colour, colour_rows = None, []
    if photo is not None and rgb is not None:
        photo_fit = (
            photo
            if photo.shape[:2] == (height, width)
            else cv2.resize(photo, (width, height), interpolation=cv2.INTER_AREA)
        )
        ssim_value = ssim(photo_fit, rgb)
        colour_rows = object_colour_errors(stage, scene, object_ids, photo_fit, rgb, (ws, hs))
        colour = summarise_colour(colour_rows)
    summary, rows, gt_info, warnings = None, [], None, ()
    if gt is not None:
        truth = truth_in_world(gt, camera.world_from_cam)
        placed = world_objects(stage)
        use_ids = ids_match_world(stage, gt) if ids_match is None else ids_match
        matches, unmatched = match_objects(truth, placed, camera.world_from_cam[:3, 3], use_ids)
        rows = [match_errors(m, camera.world_from_cam) for m in matches]
        summary = summarise(rows, len(unmatched))
        summary["matched_by_instance_id"] = use_ids
        gt_info = {"kind": gt.kind, "file": gt.file_name}
        source = view_camera(stage, ws, hs)
        warnings = scene_disagreements(gt, (ws, hs), source.K, source.world_from_cam, matches, len(placed), use_ids)
    return Evaluation(
        size=(width, height),
        classes=tuple(int(c) for c in classes),
        per_class_iou=per_class,
        intersections=inter,
        unions=union,
        miou=miou,
        ssim=ssim_value,
        objects=summary,
        object_rows=rows,
        ground_truth=gt_info,
        rendered_class_ids=class_ids,
        scene_warnings=warnings,
        colour=colour,
        colour_rows=[r.to_json() for r in colour_rows],
        light=light_errors(stage, gt) if gt is not None else None,
    )


def light_errors(stage: Usd.Stage, gt: GroundTruth) -> dict[str, Any] | None:
    """The world's sun against the true one: azimuth and elevation errors, overcast or not.

    The errors are measured when both are sunny (the world's ``usdworld:lightMethod`` is
    ``cast_shadows``, or ``weak_fit`` whose default sun counts with its error, and the truth
    is not overcast); the azimuth error wraps at 360 degrees.

    Returns:
        ``{true_overcast, overcast, method, azimuth_error_deg, elevation_error_deg}`` (errors
        None when not both sunny), or None when the truth has no sun or the world no lights.
    """
    lights = stage.GetPrimAtPath(LIGHTS_PATH)
    if gt.sun_direction_world is None or not lights or not lights.GetAttribute("usdworld:lightMethod"):
        return None
    method = str(lights.GetAttribute("usdworld:lightMethod").Get())
    sun = lighting_from_stage(stage).sun_direction_world
    truth = gt.sun_direction_world
    both_sunny = method in ("cast_shadows", "weak_fit") and not gt.overcast
    az = math.degrees(math.atan2(sun[1], sun[0]) - math.atan2(truth[1], truth[0]))
    az = abs((az + 180.0) % 360.0 - 180.0)
    el = abs(math.degrees(math.asin(min(sun[2], 1.0)) - math.asin(min(truth[2], 1.0))))
    return {
        "true_overcast": bool(gt.overcast),
        "overcast": bool(lights.GetAttribute("usdworld:overcast").Get()),
        "method": method,
        "azimuth_error_deg": round(az, 3) if both_sunny else None,
        "elevation_error_deg": round(el, 3) if both_sunny else None,
    }
