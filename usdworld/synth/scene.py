"""Procedural straight-road street scenes from a random generator.

Example:
    >>> scene = make_street_scene(np.random.default_rng(19), 1024, 512)   # doctest: +SKIP
    >>> stage = author_stage(scene)                                       # doctest: +SKIP

Camera (sampled, in realistic ranges for a car-mounted camera): height 1.2-1.7 m,
pitch -2..+5 degrees (positive looks down), roll +-1 degree, yaw +-2 degrees, horizontal
field of view 50-90 degrees with square pixels, principal point within about 1 % of the
image centre. The sun stands 40-65 degrees high, behind the camera and 25-70 degrees to
one side, so cars and people cast visible shadows on the road. A fraction
``OVERCAST_FRACTION`` of the scenes is overcast: rendered without direct sun (ambient light
only, no shadows). Whether a scene is overcast is drawn from a generator spawned from
``rng`` (:meth:`numpy.random.Generator.spawn`), which leaves ``rng``'s own draws alone, so
every scene's camera, street, objects and sun are the same as before overcast scenes existed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from usdworld.errors import UsdWorldError
from usdworld.geometry.camera import PinholeCamera, intrinsics_from_fov
from usdworld.render.lighting import sun_direction
from usdworld.synth.assets import AssetSource, ClassAsset, class_asset, default_assets
from usdworld.synth.placement import SYNTH_CLASSES, SynthObject, place_objects
from usdworld.synth.street import StreetLayout, sample_street

CAMERA_HEIGHT_RANGE_M = (1.2, 1.7)
PITCH_RANGE_DEG = (-2.0, 5.0)
ROLL_RANGE_DEG = (-1.0, 1.0)
YAW_RANGE_DEG = (-2.0, 2.0)
HFOV_RANGE_DEG = (50.0, 90.0)
#: Share of overcast scenes: about 15 in a 50-scene evaluation, enough to measure how often
#: overcast is recognised.
OVERCAST_FRACTION = 0.3


@dataclass(frozen=True)
class SynthScene:
    """A sampled street scene: everything needed to author and render it.

    Attributes:
        camera: the source camera (its image size is the render size).
        street: the street cross-section.
        objects: the placed assets, in stage order.
        sun_direction_world: (3,) float64 unit vector towards the sun.
        asset_paths: class -> asset layer the objects of that class reference.
        overcast: True when the scene is lit by the sky only (no direct sun, no shadows).
    """

    camera: PinholeCamera
    street: StreetLayout
    objects: tuple[SynthObject, ...]
    sun_direction_world: np.ndarray
    asset_paths: Mapping[str, Path]
    overcast: bool = False

    def __post_init__(self) -> None:
        sun = np.array(self.sun_direction_world, dtype=np.float64)
        sun.setflags(write=False)
        object.__setattr__(self, "sun_direction_world", sun)
        object.__setattr__(self, "asset_paths", MappingProxyType(dict(self.asset_paths)))
        missing = sorted({o.class_name for o in self.objects} - set(self.asset_paths))
        if missing:
            raise UsdWorldError(f"SynthScene: no asset path for classes {missing}")


def sample_camera(rng: np.random.Generator, width: int, height: int) -> PinholeCamera:
    """A car-mounted camera in the ranges of the module docstring."""
    hfov = float(rng.uniform(*HFOV_RANGE_DEG))
    K = intrinsics_from_fov(width, height, hfov)
    K[0, 2] += float(rng.uniform(-0.01, 0.01)) * width
    K[1, 2] += float(rng.uniform(-0.01, 0.01)) * height
    return PinholeCamera(
        width=width,
        height=height,
        K=K,
        height_m=float(rng.uniform(*CAMERA_HEIGHT_RANGE_M)),
        pitch=math.radians(float(rng.uniform(*PITCH_RANGE_DEG))),
        roll=math.radians(float(rng.uniform(*ROLL_RANGE_DEG))),
        yaw=math.radians(float(rng.uniform(*YAW_RANGE_DEG))),
    )


def make_street_scene(
    rng: np.random.Generator, width: int, height: int, assets: AssetSource | None = None
) -> SynthScene:
    """Sample a street scene.

    Args:
        rng: random generator; the same seed gives the same scene.
        width: image width in pixels.
        height: image height in pixels.
        assets: where class assets come from (default: the built-in library).

    Raises:
        AuthoringError: a class the sampler needs is missing from the asset source.
    """
    source = assets if assets is not None else default_assets()
    library: dict[str, ClassAsset] = {c: class_asset(source, c) for c in SYNTH_CLASSES}
    camera = sample_camera(rng, width, height)
    street = sample_street(rng)
    side = 1.0 if rng.random() < 0.5 else -1.0
    sun = sun_direction(180.0 + side * float(rng.uniform(25.0, 70.0)), float(rng.uniform(40.0, 65.0)))
    objects = place_objects(rng, street, library)
    weather = rng.spawn(1)[0]  # an independent stream: the draws above stay what they were
    overcast = bool(weather.random() < OVERCAST_FRACTION)
    return SynthScene(
        camera=camera,
        street=street,
        objects=objects,
        sun_direction_world=sun,
        asset_paths={c: a.path for c, a in library.items()},
        overcast=overcast,
    )
