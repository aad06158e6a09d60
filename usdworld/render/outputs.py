"""What ``usdworld render`` writes: colour, class, instance and depth images of one view.

Files it can write into the output folder (all atomically, PNGs without timestamps), by the
name that asks for them (:data:`OUTPUT_FILES`):

Data (:data:`DATA`, the default):

* ``render``: ``render.png``, the lit colour render (RGB).
* ``labelIds``: ``labelIds.png``, 8-bit Cityscapes label ids (sky, 23, where nothing was
  hit), the same format as ``*_gtFine_labelIds.png``.
* ``instanceIds``: ``instanceIds.png``, 16-bit Cityscapes instance ids (``class*1000+k`` for
  things, the label id for stuff, sky where nothing was hit).
* ``depth``: ``depth.npy``, (H, W) float32 depth along the optical axis in metres, 0 where
  nothing was hit.

Views for people (:data:`VIEWS`):

* ``class``: ``class.png``, Cityscapes colours of the class ids (sky colour where nothing was hit).
* ``instance``: ``instance.png``, one colour per object (stuff in its class colour, darkened).
* ``depth_png``: ``depth.png``, the depth colour-mapped (turbo on inverse depth; black: nothing hit).

Comparisons with the source photo (:data:`COMPARISONS`): ``side_by_side.png`` (photo |
render) and ``overlay.png`` (the photo with the class colours blended over it).

The group names ``data``, ``views``, ``comparisons`` and ``all`` stand for their files
(:data:`OUTPUT_GROUPS`). The images are made and PNG-encoded in parallel threads (OpenCV's
encoder releases the GIL) with the fast settings of :data:`PNG_PARAMS`.
"""

from __future__ import annotations

import functools
import io
import logging
import os
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from pxr import Usd, UsdGeom

from usdworld.atomic import ensure_output_dir, write_bytes_atomic
from usdworld.authoring.provenance import read_values
from usdworld.errors import CalibrationError, InputError, OutputError
from usdworld.io.label_table import label_table
from usdworld.render.camera import CameraPose, camera_from_usd
from usdworld.render.classes import label_id_for_class
from usdworld.render.renderer import RenderResult

log = logging.getLogger(__name__)

#: Label id written where the render hit nothing.
SKY_ID = label_id_for_class("sky")
#: Weight of the class colours in ``overlay.png``.
OVERLAY_ALPHA = 0.5
#: Prim path of the world's source camera and of the prim holding the scene facts.
SOURCE_CAMERA = "/World/SourceCamera"
WORLD_PRIM = "/World"
#: Render size used when a world records no image size.
FALLBACK_SIZE = (1024, 512)
#: How the PNGs are compressed: zlib level 1 with the run-length strategy after the Paeth
#: filter. Lossless like any PNG; on a 2048x1024 colour render about 5x faster than OpenCV's
#: default (level 6, adaptive filters) for a file about 10 % larger (BENCHMARKS.md, issue 21).
#: OpenCV before 4.10 has no filter choice and keeps its adaptive one.
PNG_PARAMS = (cv2.IMWRITE_PNG_COMPRESSION, 1, cv2.IMWRITE_PNG_STRATEGY, cv2.IMWRITE_PNG_STRATEGY_RLE) + (
    (cv2.IMWRITE_PNG_FILTER, cv2.IMWRITE_PNG_FILTER_PAETH) if hasattr(cv2, "IMWRITE_PNG_FILTER") else ()
)

#: Every file ``usdworld render`` can write, by the name that asks for it.
OUTPUT_FILES = {
    "render": "render.png",
    "labelIds": "labelIds.png",
    "instanceIds": "instanceIds.png",
    "depth": "depth.npy",
    "class": "class.png",
    "instance": "instance.png",
    "depth_png": "depth.png",
    "side_by_side": "side_by_side.png",
    "overlay": "overlay.png",
}
#: The passes as data (the default output).
DATA = ("render", "labelIds", "instanceIds", "depth")
#: The passes colourised for people.
VIEWS = ("class", "instance", "depth_png")
#: The comparisons with the source photo (written only when the photo is found or given).
COMPARISONS = ("side_by_side", "overlay")
#: Names that stand for several files.
OUTPUT_GROUPS = {"data": DATA, "views": VIEWS, "comparisons": COMPARISONS, "all": DATA + VIEWS + COMPARISONS}


# -- the world's view ------------------------------------------------------------------


def world_facts(stage: Usd.Stage) -> dict[str, Any]:
    """The ``usdworld:`` attributes of ``/World`` (empty for stages usdworld did not write)."""
    prim = stage.GetPrimAtPath(WORLD_PRIM)
    return read_values(prim) if prim else {}


def world_image_size(stage: Usd.Stage) -> tuple[int, int]:
    """(width, height) of the source image (``usdworld:imageSize``), else :data:`FALLBACK_SIZE`."""
    size = world_facts(stage).get("usdworld:imageSize")
    if size is not None and int(size[0]) > 0 and int(size[1]) > 0:
        return int(size[0]), int(size[1])
    return FALLBACK_SIZE


def world_source_image(stage: Usd.Stage) -> str:
    """File name of the source photo (``usdworld:sourceImage``), or ``""``."""
    return str(world_facts(stage).get("usdworld:sourceImage", "") or "")


def view_camera(
    stage: Usd.Stage, width: int, height: int, camera_path: str | None = None, time: float | None = None
) -> CameraPose:
    """K and pose of a camera prim (default the world's ``SourceCamera``) for a ``width`` x ``height`` image.

    ``time`` is the time code of its pose (a drive's ``/World/Ego/Camera`` moves); None for
    the default time.

    Raises:
        InputError: the path is not a prim of the stage.
        CalibrationError: the prim is not a usable camera.
    """
    path = camera_path or SOURCE_CAMERA
    try:
        prim = stage.GetPrimAtPath(path)
    except Exception:  # noqa: BLE001  (Sdf raises on malformed paths)
        prim = None
    if not prim:
        cams = [str(p.GetPath()) for p in stage.Traverse() if p.IsA(UsdGeom.Camera)]
        hint = f"cameras in the stage: {', '.join(cams)}" if cams else "the stage has no camera"
        raise InputError(f"--camera {path}: no such prim; {hint}")
    if not prim.IsA(UsdGeom.Camera):
        raise CalibrationError(f"--camera {path}: is a {prim.GetTypeName() or 'typeless'} prim, not a Camera")
    return camera_from_usd(prim, width, height, None if time is None else Usd.TimeCode(float(time)))


@functools.cache
def cityscapes_palette() -> np.ndarray:
    """(256, 3) uint8 RGB colour of every Cityscapes label id (black for unknown ids)."""
    palette = np.zeros((256, 3), dtype=np.uint8)
    for row in label_table():
        palette[row.id] = row.color
    palette.setflags(write=False)
    return palette


def label_ids_image(result: RenderResult) -> np.ndarray:
    """(H, W) uint8 Cityscapes label ids, sky where the render hit nothing."""
    return np.where(result.depth_m > 0, result.class_ids, SKY_ID).astype(np.uint8)


def instance_ids_image(result: RenderResult) -> np.ndarray:
    """(H, W) uint16 Cityscapes instance ids, sky where the render hit nothing."""
    return np.where(result.depth_m > 0, result.instance_ids, SKY_ID).astype(np.uint16)


def colorize_labels(label_ids: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 RGB Cityscapes colours of (H, W) label ids."""
    return cityscapes_palette()[np.clip(np.asarray(label_ids), 0, 255).astype(np.int64)]


def colorize_instances(instance_ids: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 RGB: a distinct colour per thing instance, stuff in darkened class colours."""
    ids = np.asarray(instance_ids).astype(np.int64)
    out = (colorize_labels(np.where(ids >= 1000, 0, ids)).astype(np.float64) * 0.5).astype(np.uint8)
    things = ids >= 1000
    if things.any():
        # A fixed hash of the id: golden-ratio hue steps, full saturation.
        hue = ((ids[things] * 0.61803398875) % 1.0 * 179).astype(np.uint8)
        hsv = np.stack([hue, np.full_like(hue, 200), np.full_like(hue, 255)], axis=-1)[None]
        out[things] = cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[0]
    return out


def colorize_depth(depth_m: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 RGB turbo colour map of inverse depth (near: red, far: blue; 0: black).

    The inverse depth is scaled between its 1st and 99th percentile over the hit pixels.
    """
    d = np.asarray(depth_m, dtype=np.float64)
    hit = d > 0
    out = np.zeros(d.shape + (3,), dtype=np.uint8)
    if not hit.any():
        return out
    inv = np.zeros_like(d)
    inv[hit] = 1.0 / d[hit]
    lo, hi = np.percentile(inv[hit], [1.0, 99.0])
    scaled = np.clip((inv - lo) / max(hi - lo, 1e-12), 0.0, 1.0)
    bgr = cv2.applyColorMap((scaled * 255).astype(np.uint8), cv2.COLORMAP_TURBO)
    out[hit] = bgr[hit][:, ::-1]
    return out


def fit_photo(photo_rgb: np.ndarray, width: int, height: int) -> np.ndarray:
    """The photo resized to ``width`` x ``height`` (area filter when shrinking)."""
    if photo_rgb.shape[:2] == (height, width):
        return photo_rgb
    shrink = photo_rgb.shape[1] > width
    return cv2.resize(
        photo_rgb, (width, height), interpolation=cv2.INTER_AREA if shrink else cv2.INTER_LINEAR
    )


def side_by_side(photo_rgb: np.ndarray, render_rgb: np.ndarray, gap_px: int = 4) -> np.ndarray:
    """(H, 2W + gap, 3) uint8: the photo (resized to the render) left, the render right."""
    h, w = render_rgb.shape[:2]
    gap = np.full((h, gap_px, 3), 255, dtype=np.uint8)
    return np.concatenate([fit_photo(photo_rgb, w, h), gap, render_rgb], axis=1)


def overlay(photo_rgb: np.ndarray, class_rgb: np.ndarray, alpha: float = OVERLAY_ALPHA) -> np.ndarray:
    """(H, W, 3) uint8: the photo with the class colours blended over it."""
    h, w = class_rgb.shape[:2]
    photo = fit_photo(photo_rgb, w, h).astype(np.float64)
    return np.clip((1.0 - alpha) * photo + alpha * class_rgb, 0, 255).astype(np.uint8)


def png_bytes(image: np.ndarray) -> bytes:
    """PNG encoding of an (H, W) grey (8/16-bit) or (H, W, 3) RGB uint8 image."""
    a = np.asarray(image)
    if a.ndim == 3:
        a = a[:, :, ::-1]  # OpenCV writes BGR
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(a), list(PNG_PARAMS))
    if not ok:
        raise OutputError("PNG encoding failed")
    return buf.tobytes()


def _npy_bytes(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array, allow_pickle=False)
    return buf.getvalue()


def read_photo(path: str | Path) -> np.ndarray:
    """(H, W, 3) uint8 RGB of a PNG or JPEG photo.

    Raises:
        InputError: missing or undecodable file.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such photo; pass --photo with the source image")
    img = cv2.imread(str(p), cv2.IMREAD_COLOR)
    if img is None:
        raise InputError(f"{p}: not a readable PNG or JPEG image")
    return img[:, :, ::-1].copy()


def find_beside_world(world_file: str | Path, name: str, extra_dirs: Sequence[Path] = ()) -> Path | None:
    """A file the world names (its photo, its labels) in the world's folder, the folder
    above, or ``extra_dirs``, in that order; None when absent.

    Args:
        world_file: the world's root layer.
        name: a bare file name, as recorded in ``usdworld:sourceImage`` / ``usdworld:inputFiles``.
        extra_dirs: more folders to look in (e.g. the bundled demo data).
    """
    if not name or Path(name).name != name:
        return None
    folder = Path(world_file).resolve().parent
    for directory in (folder, folder.parent, *extra_dirs):
        candidate = Path(directory) / name
        if candidate.is_file():
            return candidate
    return None


def parse_outputs(text: str) -> tuple[str, ...]:
    """``"data,class"`` -> the file names (:data:`OUTPUT_FILES` keys) asked for, in a fixed order.

    Raises:
        InputError: an unknown name, or nothing asked for.
    """
    names = [n.strip() for n in text.split(",") if n.strip()]
    wanted: set[str] = set()
    for name in names:
        if name in OUTPUT_GROUPS:
            wanted.update(OUTPUT_GROUPS[name])
        elif name in OUTPUT_FILES:
            wanted.add(name)
        else:
            choices = ", ".join([*OUTPUT_GROUPS, *OUTPUT_FILES])
            raise InputError(f"--write {text!r}: unknown output '{name}'; choose from {choices}")
    if not wanted:
        raise InputError(f"--write {text!r}: names no output; e.g. --write data or --write all")
    return tuple(n for n in OUTPUT_FILES if n in wanted)


def _encoders(
    result: RenderResult, photo_rgb: np.ndarray | None, outputs: Iterable[str]
) -> dict[str, Callable[[], bytes]]:
    """role -> a function making that file's bytes (independent, so they may run in parallel)."""
    wanted = set(outputs)
    labels = label_ids_image(result) if wanted & {"labelIds", "class", "overlay"} else None
    instances = instance_ids_image(result) if wanted & {"instanceIds", "instance"} else None
    class_rgb = colorize_labels(labels) if labels is not None and wanted & {"class", "overlay"} else None
    makers: dict[str, Callable[[], bytes]] = {
        "render": lambda: png_bytes(result.rgb),
        "labelIds": lambda: png_bytes(labels),
        "instanceIds": lambda: png_bytes(instances),
        "depth": lambda: _npy_bytes(result.depth_m.astype(np.float32)),
        "class": lambda: png_bytes(class_rgb),
        "instance": lambda: png_bytes(colorize_instances(instances)),
        "depth_png": lambda: png_bytes(colorize_depth(result.depth_m)),
    }
    if photo_rgb is not None:
        makers["side_by_side"] = lambda: png_bytes(side_by_side(photo_rgb, result.rgb))
        makers["overlay"] = lambda: png_bytes(overlay(photo_rgb, class_rgb))
    return {role: makers[role] for role in OUTPUT_FILES if role in wanted and role in makers}


def encode_render_outputs(
    result: RenderResult,
    photo_rgb: np.ndarray | None = None,
    outputs: Iterable[str] = OUTPUT_GROUPS["all"],
) -> dict[str, bytes]:
    """The bytes of every file asked for, made and encoded in a thread pool (one file per task).

    Args:
        result: all passes of one view.
        photo_rgb: (H', W', 3) uint8 source photo, or None: the comparisons are then left out.
        outputs: :data:`OUTPUT_FILES` keys (:func:`parse_outputs`); default every file.

    Returns:
        The files' bytes by role, in :data:`OUTPUT_FILES` order.
    """
    makers = _encoders(result, photo_rgb, outputs)
    with ThreadPoolExecutor(max_workers=max(1, min(len(makers), os.cpu_count() or 1))) as pool:
        futures = {role: pool.submit(make) for role, make in makers.items()}
        return {role: future.result() for role, future in futures.items()}  # re-raises a task's error


def write_render_outputs(
    out_dir: str | Path,
    result: RenderResult,
    photo_rgb: np.ndarray | None = None,
    outputs: Iterable[str] = OUTPUT_GROUPS["all"],
) -> dict[str, Path]:
    """Write the files asked for (see the module docstring) into ``out_dir``.

    Args:
        out_dir: folder to write into (created when missing).
        result: all passes of one view.
        photo_rgb: (H', W', 3) uint8 source photo, or None: the comparisons are then left out.
        outputs: :data:`OUTPUT_FILES` keys (:func:`parse_outputs`); default every file.

    Returns:
        Paths by role (:data:`OUTPUT_FILES` order) of the files written.

    Raises:
        OutputError: the folder cannot be created or written.
    """
    out = ensure_output_dir(out_dir)
    paths = {}
    for role, data in encode_render_outputs(result, photo_rgb, outputs).items():
        paths[role] = out / OUTPUT_FILES[role]
        write_bytes_atomic(paths[role], data)
    return paths
