"""Measure a world against its inputs: layout IoU, photo SSIM and 3D object errors.

Public API:

* :func:`evaluate_world` ``(stage, labels, photo, gt) -> Evaluation`` (``.to_json()``).
* :func:`read_ground_truth`: synth ``*_gt.json``, KITTI ``label_2`` (+ calib), nuScenes info JSON.
* :func:`iou_per_class`, :func:`mean_iou`, :func:`label_similarity`, :func:`placeable_label_ids`.
* :func:`ssim`: structural similarity (Wang et al. 2004).
"""

from __future__ import annotations

from usdworld.evaluation.evaluate import (
    Evaluation,
    evaluate_world,
    ids_match_world,
    read_label_ids,
    world_input_names,
)
from usdworld.evaluation.ground_truth import GroundTruth, GtObject, read_ground_truth
from usdworld.evaluation.segmentation import (
    STUDY_CLASSES,
    class_counts,
    ignored_mask,
    iou_per_class,
    label_similarity,
    mean_iou,
    placeable_label_ids,
)
from usdworld.evaluation.ssim import ssim, ssim_map
from usdworld.render.outputs import find_beside_world

__all__ = [
    "STUDY_CLASSES",
    "Evaluation",
    "GroundTruth",
    "GtObject",
    "class_counts",
    "evaluate_world",
    "find_beside_world",
    "ids_match_world",
    "ignored_mask",
    "iou_per_class",
    "label_similarity",
    "mean_iou",
    "placeable_label_ids",
    "read_ground_truth",
    "read_label_ids",
    "ssim",
    "ssim_map",
    "world_input_names",
]
