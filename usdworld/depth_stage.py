"""The depth stage of ``build`` and ``usdworld depth``: backend, metric alignment, provenance.

``ground`` (the default) adds no dense map: objects are placed by their ground contact
and height cues. ``file`` reads a metric depth map. The networks predict a map that is
metric, relative, affine-invariant or a disparity; every non-metric output is aligned
to metres on the ground pixels against the camera's ground-plane depth (RANSAC + robust
refit), and the fit goes into the world's provenance. Metric outputs are used as they
are (their fit to the ground is still computed and recorded when possible, as a check).
"""

from __future__ import annotations

import io
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from usdworld.errors import CalibrationError, InputError
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.label_table import label_lookups
from usdworld.io.types import DepthMap, Segmentation, SourceImage
from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams
from usdworld.perception.depth import BACKEND_NAMES, align_to_ground, make_backend
from usdworld.perception.objects import ImageObject

log = logging.getLogger(__name__)

#: Cityscapes names used as ground for alignment.
ALIGN_GROUND = ("road", "sidewalk", "parking", "ground", "terrain")


@dataclass(frozen=True)
class DepthOutcome:
    """The dense depth a world was built with, and how it was made metric.

    Attributes:
        depth_map: metric depth, or None with the ``ground`` backend.
        source: backend and weights (``ground``, ``file:d.npy``, ``monodepth2:<folder>`` ...).
        kind: what the backend predicted (``metric``, ``relative``, ``affine_invariant``,
            ``disparity``; ``none`` for ``ground``).
        alignment: one line on the ground fit (scale, shift, inliers, residual, space),
            or why there is none.
        fit: (scale, shift, inlier ratio, residual metres); NaNs when no fit was made.
    """

    depth_map: DepthMap | None
    source: str
    kind: str
    alignment: str
    fit: tuple[float, float, float, float]


_NO_FIT = (float("nan"),) * 4


def ground_mask(image: SourceImage, camera: PinholeCamera, seg: Segmentation | None, objects: list[ImageObject]) -> np.ndarray:
    """(H, W) bool pixels to align on: ground classes, or (without labels) the area below
    the horizon outside every object's box."""
    if seg is not None:
        ids = [label_lookups().id_of(n) for n in ALIGN_GROUND]
        return np.isin(np.asarray(seg.label_ids), ids)
    mask = np.zeros((image.height, image.width), dtype=bool)
    top = int(np.clip(np.ceil(camera.horizon_v()) + 0.05 * image.height, 0, image.height))
    mask[top:] = True
    for o in objects:
        x0, y0, x1, y1 = (int(b) for b in o.box_px)
        mask[y0:y1, x0:x1] = False
    return mask


def estimate_depth(
    backend: str,
    weights: Path | None,
    depth_file: Path | None,
    image: SourceImage,
    camera: PinholeCamera,
    seg: Segmentation | None,
    objects: list[ImageObject],
    params: PerceptionParams = DEFAULT_PERCEPTION,
) -> DepthOutcome:
    """Run the chosen depth backend and make its output metric.

    Args:
        backend: one of :data:`BACKEND_NAMES`.
        weights: network weights (file or folder) for the network backends.
        depth_file: depth map for ``file`` (also implies ``file`` when given alone).
        image: the photo.
        camera: the source camera.
        seg: labels, for the alignment's ground pixels.
        objects: image objects (kept out of the ground pixels without labels).
        params: the alignment's RANSAC tolerance and limits.

    Raises:
        InputError: unknown backend, missing or bad weights, bad depth file.
    """
    if backend not in BACKEND_NAMES:
        raise InputError(f"--depth {backend}: unknown backend; choose one of {', '.join(BACKEND_NAMES)}")
    if depth_file is not None and backend not in ("file", "ground"):
        raise InputError(f"--depth-map is the input of --depth file, not of --depth {backend}; drop one of them")
    if depth_file is not None:
        backend = "file"
    if backend == "ground":
        return DepthOutcome(None, "ground", "none", "none: objects placed by ground contact and height", _NO_FIT)
    if backend == "file":
        if depth_file is None:
            raise InputError("--depth file needs --depth-map FILE (.npy, 16-bit PNG in metres*256, or .pfm)")
        from usdworld.io.depth_files import read_depth  # only a build with --depth-map reads one

        depth = read_depth(depth_file, image)
        return DepthOutcome(depth, f"file:{depth_file.name}", "metric", "none: the file is metric", _NO_FIT)
    prediction = make_backend(backend, weights).predict(np.asarray(image.rgb), camera)
    mask = ground_mask(image, camera, seg, objects)
    source = f"{backend}:{weights.name if weights is not None else ''}"
    try:
        fit, aligned = align_to_ground(prediction, mask, camera, params=params)
    except CalibrationError as exc:
        if prediction.kind == "metric":
            return DepthOutcome(prediction.to_depth_map(), source, "metric", f"none: {exc}", _NO_FIT)
        raise CalibrationError(
            f"depth from {backend} is {prediction.kind} and cannot be made metric: {exc}; "
            "pass labels with road pixels, or use --depth ground"
        ) from exc
    line = (
        f"{fit.space} fit to {fit.n_pixels} ground px: scale {fit.scale:.4g}, shift {fit.shift:.4g}, "
        f"inliers {fit.inlier_ratio:.0%}, residual {fit.residual_m:.3g}"
    )
    numbers = (fit.scale, fit.shift, fit.inlier_ratio, fit.residual_m)
    if prediction.kind == "metric":
        log.info("metric depth kept as predicted; its ground fit for reference: %s", line)
        return DepthOutcome(prediction.to_depth_map(), source, "metric", "reference only: " + line, numbers)
    return DepthOutcome(aligned, source, prediction.kind, line, numbers)


def write_depth_outputs(depth: DepthMap, out_dir: Path, stem: str) -> dict[str, Path]:
    """Write a metric depth map as ``.npy``, 16-bit PNG (metres*256) and a colour preview.

    Args:
        depth: the metric depth.
        out_dir: folder to write into (created).
        stem: file name stem.

    Returns:
        Paths by kind: ``npy``, ``png16``, ``preview``.
    """
    import cv2

    from usdworld.atomic import ensure_output_dir, write_bytes_atomic
    from usdworld.io.depth_files import write_depth_png16

    ensure_output_dir(out_dir)
    values = np.where(depth.valid, depth.depth_m, 0.0).astype(np.float32)
    paths = {"npy": out_dir / f"{stem}_depth.npy", "png16": out_dir / f"{stem}_depth.png", "preview": out_dir / f"{stem}_depth_preview.png"}
    buffer = io.BytesIO()
    np.save(buffer, values)
    write_bytes_atomic(paths["npy"], buffer.getvalue())
    write_depth_png16(paths["png16"], values)
    # Preview: inverse depth (near = bright) through a perceptual colour map; invalid black.
    inv = np.zeros_like(values)
    inv[depth.valid] = 1.0 / np.maximum(values[depth.valid], 0.1)
    hi = np.percentile(inv[depth.valid], 99) if depth.valid.any() else 1.0
    grey = np.clip(inv / max(hi, 1e-6) * 255.0, 0, 255).astype(np.uint8)
    preview = cv2.applyColorMap(grey, cv2.COLORMAP_MAGMA)
    preview[~depth.valid] = 0
    ok, data = cv2.imencode(".png", preview)
    write_bytes_atomic(paths["preview"], data.tobytes())
    return paths
