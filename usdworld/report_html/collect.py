"""Gather what the report page shows: ``report.json``, the photo, a render and the evaluation.

The world's ``report.json`` is the build's record (camera, every object's cues and
placement). The composed stage adds what edits changed since (objects moved, deleted or
added). The render, the overlay and the evaluation need headless OpenGL (the ``render``
extra): without it the page says why they are missing and shows the photo alone.

This module reads USD and renders, so it sits downstream of ``render`` and ``evaluation``.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from usdworld.authoring.inspect import open_world
from usdworld.demo import demo_dir
from usdworld.errors import InputError
from usdworld.evaluation import (
    evaluate_world,
    find_beside_world,
    read_ground_truth,
    read_label_ids,
    world_input_names,
)
from usdworld.evaluation.world_objects import world_objects
from usdworld.render import Renderer, RenderError, RenderScene
from usdworld.render.world_lights import lighting_from_stage
from usdworld.render.outputs import (
    colorize_labels,
    label_ids_image,
    overlay,
    png_bytes,
    read_photo,
    view_camera,
    world_image_size,
)

log = logging.getLogger(__name__)

#: Distance (m) beyond which an object's position on the stage counts as moved since the
#: build; report.json rounds to 1e-6 m, so anything above this tolerance is an edit.
MOVED_TOLERANCE_M = 1e-4


@dataclass(frozen=True)
class PageImages:
    """The page's images, encoded, and why any of them is missing.

    Attributes:
        photo: (bytes, MIME type) of the source photo as found on disk, or None.
        render: PNG of the render from the source camera, or None.
        overlay: PNG of the photo with the rendered class colours over it, or None.
        notes: one sentence per missing image, saying why.
    """

    photo: tuple[bytes, str] | None
    render: bytes | None
    overlay: bytes | None
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class PageInputs:
    """Everything the report page shows.

    Attributes:
        world_file: the world's root layer.
        report: the content of the world's ``report.json``.
        states: object name -> ``built``, ``moved``, ``deleted`` or ``added`` (from the stage).
        added: objects on the stage that the build did not place: ``name``, ``class``, ``position_world``.
        images: photo, render and overlay.
        evaluation: :meth:`usdworld.evaluation.Evaluation.to_json` output, or None.
        evaluation_notes: why parts of the evaluation are missing.
    """

    world_file: Path
    report: dict[str, Any] = field(repr=False)
    states: dict[str, str]
    added: tuple[dict[str, Any], ...]
    images: PageImages
    evaluation: dict[str, Any] | None
    evaluation_notes: tuple[str, ...] = ()


def read_report_json(world_file: Path) -> dict[str, Any]:
    """The ``report.json`` beside a world's root layer.

    Raises:
        InputError: missing, not JSON, or without the ``objects`` and ``camera`` entries.
    """
    path = world_file.parent / "report.json"
    if not path.is_file():
        raise InputError(
            f"{path}: no such file; the report needs the report.json that `usdworld build` writes"
        )
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not valid JSON ({exc}); rebuild the world") from None
    if (
        not isinstance(doc, dict)
        or not isinstance(doc.get("objects"), list)
        or not isinstance(doc.get("camera"), dict)
    ):
        raise InputError(f"{path}: has no 'objects' list and 'camera' entry; is it a usdworld report.json?")
    return doc


def image_mime(data: bytes) -> str | None:
    """``image/png`` or ``image/jpeg`` from the first bytes, else None."""
    if data.startswith(b"\x89PNG\r\n\x1a\n"):
        return "image/png"
    if data.startswith(b"\xff\xd8\xff"):
        return "image/jpeg"
    return None


def object_states(stage: Any, report: dict[str, Any]) -> tuple[dict[str, str], tuple[dict[str, Any], ...]]:
    """How each built object stands on the composed stage now, and the objects edits added.

    Returns:
        (name -> ``built`` | ``moved`` | ``deleted``, added objects as ``name``, ``class``, ``position_world``).
    """
    now = {o.name: o for o in world_objects(stage)}
    states = {}
    for o in report["objects"]:
        placed = now.get(o["name"])
        pos = o.get("position_world") or []
        if placed is None:
            states[o["name"]] = "deleted"
        elif (
            len(pos) == 3
            and None not in pos
            and np.linalg.norm(placed.bottom_centre_world - np.array(pos)) > MOVED_TOLERANCE_M
        ):
            states[o["name"]] = "moved"
        else:
            states[o["name"]] = "built"
    added = tuple(
        {
            "name": o.name,
            "class": o.class_name,
            "position_world": [round(float(v), 6) for v in o.bottom_centre_world],
        }
        for name, o in now.items()
        if name not in states
    )
    return states, added


def collect(
    world: str | Path,
    labels: Path | None = None,
    gt: Path | None = None,
    calib: Path | None = None,
    photo: Path | None = None,
    nuscenes_camera: str = "CAM_FRONT",
) -> PageInputs:
    """Read a world and render it from its source camera, for the report page.

    Args:
        world: the world's ``world.usda`` or its folder.
        labels: Cityscapes ``*_gtFine_labelIds.png`` (default: the world's labels input, found next to it).
        gt: 3D ground truth (synth ``*_gt.json``, KITTI ``label_2`` or nuScenes info JSON), or None.
        calib: KITTI calib for a ``label_2`` ground truth (default: found by its name).
        photo: the source photo (default: found next to the world).
        nuscenes_camera: camera of a nuScenes info file.

    Raises:
        InputError: not a world, no usable report.json, or unreadable labels, ground truth or photo.
    """
    stage = open_world(world)
    root = Path(stage.GetRootLayer().realPath)
    report = read_report_json(root)
    states, added = object_states(stage, report)
    notes: list[str] = []
    eval_notes: list[str] = []
    if photo is None:
        photo = find_beside_world(root, str(report.get("source_image") or ""), [demo_dir()])
        if photo is None:
            notes.append(
                f"source photo {report.get('source_image') or '(none recorded)'} not found next to the world; pass --photo"
            )
    photo_rgb = read_photo(photo) if photo is not None else None
    if photo is None:
        eval_notes.append("no SSIM: the source photo was not found; pass --photo")
    photo_entry = None
    if photo is not None:
        data = photo.read_bytes()
        photo_entry = (data, image_mime(data) or "image/png")
    if labels is None:
        name = world_input_names(stage).get("labels", "")
        labels = find_beside_world(root, name, [demo_dir()])
        if labels is None:
            eval_notes.append(
                f"no layout IoU: {name} not found next to the world; pass --labels"
                if name
                else "no layout IoU: the world was built without labels; pass --labels"
            )
    label_ids = read_label_ids(labels) if labels is not None else None
    truth = read_ground_truth(gt, calib, nuscenes_camera) if gt is not None else None
    if truth is None:
        eval_notes.append(
            "no 3D errors: pass --gt with a synth *_gt.json, KITTI label_2 file or nuScenes info JSON"
        )
    render = overlay_png = None
    evaluation = None
    width, height = world_image_size(stage)
    try:
        scene = RenderScene.from_stage(stage)
        pose = view_camera(stage, width, height)
        with Renderer(width, height, lighting=lighting_from_stage(stage)) as renderer:
            result = renderer.render(scene, pose.K, pose.world_from_cam)
            # labels of another size: evaluate_world renders at their size with a renderer of its own
            same_size = label_ids is None or label_ids.shape == (height, width)
            evaluation = evaluate_world(
                stage, labels=label_ids, photo=photo_rgb, gt=truth, renderer=renderer if same_size else None
            ).to_json()
    except RenderError as exc:
        log.warning("no render: %s", exc)
        notes.append(f"no render, overlay or evaluation: {exc}")
        eval_notes.append(f"no evaluation: it renders the world, and rendering is unavailable ({exc})")
    else:
        render = png_bytes(result.rgb)
        if photo_rgb is not None:
            overlay_png = png_bytes(overlay(photo_rgb, colorize_labels(label_ids_image(result))))
        else:
            notes.append("no overlay: it needs the source photo")
    return PageInputs(
        world_file=root,
        report=report,
        states=states,
        added=added,
        images=PageImages(photo_entry, render, overlay_png, tuple(notes)),
        evaluation=evaluation,
        evaluation_notes=tuple(eval_notes),
    )
