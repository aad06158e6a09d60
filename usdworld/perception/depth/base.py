"""The one interface every depth backend implements, and what it returns.

A backend turns the photo into a dense :class:`DepthPrediction`. What its values mean is
said by :attr:`DepthPrediction.kind`:

============================  =========================================================
kind                          values ``v`` and true depth ``d`` (metres, optical axis)
============================  =========================================================
``metric``                    ``d = v``
``relative``                  ``d = s * v`` for an unknown scale ``s > 0``
``affine_invariant``          ``d = s * v + t`` for unknown ``s > 0`` and shift ``t``
``disparity``                 ``1 / d = s * v + t`` (affine-invariant inverse depth:
                              larger is nearer; MiDaS, DPT, Depth Anything)
============================  =========================================================

Only ``metric`` predictions turn into a :class:`~usdworld.io.types.DepthMap` directly
(:meth:`DepthPrediction.to_depth_map`); the others are scaled to metres with the
ground (:func:`usdworld.perception.depth.align.align_to_ground`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Protocol, get_args, runtime_checkable

import numpy as np

from usdworld.errors import CalibrationError, InputError
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.types import DepthMap

DepthKind = Literal["metric", "relative", "affine_invariant", "disparity"]
DEPTH_KINDS: tuple[str, ...] = get_args(DepthKind)


@dataclass(frozen=True)
class DepthPrediction:
    """One backend's dense output for one image.

    Invalid pixels are masked on construction: ``valid`` is and-ed with "finite" (and
    with "> 0" for ``metric`` and ``relative`` depth, and for ``disparity``), and
    ``depth`` is set to 0 where not valid, so NaN/inf never travel further.

    Attributes:
        depth: (H, W) float32 values; metres when ``kind == "metric"``, else see the
            module table (for ``disparity`` these are inverse-depth-like values).
        valid: (H, W) bool, True where ``depth`` holds a usable value.
        name: backend name (``ground``, ``monodepth``, ``monodepth2``, ``hf:<model>``,
            ``file:<name>``), for provenance.
        kind: how values relate to metres (module table).
        scaling: one line saying how the values were scaled, for provenance
            (e.g. ``d = b*f/disp, b=0.54 m (checkpoint), f=721.5 px (camera)``).
    """

    depth: np.ndarray
    valid: np.ndarray
    name: str
    kind: DepthKind
    scaling: str = ""

    def __post_init__(self) -> None:
        if self.kind not in DEPTH_KINDS:
            raise InputError(
                f"depth prediction {self.name}: kind must be one of {DEPTH_KINDS}, got {self.kind!r}"
            )
        depth = np.array(self.depth, dtype=np.float32)
        valid = np.array(self.valid, dtype=bool)
        if depth.ndim != 2 or depth.shape != valid.shape:
            raise InputError(
                f"depth prediction {self.name}: depth and valid must be (H, W) of one shape, "
                f"got {depth.shape} and {valid.shape}"
            )
        valid &= np.isfinite(depth)
        if self.kind in ("metric", "relative", "disparity"):
            with np.errstate(invalid="ignore"):
                valid &= depth > 0
        depth[~valid] = 0.0
        depth.setflags(write=False)
        valid.setflags(write=False)
        object.__setattr__(self, "depth", depth)
        object.__setattr__(self, "valid", valid)

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) of the prediction."""
        return (int(self.depth.shape[0]), int(self.depth.shape[1]))

    def to_depth_map(self) -> DepthMap:
        """The prediction as a metric :class:`DepthMap` (source = backend name).

        Raises:
            CalibrationError: when the prediction is not metric; align it first with
                :func:`usdworld.perception.depth.align.align_to_ground`.
        """
        if self.kind != "metric":
            raise CalibrationError(
                f"depth from {self.name} is {self.kind.replace('_', '-')}, not metres: "
                "align it to the ground (needs a camera and road/sidewalk labels)"
            )
        return DepthMap(depth_m=self.depth, valid=self.valid, source=self.name)


@runtime_checkable
class DepthBackend(Protocol):
    """Image -> dense depth. Implementations load their weights in ``__init__``."""

    @property
    def name(self) -> str:
        """Backend name as recorded in provenance."""
        ...

    def predict(self, rgb: np.ndarray, camera: PinholeCamera | None = None) -> DepthPrediction:
        """Estimate depth for one photo.

        Args:
            rgb: (H, W, 3) uint8 RGB image.
            camera: the photo's camera when known (focal length for disparity -> depth,
                the ground plane for the ``ground`` backend), else None.

        Returns:
            A prediction of shape (H, W).
        """
        ...


def check_rgb(rgb: np.ndarray, where: str) -> np.ndarray:
    """Validate an input photo.

    Args:
        rgb: (H, W, 3) uint8 RGB image.
        where: backend name for the message.

    Returns:
        The same array (as an ndarray).

    Raises:
        InputError: wrong shape or dtype.
    """
    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8 or rgb.shape[0] < 1 or rgb.shape[1] < 1:
        raise InputError(f"{where}: image must be (H, W, 3) uint8 RGB, got {rgb.shape} {rgb.dtype}")
    return rgb


def check_camera_matches(camera: PinholeCamera | None, rgb: np.ndarray, where: str) -> None:
    """Raise InputError when the camera's image size differs from the photo's."""
    if camera is not None and (camera.height, camera.width) != rgb.shape[:2]:
        raise InputError(
            f"{where}: camera is for a {camera.width}x{camera.height} image, "
            f"the photo is {rgb.shape[1]}x{rgb.shape[0]}"
        )
