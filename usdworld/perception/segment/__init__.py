"""Segmentation: pluggable backends (image -> Cityscapes label and instance ids).

Backends (:func:`make_backend`):

* ``none``: no backend; labels come from files (``--labels``, ``--polygons``) or not at all.
* ``hf``: a transformers segmentation model (SegFormer, Mask2Former ...) from a
  local folder, offline (:mod:`usdworld.perception.segment.hf`).

torch and transformers are imported only when a network backend is made, so this
package imports without them.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from usdworld.errors import InputError
from usdworld.io.label_table import LabelLookups
from usdworld.perception.segment.base import SEGMENT_KINDS, SegmentBackend, SegmentKind, SegmentPrediction

#: Names accepted by ``--segment``, in CLI order (``none``: no backend).
BACKEND_NAMES: tuple[str, ...] = ("none", "hf")

__all__ = ["BACKEND_NAMES", "SEGMENT_KINDS", "SegmentBackend", "SegmentKind", "SegmentPrediction", "make_backend"]


def make_backend(
    name: str,
    model_dir: Path | None,
    table: Mapping[str, str],
    lookups: LabelLookups,
    min_area_px: int,
    device: str | None = None,
) -> SegmentBackend:
    """Build a segmentation backend by name, loading its model now.

    Args:
        name: a network backend of :data:`BACKEND_NAMES` (not ``none``).
        model_dir: the model folder.
        table: model label -> Cityscapes name (:func:`usdworld.io.segment_labels.segment_labels`).
        lookups: the Cityscapes table's arrays.
        min_area_px: smallest thing piece kept as an instance (``perception.min_thing_area_px``).
        device: torch device; None picks CUDA when available, else the CPU.

    Raises:
        InputError: unknown name, a missing or unloadable model, or torch/transformers not installed.
    """
    if name == "hf":
        from usdworld.perception.segment.hf import HfSegmentBackend

        return HfSegmentBackend(model_dir, table, lookups, min_area_px, device=device)
    raise InputError(f"segmentation backend {name!r}: not a network backend; choose {', '.join(BACKEND_NAMES[1:])}")
