"""The complete metric description of a world, handed from layout to authoring."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usdworld.geometry.estimate import CameraEstimate
from usdworld.geometry.homography import HomographyFit
from usdworld.io.types import InputFile
from usdworld.layout.placement import Placement
from usdworld.layout.surfaces import SurfaceMesh
from usdworld.perception.appearance import MeasuredColour
from usdworld.perception.light import LightEstimate


@dataclass(frozen=True)
class Appearance:
    """A colour measured in the photo and the albedo chosen to reproduce it in the render.

    Attributes:
        target: a placed object's name, or a ground surface's name (``road``, ``sidewalk``, ``terrain``).
        kind: ``object`` or ``surface``.
        measured: the colour in the photo (linear RGB) and its spread.
        albedo: (3,) float64 linear diffuse colour authored on the target's material.
    """

    target: str
    kind: str
    measured: MeasuredColour
    albedo: np.ndarray

    def __post_init__(self) -> None:
        if self.kind not in ("object", "surface"):
            raise ValueError(f"Appearance.kind: object or surface, got {self.kind!r}")
        a = np.array(self.albedo, dtype=np.float64)
        if a.shape != (3,) or not np.all((a >= 0.0) & (a <= 1.0)):
            raise ValueError(f"Appearance.albedo: 3 numbers in [0, 1], got {a}")
        a.setflags(write=False)
        object.__setattr__(self, "albedo", a)


@dataclass(frozen=True)
class LightRig:
    """The world's lights as authored: a sun and a sky dome (renderer units, linear RGB).

    Attributes:
        sun_direction_world: (3,) float64 unit vector towards the sun.
        sun_color: (3,) float64 the sun's light (zeros when overcast).
        sky_ambient: (3,) float64 the sky's ambient light from above.
        ground_ambient: (3,) float64 the ambient light from below.
        sky_zenith_srgb: (3,) float64 sRGB sky colour straight up.
        sky_horizon_srgb: (3,) float64 sRGB sky colour at the horizon.
    """

    sun_direction_world: np.ndarray
    sun_color: np.ndarray
    sky_ambient: np.ndarray
    ground_ambient: np.ndarray
    sky_zenith_srgb: np.ndarray
    sky_horizon_srgb: np.ndarray

    def __post_init__(self) -> None:
        for name in ("sun_direction_world", "sun_color", "sky_ambient", "ground_ambient", "sky_zenith_srgb", "sky_horizon_srgb"):
            a = np.array(getattr(self, name), dtype=np.float64)
            if a.shape != (3,) or not np.all(np.isfinite(a)):
                raise ValueError(f"LightRig.{name}: 3 finite numbers, got {a}")
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        if not self.sun_direction_world[2] > 0:
            raise ValueError(f"LightRig.sun_direction_world: the sun must be above the horizon, got {self.sun_direction_world}")


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
        appearances: colours measured in the photo, per object and surface (those measured).
        light: the sun and sky estimated from the photo (None: not estimated, the default sun).
        lights: the lights authored (None: none authored; renderers use their default).
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
    appearances: tuple[Appearance, ...] = ()
    light: LightEstimate | None = None
    lights: LightRig | None = None
