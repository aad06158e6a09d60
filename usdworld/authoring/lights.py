"""The world's lights: a ``UsdLux.DistantLight`` sun and a ``UsdLux.DomeLight`` sky in the base layer.

``/World/Lights`` (an Xform) holds:

* ``Sun``: a DistantLight. UsdLux lights shine along their local -Z, so its ``xformOp:orient``
  turns +Z onto the direction towards the sun. ``inputs:intensity`` times ``inputs:color``
  is the renderer's sun colour (linear RGB; 0 when overcast), ``inputs:angle`` the sun's
  angular diameter (0.53 degrees).
* ``Sky``: a DomeLight whose ``inputs:intensity`` times ``inputs:color`` is the renderer's
  ambient light from above.

The estimate behind them (method, sun angles, shadow contrast, the sky's measured colours
and the ambient light from below, which UsdLux has no input for) is on ``/World/Lights``
as ``UsdWorldLightAPI``. :func:`usdworld.render.world_lights.lighting_from_stage` reads it all
back, edits included.

The lights are authored through the generic prim API, by their schema type names and
``UsdLux.LightAPI``'s ``inputs:`` attributes, exactly the specs ``UsdLux.DistantLight.Define``
and its ``Create*Attr`` write (non-custom, varying): a build does not import ``pxr.UsdLux``
(~5 ms of every ``usdworld build``; the render reads the lights the same way).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom

from usdworld.authoring.provenance import LIGHT_API, apply_with_values
from usdworld.world_files import LIGHTS_PATH, SKY_PATH, SUN_PATH

if TYPE_CHECKING:
    from usdworld.layout.model import LightRig
    from usdworld.perception.light import LightEstimate

#: Angular diameter of the sun seen from the earth, degrees.
SUN_ANGLE_DEG = 0.53


def sun_orientation(sun_direction_world: np.ndarray) -> Gf.Quatf:
    """The rotation that turns a light's +Z onto the direction towards the sun.

    Args:
        sun_direction_world: (3,) float unit vector towards the sun.
    """
    d = np.asarray(sun_direction_world, dtype=np.float64)
    rotation = Gf.Rotation(Gf.Vec3d(0.0, 0.0, 1.0), Gf.Vec3d(*(d / np.linalg.norm(d)).tolist()))
    return Gf.Quatf(rotation.GetQuat())


def _colour_and_intensity(rgb: np.ndarray) -> tuple[Gf.Vec3f, float]:
    """Split a linear RGB light into a colour with its largest channel 1 and an intensity."""
    peak = float(np.max(rgb))
    if peak <= 0:
        return Gf.Vec3f(1.0, 1.0, 1.0), 0.0
    return Gf.Vec3f(*(float(c) / peak for c in rgb)), peak


def _define_light(
    stage: Usd.Stage, path: str, type_name: str, inputs: dict[str, tuple[Sdf.ValueTypeName, object]]
) -> Usd.Prim:
    """A UsdLux light prim as its schema class's ``Define`` and ``Create*Attr`` author it.

    Args:
        stage: the world's base stage.
        path: the light's prim path.
        type_name: its schema type (``DistantLight``, ``DomeLight``).
        inputs: ``inputs:`` attribute name -> (its schema value type, the value), in authoring order.
    """
    prim = stage.DefinePrim(path, type_name)
    for name, (value_type, value) in inputs.items():
        prim.CreateAttribute(name, value_type, custom=False, variability=Sdf.VariabilityVarying).Set(value)
    return prim


def define_lights(stage: Usd.Stage, rig: LightRig, estimate: LightEstimate | None) -> UsdGeom.Xform:
    """Author ``/World/Lights`` with the sun and the sky (see the module docstring).

    Args:
        stage: the world's base stage.
        rig: the lights.
        estimate: how they were found in the photo (None: not estimated; recorded as ``no_evidence``).

    Returns:
        The ``Lights`` Xform.
    """
    lights = UsdGeom.Xform.Define(stage, LIGHTS_PATH)
    colour, intensity = _colour_and_intensity(rig.sun_color)
    float_ = Sdf.ValueTypeNames.Float
    sun = _define_light(
        stage,
        SUN_PATH,
        "DistantLight",
        {
            "inputs:color": (Sdf.ValueTypeNames.Color3f, colour),
            "inputs:intensity": (float_, intensity),
            "inputs:angle": (float_, SUN_ANGLE_DEG),
        },
    )
    UsdGeom.Xformable(sun).AddOrientOp().Set(sun_orientation(rig.sun_direction_world))
    colour, intensity = _colour_and_intensity(rig.sky_ambient)
    _define_light(
        stage,
        SKY_PATH,
        "DomeLight",
        {"inputs:color": (Sdf.ValueTypeNames.Color3f, colour), "inputs:intensity": (float_, intensity)},
    )
    d = rig.sun_direction_world
    values = {
        "usdworld:lightMethod": "no_evidence" if estimate is None else estimate.method,
        "usdworld:overcast": False if estimate is None else bool(estimate.overcast),
        "usdworld:sunAzimuth": float(math.atan2(d[1], d[0])),
        "usdworld:sunElevation": float(math.asin(min(max(d[2], -1.0), 1.0))),
        "usdworld:shadowContrast": math.nan if estimate is None else float(estimate.shadow_contrast),
        "usdworld:shadowShare": math.nan if estimate is None else float(estimate.shadow_share),
        "usdworld:shadowFitIoU": math.nan if estimate is None else float(estimate.fit_iou),
        "usdworld:shadowCasters": 0 if estimate is None else int(estimate.casters),
        "usdworld:groundAmbient": Gf.Vec3f(*(float(c) for c in rig.ground_ambient)),
        "usdworld:skyZenithColor": Gf.Vec3f(*(float(c) for c in rig.sky_zenith_srgb)),
        "usdworld:skyHorizonColor": Gf.Vec3f(*(float(c) for c in rig.sky_horizon_srgb)),
        "usdworld:skySource": "none" if estimate is None else estimate.sky_source,
    }
    apply_with_values(lights.GetPrim(), LIGHT_API, values)
    return lights
