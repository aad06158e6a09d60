"""The ``file`` backend: a precomputed metric depth map read from disk.

The formats (``.npy`` metres, 16-bit PNG in the KITTI convention metres*256, PFM) are
read by :func:`usdworld.io.depth_files.read_depth`, which also masks NaN, inf and
zeros. The map must have the photo's size: a depth map of another size is an input
error, not something to resample silently.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from usdworld.errors import InputError
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.types import DepthMap
from usdworld.perception.depth.base import DepthPrediction, check_rgb


class FileDepthBackend:
    """Serve one depth map file as the prediction for the photo.

    The file is read once, on construction.

    Args:
        path: the depth map file.

    Raises:
        InputError: missing, unreadable or malformed file.
    """

    def __init__(self, path: Path) -> None:
        from usdworld.io.depth_files import read_depth  # io owns file formats

        self.path = Path(path)
        if not self.path.is_file():
            raise InputError(
                f"depth map {self.path}: no such file; give a .npy (metres), "
                "a 16-bit PNG (metres*256) or a .pfm file"
            )
        self.depth_map: DepthMap = read_depth(self.path)
        self.name = f"file:{self.path.name}"

    def predict(self, rgb: np.ndarray, camera: PinholeCamera | None = None) -> DepthPrediction:
        """The file's depth map.

        Args:
            rgb: (H, W, 3) uint8 RGB image (only its size is used).
            camera: unused.

        Raises:
            InputError: the depth map's size differs from the image's.
        """
        rgb = check_rgb(rgb, self.name)
        h, w = self.depth_map.depth_m.shape
        if (h, w) != rgb.shape[:2]:
            raise InputError(
                f"depth map {self.path.name}: is {w}x{h} pixels, the image is "
                f"{rgb.shape[1]}x{rgb.shape[0]}; give a depth map of the image's size"
            )
        return DepthPrediction(
            depth=self.depth_map.depth_m,
            valid=self.depth_map.valid,
            name=self.name,
            kind="metric",
            scaling="metres as stored in the file",
        )
