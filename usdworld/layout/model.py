"""The complete metric description of a world, handed from layout to authoring."""

from __future__ import annotations

from dataclasses import dataclass

from usdworld.geometry.estimate import CameraEstimate
from usdworld.geometry.homography import HomographyFit
from usdworld.io.types import InputFile
from usdworld.layout.placement import Placement
from usdworld.layout.surfaces import SurfaceMesh


@dataclass(frozen=True)
class WorldModel:
    """Everything a world's USD layers are written from.

    Attributes:
        image_name: file name of the source image.
        image_size: (width, height) in pixels.
        camera: the camera and how it was obtained.
        ground_fit: the DLT homography ``ground_from_px`` (src = pixels, dst = ground).
        dlt_source: ``camera_model`` or ``manual``.
        placements: the placed objects.
        surfaces: ground meshes.
        inputs: every input file, for provenance.
        depth_source: dense depth backend (``ground`` when none).
        depth_kind: what that backend predicted (``none`` for ``ground``).
        depth_alignment: one line on how the dense depth was made metric.
        depth_fit: (scale, shift, inlier ratio, residual) of the ground fit; NaNs when none.
        warnings: things the user should know (one line each).
    """

    image_name: str
    image_size: tuple[int, int]
    camera: CameraEstimate
    ground_fit: HomographyFit
    dlt_source: str
    placements: tuple[Placement, ...]
    surfaces: tuple[SurfaceMesh, ...]
    inputs: tuple[InputFile, ...]
    depth_source: str = "ground"
    depth_kind: str = "none"
    depth_alignment: str = "none"
    depth_fit: tuple[float, float, float, float] = (float("nan"),) * 4
    warnings: tuple[str, ...] = ()
