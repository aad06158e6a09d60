"""Read a world back: objects, classes, camera facts and edit counts (for ``usdworld info``)."""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path
from typing import Any

from pxr import Sdf, Usd, UsdSemantics

from usdworld.authoring.provenance import read_values
from usdworld.authoring.stages import open_stage
from usdworld.errors import InputError
from usdworld.world_files import OBJECTS_PATH, WORLD_PATH


def open_world(path: str | Path) -> Usd.Stage:
    """Open a world's root layer, with a one-line error when it is not one."""
    path = Path(path)
    if path.is_dir():
        path = path / "world.usda"
    if not path.is_file():
        raise InputError(f"{path}: no such file; pass a world's world.usda (or its folder)")
    stage = open_stage(path)
    if not stage.GetPrimAtPath(WORLD_PATH):
        raise InputError(f"{path}: has no {WORLD_PATH} prim; is it a usdworld world?")
    return stage


def world_summary(stage: Usd.Stage) -> dict[str, Any]:
    """Facts about a composed world.

    Returns:
        A JSON-ready dictionary: layers, object counts per class (active and
        inactive), camera and DLT provenance, and the number of prims the edits
        layer touches.
    """
    world = stage.GetPrimAtPath(WORLD_PATH)
    scene = read_values(world)
    classes: Counter[str] = Counter()
    inactive = 0
    objects = []
    parent = stage.GetPrimAtPath(OBJECTS_PATH)
    children = parent.GetAllChildren() if parent else []
    query = UsdSemantics.LabelsQuery("class", Usd.TimeCode.Default())
    for prim in children:
        labels = [str(label) for label in query.ComputeUniqueDirectLabels(prim)] if prim.IsActive() else []
        label = labels[0] if labels else prim.GetName().rsplit("_", 1)[0]
        if prim.IsActive():
            classes[label] += 1
        else:
            inactive += 1
        values = read_values(prim)
        objects.append(
            {
                "name": prim.GetName(),
                "class": label,
                "active": prim.IsActive(),
                "depth_m": values.get("usdworld:depth"),
                "depth_method": values.get("usdworld:depthMethod"),
            }
        )
    layers = [layer.identifier for layer in stage.GetLayerStack(includeSessionLayers=False)]
    edits = [layer for layer in stage.GetLayerStack(includeSessionLayers=False) if layer.identifier.endswith("edits.usda")]
    edited = 0
    if edits:
        edited = sum(1 for _ in _prim_specs(edits[0]))
    return {
        "root": stage.GetRootLayer().identifier,
        "layers": [Path(p).name for p in layers],
        "source_image": scene.get("usdworld:sourceImage", ""),
        "usdworld_version": scene.get("usdworld:version", ""),
        "objects_active": sum(classes.values()),
        "objects_inactive": inactive,
        "classes": dict(sorted(classes.items())),
        "camera_height_m": scene.get("usdworld:cameraHeight"),
        "camera_pitch_deg": _degrees(scene.get("usdworld:cameraPitch")),
        "camera_estimated": list(scene.get("usdworld:cameraEstimated", [])),
        "camera_method": scene.get("usdworld:cameraMethod", ""),
        "dlt_rms_px": scene.get("usdworld:dltRmsPx"),
        "dlt_source": scene.get("usdworld:dltSource", ""),
        "edited_prims": edited,
        "objects": objects,
    }


def _degrees(radians: float | None) -> float | None:
    """An angle recorded in radians, in degrees (as every command prints angles); None stays None."""
    return None if radians is None else math.degrees(radians)


def _prim_specs(layer: Sdf.Layer):
    stack = [layer.pseudoRoot]
    while stack:
        spec = stack.pop()
        for child in spec.nameChildren:
            if child.path.pathElementCount >= 3:
                yield child
            stack.append(child)
