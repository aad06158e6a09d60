"""Authoring an object a user adds, and the ``class`` label of a replaced one."""

from __future__ import annotations

from typing import Any

from pxr import Gf, Sdf, Usd, UsdGeom, UsdSemantics

from usdworld.authoring import asset_library
from usdworld.authoring.provenance import PROVENANCE_API, apply_with_values


def user_provenance(class_name: str, scale: float) -> dict[str, Any]:
    """Provenance values of an object a user added: no image evidence, placed by hand."""
    return {
        "usdworld:sourceImage": "",
        "usdworld:sourceClass": class_name,
        "usdworld:instanceId": -1,
        "usdworld:imageBBox": Gf.Vec4f(0, 0, 0, 0),
        "usdworld:groundContactPixel": Gf.Vec2f(0, 0),
        "usdworld:maskArea": 0,
        "usdworld:bottomTruncated": False,
        "usdworld:bottomOccluded": False,
        "usdworld:depth": 0.0,
        "usdworld:depthMethod": "user",
        "usdworld:depthCueNames": [],
        "usdworld:depthCueValues": [],
        "usdworld:depthCueSigmas": [],
        "usdworld:scaleFactor": float(scale),
        "usdworld:scaleMeasured": float(scale),
        "usdworld:yawSource": "user",
        "usdworld:collisionDisplacement": Gf.Vec2f(0, 0),
        "usdworld:confidence": 1.0,
    }


def author_user_object(
    stage: Usd.Stage,
    path: Sdf.Path,
    class_name: str,
    ref: str,
    variant: str,
    position_world: tuple[float, float, float],
    yaw_deg: float,
    scale: float,
) -> UsdGeom.Xform:
    """Define a user-added object in the stage's edit target.

    Args:
        stage: the world, its edit target the edits layer.
        path: the new prim's path (``/World/Objects/<class>_<NNNN>``).
        class_name: its class (label and provenance).
        ref: relative reference to the class's asset.
        variant: the ``model`` variant to select ('' for none).
        position_world: (x, y, z) of its origin, metres.
        yaw_deg: rotation about Z, degrees.
        scale: uniform scale.
    """
    xform = UsdGeom.Xform.Define(stage, path)
    prim = xform.GetPrim()
    prim.GetReferences().SetReferences([Sdf.Reference(ref)])
    if variant:
        prim.GetVariantSets().SetSelection(asset_library.VARIANT_SET, variant)
    xform.AddTranslateOp().Set(Gf.Vec3d(*position_world))
    xform.AddRotateZOp().Set(float(yaw_deg))
    xform.AddScaleOp().Set(Gf.Vec3f(scale, scale, scale))
    UsdSemantics.LabelsAPI.Apply(prim, "class").CreateLabelsAttr([class_name])
    apply_with_values(prim, PROVENANCE_API, user_provenance(class_name, scale))
    return xform


def set_label(prim: Usd.Prim, class_name: str) -> None:
    """Author the ``class`` label (applying LabelsAPI only where no layer has yet)."""
    attr = prim.GetAttribute("semantics:labels:class")
    if attr:
        attr.Set([class_name])
    else:
        UsdSemantics.LabelsAPI.Apply(prim, "class").CreateLabelsAttr([class_name])
