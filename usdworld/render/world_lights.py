"""The renderer's :class:`~usdworld.render.lighting.Lighting` from a world's authored lights.

Reads ``/World/Lights/Sun`` (a ``UsdLux.DistantLight``: its world transform's +Z points
towards the sun; ``intensity * 2**exposure * color`` is the sun's light) and
``/World/Lights/Sky`` (a ``UsdLux.DomeLight``: the ambient light from above), and the
ambient light from below and the sky's colours from ``UsdWorldLightAPI`` on
``/World/Lights`` (see :mod:`usdworld.authoring.lights`). Edits in the edits layer count:
the stage is read composed. A world without lights (built before they were authored), or
a light deactivated, falls back to the default :class:`Lighting` for what is missing.

The lights are read through the generic prim API (their schema's type names and attribute
names), not the ``UsdLux`` classes: ``usdworld render`` then does not load the UsdLux Python
module (its wrappers cost more than the few reads here).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pxr import Usd, UsdGeom

from usdworld.render.lighting import Lighting
from usdworld.world_files import LIGHTS_PATH, SKY_PATH, SUN_PATH


def _light_rgb(light: Usd.Prim) -> np.ndarray:
    """(3,) float64 linear RGB of a UsdLux light: intensity * 2**exposure * color (``UsdLux.LightAPI``'s
    ``inputs:`` attributes; their schema's fallbacks where not authored)."""
    colour = np.array(light.GetAttribute("inputs:color").Get() or (1.0, 1.0, 1.0), dtype=np.float64)
    intensity = float(light.GetAttribute("inputs:intensity").Get() or 0.0)
    exposure = float(light.GetAttribute("inputs:exposure").Get() or 0.0)
    return colour * intensity * 2.0**exposure


def _colour(prim: Usd.Prim, name: str) -> np.ndarray | None:
    attr = prim.GetAttribute(name)
    value = attr.Get() if attr and attr.HasAuthoredValue() else None
    return None if value is None else np.array(value, dtype=np.float64)


def lighting_from_stage(stage: Usd.Stage, base: Lighting | None = None) -> Lighting:
    """The lighting a world's authored lights describe.

    Args:
        stage: the composed world.
        base: what is not authored comes from here (default: :class:`Lighting`).

    Returns:
        The lighting; ``base`` itself when the world has no lights.
    """
    light = base if base is not None else Lighting()
    changes: dict[str, object] = {}
    sun = stage.GetPrimAtPath(SUN_PATH)
    if sun and sun.IsActive() and sun.IsA("DistantLight"):  # UsdLux.DistantLight, by its schema's name
        world_from_light = np.array(UsdGeom.Xformable(sun).ComputeLocalToWorldTransform(Usd.TimeCode.Default()))
        towards_sun = world_from_light[2, :3]  # row-vector convention: row 2 is the image of +Z
        if towards_sun[2] > 1e-3 * np.linalg.norm(towards_sun):
            changes["sun_direction_world"] = towards_sun
        changes["sun_color"] = _light_rgb(sun)
    sky = stage.GetPrimAtPath(SKY_PATH)
    if sky and sky.IsActive() and sky.IsA("DomeLight"):  # UsdLux.DomeLight
        up = _light_rgb(sky)
        changes["sky_ambient"] = up
    lights = stage.GetPrimAtPath(LIGHTS_PATH)
    if lights:
        for name, field in (
            ("usdworld:groundAmbient", "ground_ambient"),
            ("usdworld:skyZenithColor", "sky_zenith_srgb"),
            ("usdworld:skyHorizonColor", "sky_horizon_srgb"),
        ):
            value = _colour(lights, name)
            if value is not None and value.shape == (3,) and np.all(np.isfinite(value)):
                changes[field] = value
    return dataclasses.replace(light, **changes) if changes else light
