"""The paper's depth network: Godard, Mac Aodha and Brostow, "Unsupervised Monocular
Depth Estimation with Left-Right Consistency", CVPR 2017 (VGG variant), in torch.

Network (the authors' ``build_vgg``): seven encoder blocks of two convolutions each
(the second with stride 2; 32, 64, 128, 256, 512, 512, 512 channels, kernels 7, 5, 3 ...),
a decoder of nearest-neighbour up-convolutions with skip connections, and disparity
heads at four scales (1/8, 1/4, 1/2, 1/1). Each head is ``0.3 * sigmoid(conv)`` with two
channels (left and right disparity) as a fraction of the image width, so pixel
disparity is at most 0.3 x width. Convolutions are zero-padded, ELU-activated.
Input is RGB in [0, 1] at 512x256.

Checkpoint: a ``.pth`` file holding either the state dict or
``{"state_dict": ..., "meta": {"baseline_m": .., "focal_px": .., "width": ..}}`` where
``focal_px`` is the training rig's focal length at image width ``width``. Keys are those
of :class:`MonodepthNet` (``enc1.conv1.weight`` ... ``upconv7.conv.weight`` ...
``iconv1.weight`` ... ``disp1.weight``). The authors released TensorFlow checkpoints
(github.com/mrharicot/monodepth, ``model_cityscapes``, ``model_kitti``,
``model_city2kitti``; licence: the authors' terms, academic use); converting one means
renaming its variables to these keys.

Depth: ``d = b * f / (disp * W)`` with ``W`` the network width, ``f`` the focal length at
that width (from the checkpoint, else the camera's ``fx`` rescaled) and ``b`` the
stereo baseline (checkpoint metadata or the ``baseline_m`` argument). Without a
baseline or a focal length the output is ``relative`` (``1 / disp``).

Test-time post-processing as in the authors' model: the image and its mirror image are
run together, and the two disparities blended, using the mirrored one at the left
edge, the direct one at the right edge (5 % ramps) and their mean elsewhere.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from usdworld.errors import InputError
from usdworld.geometry.camera import PinholeCamera
from usdworld.perception.depth.base import DepthKind, DepthPrediction, check_camera_matches, check_rgb
from usdworld.perception.depth.runtime import (
    load_checkpoint,
    load_state_dict_strict,
    require_weights_path,
    resize_map,
    rgb_to_tensor,
    select_device,
)

log = logging.getLogger(__name__)

NAME = "monodepth"
INPUT_WIDTH = 512
INPUT_HEIGHT = 256
#: Largest disparity as a fraction of the image width.
MAX_DISPARITY = 0.3
WEIGHTS_SOURCE = (
    "monodepth (Godard et al. 2017) weights come from the authors' release "
    "(github.com/mrharicot/monodepth, TensorFlow checkpoints converted to a torch state dict "
    "with keys of usdworld.perception.depth.monodepth.MonodepthNet)"
)

_ENCODER = ((3, 32, 7), (32, 64, 5), (64, 128, 3), (128, 256, 3), (256, 512, 3), (512, 512, 3), (512, 512, 3))


class EncoderBlock(nn.Module):
    """Two ELU convolutions, the second with stride 2 (halves the size)."""

    def __init__(self, c_in: int, c_out: int, kernel: int) -> None:
        super().__init__()
        pad = (kernel - 1) // 2
        self.conv1 = nn.Conv2d(c_in, c_out, kernel, stride=1, padding=pad)
        self.conv2 = nn.Conv2d(c_out, c_out, kernel, stride=2, padding=pad)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.elu(self.conv2(F.elu(self.conv1(x))))


class UpConv(nn.Module):
    """Nearest-neighbour upsampling to ``size`` followed by an ELU 3x3 convolution."""

    def __init__(self, c_in: int, c_out: int) -> None:
        super().__init__()
        self.conv = nn.Conv2d(c_in, c_out, 3, padding=1)

    def forward(self, x: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
        return F.elu(self.conv(F.interpolate(x, size=size, mode="nearest")))


class MonodepthNet(nn.Module):
    """VGG encoder-decoder of Godard et al. 2017.

    ``forward`` takes (B, 3, H, W) RGB in [0, 1] and returns four (B, 2, h, w) disparity
    maps (fractions of the width, channel 0 left, 1 right), finest first:
    full, 1/2, 1/4 and 1/8 resolution.
    """

    def __init__(self) -> None:
        super().__init__()
        for i, (c_in, c_out, k) in enumerate(_ENCODER, start=1):
            self.add_module(f"enc{i}", EncoderBlock(c_in, c_out, k))
        # (up-conv in, up-conv out, skip channels, disparity channels in) per level 7..1
        self.upconv7, self.iconv7 = UpConv(512, 512), nn.Conv2d(512 + 512, 512, 3, padding=1)
        self.upconv6, self.iconv6 = UpConv(512, 512), nn.Conv2d(512 + 512, 512, 3, padding=1)
        self.upconv5, self.iconv5 = UpConv(512, 256), nn.Conv2d(256 + 256, 256, 3, padding=1)
        self.upconv4, self.iconv4 = UpConv(256, 128), nn.Conv2d(128 + 128, 128, 3, padding=1)
        self.disp4 = nn.Conv2d(128, 2, 3, padding=1)
        self.upconv3, self.iconv3 = UpConv(128, 64), nn.Conv2d(64 + 64 + 2, 64, 3, padding=1)
        self.disp3 = nn.Conv2d(64, 2, 3, padding=1)
        self.upconv2, self.iconv2 = UpConv(64, 32), nn.Conv2d(32 + 32 + 2, 32, 3, padding=1)
        self.disp2 = nn.Conv2d(32, 2, 3, padding=1)
        self.upconv1, self.iconv1 = UpConv(32, 16), nn.Conv2d(16 + 2, 16, 3, padding=1)
        self.disp1 = nn.Conv2d(16, 2, 3, padding=1)

    @staticmethod
    def _disp(head: nn.Conv2d, x: torch.Tensor) -> torch.Tensor:
        return MAX_DISPARITY * torch.sigmoid(head(x))

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        skips = []
        for i in range(1, 8):
            x = getattr(self, f"enc{i}")(x)
            skips.append(x)
        s1, s2, s3, s4, s5, s6, _ = skips

        def up(t: torch.Tensor, like: torch.Tensor) -> torch.Tensor:
            return F.interpolate(t, size=like.shape[2:], mode="nearest")

        x = F.elu(self.iconv7(torch.cat([self.upconv7(x, s6.shape[2:]), s6], 1)))
        x = F.elu(self.iconv6(torch.cat([self.upconv6(x, s5.shape[2:]), s5], 1)))
        x = F.elu(self.iconv5(torch.cat([self.upconv5(x, s4.shape[2:]), s4], 1)))
        x = F.elu(self.iconv4(torch.cat([self.upconv4(x, s3.shape[2:]), s3], 1)))
        disp4 = self._disp(self.disp4, x)
        x = F.elu(self.iconv3(torch.cat([self.upconv3(x, s2.shape[2:]), s2, up(disp4, s2)], 1)))
        disp3 = self._disp(self.disp3, x)
        x = F.elu(self.iconv2(torch.cat([self.upconv2(x, s1.shape[2:]), s1, up(disp3, s1)], 1)))
        disp2 = self._disp(self.disp2, x)
        full = (s1.shape[2] * 2, s1.shape[3] * 2)
        udisp2 = F.interpolate(disp2, size=full, mode="nearest")
        x = F.elu(self.iconv1(torch.cat([self.upconv1(x, full), udisp2], 1)))
        disp1 = self._disp(self.disp1, x)
        return [disp1, disp2, disp3, disp4]


def post_process_disparity(disp: np.ndarray, disp_flipped: np.ndarray) -> np.ndarray:
    """Blend the disparity of an image with that of its mirror image (Godard et al. 2017).

    Args:
        disp: (h, w) disparity of the image.
        disp_flipped: (h, w) disparity of the mirrored image, as the network gave it
            (not mirrored back).

    Returns:
        (h, w) float32 blended disparity: mirrored-back disparity near the left edge,
        the direct one near the right edge (ramps over the outer 5 % of the width), the
        mean elsewhere.
    """
    h, w = disp.shape
    r_disp = disp_flipped[:, ::-1]
    m_disp = 0.5 * (disp + r_disp)
    ramp = np.broadcast_to(np.linspace(0.0, 1.0, w), (h, w))
    l_mask = 1.0 - np.clip(20.0 * (ramp - 0.05), 0.0, 1.0)
    r_mask = l_mask[:, ::-1]
    return (r_mask * disp + l_mask * r_disp + (1.0 - l_mask - r_mask) * m_disp).astype(np.float32)


@dataclass(frozen=True)
class MonodepthMeta:
    """Stereo rig of the checkpoint's training data (what turns disparity into metres).

    Attributes:
        baseline_m: stereo baseline in metres, or None.
        focal_px: focal length in pixels at image width ``width``, or None.
        width: image width in pixels that ``focal_px`` refers to, or None.
    """

    baseline_m: float | None = None
    focal_px: float | None = None
    width: int | None = None


def _parse_meta(raw: Any, path: Path) -> MonodepthMeta:
    if raw is None:
        return MonodepthMeta()
    if not isinstance(raw, dict):
        raise InputError(f"{NAME} weights {path}: meta must be a dictionary, got {type(raw).__name__}")
    unknown = sorted(set(raw) - {"baseline_m", "focal_px", "width"})
    if unknown:
        raise InputError(
            f"{NAME} weights {path}: meta has unknown keys {unknown}; known: baseline_m, focal_px, width"
        )
    values: dict[str, float | None] = {}
    for key in ("baseline_m", "focal_px", "width"):
        v = raw.get(key)
        if v is not None:
            v = float(v)
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"{NAME} weights {path}: meta -> {key}: must be > 0, got {v}")
        values[key] = v
    if (values["focal_px"] is None) != (values["width"] is None):
        raise InputError(f"{NAME} weights {path}: meta -> focal_px and width must be given together")
    width = None if values["width"] is None else int(values["width"])
    return MonodepthMeta(values["baseline_m"], values["focal_px"], width)


class MonodepthBackend:
    """The ``monodepth`` backend (Godard et al. 2017, VGG, 512x256).

    Args:
        weights: the ``.pth`` checkpoint (module docstring).
        device: torch device; None picks CUDA when available, else CPU.
        baseline_m: stereo baseline in metres, used when the checkpoint has none.
        post_process: run the flip post-processing (doubles the work).

    Raises:
        InputError: missing or bad weights, mismatched keys.
    """

    name = NAME

    def __init__(
        self,
        weights: Path | None,
        device: str | None = None,
        baseline_m: float | None = None,
        post_process: bool = True,
    ) -> None:
        path = require_weights_path(weights, NAME, WEIGHTS_SOURCE)
        if path.is_dir():
            raise InputError(f"{NAME} weights {path}: is a folder; give the .pth checkpoint file")
        raw = load_checkpoint(path, NAME)
        if "state_dict" in raw and isinstance(raw["state_dict"], dict):
            state = raw["state_dict"]
            extra = sorted(set(raw) - {"state_dict", "meta"})
            if extra:
                raise InputError(
                    f"{NAME} weights {path}: unknown top-level keys {extra}; expected state_dict, meta"
                )
            self.meta = _parse_meta(raw.get("meta"), path)
        else:
            state = raw
            self.meta = MonodepthMeta()
        self.baseline_from = "checkpoint"
        if self.meta.baseline_m is None and baseline_m is not None:
            self.baseline_from = "argument"
            if not (np.isfinite(baseline_m) and baseline_m > 0):
                raise InputError(f"{NAME}: baseline_m must be > 0, got {baseline_m}")
            self.meta = MonodepthMeta(float(baseline_m), self.meta.focal_px, self.meta.width)
        self.device = select_device(device, NAME)
        self.net = MonodepthNet()
        load_state_dict_strict(self.net, state, path, NAME)
        self.net.to(self.device).eval()
        self.post_process = post_process
        self.path = path

    def predict_disparity(self, rgb: np.ndarray) -> np.ndarray:
        """Disparity as a fraction of the width, at the network resolution.

        Args:
            rgb: (H, W, 3) uint8 RGB image.

        Returns:
            (256, 512) float32 disparity in (0, 0.3).
        """
        rgb = check_rgb(rgb, NAME)
        x = rgb_to_tensor(rgb, INPUT_HEIGHT, INPUT_WIDTH, self.device)
        with torch.inference_mode():
            if self.post_process:
                disp = self.net(torch.cat([x, torch.flip(x, dims=[3])], 0))[0][:, 0].float().cpu().numpy()
                return post_process_disparity(disp[0], disp[1])
            return self.net(x)[0][0, 0].float().cpu().numpy()

    def predict(self, rgb: np.ndarray, camera: PinholeCamera | None = None) -> DepthPrediction:
        """Depth of the photo (metric when baseline and focal length are known).

        Args:
            rgb: (H, W, 3) uint8 RGB image.
            camera: the photo's camera; its ``fx`` is the focal length when the
                checkpoint has none.

        Returns:
            (H, W) prediction; ``metric`` or ``relative`` (module docstring).
        """
        rgb = check_rgb(rgb, NAME)
        check_camera_matches(camera, rgb, NAME)
        h, w = rgb.shape[:2]
        disp = resize_map(torch.from_numpy(self.predict_disparity(rgb)), h, w)
        if self.meta.focal_px is not None and self.meta.width is not None:
            focal_net = self.meta.focal_px * INPUT_WIDTH / self.meta.width
            focal_from = "checkpoint"
        elif camera is not None:
            focal_net = camera.fx * INPUT_WIDTH / camera.width
            focal_from = "camera"
        else:
            focal_net, focal_from = None, ""
        kind: DepthKind
        with np.errstate(divide="ignore"):
            if self.meta.baseline_m is not None and focal_net is not None:
                depth = self.meta.baseline_m * focal_net / (disp * INPUT_WIDTH)
                scaling = (
                    f"d = b*f/(disp*{INPUT_WIDTH}), b={self.meta.baseline_m:g} m ({self.baseline_from}), "
                    f"f={focal_net:.2f} px at width {INPUT_WIDTH} ({focal_from})"
                )
                kind = "metric"
            else:
                depth = 1.0 / disp
                why = "no baseline" if self.meta.baseline_m is None else "no focal length"
                scaling = f"d ~ 1/disp ({why}: scale unknown)"
                kind = "relative"
        return DepthPrediction(depth=depth, valid=np.isfinite(depth), name=NAME, kind=kind, scaling=scaling)
