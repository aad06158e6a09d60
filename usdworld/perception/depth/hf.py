"""The ``hf`` backend: any Hugging Face ``transformers`` depth-estimation model
(DPT, GLPN, Depth Anything, ZoeDepth ...) from a local folder, offline.

The folder is what ``save_pretrained`` (model and image processor) or
``huggingface-cli download <repo> --local-dir <folder>`` wrote on a machine with hub
access: ``config.json``, the weights (``model.safetensors`` or ``pytorch_model.bin``)
and ``preprocessor_config.json``. Loading never touches the network:
``local_files_only=True``, and ``HF_HUB_OFFLINE=1`` is set in this process's
environment before transformers is imported.

What the model's output means is read from its config (override with ``kind``):

* ``glpn``, ``zoedepth`` and ``depth_anything`` with ``depth_estimation_type="metric"``:
  metric depth in metres;
* everything else (``dpt`` MiDaS-style, relative ``depth_anything`` ...): affine-invariant
  inverse depth (``disparity``), to be aligned to the ground.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from usdworld.errors import InputError
from usdworld.geometry.camera import PinholeCamera
from usdworld.perception.depth.base import (
    DEPTH_KINDS,
    DepthKind,
    DepthPrediction,
    check_camera_matches,
    check_rgb,
)
from usdworld.perception.depth.runtime import (
    first_line,
    import_torch,
    import_transformers,
    progress_bars_off,
    require_weights_path,
    select_device,
)

log = logging.getLogger(__name__)

NAME = "hf"
WEIGHTS_SOURCE = (
    "hf weights are a local folder written elsewhere by save_pretrained (model + image processor) or "
    "`huggingface-cli download <repo> --local-dir <folder>` (e.g. depth-anything/Depth-Anything-V2-Small-hf, "
    "Intel/dpt-large, vinvino02/glpn-kitti; each model has its own licence)"
)
#: Model types whose ``predicted_depth`` is metres.
METRIC_MODEL_TYPES = frozenset({"glpn", "zoedepth"})


def output_kind(config: Any) -> DepthKind:
    """What a transformers depth model's ``predicted_depth`` means (module docstring)."""
    model_type = getattr(config, "model_type", "")
    if model_type in METRIC_MODEL_TYPES:
        return "metric"
    if getattr(config, "depth_estimation_type", None) == "metric":
        return "metric"
    return "disparity"


class HfDepthBackend:
    """A transformers depth-estimation model loaded from a local folder.

    Args:
        weights: the model folder (module docstring).
        device: torch device; None picks CUDA when available, else CPU.
        kind: override of what the output means (default: from the config).

    Raises:
        InputError: missing folder, transformers missing, or the folder does not hold a
            loadable depth-estimation model and image processor.
    """

    def __init__(
        self, weights: Path | None, device: str | None = None, kind: DepthKind | None = None
    ) -> None:
        folder = require_weights_path(weights, NAME, WEIGHTS_SOURCE)
        if not folder.is_dir() or not (folder / "config.json").is_file():
            raise InputError(
                f"{NAME} weights {folder}: not a model folder (no config.json); {WEIGHTS_SOURCE}"
            )
        if kind is not None and kind not in DEPTH_KINDS:
            raise InputError(f"{NAME}: kind must be one of {DEPTH_KINDS}, got {kind!r}")
        import_torch(NAME)
        transformers = import_transformers(NAME)
        self.device = select_device(device, NAME)
        try:
            with progress_bars_off(transformers):
                self.processor = transformers.AutoImageProcessor.from_pretrained(folder, local_files_only=True)
                self.model = transformers.AutoModelForDepthEstimation.from_pretrained(folder, local_files_only=True)
        except Exception as exc:  # transformers raises many types for a folder it cannot load
            raise InputError(
                f"{NAME} weights {folder}: cannot load a depth-estimation model and image processor ({first_line(exc)})"
            ) from exc
        self.model.to(self.device).eval()
        self.kind: DepthKind = kind if kind is not None else output_kind(self.model.config)
        model_type = getattr(self.model.config, "model_type", "unknown")
        self.name = f"{NAME}:{model_type}:{folder.name}"
        self.path = folder

    def predict(self, rgb: np.ndarray, camera: PinholeCamera | None = None) -> DepthPrediction:
        """Run the model and resize its output back to the photo (bicubic).

        Args:
            rgb: (H, W, 3) uint8 RGB image.
            camera: only checked against the image size.
        """
        torch = import_torch(NAME)
        rgb = check_rgb(rgb, self.name)
        check_camera_matches(camera, rgb, self.name)
        h, w = rgb.shape[:2]
        inputs = self.processor(images=rgb, return_tensors="pt")
        inputs = {k: v.to(self.device) if hasattr(v, "to") else v for k, v in inputs.items()}
        with torch.inference_mode():
            outputs = self.model(**inputs)
        post = getattr(self.processor, "post_process_depth_estimation", None)
        if post is not None:
            predicted = post(outputs, target_sizes=[(h, w)])[0]["predicted_depth"]
        else:
            predicted = torch.nn.functional.interpolate(
                outputs.predicted_depth[:, None], size=(h, w), mode="bicubic", align_corners=False
            )[0, 0]
        values = predicted.detach().float().cpu().numpy().reshape(h, w)
        scaling = (
            f"{getattr(self.model.config, 'model_type', 'model')} output as {self.kind.replace('_', '-')}, "
            f"resized bicubic to {w}x{h}"
        )
        return DepthPrediction(
            depth=values, valid=np.isfinite(values), name=self.name, kind=self.kind, scaling=scaling
        )
