"""The placed objects of a composed world, as the evaluation compares them with ground truth.

Read from the composed stage (edits and variant selections applied, inactive objects
skipped), so an edited world is evaluated as it is. Each child of ``/World/Objects`` gives
its class label, its origin (the asset convention: the footprint centre on the ground),
its heading (the local +X axis), its size (the untransformed bounds of its geometry times
its scale), its scale, its asset's ``model`` variant and the ``usdworld:instanceId`` it was
built from.

This module reads USD (``pxr``), which the house style otherwise keeps to ``authoring/``
and ``render/``: evaluation sits downstream of rendering and must read the composed stage.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pxr import Usd, UsdGeom

from usdworld.render.scene import matrix_from_gf, world_from_stage

OBJECTS_PATH = "/World/Objects"
_LABEL_ATTR = "semantics:labels:class"
_INSTANCE_ATTR = "usdworld:instanceId"


@dataclass(frozen=True)
class WorldObject:
    """One placed object.

    Attributes:
        name: prim name (``car_0003``).
        class_name: its ``class`` label.
        instance_id: ``usdworld:instanceId`` (-1 when absent or for stuff).
        bottom_centre_world: (3,) float64 origin of the object (footprint centre), metres.
        heading_world: (3,) float64 unit vector of the object's +X axis.
        size_lwh: (3,) float64 length (along +X), width, height in metres.
        scale: (3,) float64 its scale along its own X, Y, Z.
        variant: the selection of its ``model`` variant set ('' when it has none).
    """

    name: str
    class_name: str
    instance_id: int
    bottom_centre_world: np.ndarray
    heading_world: np.ndarray
    size_lwh: np.ndarray
    scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    variant: str = ""


def _label(prim: Usd.Prim) -> str:
    attr = prim.GetAttribute(_LABEL_ATTR)
    value = attr.Get() if attr else None
    if value is not None and len(value):
        return str(value[0])
    return prim.GetName().rsplit("_", 1)[0]


def _variant(prim: Usd.Prim) -> str:
    sets = prim.GetVariantSets()
    return sets.GetVariantSet("model").GetVariantSelection() if sets.HasVariantSet("model") else ""


def world_objects(stage: Usd.Stage, objects_path: str = OBJECTS_PATH) -> list[WorldObject]:
    """Every active object under ``objects_path``, in stage order."""
    parent = stage.GetPrimAtPath(objects_path)
    if not parent:
        return []
    to_world = world_from_stage(stage)
    xf_cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    bbox = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_, UsdGeom.Tokens.render])
    out = []
    for prim in parent.GetChildren():  # active children only
        M = to_world @ matrix_from_gf(xf_cache.GetLocalToWorldTransform(prim))
        scale = np.linalg.norm(M[:3, :3], axis=0)
        x_axis = M[:3, 0] / max(scale[0], 1e-12)
        box = bbox.ComputeUntransformedBound(prim).ComputeAlignedRange()
        size = np.zeros(3) if box.IsEmpty() else np.array(box.GetSize(), dtype=np.float64) * scale
        inst = prim.GetAttribute(_INSTANCE_ATTR)
        value = inst.Get() if inst else None
        out.append(
            WorldObject(
                name=prim.GetName(),
                class_name=_label(prim),
                instance_id=int(value) if value is not None else -1,
                bottom_centre_world=M[:3, 3].copy(),
                heading_world=x_axis,
                size_lwh=size,
                scale=scale,
                variant=_variant(prim),
            )
        )
    return out
