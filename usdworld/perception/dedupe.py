"""Merge detections of one object seen twice: greedy non-maximum suppression per class.

A detector's raw output lists each object several times with slightly shifted boxes, and
a label file may repeat a line. Left alone, each copy becomes an object of its own that
collision resolution must push out of the others' way, so a few hundred copies of one
car make a slow pile of cars. Two thresholds of :class:`CollisionParams` decide what is
one object:

* ``duplicate_iou`` (0.95) always applies: two real objects of one class cannot fill
  95 % of the same box (the farther one projects smaller and higher);
* above ``dense_detections`` thing detections in one image, ``dense_iou`` (0.7) applies
  instead, the usual suppression threshold of a detector's proposals: such an input is
  a raw output rather than a scene (KITTI's densest frames have about 40 objects).

Of each group the highest score is kept (ties: the earlier object in the list); what the
kept object's bottom was hidden by is redirected to the survivor of a merged occluder.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np

from usdworld.parameters.collision import CollisionParams
from usdworld.perception.objects import ImageObject

log = logging.getLogger(__name__)


def box_iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Intersection over union of one box with many.

    Args:
        box: (4,) float64 ``xmin, ymin, xmax, ymax``, pixels (edges).
        boxes: (N, 4) float64, the same layout.

    Returns:
        (N,) float64 IoU in [0, 1]; 0 where both boxes are empty.
    """
    box = np.asarray(box, dtype=np.float64)
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    w = np.clip(np.minimum(box[2], boxes[:, 2]) - np.maximum(box[0], boxes[:, 0]), 0.0, None)
    h = np.clip(np.minimum(box[3], boxes[:, 3]) - np.maximum(box[1], boxes[:, 1]), 0.0, None)
    inter = w * h
    area = (box[2] - box[0]) * (box[3] - box[1])
    areas = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
    union = area + areas - inter
    return np.divide(inter, union, out=np.zeros_like(inter), where=union > 0)


def suppress(boxes: np.ndarray, scores: np.ndarray, classes: list[str], iou: float) -> np.ndarray:
    """Greedy non-maximum suppression within each class.

    Args:
        boxes: (N, 4) float64 ``xmin, ymin, xmax, ymax``, pixels.
        scores: (N,) float64 confidences; higher is kept first, ties by index.
        classes: N class names; boxes of different classes never suppress each other.
        iou: a box is dropped when its IoU with a kept box of its class is at least this.

    Returns:
        (N,) int64: for each box the index of the box it was merged into (itself when kept).
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    scores = np.asarray(scores, dtype=np.float64).reshape(-1)
    _, cls = np.unique(np.array(classes, dtype=object), return_inverse=True)
    order = np.argsort(-scores, kind="stable")
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    into = np.full(len(boxes), -1, dtype=np.int64)
    for i in order:
        if into[i] >= 0:
            continue
        into[i] = i
        rest = np.nonzero((into < 0) & (cls == cls[i]) & (rank > rank[i]))[0]
        if len(rest):
            into[rest[box_iou(boxes[i], boxes[rest]) >= iou]] = i
    return into


def merge_duplicates(objects: list[ImageObject], params: CollisionParams = CollisionParams()) -> list[ImageObject]:
    """Drop thing objects that repeat another of the same class (see the module docstring).

    Args:
        objects: objects from detections (stuff regions, ``instance_id`` -1, pass through).
        params: ``duplicate_iou``, ``dense_detections`` and ``dense_iou``.

    Returns:
        The kept objects in their input order; a warning says how many were merged.
    """
    things = [k for k, o in enumerate(objects) if o.is_thing]
    if len(things) < 2:
        return list(objects)
    dense = len(things) > params.dense_detections
    iou = params.dense_iou if dense else params.duplicate_iou
    into = suppress(
        np.array([objects[k].box_px for k in things], dtype=np.float64),
        np.array([objects[k].score for k in things]),
        [objects[k].class_name for k in things],
        iou,
    )
    merged = int(np.count_nonzero(into != np.arange(len(things))))
    if merged == 0:
        return list(objects)
    survivor = {objects[things[k]].ref: objects[things[int(t)]].ref for k, t in enumerate(into)}
    dropped = {things[k] for k, t in enumerate(into) if t != k}
    log.warning(
        "merged %d of %d thing detections into the box they repeat (same class, box IoU >= %g%s)",
        merged,
        len(things),
        iou,
        f"; more than {params.dense_detections} detections" if dense else "",
    )
    kept = []
    for k, o in enumerate(objects):
        if k in dropped:
            continue
        occ = survivor.get(o.occluded_by, o.occluded_by)
        kept.append(o if occ in (o.occluded_by, o.ref) else dataclasses.replace(o, occluded_by=occ))
    return kept
