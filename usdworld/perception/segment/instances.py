"""Cityscapes instance ids from a segmentation model's output.

* Semantic models label classes, not objects: :func:`instances_from_semantic` splits each
  thing class into 8-connected components; a component that reaches into two or more
  detection boxes of its own placed class (a car blob by ``car`` boxes) is split between them (a pixel inside several boxes goes to the box
  whose bottom edge is lowest: on a flat street that object is the nearest, so it is in
  front), and its pixels outside every box form components of their own.
* Panoptic models give objects: :func:`instances_from_panoptic` numbers the segments of
  each thing class.

Instance ids follow Cityscapes: ``class*1000+k`` with ``k`` counting from 0 per class in
reading order (the row-major position of each piece's first pixel), the label id where a
thing has no instance (pieces below the smallest kept thing area, or beyond 1000 per class).
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from usdworld.errors import InputError
from usdworld.io.label_table import LabelLookups

#: Instances one class can hold in a Cityscapes instance id (``class*1000+k``, k < 1000).
MAX_INSTANCES_PER_CLASS = 1000


def _components(mask: np.ndarray) -> list[np.ndarray]:
    """(H, W) bool -> flat pixel indices of each 8-connected component."""
    n, comp = cv2.connectedComponents(mask.astype(np.uint8), connectivity=8, ltype=cv2.CV_32S)
    if n <= 1:
        return []
    flat = comp.ravel()
    order = np.argsort(flat, kind="stable")
    starts = np.searchsorted(flat[order], np.arange(1, n + 1))
    return [order[starts[i] : starts[i + 1]] for i in range(n - 1)]


def _split_by_boxes(pixels: np.ndarray, width: int, boxes_px: np.ndarray, shape: tuple[int, int]) -> list[np.ndarray]:
    """One component's flat pixel indices, split between the boxes that hold them.

    Args:
        pixels: (P,) int64 flat indices of the component.
        width: image width.
        boxes_px: (N, 4) float64 ``xmin, ymin, xmax, ymax`` (exclusive max edges).
        shape: (H, W) of the image.
    """
    v, u = np.divmod(pixels, width)
    inside = (
        (u[:, None] >= boxes_px[None, :, 0])
        & (u[:, None] < boxes_px[None, :, 2])
        & (v[:, None] >= boxes_px[None, :, 1])
        & (v[:, None] < boxes_px[None, :, 3])
    )
    holding = np.flatnonzero(inside.any(axis=0))
    if len(holding) < 2:
        return [pixels]
    # Among the boxes holding a pixel, the one with the lowest bottom edge (ties: first box).
    bottoms = np.where(inside, boxes_px[None, :, 3], -np.inf)
    owner = np.argmax(bottoms, axis=1)
    in_box = inside.any(axis=1)
    pieces = [pixels[in_box & (owner == b)] for b in holding]
    rest = pixels[~in_box]
    if len(rest):
        mask = np.zeros(shape, dtype=bool)
        mask.ravel()[rest] = True
        pieces.extend(_components(mask))
    return [p for p in pieces if len(p)]


def instances_from_semantic(
    label_ids: np.ndarray,
    lookups: LabelLookups,
    min_area_px: int,
    boxes_px: np.ndarray | None = None,
    box_classes: Sequence[str] = (),
) -> np.ndarray:
    """Instance ids for a semantic label map (module docstring).

    Args:
        label_ids: (H, W) uint8 Cityscapes label ids.
        lookups: the Cityscapes table's arrays (which ids are things).
        min_area_px: pieces smaller than this get no instance (the perception stage's
            smallest thing, ``perception.min_thing_area_px``).
        boxes_px: (N, 4) float64 detection boxes ``xmin, ymin, xmax, ymax``, or None.
        box_classes: (N) the placed class of each box (``car``, ``person`` ...); a box
            splits only components whose label is placed as the same class.

    Returns:
        (H, W) int32 Cityscapes instance ids.

    Raises:
        InputError: ``box_classes`` does not give one class per box.
    """
    labels = np.asarray(label_ids)
    h, w = labels.shape
    instances = labels.astype(np.int32)
    boxes = np.zeros((0, 4)) if boxes_px is None else np.asarray(boxes_px, dtype=np.float64).reshape(-1, 4)
    classes = np.array(list(box_classes), dtype=object)
    if len(classes) != len(boxes):
        raise InputError(f"detection boxes: {len(boxes)} boxes but {len(classes)} classes; give one class per box")
    flat = instances.ravel()
    present = np.flatnonzero(np.bincount(labels.ravel(), minlength=256))
    for label in (int(i) for i in present if lookups.is_thing[i]):
        own = boxes[classes == lookups.placed[label]] if len(boxes) else boxes
        pieces: list[np.ndarray] = []
        for component in _components(labels == label):
            pieces.extend(_split_by_boxes(component, w, own, (h, w)) if len(own) > 1 else [component])
        kept = sorted((p for p in pieces if len(p) >= min_area_px), key=lambda p: int(p.min()))
        for k, piece in enumerate(kept[:MAX_INSTANCES_PER_CLASS]):
            flat[piece] = label * 1000 + k
    return instances


def instances_from_panoptic(
    segment_map: np.ndarray,
    segments: Sequence[tuple[int, int]],
    class_label_ids: np.ndarray,
    lookups: LabelLookups,
) -> tuple[np.ndarray, np.ndarray]:
    """Cityscapes label and instance ids of a panoptic segment map.

    Args:
        segment_map: (H, W) integer segment id per pixel; ids not in ``segments`` (0, -1:
            no segment) become ``unlabeled``.
        segments: (segment id, model class index) of each segment.
        class_label_ids: (N,) uint8 Cityscapes label id of each model class
            (:class:`~usdworld.perception.segment.classes.ClassMap`).
        lookups: the Cityscapes table's arrays.

    Returns:
        label_ids: (H, W) uint8; instance_ids: (H, W) int32.
    """
    seg = np.asarray(segment_map).astype(np.int64)
    known = [(int(s), int(c)) for s, c in segments if int(s) >= 0]
    top = max([int(seg.max(initial=0))] + [s for s, _ in known]) + 1
    label_of = np.full(top + 1, lookups.id_of("unlabeled"), dtype=np.int64)  # index top: negative ids
    instance_of = label_of.copy()
    counts: dict[int, int] = {}
    for segment_id, model_class in sorted(known):
        label = int(class_label_ids[model_class])
        label_of[segment_id] = instance_of[segment_id] = label
        if lookups.is_thing[label]:
            k = counts.get(label, 0)
            counts[label] = k + 1
            if k < MAX_INSTANCES_PER_CLASS:
                instance_of[segment_id] = label * 1000 + k
    index = np.where(seg >= 0, seg, top)
    return label_of[index].astype(np.uint8), instance_of[index].astype(np.int32)
