"""Colours from the photo as per-object material overrides in the base layer.

For an object, the override is the material half of what ``restyle`` authors (see
:mod:`usdworld.authoring.editing.restyle`): its paint materials' ``inputs:diffuseColor``, in
the **base** layer. The meshes' ``primvars:displayColor`` (a fallback for viewers that show
no materials) keeps the asset's value: an opinion on a mesh makes every export validate that
mesh's points again (the asset's validation on its card no longer covers it), which tripled
the usdz export time; the renderer, the GLB export, the browser editor and the DCC importers
all read the material. DCC tools see it as the material's value, and a ``restyle`` in the
edits layer, the stronger layer, wins over it (removing the restyle brings the photo's colour back).
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

from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

from usdworld.authoring.asset_library import VARIANT_SET
from usdworld.authoring.editing.restyle import restyle_targets
from usdworld.authoring.provenance import APPEARANCE_API, apply_with_values
from usdworld.errors import AuthoringError
from usdworld.world_files import GROUND_PATH, OBJECTS_PATH

if TYPE_CHECKING:
    from usdworld.layout.model import Appearance


def define_appearances(stage: Usd.Stage, appearances: Sequence[Appearance]) -> None:
    """Author each appearance on its object or ground surface (in the stage's root layer).

    The targets are found on the composed stage once per asset and variant (every object of
    a class references the same asset), then all overrides are written as specs in one
    change block.

    Args:
        stage: the world's base stage, objects and ground already authored (the overrides
            land on the composed assets' materials).
        appearances: the colours; targets are object names or surface names.

    Raises:
        AuthoringError: a target that is not in the stage.
    """
    layer = stage.GetRootLayer()
    cache: dict[tuple, dict[str, _Targets]] = {}
    plans = []
    for look in appearances:
        path = (
            f"{OBJECTS_PATH}/{look.target}"
            if look.kind == "object"
            else f"{GROUND_PATH}/{look.target.capitalize()}"
        )
        prim = stage.GetPrimAtPath(path)
        if not prim:
            raise AuthoringError(f"appearance of '{look.target}': no such {look.kind} in the world")
        plans.append(
            (
                look,
                prim,
                _object_targets(stage, prim, cache) if look.kind == "object" else _surface_targets(prim),
            )
        )
    with Sdf.ChangeBlock():
        for look, prim, by_variant in plans:
            albedo = Gf.Vec3f(*(float(c) for c in look.albedo))
            spec = layer.GetPrimAtPath(prim.GetPath()) or Sdf.CreatePrimInLayer(layer, prim.GetPath())
            for variant, (shaders, meshes) in by_variant.items():
                root = prim.GetPath()
                if variant:
                    if VARIANT_SET not in spec.variantSetNameList.prependedItems:
                        spec.variantSetNameList.prependedItems.append(VARIANT_SET)
                    root = root.AppendVariantSelection(VARIANT_SET, variant)
                for rel in shaders:
                    _set(
                        layer, root.AppendPath(rel), "inputs:diffuseColor", Sdf.ValueTypeNames.Color3f, albedo
                    )
                for rel in meshes:
                    _set(
                        layer,
                        root.AppendPath(rel),
                        "primvars:displayColor",
                        Sdf.ValueTypeNames.Color3fArray,
                        Vt.Vec3fArray([albedo]),
                    )
    for look, prim, _ in plans:
        m = look.measured
        apply_with_values(
            prim,
            APPEARANCE_API,
            {
                "usdworld:measuredColor": Gf.Vec3f(*(float(c) for c in m.linear_rgb)),
                "usdworld:measuredColorSpread": Gf.Vec3f(*(float(c) for c in m.spread)),
                "usdworld:measuredColorPixels": int(m.pixels),
                "usdworld:measuredColorRegion": m.region,
                "usdworld:albedo": Gf.Vec3f(*(float(c) for c in look.albedo)),
            },
        )


#: Paths relative to an object (or absolute, for surfaces) of the shaders and meshes to colour.
_Targets = tuple[list[Sdf.Path], list[Sdf.Path]]


def _set(
    layer: Sdf.Layer, prim_path: Sdf.Path, name: str, type_name: Sdf.ValueTypeName, value: object
) -> None:
    spec = layer.GetPrimAtPath(prim_path) or Sdf.CreatePrimInLayer(layer, prim_path)
    attr = spec.attributes.get(name) or Sdf.AttributeSpec(spec, name, type_name)
    attr.default = value


def _relative(prim: Usd.Prim, materials: list[UsdShade.Material], meshes: list[UsdGeom.Mesh]) -> _Targets:
    shaders = []
    for m in materials:
        shader, _, _ = m.ComputeSurfaceSource()
        if shader and shader.GetPrim().IsValid():
            shaders.append(shader.GetPath().MakeRelativePath(prim.GetPath()))
    return shaders, [mesh.GetPath().MakeRelativePath(prim.GetPath()) for mesh in meshes]


def _object_targets(
    stage: Usd.Stage, prim: Usd.Prim, cache: dict[tuple, dict[str, _Targets]]
) -> dict[str, _Targets]:
    """Variant name ('' for an asset without variants) -> the restyle targets in that variant."""
    refs = prim.GetMetadata("references")
    vsets = prim.GetVariantSets()
    names = (
        tuple(vsets.GetVariantSet(VARIANT_SET).GetVariantNames()) if vsets.HasVariantSet(VARIANT_SET) else ()
    )
    key = (str(refs), names)
    if key not in cache:
        if not names:
            cache[key] = {"": _relative(prim, restyle_targets(prim)[0], [])}
        else:
            vset = vsets.GetVariantSet(VARIANT_SET)
            found = {}
            try:
                for name in names:
                    with Usd.EditContext(stage, stage.GetSessionLayer()):
                        vset.SetVariantSelection(name)
                    found[name] = _relative(prim, restyle_targets(prim)[0], [])  # materials only
            finally:
                session = stage.GetSessionLayer().GetPrimAtPath(prim.GetPath())
                if session:
                    del session.variantSelections[VARIANT_SET]
            cache[key] = found
    return cache[key]


def _surface_targets(prim: Usd.Prim) -> dict[str, _Targets]:
    """The surface mesh's own bound material and the mesh (relative to the mesh)."""
    bound = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]
    return {"": _relative(prim, [bound] if bound else [], [UsdGeom.Mesh(prim)])}
