"""The segmentation stage of ``build --segment`` and ``usdworld segment``: a model's labels
as the Cityscapes maps the rest of the pipeline reads, and writing them out.

The backend's output becomes a :class:`~usdworld.io.types.Segmentation` exactly like one
read from ``--labels`` and ``--instances``; its provenance is the model folder
(role ``segment_model``, digest of its files).
"""

from __future__ import annotations

import logging
from pathlib import Path

import cv2
import numpy as np

from usdworld.io.hashing import folder_identity
from usdworld.io.label_table import label_lookups, label_table
from usdworld.io.segment_labels import segment_labels
from usdworld.io.types import Detections, Segmentation, SourceImage
from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams
from usdworld.perception.classes import placed_class_for_label
from usdworld.perception.segment import make_backend

log = logging.getLogger(__name__)


def detection_boxes(detections: Detections | None) -> tuple[np.ndarray, tuple[str, ...]]:
    """Boxes of the detections of placed classes and their placed classes.

    Returns:
        boxes_px: (N, 4) float64 ``xmin, ymin, xmax, ymax``; classes: (N) placed class names.
        Both empty without detections.
    """
    lookups = label_lookups()
    items = [] if detections is None else [(placed_class_for_label(d.label, lookups), d.box_px) for d in detections.items]
    kept = [(c, b) for c, b in items if c is not None]
    return np.array([b for _, b in kept], dtype=np.float64).reshape(-1, 4), tuple(str(c) for c, _ in kept)


def segment_photo(
    backend: str,
    model_dir: Path | None,
    image: SourceImage,
    detections: Detections | None = None,
    params: PerceptionParams = DEFAULT_PERCEPTION,
    device: str | None = None,
) -> Segmentation:
    """Run a segmentation backend on the photo.

    Args:
        backend: a network backend name (``hf``).
        model_dir: the model folder.
        image: the photo.
        detections: 2D detections whose boxes split touching things of their class in a
            semantic model's output, or None.
        params: the perception parameters (``min_thing_area_px``: smallest instance kept).
        device: torch device, None for CUDA when available, else the CPU.

    Returns:
        The labels, as if read from ``--labels`` and ``--instances``; ``files`` holds the
        model folder's identity.

    Raises:
        InputError: a missing or unloadable model, or torch/transformers not installed.
    """
    net = make_backend(backend, model_dir, segment_labels(), label_lookups(), params.min_thing_area_px, device)
    boxes_px, box_classes = detection_boxes(detections)
    prediction = net.predict(image.rgb, boxes_px, box_classes)
    log.debug("segmentation: %s (%s)", prediction.name, prediction.kind)
    return Segmentation(
        label_ids=prediction.label_ids,
        instance_ids=prediction.instance_ids,
        files=(folder_identity(model_dir, "segment_model"),) if model_dir is not None else (),
    )


def colour_preview(label_ids: np.ndarray, instance_ids: np.ndarray | None = None) -> np.ndarray:
    """Cityscapes colours of a label map, with each instance's outline drawn in white.

    Args:
        label_ids: (H, W) uint8 Cityscapes label ids.
        instance_ids: (H, W) int32 instance ids, or None.

    Returns:
        (H, W, 3) uint8 RGB image.
    """
    palette = np.zeros((256, 3), dtype=np.uint8)
    for cls in label_table():
        palette[cls.id] = cls.color
    rgb = palette[np.asarray(label_ids)]
    if instance_ids is not None:
        inst = np.asarray(instance_ids)
        edge = np.zeros(inst.shape, dtype=bool)
        edge[:, 1:] |= inst[:, 1:] != inst[:, :-1]
        edge[1:, :] |= inst[1:, :] != inst[:-1, :]
        rgb[edge & (inst >= 1000)] = 255
    return rgb


def write_segment_outputs(seg: Segmentation, out_dir: Path, stem: str) -> dict[str, Path]:
    """Write Cityscapes-format maps and a colour preview.

    Args:
        seg: the labels (with instance ids).
        out_dir: folder to write into (created).
        stem: file name stem.

    Returns:
        Paths by kind: ``labels`` (``<stem>_labelIds.png``, 8-bit), ``instances``
        (``<stem>_instanceIds.png``, 16-bit), ``preview`` (``<stem>_color.png``).
    """
    from usdworld.atomic import ensure_output_dir, write_bytes_atomic

    ensure_output_dir(out_dir)
    paths = {
        "labels": out_dir / f"{stem}_labelIds.png",
        "instances": out_dir / f"{stem}_instanceIds.png",
        "preview": out_dir / f"{stem}_color.png",
    }
    instances = seg.instance_ids if seg.instance_ids is not None else seg.label_ids
    images = {
        "labels": np.ascontiguousarray(seg.label_ids, dtype=np.uint8),
        "instances": np.ascontiguousarray(instances).astype(np.uint16),
        "preview": np.ascontiguousarray(colour_preview(seg.label_ids, seg.instance_ids)[:, :, ::-1]),
    }
    for kind, path in paths.items():
        ok, data = cv2.imencode(".png", images[kind])
        write_bytes_atomic(path, data.tobytes())
    return paths
