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
``Looks/paint_white`` in another), so an object's override is written for its **selected**
variant only, in that variant's body of the object's own variant set in the base layer
(``car_0001{model=sedan}Looks/paint_white/...``): when ``replace`` selects another variant
the override falls away with it (no opinion is left dangling on a material the new
selection does not have) and ``replace`` authors the photo's colour, the prim's
``usdworld:albedo``, on the new variant's paint in the edits layer
(:func:`usdworld.authoring.editing.restyle.apply_photo_colour`). Writing it into every
variant made an export validate every variant's materials. An asset without variants gets
the overrides directly. The targets are found in each class asset's own stage, not in the
composed world.
For a ground surface, it is the ``diffuseColor`` of the surface's own material and its
``displayColor``. The measured colour, its spread and the albedo go into the prim's
``UsdWorldAppearanceAPI`` attributes.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

from usdworld.authoring.asset_library import VARIANT_SET
from usdworld.authoring.editing.restyle import restyle_targets
from usdworld.authoring.provenance import APPEARANCE_API, author_values
from usdworld.errors import AuthoringError
from usdworld.world_files import GROUND_PATH, OBJECTS_PATH

if TYPE_CHECKING:
    from usdworld.layout.model import Appearance


def define_appearances(
    layer: Sdf.Layer,
    appearances: Sequence[Appearance],
    asset_files: Mapping[str, Sequence[Path]] | None = None,
) -> None:
    """Author each appearance on its object or ground surface (in the base layer).

    No stage composes the world for this: an object's targets are found in its class
    asset's own stage (opened once per asset, its paint found once per variant), a
    surface's in the ground layer's stage; then all overrides are written as specs in one
    change block.

    Args:
        layer: the world's base layer, objects (their reference and ``model`` variant
            selection) and the ground reference already authored.
        appearances: the colours; targets are object names or surface names.
        asset_files: asset path as the layer references it -> the files of the library asset
            it is a copy of, root layer first (:func:`usdworld.authoring.world.asset_dependencies`):
            such an asset's targets are remembered in this process while none of those files
            changes (a process that builds many worlds opens each asset once).

    Raises:
        AuthoringError: a target that is not in the world.
    """
    finder = _TargetFinder(layer, asset_files or {})
    plans = []
    for look in appearances:
        if look.kind == "object":
            path = Sdf.Path(f"{OBJECTS_PATH}/{look.target}")
            by_variant = finder.object_targets(path)
        else:
            path = Sdf.Path(f"{GROUND_PATH}/{look.target.capitalize()}")
            by_variant = finder.surface_targets(path)
        if by_variant is None:
            raise AuthoringError(f"appearance of '{look.target}': no such {look.kind} in the world")
        plans.append((look, path, by_variant))
    with Sdf.ChangeBlock():
        for look, path, by_variant in plans:
            albedo = Gf.Vec3f(*(float(c) for c in look.albedo))
            spec = layer.GetPrimAtPath(path) or Sdf.CreatePrimInLayer(layer, path)
            for variant, (shaders, meshes) in by_variant.items():
                root = path
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
        for look, path, _ in plans:
            m = look.measured
            author_values(
                layer.GetPrimAtPath(path) or Sdf.CreatePrimInLayer(layer, path),
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

#: (library asset's root layer, chosen variant) -> (its files' modification stamps, the targets
#: of :meth:`_TargetFinder.object_targets`), remembered across worlds; at most
#: ``_MAX_REMEMBERED`` pairs.
_REMEMBERED: dict[tuple[Path, str], tuple[tuple[tuple[int, int], ...], dict[str, _Targets]]] = {}
_MAX_REMEMBERED = 512


def _stamps(files: Sequence[Path]) -> tuple[tuple[int, int], ...] | None:
    """Modification time and size of each file; None when one cannot be read."""
    try:
        return tuple((st.st_mtime_ns, st.st_size) for st in (os.stat(f) for f in files))
    except OSError:
        return None


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


class _TargetFinder:
    """The restyle targets of the base layer's objects and surfaces, each class asset (and
    the ground layer) opened on its own, once, and each asset variant's paint found once."""

    def __init__(self, layer: Sdf.Layer, asset_files: Mapping[str, Sequence[Path]]) -> None:
        self.layer = layer
        self.asset_files = asset_files
        self.stages: dict[str, Usd.Stage] = {}
        self.found: dict[tuple[str, str], dict[str, _Targets]] = {}

    def _stage(self, asset_path: str) -> Usd.Stage | None:
        resolved = self.layer.ComputeAbsolutePath(asset_path)
        if resolved not in self.stages:
            self.stages[resolved] = Usd.Stage.Open(resolved)
        return self.stages[resolved]

    def object_targets(self, path: Sdf.Path) -> dict[str, _Targets] | None:
        """Variant name ('' for an asset without variants) -> the restyle targets of the
        object's selected variant (materials only), relative to the object; None when the
        layer holds no such object."""
        spec = self.layer.GetPrimAtPath(path)
        refs = spec.referenceList.prependedItems if spec else []
        if not refs:
            return None
        asset = refs[0].assetPath
        chosen = spec.variantSelections.get(VARIANT_SET, "")
        key = (asset, chosen)
        if key not in self.found:
            self.found[key] = self._remembered(asset, chosen)
        return self.found[key]

    def _remembered(self, asset: str, chosen: str) -> dict[str, _Targets]:
        """:meth:`_variant_targets`, remembered per library asset while its files are unchanged."""
        files = self.asset_files.get(asset)
        stamps = _stamps(files) if files else None
        if files is None or stamps is None:
            return self._variant_targets(asset, chosen)
        key = (Path(files[0]), chosen)
        remembered = _REMEMBERED.get(key)
        if remembered is not None and remembered[0] == stamps:
            return remembered[1]
        targets = self._variant_targets(asset, chosen)
        if len(_REMEMBERED) >= _MAX_REMEMBERED:
            _REMEMBERED.pop(next(iter(_REMEMBERED)))
        _REMEMBERED[key] = (stamps, targets)
        return targets

    def _variant_targets(self, asset: str, chosen: str) -> dict[str, _Targets]:
        """The restyle targets of the asset's ``chosen`` variant ('' for its default), found in its stage."""
        stage = self._stage(asset)
        root = stage.GetDefaultPrim()
        vsets = root.GetVariantSets()
        if not vsets.HasVariantSet(VARIANT_SET):
            return {"": _relative(root, restyle_targets(root)[0], [])}
        vset = vsets.GetVariantSet(VARIANT_SET)
        variant = chosen or vset.GetVariantSelection()
        session = stage.GetSessionLayer()
        try:
            with Usd.EditContext(stage, session):
                vset.SetVariantSelection(variant)
            return {variant: _relative(root, restyle_targets(root)[0], [])}
        finally:
            over = session.GetPrimAtPath(root.GetPath())
            if over:
                del over.variantSelections[VARIANT_SET]

    def surface_targets(self, path: Sdf.Path) -> dict[str, _Targets] | None:
        """The surface mesh's own bound material and the mesh (relative to the mesh), found in
        the ground layer the base layer references; None when it has no such surface."""
        ground = self.layer.GetPrimAtPath(GROUND_PATH)
        refs = ground.referenceList.prependedItems if ground else []
        if not refs:
            return None
        stage = self._stage(refs[0].assetPath)
        root = stage.GetDefaultPrim()
        prim = stage.GetPrimAtPath(path.ReplacePrefix(Sdf.Path(GROUND_PATH), root.GetPath()))
        if not prim:
            return None
        bound = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]
        return {"": _relative(prim, [bound] if bound else [], [UsdGeom.Mesh(prim)])}
