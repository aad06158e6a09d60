"""Authoring the usdworld schema attributes explicitly (tools without the plugin read them too)."""

from __future__ import annotations

from typing import Any

from pxr import Sdf, Usd

PROVENANCE_API = "UsdWorldProvenanceAPI"
SCENE_API = "UsdWorldSceneAPI"
APPEARANCE_API = "UsdWorldAppearanceAPI"
LIGHT_API = "UsdWorldLightAPI"

#: Attribute name -> value type, for the API schemas (mirrors schemas/schema.usda).
ATTRIBUTE_TYPES: dict[str, Sdf.ValueTypeName] = {
    "usdworld:sourceImage": Sdf.ValueTypeNames.String,
    "usdworld:sourceClass": Sdf.ValueTypeNames.String,
    "usdworld:instanceId": Sdf.ValueTypeNames.Int,
    "usdworld:imageBBox": Sdf.ValueTypeNames.Float4,
    "usdworld:groundContactPixel": Sdf.ValueTypeNames.Float2,
    "usdworld:maskArea": Sdf.ValueTypeNames.Int,
    "usdworld:bottomTruncated": Sdf.ValueTypeNames.Bool,
    "usdworld:bottomOccluded": Sdf.ValueTypeNames.Bool,
    "usdworld:depth": Sdf.ValueTypeNames.Float,
    "usdworld:depthMethod": Sdf.ValueTypeNames.Token,
    "usdworld:depthCueNames": Sdf.ValueTypeNames.StringArray,
    "usdworld:depthCueValues": Sdf.ValueTypeNames.FloatArray,
    "usdworld:depthCueSigmas": Sdf.ValueTypeNames.FloatArray,
    "usdworld:scaleFactor": Sdf.ValueTypeNames.Float,
    "usdworld:scaleMeasured": Sdf.ValueTypeNames.Float,
    "usdworld:yawSource": Sdf.ValueTypeNames.Token,
    "usdworld:collisionDisplacement": Sdf.ValueTypeNames.Float2,
    "usdworld:confidence": Sdf.ValueTypeNames.Float,
    "usdworld:version": Sdf.ValueTypeNames.String,
    "usdworld:imageSize": Sdf.ValueTypeNames.Int2,
    "usdworld:intrinsics": Sdf.ValueTypeNames.Matrix3d,
    "usdworld:intrinsicsEstimated": Sdf.ValueTypeNames.Bool,
    "usdworld:cameraHeight": Sdf.ValueTypeNames.Float,
    "usdworld:cameraPitch": Sdf.ValueTypeNames.Float,
    "usdworld:cameraRoll": Sdf.ValueTypeNames.Float,
    "usdworld:cameraYaw": Sdf.ValueTypeNames.Float,
    "usdworld:cameraEstimated": Sdf.ValueTypeNames.StringArray,
    "usdworld:cameraMethod": Sdf.ValueTypeNames.String,
    "usdworld:homography": Sdf.ValueTypeNames.Matrix3d,
    "usdworld:dltPixels": Sdf.ValueTypeNames.DoubleArray,
    "usdworld:dltGround": Sdf.ValueTypeNames.DoubleArray,
    "usdworld:dltRmsPx": Sdf.ValueTypeNames.Float,
    "usdworld:dltSource": Sdf.ValueTypeNames.Token,
    "usdworld:depthSource": Sdf.ValueTypeNames.String,
    "usdworld:depthKind": Sdf.ValueTypeNames.Token,
    "usdworld:depthAlignment": Sdf.ValueTypeNames.String,
    "usdworld:depthAlignmentFit": Sdf.ValueTypeNames.Float4,
    "usdworld:inputFiles": Sdf.ValueTypeNames.StringArray,
    "usdworld:inputHashes": Sdf.ValueTypeNames.StringArray,
    "usdworld:measuredColor": Sdf.ValueTypeNames.Color3f,
    "usdworld:measuredColorSpread": Sdf.ValueTypeNames.Color3f,
    "usdworld:measuredColorPixels": Sdf.ValueTypeNames.Int,
    "usdworld:measuredColorRegion": Sdf.ValueTypeNames.Token,
    "usdworld:albedo": Sdf.ValueTypeNames.Color3f,
    "usdworld:lightMethod": Sdf.ValueTypeNames.Token,
    "usdworld:overcast": Sdf.ValueTypeNames.Bool,
    "usdworld:sunAzimuth": Sdf.ValueTypeNames.Float,
    "usdworld:sunElevation": Sdf.ValueTypeNames.Float,
    "usdworld:shadowContrast": Sdf.ValueTypeNames.Float,
    "usdworld:shadowShare": Sdf.ValueTypeNames.Float,
    "usdworld:shadowFitIoU": Sdf.ValueTypeNames.Float,
    "usdworld:shadowCasters": Sdf.ValueTypeNames.Int,
    "usdworld:groundAmbient": Sdf.ValueTypeNames.Color3f,
    "usdworld:skyZenithColor": Sdf.ValueTypeNames.Color3f,
    "usdworld:skyHorizonColor": Sdf.ValueTypeNames.Color3f,
    "usdworld:skySource": Sdf.ValueTypeNames.Token,
}


def apply_with_values(prim: Usd.Prim, api: str, values: dict[str, Any]) -> None:
    """Apply an API schema and author every given attribute explicitly.

    Works whether or not the schema plugin is registered (``AddAppliedSchema`` plus
    non-custom attributes of the schema's types).

    Args:
        prim: the prim.
        api: ``UsdWorldProvenanceAPI``, ``UsdWorldSceneAPI`` or ``UsdWorldAppearanceAPI``.
        values: attribute name -> Python/Gf value.
    """
    prim.AddAppliedSchema(api)
    for name, value in values.items():
        prim.CreateAttribute(name, ATTRIBUTE_TYPES[name], custom=False).Set(value)


def author_values(spec: Sdf.PrimSpec, api: str, values: dict[str, Any]) -> None:
    """:func:`apply_with_values` on a prim spec: the same opinions, written through Sdf.

    Prepends ``api`` to the spec's ``apiSchemas`` and writes each attribute as a non-custom
    spec with its default value (cast to the attribute's type, as ``Usd.Attribute.Set`` does).

    Args:
        spec: the prim spec to write into.
        api: ``UsdWorldProvenanceAPI`` or ``UsdWorldSceneAPI``.
        values: attribute name -> Python/Gf value.
    """
    prepend_api_schema(spec, api)
    for name, value in values.items():
        Sdf.AttributeSpec(spec, name, ATTRIBUTE_TYPES[name], Sdf.VariabilityVarying, declaresCustom=False).default = value


def prepend_api_schema(spec: Sdf.PrimSpec, api: str) -> None:
    """Add ``api`` at the end of the spec's prepended ``apiSchemas`` (``Usd.Prim.AddAppliedSchema`` on a new spec)."""
    schemas = spec.GetInfo("apiSchemas") if spec.HasInfo("apiSchemas") else Sdf.TokenListOp()
    spec.SetInfo("apiSchemas", Sdf.TokenListOp.Create(prependedItems=[*schemas.prependedItems, api]))


def read_values(prim: Usd.Prim) -> dict[str, Any]:
    """Every authored ``usdworld:`` attribute of a prim, by name."""
    out = {}
    for attr in prim.GetAttributes():
        name = attr.GetName()
        if name.startswith("usdworld:") and attr.HasAuthoredValue():
            out[name] = attr.Get()
    return out
