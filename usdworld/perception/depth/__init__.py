"""Depth: pluggable backends (image -> depth), metric alignment to the ground, and
per-object depth fusion.

Backends (:func:`make_backend`):

* ``ground``: ground-plane depth from the camera (no network; the default when the
  camera is known).
* ``monodepth``: the paper's network (Godard et al. 2017, VGG, 512x256), torch.
* ``monodepth2``: ResNet-18 monodepth2, loads nianticlabs' released ``encoder.pth`` /
  ``depth.pth`` unchanged.
* ``hf``: a transformers depth-estimation model from a local folder, offline.
* ``file``: a precomputed depth map (``.npy``, 16-bit PNG metres*256, ``.pfm``).

torch and transformers are imported only when a network backend is made, so this
package imports without them.

Example:
    >>> backend = make_backend("monodepth2", Path("weights/mono+stereo_640x192"))  # doctest: +SKIP
    >>> pred = backend.predict(image.rgb, camera)  # doctest: +SKIP
    >>> if pred.kind == "metric":  # doctest: +SKIP
    ...     depth_map = pred.to_depth_map()
    ... else:
    ...     fit, depth_map = align_to_ground(pred, road_mask, camera)
"""

from __future__ import annotations

from pathlib import Path

from usdworld.errors import InputError
from usdworld.perception.depth.align import AlignmentFit, align_to_ground
from usdworld.perception.depth.base import DEPTH_KINDS, DepthBackend, DepthKind, DepthPrediction
from usdworld.perception.depth.fusion import DepthCue, FusedDepth, fuse, object_depth_cues
from usdworld.perception.depth.ground import GroundDepthBackend, ground_plane_depth

#: Names accepted by :func:`make_backend`, in CLI order.
BACKEND_NAMES: tuple[str, ...] = ("ground", "monodepth", "monodepth2", "hf", "file")

__all__ = [
    "BACKEND_NAMES",
    "DEPTH_KINDS",
    "AlignmentFit",
    "DepthBackend",
    "DepthCue",
    "DepthKind",
    "DepthPrediction",
    "FusedDepth",
    "GroundDepthBackend",
    "align_to_ground",
    "fuse",
    "ground_plane_depth",
    "make_backend",
    "object_depth_cues",
]


def make_backend(name: str, weights: Path | None = None, device: str | None = None) -> DepthBackend:
    """Build a depth backend by name, loading its weights now.

    Args:
        name: one of :data:`BACKEND_NAMES`.
        weights: ``monodepth``: the ``.pth`` checkpoint; ``monodepth2``: the folder with
            ``encoder.pth`` and ``depth.pth``; ``hf``: the model folder; ``file``: the depth
            map file; ``ground``: must be None.
        device: torch device (``cpu``, ``cuda``, ``cuda:0`` ...); None picks CUDA when
            available, else the CPU. Ignored by ``ground`` and ``file``.

    Returns:
        The backend.

    Raises:
        InputError: unknown name, missing/bad weights (the message says where such
            weights come from), or torch/transformers not installed.
    """
    if name == "ground":
        if weights is not None:
            raise InputError(f"depth backend ground: takes no weights, got {weights}")
        return GroundDepthBackend()
    if name == "file":
        from usdworld.perception.depth.file import FileDepthBackend

        if weights is None:
            raise InputError("depth backend file: needs the depth map file (--depth-map FILE)")
        return FileDepthBackend(Path(weights))
    if name == "monodepth":
        from usdworld.perception.depth.runtime import import_torch

        import_torch(name)
        from usdworld.perception.depth.monodepth import MonodepthBackend

        return MonodepthBackend(weights, device=device)
    if name == "monodepth2":
        from usdworld.perception.depth.runtime import import_torch

        import_torch(name)
        from usdworld.perception.depth.monodepth2 import Monodepth2Backend

        return Monodepth2Backend(weights, device=device)
    if name == "hf":
        from usdworld.perception.depth.hf import HfDepthBackend

        return HfDepthBackend(weights, device=device)
    raise InputError(f"depth backend {name!r}: unknown; choose one of {', '.join(BACKEND_NAMES)}")
