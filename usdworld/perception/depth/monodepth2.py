"""Monodepth2 (Godard et al., ICCV 2019): ResNet-18 encoder + depth decoder, in torch.

The modules reproduce the layout of the publicly released weights (nianticlabs'
``mono+stereo_640x192`` and siblings) so that the downloaded folder loads unchanged:

* ``encoder.pth``: a torchvision-style ResNet-18 under ``encoder.`` (``encoder.conv1.weight``,
  ``encoder.bn1.*``, ``encoder.layer1.0.conv1.weight`` ... ``encoder.fc.weight``) plus the
  entries ``height``, ``width`` (the training resolution, the network's input size) and
  ``use_stereo``.
* ``depth.pth``: the depth decoder, an ``nn.ModuleList`` ``decoder.0`` ... ``decoder.13``:
  ten ELU conv blocks (``decoder.i.conv.conv.weight``; up-convolutions for levels 4..0,
  two per level) followed by four disparity heads (``decoder.10.conv.weight`` ...,
  scales 0..3), all 3x3 convolutions with reflection padding.

Depth: ``disp_to_depth`` with min 0.1 / max 100: ``d = 1 / (1/100 + (1/0.1 - 1/100) * sigmoid)``.
Models trained with stereo (``use_stereo``) are metric after multiplying by 5.4
(KITTI baseline 0.54 m over the 0.1 training baseline); mono-only models are
``relative``. Weights: github.com/nianticlabs/monodepth2 (Niantic's licence,
non-commercial use only), e.g. ``mono+stereo_640x192``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from usdworld.errors import InputError
from usdworld.geometry.camera import PinholeCamera
from usdworld.perception.depth.base import DepthPrediction, check_camera_matches, check_rgb
from usdworld.perception.depth.runtime import (
    load_checkpoint,
    load_state_dict_strict,
    require_weights_path,
    resize_map,
    rgb_to_tensor,
    select_device,
)

NAME = "monodepth2"
MIN_DEPTH = 0.1
MAX_DEPTH = 100.0
#: Metres per training unit of stereo-trained models (0.54 m KITTI baseline / 0.1).
STEREO_SCALE_FACTOR = 5.4
DEFAULT_HEIGHT = 192
DEFAULT_WIDTH = 640
#: Entries of ``encoder.pth`` that are not weights.
ENCODER_EXTRA_KEYS = ("height", "width", "use_stereo")
NUM_CH_ENC = (64, 64, 128, 256, 512)
NUM_CH_DEC = (16, 32, 64, 128, 256)
WEIGHTS_SOURCE = (
    "monodepth2 weights are a folder holding encoder.pth and depth.pth from nianticlabs' release "
    "(github.com/nianticlabs/monodepth2, e.g. mono+stereo_640x192; non-commercial licence)"
)


class BasicBlock(nn.Module):
    """ResNet basic block (two 3x3 convolutions + identity or 1x1 downsample)."""

    def __init__(self, c_in: int, c_out: int, stride: int = 1) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(c_in, c_out, 3, stride=stride, padding=1, bias=False)
        self.bn1 = nn.BatchNorm2d(c_out)
        self.relu = nn.ReLU(inplace=True)
        self.conv2 = nn.Conv2d(c_out, c_out, 3, stride=1, padding=1, bias=False)
        self.bn2 = nn.BatchNorm2d(c_out)
        self.downsample: nn.Module | None = None
        if stride != 1 or c_in != c_out:
            self.downsample = nn.Sequential(
                nn.Conv2d(c_in, c_out, 1, stride=stride, bias=False), nn.BatchNorm2d(c_out)
            )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        identity = x if self.downsample is None else self.downsample(x)
        out = self.relu(self.bn1(self.conv1(x)))
        out = self.bn2(self.conv2(out))
        return self.relu(out + identity)


class ResNet18(nn.Module):
    """ResNet-18 with torchvision's attribute names (so its state dict keys match)."""

    def __init__(self) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(3, 64, 7, stride=2, padding=3, bias=False)
        self.bn1 = nn.BatchNorm2d(64)
        self.relu = nn.ReLU(inplace=True)
        self.maxpool = nn.MaxPool2d(kernel_size=3, stride=2, padding=1)
        self.layer1 = nn.Sequential(BasicBlock(64, 64), BasicBlock(64, 64))
        self.layer2 = nn.Sequential(BasicBlock(64, 128, 2), BasicBlock(128, 128))
        self.layer3 = nn.Sequential(BasicBlock(128, 256, 2), BasicBlock(256, 256))
        self.layer4 = nn.Sequential(BasicBlock(256, 512, 2), BasicBlock(512, 512))
        self.avgpool = nn.AdaptiveAvgPool2d((1, 1))
        self.fc = nn.Linear(512, 1000)  # unused; kept because the released encoder.pth has it


class ResnetEncoder(nn.Module):
    """Monodepth2's encoder: five feature maps (1/2, 1/4, 1/8, 1/16, 1/32) of a ResNet-18."""

    def __init__(self) -> None:
        super().__init__()
        self.encoder = ResNet18()

    def forward(self, image: torch.Tensor) -> list[torch.Tensor]:
        """(B, 3, H, W) RGB in [0, 1] -> features with 64, 64, 128, 256, 512 channels."""
        e = self.encoder
        x = (image - 0.45) / 0.225
        f0 = e.relu(e.bn1(e.conv1(x)))
        f1 = e.layer1(e.maxpool(f0))
        f2 = e.layer2(f1)
        f3 = e.layer3(f2)
        f4 = e.layer4(f3)
        return [f0, f1, f2, f3, f4]


class Conv3x3(nn.Module):
    """Reflection-padded 3x3 convolution."""

    def __init__(self, c_in: int, c_out: int) -> None:
        super().__init__()
        self.pad = nn.ReflectionPad2d(1)
        self.conv = nn.Conv2d(c_in, c_out, 3)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.conv(self.pad(x))


class ConvBlock(nn.Module):
    """Conv3x3 followed by ELU."""

    def __init__(self, c_in: int, c_out: int) -> None:
        super().__init__()
        self.conv = Conv3x3(c_in, c_out)
        self.nonlin = nn.ELU(inplace=True)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.nonlin(self.conv(x))


class DepthDecoder(nn.Module):
    """Monodepth2's depth decoder; ``decoder`` holds the modules in the released order.

    Index ``2 * (4 - i)`` is level i's first up-convolution, ``2 * (4 - i) + 1`` its
    second (after the skip concatenation), ``10 + s`` the disparity head of scale s.
    """

    def __init__(self) -> None:
        super().__init__()
        blocks: list[nn.Module] = []
        for i in range(4, -1, -1):
            c_in = NUM_CH_ENC[-1] if i == 4 else NUM_CH_DEC[i + 1]
            blocks.append(ConvBlock(c_in, NUM_CH_DEC[i]))
            c_in = NUM_CH_DEC[i] + (NUM_CH_ENC[i - 1] if i > 0 else 0)
            blocks.append(ConvBlock(c_in, NUM_CH_DEC[i]))
        for s in range(4):
            blocks.append(Conv3x3(NUM_CH_DEC[s], 1))
        self.decoder = nn.ModuleList(blocks)

    def forward(self, features: list[torch.Tensor]) -> dict[int, torch.Tensor]:
        """Features -> sigmoid disparity per scale: {0: (B, 1, H, W), ..., 3: (B, 1, H/8, W/8)}."""
        out: dict[int, torch.Tensor] = {}
        x = features[-1]
        for i in range(4, -1, -1):
            x = self.decoder[2 * (4 - i)](x)
            parts = [F.interpolate(x, scale_factor=2, mode="nearest")]
            if i > 0:
                skip = features[i - 1]
                if parts[0].shape[2:] != skip.shape[2:]:
                    parts[0] = F.interpolate(x, size=skip.shape[2:], mode="nearest")
                parts.append(skip)
            x = self.decoder[2 * (4 - i) + 1](torch.cat(parts, 1))
            if i < 4:
                out[i] = torch.sigmoid(self.decoder[10 + i](x))
        return out


def disp_to_depth(disp: np.ndarray, min_depth: float = MIN_DEPTH, max_depth: float = MAX_DEPTH) -> np.ndarray:
    """Monodepth2's mapping of the sigmoid output to depth.

    Args:
        disp: (...) sigmoid output in [0, 1].
        min_depth: depth at sigmoid 1.
        max_depth: depth at sigmoid 0.

    Returns:
        (...) float32 depth in [min_depth, max_depth] (training units).
    """
    min_disp, max_disp = 1.0 / max_depth, 1.0 / min_depth
    return (1.0 / (min_disp + (max_disp - min_disp) * np.asarray(disp, dtype=np.float64))).astype(np.float32)


def _int_entry(raw: dict[str, Any], key: str, default: int, path: Path) -> int:
    v = raw.get(key, default)
    if isinstance(v, torch.Tensor):
        v = v.item()
    if isinstance(v, bool) or not isinstance(v, (int, float)) or int(v) != v or int(v) < 32 or int(v) % 32:
        raise InputError(f"{NAME} weights {path}: {key} must be a positive multiple of 32, got {v!r}")
    return int(v)


class Monodepth2Backend:
    """The ``monodepth2`` backend.

    Args:
        weights: folder holding ``encoder.pth`` and ``depth.pth``.
        device: torch device; None picks CUDA when available, else CPU.

    Raises:
        InputError: missing or bad weights, mismatched keys.
    """

    name = NAME

    def __init__(self, weights: Path | None, device: str | None = None) -> None:
        folder = require_weights_path(weights, NAME, WEIGHTS_SOURCE)
        if not folder.is_dir():
            raise InputError(f"{NAME} weights {folder}: not a folder; {WEIGHTS_SOURCE}")
        for part in ("encoder.pth", "depth.pth"):
            if not (folder / part).is_file():
                raise InputError(f"{NAME} weights {folder}: has no {part}; {WEIGHTS_SOURCE}")
        enc_raw = load_checkpoint(folder / "encoder.pth", NAME)
        dec_raw = load_checkpoint(folder / "depth.pth", NAME)
        self.height = _int_entry(enc_raw, "height", DEFAULT_HEIGHT, folder / "encoder.pth")
        self.width = _int_entry(enc_raw, "width", DEFAULT_WIDTH, folder / "encoder.pth")
        stereo = enc_raw.get("use_stereo", False)
        self.use_stereo = bool(stereo.item() if isinstance(stereo, torch.Tensor) else stereo)
        self.device = select_device(device, NAME)
        self.encoder = ResnetEncoder()
        self.decoder = DepthDecoder()
        enc_state = {k: v for k, v in enc_raw.items() if k not in ENCODER_EXTRA_KEYS}
        load_state_dict_strict(self.encoder, enc_state, folder / "encoder.pth", NAME)
        load_state_dict_strict(self.decoder, dec_raw, folder / "depth.pth", NAME)
        self.encoder.to(self.device).eval()
        self.decoder.to(self.device).eval()
        self.path = folder

    def predict_sigmoid(self, rgb: np.ndarray) -> np.ndarray:
        """Scale-0 sigmoid disparity at the network resolution.

        Args:
            rgb: (H, W, 3) uint8 RGB image.

        Returns:
            (height, width) float32 in [0, 1].
        """
        rgb = check_rgb(rgb, NAME)
        x = rgb_to_tensor(rgb, self.height, self.width, self.device)
        with torch.inference_mode():
            disp = self.decoder(self.encoder(x))[0]
        return disp[0, 0].float().cpu().numpy()

    def predict(self, rgb: np.ndarray, camera: PinholeCamera | None = None) -> DepthPrediction:
        """Depth of the photo: metric for stereo-trained weights, else relative.

        Args:
            rgb: (H, W, 3) uint8 RGB image.
            camera: only checked against the image size.
        """
        rgb = check_rgb(rgb, NAME)
        check_camera_matches(camera, rgb, NAME)
        h, w = rgb.shape[:2]
        disp = resize_map(torch.from_numpy(self.predict_sigmoid(rgb)), h, w)
        depth = disp_to_depth(disp)
        scaling = f"disp_to_depth(min {MIN_DEPTH:g}, max {MAX_DEPTH:g}) at {self.width}x{self.height}"
        if self.use_stereo:
            depth = depth * np.float32(STEREO_SCALE_FACTOR)
            return DepthPrediction(
                depth=depth,
                valid=np.ones((h, w), bool),
                name=NAME,
                kind="metric",
                scaling=f"{scaling} x {STEREO_SCALE_FACTOR:g} (stereo-trained: KITTI baseline 0.54 m / 0.1)",
            )
        return DepthPrediction(
            depth=depth,
            valid=np.ones((h, w), bool),
            name=NAME,
            kind="relative",
            scaling=f"{scaling} (mono-trained: scale unknown)",
        )
