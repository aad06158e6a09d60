"""The ``hf`` segmentation backend: a Hugging Face ``transformers`` segmentation model from a
local folder, offline.

The folder is what ``save_pretrained`` (model and image processor) or
``huggingface-cli download <repo> --local-dir <folder>`` wrote on a machine with hub
access: ``config.json``, the weights and ``preprocessor_config.json``. Loading never
touches the network (``local_files_only=True``, ``HF_HUB_OFFLINE=1``).

What the model is, is read from its config:

* a universal segmentation model (Mask2Former, MaskFormer, DETR ...) runs
  panoptic segmentation (``post_process_panoptic_segmentation``, segments of stuff
  classes fused): its objects become the instances;
* any other semantic segmentation model (SegFormer, UperNet, BEiT, DPT ...) gives one class
  per pixel (``post_process_semantic_segmentation``), and things are split into instances
  by connected components and detection boxes
  (:func:`~usdworld.perception.segment.instances.instances_from_semantic`).

The config's class names (``id2label``) map to Cityscapes label ids through the
segmentation label table (:mod:`usdworld.perception.segment.classes`).

OneFormer is refused: its processor reads its class metadata from the hub
(``shi-labs/oneformer_demo``) when it loads, and it needs a text task prompt.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from usdworld.errors import InputError
from usdworld.io.label_table import LabelLookups
from usdworld.perception.depth.base import check_rgb
from usdworld.perception.depth.runtime import (
    first_line,
    import_torch,
    import_transformers,
    progress_bars_off,
    select_device,
)
from usdworld.perception.segment.base import SegmentKind, SegmentPrediction
from usdworld.perception.segment.classes import class_map, unknown_pixels
from usdworld.perception.segment.instances import instances_from_panoptic, instances_from_semantic

log = logging.getLogger(__name__)

NAME = "hf"
MODEL_SOURCE = (
    "a segmentation model folder written elsewhere by save_pretrained (model + image processor) or "
    "`huggingface-cli download <repo> --local-dir <folder>` (e.g. nvidia/segformer-b0-finetuned-cityscapes-1024-1024, "
    "facebook/mask2former-swin-tiny-cityscapes-panoptic; each model has its own licence)"
)


#: Model types refused, with the reason.
UNSUPPORTED = {
    "oneformer": "OneFormer is not supported: its processor fetches class metadata from the hub when it loads "
    "and takes a text task prompt; use a Mask2Former or SegFormer model",
}


class _Unsupported(Exception):
    """A model type of :data:`UNSUPPORTED` (turned into InputError by the loader)."""


class HfSegmentBackend:
    """A transformers segmentation model loaded from a local folder.

    Args:
        model_dir: the model folder (module docstring).
        table: model label -> Cityscapes name (:func:`usdworld.io.segment_labels.segment_labels`).
        lookups: the Cityscapes table's arrays.
        min_area_px: smallest thing piece a semantic model's output keeps as an instance
            (``perception.min_thing_area_px``).
        device: torch device; None picks CUDA when available, else CPU.

    Raises:
        InputError: no folder, no ``config.json``, torch or transformers missing, or the
            folder does not hold a loadable segmentation model and image processor.
    """

    def __init__(
        self,
        model_dir: Path | None,
        table: Mapping[str, str],
        lookups: LabelLookups,
        min_area_px: int,
        device: str | None = None,
    ) -> None:
        if model_dir is None:
            raise InputError(f"--segment {NAME}: needs --segment-model DIR, {MODEL_SOURCE}")
        folder = Path(model_dir)
        if not folder.is_dir() or not (folder / "config.json").is_file():
            raise InputError(f"segmentation model {folder}: not a model folder (no config.json); pass {MODEL_SOURCE}")
        import_torch(NAME)
        transformers = import_transformers(NAME)
        self.device = select_device(device, NAME)
        from transformers.models.auto.modeling_auto import MODEL_FOR_UNIVERSAL_SEGMENTATION_MAPPING_NAMES

        try:
            with progress_bars_off(transformers):
                config = transformers.AutoConfig.from_pretrained(folder, local_files_only=True)
                self.model_type = str(getattr(config, "model_type", "unknown"))
                if self.model_type in UNSUPPORTED:
                    raise _Unsupported(UNSUPPORTED[self.model_type])
                self.kind: SegmentKind = (
                    "panoptic" if self.model_type in MODEL_FOR_UNIVERSAL_SEGMENTATION_MAPPING_NAMES else "semantic"
                )
                auto_model = (
                    transformers.AutoModelForUniversalSegmentation
                    if self.kind == "panoptic"
                    else transformers.AutoModelForSemanticSegmentation
                )
                self.processor = transformers.AutoImageProcessor.from_pretrained(folder, local_files_only=True)
                self.model = auto_model.from_pretrained(folder, local_files_only=True)
        except _Unsupported as exc:
            raise InputError(f"segmentation model {folder}: {exc}") from None
        except Exception as exc:  # transformers raises many types for a folder it cannot load
            raise InputError(
                f"segmentation model {folder}: cannot load a segmentation model and image processor ({first_line(exc)})"
            ) from exc
        self.model.to(self.device).eval()
        self.classes = class_map(self.model.config.id2label, table, lookups)
        self.lookups = lookups
        self.min_area_px = int(min_area_px)
        self.name = f"{NAME}:{self.model_type}:{folder.name}"
        self.path = folder

    def _run_model(self, rgb: np.ndarray) -> Any:
        """The model's raw output for one photo (what the processor's post-processing takes)."""
        torch = import_torch(NAME)
        inputs = self.processor(images=rgb, return_tensors="pt")
        inputs = {k: v.to(self.device) if hasattr(v, "to") else v for k, v in inputs.items()}
        with torch.inference_mode():
            return self.model(**inputs)

    def predict(
        self, rgb: np.ndarray, boxes_px: np.ndarray | None = None, box_classes: Sequence[str] = ()
    ) -> SegmentPrediction:
        """Segment one photo into Cityscapes label and instance ids.

        Args:
            rgb: (H, W, 3) uint8 RGB image.
            boxes_px: (N, 4) float64 detection boxes ``xmin, ymin, xmax, ymax`` that split
                touching things of a semantic model's output, or None (a panoptic model's
                objects are its own).
            box_classes: (N) placed class of each box; a box splits only things placed as its class.

        Returns:
            The maps, at the photo's size.
        """
        rgb = check_rgb(rgb, self.name)
        h, w = rgb.shape[:2]
        outputs = self._run_model(rgb)
        if self.kind == "panoptic":
            stuff = {i for i, label in enumerate(self.classes.label_ids) if not self.lookups.is_thing[label]}
            result = self.processor.post_process_panoptic_segmentation(
                outputs, target_sizes=[(h, w)], label_ids_to_fuse=stuff
            )[0]
            segment_map = result["segmentation"].detach().cpu().numpy().astype(np.int64).reshape(h, w)
            segments = [(int(s["id"]), int(s["label_id"])) for s in result["segments_info"]]
            label_ids, instance_ids = instances_from_panoptic(segment_map, segments, self.classes.label_ids, self.lookups)
            model_classes = np.full(max([0] + [s for s, _ in segments]) + 2, -1, dtype=np.int64)
            for segment_id, model_class in segments:
                model_classes[segment_id] = model_class
            per_pixel = model_classes[np.clip(segment_map, -1, len(model_classes) - 2)]
        else:
            per_pixel = self.processor.post_process_semantic_segmentation(outputs, target_sizes=[(h, w)])[0]
            per_pixel = per_pixel.detach().cpu().numpy().astype(np.int64).reshape(h, w)
            label_ids = self.classes.label_ids[per_pixel]
            instance_ids = instances_from_semantic(
                label_ids, self.lookups, self.min_area_px, boxes_px, box_classes
            )
        unknown = unknown_pixels(per_pixel, self.classes)
        if unknown:
            log.warning(
                "%s: %d pixels of %d classes not in the segmentation label table were left unlabeled: %s",
                self.name,
                sum(n for _, n in unknown),
                len(unknown),
                ", ".join(f"{name} ({n} px)" for name, n in unknown),
            )
        return SegmentPrediction(label_ids, instance_ids, self.name, self.kind, unknown)
