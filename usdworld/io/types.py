"""Frozen dataclasses produced by :mod:`usdworld.io` and consumed by later stages."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _frozen_array(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a)
    if a.flags.writeable:
        a = a.copy()
        a.setflags(write=False)
    return a


@dataclass(frozen=True)
class InputFile:
    """Identity of one input file, for provenance.

    Attributes:
        role: what the file is for (``image``, ``labels``, ``instances``, ``camera`` ...).
        name: file name without directories (what goes into the USD layers).
        sha256: hex digest of the file's bytes.
    """

    role: str
    name: str
    sha256: str


@dataclass(frozen=True)
class SourceImage:
    """The photo.

    Attributes:
        rgb: (H, W, 3) uint8, RGB order.
        file: identity of the file it was read from.
    """

    rgb: np.ndarray
    file: InputFile

    def __post_init__(self) -> None:
        object.__setattr__(self, "rgb", _frozen_array(self.rgb))

    @property
    def width(self) -> int:
        return int(self.rgb.shape[1])

    @property
    def height(self) -> int:
        return int(self.rgb.shape[0])


@dataclass(frozen=True)
class Segmentation:
    """Cityscapes-style dense labels, same size as the image.

    Attributes:
        label_ids: (H, W) uint8 Cityscapes label ids.
        instance_ids: (H, W) int32 Cityscapes instance ids (``class*1000+k`` for things,
            the label id for stuff), or None when no instance map was given.
        files: identities of the files read.
    """

    label_ids: np.ndarray
    instance_ids: np.ndarray | None
    files: tuple[InputFile, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "label_ids", _frozen_array(self.label_ids))
        if self.instance_ids is not None:
            object.__setattr__(self, "instance_ids", _frozen_array(self.instance_ids))


@dataclass(frozen=True)
class Detection:
    """One 2D detection.

    Attributes:
        label: class as written in the input (``Car``, ``person`` ...).
        box_px: (4,) float64 ``xmin, ymin, xmax, ymax`` in pixels (xmax/ymax exclusive edges).
        score: detector confidence in [0, 1] (1.0 for ground-truth labels).
        mask: (H, W) bool full-image mask, or None for box-only detections.
        amodal: the box bounds the whole object, hidden parts included (KITTI labels are
            projections of 3D boxes), so its bottom edge is the object's ground contact
            even where another object hides it; False for boxes of the visible part.
        truncated: how much of the object lies outside the image, in [0, 1] (KITTI's
            ``truncated`` field; 0 when the input does not say). An object with
            ``truncated > 0`` is cut by the image border on the side(s) its box touches.
    """

    label: str
    box_px: np.ndarray
    score: float = 1.0
    mask: np.ndarray | None = None
    amodal: bool = False
    truncated: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "box_px", _frozen_array(np.asarray(self.box_px, dtype=np.float64)))
        object.__setattr__(self, "truncated", float(self.truncated))
        if not 0.0 <= self.truncated <= 1.0:
            raise ValueError(f"detection {self.label}: truncated must be in [0, 1], got {self.truncated}")
        if self.mask is not None:
            object.__setattr__(self, "mask", _frozen_array(np.asarray(self.mask, dtype=bool)))


@dataclass(frozen=True)
class Detections:
    """All detections of one image.

    Attributes:
        items: the detections, in file order.
        file: identity of the file read.
    """

    items: tuple[Detection, ...]
    file: InputFile


@dataclass(frozen=True)
class CameraSpec:
    """Whatever the camera file said; missing values are None and get estimated later.

    Attributes:
        K: (3, 3) float64 camera matrix, or None when the file gives no intrinsics.
        height_m: camera height above the ground in metres, or None.
        pitch: radians, positive looking down, or None.
        roll: radians, or None.
        yaw: radians, or None.
        source: ``cityscapes``, ``kitti`` or ``plain``.
        file: identity of the file read.
        extra_files: identities of further files (e.g. a KITTI planes file).
    """

    K: np.ndarray | None
    height_m: float | None
    pitch: float | None
    roll: float | None
    yaw: float | None
    source: str
    file: InputFile
    extra_files: tuple[InputFile, ...] = ()

    def __post_init__(self) -> None:
        if self.K is not None:
            object.__setattr__(self, "K", _frozen_array(np.asarray(self.K, dtype=np.float64)))


@dataclass(frozen=True)
class GroundCorrespondences:
    """Manual pixel <-> ground pairs (the paper's "5-6 selected points").

    Attributes:
        points_px: (N, 2) float64 pixels (u, v), N >= 4.
        points_ground: (N, 2) float64 ground points (x forward, y left) in metres.
        file: identity of the file read.
    """

    points_px: np.ndarray
    points_ground: np.ndarray
    file: InputFile

    def __post_init__(self) -> None:
        object.__setattr__(self, "points_px", _frozen_array(np.asarray(self.points_px, dtype=np.float64)))
        object.__setattr__(
            self, "points_ground", _frozen_array(np.asarray(self.points_ground, dtype=np.float64))
        )


@dataclass(frozen=True)
class DepthMap:
    """A dense metric depth map.

    Attributes:
        depth_m: (H, W) float32 depth along the optical axis in metres (0 where invalid).
        valid: (H, W) bool, True where depth is finite and > 0.
        source: how it was obtained (``file:<name>`` or a backend name).
    """

    depth_m: np.ndarray
    valid: np.ndarray
    source: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "depth_m", _frozen_array(np.asarray(self.depth_m, dtype=np.float32)))
        object.__setattr__(self, "valid", _frozen_array(np.asarray(self.valid, dtype=bool)))
