"""The one interface every segmentation backend implements, and what it returns.

A backend turns the photo into Cityscapes-format maps (the ones ``--labels`` and
``--instances`` read): a label id per pixel and an instance id per pixel, ``class*1000+k``
on objects of thing classes and the label id elsewhere.
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Sequence
from typing import Literal, Protocol, get_args, runtime_checkable

import numpy as np

from usdworld.errors import InputError

SegmentKind = Literal["semantic", "panoptic"]
SEGMENT_KINDS: tuple[str, ...] = get_args(SegmentKind)


@dataclass(frozen=True)
class SegmentPrediction:
    """One backend's maps for one image (arrays made read-only on construction).

    Attributes:
        label_ids: (H, W) uint8 Cityscapes label ids.
        instance_ids: (H, W) int32 Cityscapes instance ids (``class*1000+k`` on things,
            the label id elsewhere).
        name: backend and model (``hf:segformer:<folder>``), for provenance.
        kind: ``semantic`` (things split into instances by connected components and
            detection boxes) or ``panoptic`` (the model's own instances).
        unknown: (model class name, pixels) of the classes the label table does not know,
            left ``unlabeled``; only classes with pixels are listed.
    """

    label_ids: np.ndarray
    instance_ids: np.ndarray
    name: str
    kind: SegmentKind
    unknown: tuple[tuple[str, int], ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in SEGMENT_KINDS:
            raise InputError(f"segmentation {self.name}: kind must be one of {SEGMENT_KINDS}, got {self.kind!r}")
        labels = np.array(self.label_ids, dtype=np.uint8)
        instances = np.array(self.instance_ids, dtype=np.int32)
        if labels.ndim != 2 or labels.shape != instances.shape:
            raise InputError(
                f"segmentation {self.name}: label_ids and instance_ids must be (H, W) of one shape, "
                f"got {labels.shape} and {instances.shape}"
            )
        labels.setflags(write=False)
        instances.setflags(write=False)
        object.__setattr__(self, "label_ids", labels)
        object.__setattr__(self, "instance_ids", instances)


@runtime_checkable
class SegmentBackend(Protocol):
    """Image -> Cityscapes label and instance maps. Implementations load the model in ``__init__``."""

    @property
    def name(self) -> str:
        """Backend name as recorded in provenance."""
        ...

    def predict(
        self, rgb: np.ndarray, boxes_px: np.ndarray | None = None, box_classes: Sequence[str] = ()
    ) -> SegmentPrediction:
        """Segment one photo.

        Args:
            rgb: (H, W, 3) uint8 RGB image.
            boxes_px: (N, 4) float64 detection boxes ``xmin, ymin, xmax, ymax`` that split
                touching things of a semantic model's output, or None.
            box_classes: (N) placed class of each box.

        Returns:
            A prediction of shape (H, W).
        """
        ...
