"""Colours from the photo as per-object material overrides in the base layer.

For an object, the override is what ``restyle`` authors (see
:mod:`usdworld.authoring.editing.restyle`), on the same targets (its paint materials'
``inputs:diffuseColor`` and the ``primvars:displayColor`` of the meshes bound to them), but in
the **base** layer: DCC tools see it as the material's value, and a ``restyle`` in the edits
layer, the stronger layer, wins over it (removing the restyle brings the photo's colour back).
For a ground surface, it is the ``diffuseColor`` of the surface's own material and its
``displayColor``. The measured colour, its spread and the albedo go into the prim's
``UsdWorldAppearanceAPI`` attributes.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from pxr import Gf, Usd, UsdGeom, UsdShade

from usdworld.authoring.editing.restyle import author_colour, restyle_targets
from usdworld.authoring.provenance import APPEARANCE_API, apply_with_values
from usdworld.errors import AuthoringError
from usdworld.world_files import GROUND_PATH, OBJECTS_PATH

if TYPE_CHECKING:
    from usdworld.layout.model import Appearance


def define_appearances(stage: Usd.Stage, appearances: Sequence[Appearance]) -> None:
    """Author each appearance on its object or ground surface (in the current edit target).

    Args:
        stage: the world's base stage, objects and ground already authored (the overrides
            land on the composed assets' materials).
        appearances: the colours; targets are object names or surface names.

    Raises:
        AuthoringError: a target that is not in the stage.
    """
    for look in appearances:
        if look.kind == "object":
            prim = stage.GetPrimAtPath(f"{OBJECTS_PATH}/{look.target}")
            materials, meshes = restyle_targets(prim) if prim else ([], [])
        else:
            prim = stage.GetPrimAtPath(f"{GROUND_PATH}/{look.target.capitalize()}")
            bound = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0] if prim else None
            materials, meshes = ([bound] if bound else []), ([UsdGeom.Mesh(prim)] if prim else [])
        if not prim:
            raise AuthoringError(f"appearance of '{look.target}': no such {look.kind} in the world")
        albedo = tuple(float(c) for c in look.albedo)
        author_colour(materials, meshes, albedo)  # type: ignore[arg-type]
        m = look.measured
        apply_with_values(
            prim,
            APPEARANCE_API,
            {
                "usdworld:measuredColor": Gf.Vec3f(*(float(c) for c in m.linear_rgb)),
                "usdworld:measuredColorSpread": Gf.Vec3f(*(float(c) for c in m.spread)),
                "usdworld:measuredColorPixels": int(m.pixels),
                "usdworld:measuredColorRegion": m.region,
                "usdworld:albedo": Gf.Vec3f(*albedo),
            },
        )
