"""Import one file into Blender (the ``bpy`` module) and print what came in, as one JSON line.

Run by ``tests/test_blender_client.py`` in a fresh process per import (bpy is heavy and keeps
global state)::

    python tests/blender_import.py FILE {usd,glb}

USD files go through Blender's own importer (``bpy.ops.wm.usd_import``), GLB files through
its bundled glTF add-on (``bpy.ops.import_scene.gltf``, which turns glTF's Y up back into
Blender's Z up). The printed line starts with ``USDWORLD_BLENDER`` and holds:

- ``version``: Blender's version string;
- ``meshes``: the number of mesh objects;
- ``bounds``: ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` of every mesh vertex in world space
  (Blender units, Z up), or null when no mesh came in;
- ``objects``: ``{name: [x, y, z]}``, the world-space origin of each child of the ``Objects``
  object (the world's ``/World/Objects`` prims);
- ``cameras``: per camera object, its lens and sensor (mm), sensor fit, shifts, horizontal
  angle (radians) and ``matrix_world`` (4 x 4, rows).

bpy 4.5 is built against numpy 1.26 and asks for numpy<2. Under numpy 2 its audio module
``aud`` does not load (stderr shows "numpy.core.multiarray failed to import" and "Unable to
initialise audio"); the importers need no audio, and the glTF one runs on numpy 2.
"""

from __future__ import annotations

import json
import sys

import bpy
import numpy as np


def _bounds(meshes: list) -> list[list[float]] | None:
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for obj in meshes:
        n = len(obj.data.vertices)
        if n == 0:
            continue
        co = np.empty(n * 3, dtype=np.float64)
        obj.data.vertices.foreach_get("co", co)
        m = np.array(obj.matrix_world, dtype=np.float64)
        world = co.reshape(n, 3) @ m[:3, :3].T + m[:3, 3]
        lo, hi = np.minimum(lo, world.min(axis=0)), np.maximum(hi, world.max(axis=0))
    return None if not np.isfinite(lo).all() else [lo.tolist(), hi.tolist()]


def main(path: str, kind: str) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if kind == "glb":
        result = bpy.ops.import_scene.gltf(filepath=path)
    elif kind == "usd":
        result = bpy.ops.wm.usd_import(filepath=path)
    else:
        raise SystemExit(f"unknown kind {kind!r}: use usd or glb")
    if result != {"FINISHED"}:
        raise SystemExit(f"import of {path} returned {result}")
    scene_objects = list(bpy.context.scene.objects)
    meshes = [o for o in scene_objects if o.type == "MESH"]
    cameras = {
        o.name: {
            "lens_mm": o.data.lens,
            "sensor_width_mm": o.data.sensor_width,
            "sensor_height_mm": o.data.sensor_height,
            "sensor_fit": o.data.sensor_fit,
            "shift_x": o.data.shift_x,
            "shift_y": o.data.shift_y,
            "angle_x": o.data.angle_x,
            "matrix_world": [list(row) for row in o.matrix_world],
        }
        for o in scene_objects
        if o.type == "CAMERA"
    }
    facts = {
        "version": bpy.app.version_string,
        "meshes": len(meshes),
        "bounds": _bounds(meshes),
        "objects": {
            o.name: list(o.matrix_world.translation)
            for o in scene_objects
            if o.parent is not None and o.parent.name == "Objects"
        },
        "cameras": cameras,
    }
    print("USDWORLD_BLENDER " + json.dumps(facts), flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:3])
