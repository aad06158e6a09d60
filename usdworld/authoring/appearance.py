"""Colours from the photo as per-object material overrides in the base layer.

For an object, the override is what ``restyle`` authors (see
:mod:`usdworld.authoring.editing.restyle`), on the same targets (its paint materials'
``inputs:diffuseColor`` and the ``primvars:displayColor`` of the meshes bound to them), but in
the **base** layer: DCC tools see it as the material's value, and a ``restyle`` in the edits
layer, the stronger layer, wins over it (removing the restyle brings the photo's colour back).
The asset's paint materials are variant-specific (``Looks/paint_red`` in one model,
``Looks/paint_white`` in another), so an object's override is written for **every** variant
of its ``model`` variant set, each in that variant's body of the object's own variant set
in the base layer (``car_0001{model=sedan}Looks/paint_white/...``): the selected variant's
paint always carries the photo's colour, also after ``replace`` selects another variant, and
no opinion is left dangling on a material the new selection does not have. An asset
without variants gets the overrides directly.
For a ground surface, it is the ``diffuseColor`` of the surface's own material and its
``displayColor``. The measured colour, its spread and the albedo go into the prim's
``UsdWorldAppearanceAPI`` attributes.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from pxr import Gf, Usd, UsdGeom, UsdShade

from usdworld.authoring.asset_library import VARIANT_SET
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
        path = f"{OBJECTS_PATH}/{look.target}" if look.kind == "object" else f"{GROUND_PATH}/{look.target.capitalize()}"
        prim = stage.GetPrimAtPath(path)
        if not prim:
            raise AuthoringError(f"appearance of '{look.target}': no such {look.kind} in the world")
        albedo = tuple(float(c) for c in look.albedo)
        if look.kind == "object":
            _override_object(stage, prim, albedo)
        else:
            bound = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]
            author_colour([bound] if bound else [], [UsdGeom.Mesh(prim)], albedo)  # type: ignore[arg-type]
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


def _override_object(stage: Usd.Stage, prim: Usd.Prim, albedo: tuple[float, float, float]) -> None:
    """The restyle targets' colour in every variant's body of the object's ``model`` variant set."""
    vsets = prim.GetVariantSets()
    if not vsets.HasVariantSet(VARIANT_SET):
        author_colour(*restyle_targets(prim), albedo)
        return
    target = stage.GetEditTarget()
    layer = target.GetLayer()
    vset = vsets.GetVariantSet(VARIANT_SET)
    names = vset.GetVariantNames()
    local = vsets.AddVariantSet(VARIANT_SET)  # the object's own variant set (bodies below)
    try:
        for name in names:
            with Usd.EditContext(stage, stage.GetSessionLayer()):
                vset.SetVariantSelection(name)
            targets = restyle_targets(prim)
            local.AddVariant(name)
            stage.SetEditTarget(Usd.EditTarget.ForLocalDirectVariant(layer, prim.GetPath().AppendVariantSelection(VARIANT_SET, name)))
            author_colour(*targets, albedo)
            stage.SetEditTarget(target)
    finally:
        stage.SetEditTarget(target)
        session = stage.GetSessionLayer().GetPrimAtPath(prim.GetPath())
        if session:
            del session.variantSelections[VARIANT_SET]
