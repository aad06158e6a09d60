"""Per-class IoU of a rendered class map against Cityscapes label ids.

Before comparing, the input labels are mapped onto what a world can place
(:func:`placeable_label_ids`): a Cityscapes class that usdworld places *as* another class
counts as that class (``wall`` -> ``fence``, ``caravan`` / ``trailer`` -> ``truck``,
``polegroup`` -> ``pole``; rule 1 of :mod:`usdworld.render.classes`), and ``parking`` counts
as ``road`` (the road surface is meshed from both). Pixels whose input label is in the
Cityscapes ``void`` category (unlabeled, ego vehicle, rectification border, out of roi,
static, dynamic, ground) are ignored, as the Cityscapes benchmark does.

IoU of class ``c`` is ``|P & G| / |P | G|`` over the non-ignored pixels, where ``P`` are the
pixels rendered as ``c`` and ``G`` the pixels labelled ``c``; it is NaN when both are
empty (the class is absent from both maps) and such classes are left out of the mean.

Example:
    >>> pred = np.array([[26, 26], [7, 7]])
    >>> gt = np.array([[26, 7], [7, 7]])
    >>> iou_per_class(pred, gt, [26, 7])
    {26: 0.5, 7: 0.6666666666666666}
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from usdworld.errors import InputError
from usdworld.io.label_table import label_table
from usdworld.render.classes import label_id_for_class

#: Extra merges for the ground surfaces (the pipeline meshes road from road + parking).
SURFACE_MERGES = {"parking": "road"}
#: The four classes the T1 study's mIoU is reported over (Cityscapes label ids).
STUDY_CLASSES: Mapping[str, int] = {"car": 26, "person": 24, "vegetation": 21, "building": 11}


@functools.cache
def _lookup() -> tuple[np.ndarray, np.ndarray]:
    """(256,) int32 label id -> placeable id, and (256,) bool 'ignored' (void category)."""
    remap = np.arange(256, dtype=np.int32)
    ignore = np.zeros(256, dtype=bool)
    for row in label_table():
        if row.category == "void":
            ignore[row.id] = True
            continue
        target = SURFACE_MERGES.get(row.name, row.placed_as)
        if target:
            tid = label_id_for_class(target)
            if tid:
                remap[row.id] = tid
    remap.setflags(write=False)
    ignore.setflags(write=False)
    return remap, ignore


def placeable_label_ids(label_ids: np.ndarray) -> np.ndarray:
    """Input label ids mapped onto the ids a world renders (see the module docstring).

    Args:
        label_ids: (H, W) integer Cityscapes label ids (0..255).

    Returns:
        (H, W) int32 label ids.
    """
    a = np.asarray(label_ids)
    if a.size and (a.min() < 0 or a.max() > 255):
        raise InputError(f"label ids must be in 0..255, got {int(a.min())}..{int(a.max())}")
    return _lookup()[0][a.astype(np.int64)]


def ignored_mask(label_ids: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels whose input label is in the Cityscapes void category."""
    a = np.asarray(label_ids).astype(np.int64)
    return _lookup()[1][np.clip(a, 0, 255)]


def _check_pair(pred: np.ndarray, gt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    pred, gt = np.asarray(pred), np.asarray(gt)
    if pred.shape != gt.shape or pred.ndim != 2:
        raise InputError(
            f"class maps must be two images of the same size, got {pred.shape} and {gt.shape}; "
            "render at the labels' size"
        )
    return pred, gt


@dataclass(frozen=True)
class ClassCounts:
    """Pixel counts of one class: ``intersection`` = |P & G|, ``union`` = |P | G|."""

    intersection: int
    union: int

    @property
    def iou(self) -> float:
        return self.intersection / self.union if self.union else float("nan")


def confusion_matrix(pred: np.ndarray, gt: np.ndarray, ignore: np.ndarray | None = None) -> np.ndarray:
    """(256, 256) int64 pixel counts ``[rendered id, reference id]`` over the kept pixels.

    Args:
        pred: (H, W) integer rendered class ids in 0..255.
        gt: (H, W) integer reference class ids in 0..255.
        ignore: (H, W) bool pixels to leave out, or None.
    """
    pred, gt = _check_pair(pred, gt)
    p = pred.astype(np.int64).ravel()
    g = gt.astype(np.int64).ravel()
    if ignore is not None:
        keep = ~np.asarray(ignore, dtype=bool).ravel()
        p, g = p[keep], g[keep]
    if p.size and (p.min() < 0 or p.max() > 255 or g.min() < 0 or g.max() > 255):
        raise InputError("class ids must be in 0..255")
    return np.bincount(p * 256 + g, minlength=256 * 256).reshape(256, 256)


def counts_from_confusion(cm: np.ndarray, class_ids: Iterable[int]) -> dict[int, ClassCounts]:
    """Intersection and union per class from a :func:`confusion_matrix`."""
    out = {}
    for c in class_ids:
        c = int(c)
        inter = int(cm[c, c])
        out[c] = ClassCounts(inter, int(cm[c, :].sum() + cm[:, c].sum()) - inter)
    return out


def class_counts(
    pred: np.ndarray, gt: np.ndarray, class_ids: Iterable[int], ignore: np.ndarray | None = None
) -> dict[int, ClassCounts]:
    """Intersection and union pixel counts per class (sum them over images for a dataset IoU).

    Args:
        pred: (H, W) integer rendered class ids (0..255).
        gt: (H, W) integer reference class ids (0..255, already mapped, e.g. by
            :func:`placeable_label_ids`).
        class_ids: the classes to count.
        ignore: (H, W) bool pixels to leave out, or None.
    """
    return counts_from_confusion(confusion_matrix(pred, gt, ignore), class_ids)


def iou_per_class(
    pred: np.ndarray, gt: np.ndarray, class_ids: Iterable[int], ignore: np.ndarray | None = None
) -> dict[int, float]:
    """IoU per class (NaN when the class is in neither map); arguments as :func:`class_counts`."""
    return {c: k.iou for c, k in class_counts(pred, gt, class_ids, ignore).items()}


def mean_iou(ious: Mapping[int, float] | Mapping[str, float] | Iterable[float]) -> float:
    """Mean of the finite IoUs; NaN when there is none."""
    values = list(ious.values()) if isinstance(ious, Mapping) else list(ious)
    finite = [v for v in values if np.isfinite(v)]
    return float(np.mean(finite)) if finite else float("nan")


def label_similarity(pred: np.ndarray, labels: np.ndarray, class_ids: Iterable[int]) -> float:
    """mIoU of a rendered class map against raw Cityscapes labels (mapped and void-ignored).

    This is the score the automated T1 study ranks candidate source images by.

    Args:
        pred: (H, W) rendered class ids.
        labels: (H, W) raw Cityscapes label ids.
        class_ids: the classes averaged over.
    """
    mapped = placeable_label_ids(labels)
    m = mean_iou(iou_per_class(pred, mapped, class_ids, ignored_mask(labels)))
    return 0.0 if not np.isfinite(m) else m
