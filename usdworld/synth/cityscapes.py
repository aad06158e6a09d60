"""Render a :class:`SynthScene` to Cityscapes-format files plus a ground-truth JSON.

Files written for ``name`` into ``out_dir``:

* ``<name>_leftImg8bit.png``: RGB, lit, with shadows and a sky gradient.
* ``<name>_gtFine_labelIds.png``: 8-bit Cityscapes label ids (sky 23 where no surface was hit).
* ``<name>_gtFine_instanceIds.png``: 16-bit, ``class*1000+k`` for thing pixels, the label id
  for stuff (sky 23), 0 for void.
* ``<name>_camera.json``: Cityscapes camera JSON; ``extrinsic`` x = y = 0 (the world origin is
  below the camera), z = camera height, pitch / roll / yaw in radians, baseline 0 (mono).
* ``<name>_gt.json``: camera, ``sun_direction_world`` (towards the sun) and ``overcast``
  (lit by the sky only: no direct sun, no shadows), street and per object ``name, class, label_id, instance_id,
  variant, centre_world [x, y, z_bottom], yaw_rad, size_m [l, w, h]`` (after scaling), the
  scale, the role and ``visible_pixels`` (0: hidden or outside the view), read from the same
  render as the label images, so instance ids match the instance map.

Every file is written atomically, and the same scene gives the same bytes.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from usdworld.atomic import write_bytes_atomic
from usdworld.errors import OutputError
from usdworld.render import Lighting, Renderer, RenderResult, RenderScene, label_id_for_class
from usdworld.render.lighting import overcast_lighting
from usdworld.synth.scene import SynthScene
from usdworld.synth.stage import OBJECTS, author_stage

#: Cityscapes label id of sky, written where the render hit nothing.
SKY_ID = label_id_for_class("sky")
GT_FORMAT = "usdworld-synth-gt/1"


def rounded(value: float, digits: int = 6) -> float:
    """``value`` rounded to ``digits`` decimals for the JSON files, with -0.0 written as 0.0."""
    v = round(float(value), digits)
    return 0.0 if v == 0 else v



def _png(image: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", image, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    if not ok:
        raise OutputError("PNG encoding failed")
    return buf.tobytes()


def json_bytes(doc: Any) -> bytes:
    """``doc`` as the synth files' JSON: two-space indent, a final newline, UTF-8."""
    return (json.dumps(doc, indent=2) + "\n").encode("utf-8")


def output_folder(out_dir: str | Path) -> Path:
    """``out_dir`` as a Path, created if missing.

    Raises:
        OutputError: it cannot be created.
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{out}: cannot create the output folder ({exc})") from None
    return out


def cityscapes_camera_json(scene: SynthScene) -> dict[str, Any]:
    """The Cityscapes camera document of the scene's camera."""
    cam = scene.camera
    return {
        "extrinsic": {
            "baseline": 0.0,
            "pitch": rounded(cam.pitch, 9),
            "roll": rounded(cam.roll, 9),
            "x": 0.0,
            "y": 0.0,
            "yaw": rounded(cam.yaw, 9),
            "z": rounded(cam.height_m, 9),
        },
        "intrinsic": {"fx": rounded(cam.fx, 9), "fy": rounded(cam.fy, 9), "u0": rounded(cam.cx, 9), "v0": rounded(cam.cy, 9)},
    }


def label_images(result: RenderResult) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) uint8 label ids and (H, W) uint16 instance ids, with sky where nothing was hit."""
    sky = result.depth_m == 0
    labels = np.where(sky, SKY_ID, result.class_ids)
    instances = np.where(sky, SKY_ID, result.instance_ids)
    return labels.astype(np.uint8), instances.astype(np.uint16)


def ground_truth(scene: SynthScene, render_scene: RenderScene, result: RenderResult) -> dict[str, Any]:
    """The ground-truth document (see the module docstring)."""
    cam = scene.camera
    by_path = render_scene.object_by_path()
    counts = np.bincount(result.object_ids.ravel(), minlength=len(render_scene.objects) + 1)
    objects = []
    for obj in scene.objects:
        rendered = by_path.get(f"{OBJECTS}/{obj.name}")
        objects.append(
            {
                "name": obj.name,
                "class": obj.class_name,
                "label_id": rendered.label_id if rendered else label_id_for_class(obj.class_name),
                "instance_id": rendered.instance_id if rendered else 0,
                "variant": obj.variant,
                "role": obj.role,
                "centre_world": [rounded(v) for v in obj.centre_world],
                "yaw_rad": rounded(obj.yaw),
                "size_m": [rounded(v) for v in obj.size_m],
                "scale": [rounded(v) for v in obj.scale],
                "visible_pixels": int(counts[rendered.index]) if rendered else 0,
            }
        )
    return {
        "format": GT_FORMAT,
        "camera": {
            "width": cam.width,
            "height": cam.height,
            "K": [[rounded(v, 9) for v in row] for row in cam.K],
            "height_m": rounded(cam.height_m, 9),
            "pitch": rounded(cam.pitch, 9),
            "roll": rounded(cam.roll, 9),
            "yaw": rounded(cam.yaw, 9),
        },
        "sun_direction_world": [rounded(v) for v in scene.sun_direction_world],
        "overcast": scene.overcast,
        "street": scene.street.to_json(),
        "objects": objects,
    }


def scene_lighting(scene: SynthScene) -> Lighting:
    """The lighting ``scene`` is rendered with: its sun, or the overcast sky when overcast."""
    if scene.overcast:
        return overcast_lighting(scene.sun_direction_world)
    return Lighting(sun_direction_world=scene.sun_direction_world)


def render_scene(scene: SynthScene) -> tuple[RenderScene, RenderResult]:
    """Author ``scene`` in memory and render every pass from its camera."""
    render_input = RenderScene.from_stage(author_stage(scene))
    cam = scene.camera
    with Renderer(cam.width, cam.height, lighting=scene_lighting(scene)) as r:
        result = r.render(render_input, cam.K, cam.world_from_cam())
    return render_input, result


def write_cityscapes_frame(scene: SynthScene, out_dir: str | Path, name: str) -> dict[str, Path]:
    """Render ``scene`` and write its Cityscapes-format files.

    Args:
        scene: the scene.
        out_dir: folder to write into (created if missing).
        name: file name prefix, e.g. ``demo_000000_000019``.

    Returns:
        Paths by role: ``image``, ``labels``, ``instances``, ``camera``, ``gt``.

    Raises:
        RenderError: no usable OpenGL.
        OutputError: the folder cannot be written.
    """
    out = output_folder(out_dir)
    render_input, result = render_scene(scene)
    labels, instances = label_images(result)
    paths = {
        "image": out / f"{name}_leftImg8bit.png",
        "labels": out / f"{name}_gtFine_labelIds.png",
        "instances": out / f"{name}_gtFine_instanceIds.png",
        "camera": out / f"{name}_camera.json",
        "gt": out / f"{name}_gt.json",
    }
    write_bytes_atomic(paths["image"], _png(result.rgb[:, :, ::-1]))
    write_bytes_atomic(paths["labels"], _png(labels))
    write_bytes_atomic(paths["instances"], _png(instances))
    write_bytes_atomic(paths["camera"], json_bytes(cityscapes_camera_json(scene)))
    write_bytes_atomic(paths["gt"], json_bytes(ground_truth(scene, render_input, result)))
    return paths
