"""Blender (4.5 LTS, the ``bpy`` module from the ``blender`` extra) opens our worlds and exports.

The demo world and a copy with two edits (``car_0002`` moved 3 m along +X, ``car_0003``
deleted) are imported as ``world.usda``, usdz, usdc (Blender's USD importer) and GLB (its
glTF importer), each in a fresh process running ``tests/blender_import.py``. What Blender
holds must equal the composed stage as pxr reads it:

- the number of mesh objects and the world-space bounds of their vertices (metres, Z up:
  both importers convert to Blender's frame, the glTF one from Y up);
- the origin of every object under ``/World/Objects``, so the moved car stands at its new
  place and the deleted one is absent;
- the source camera (USD formats; the GLB carries no camera): the horizontal field of view
  ``2 atan(W / 2 fx)`` and the principal-point shift of ``K`` in ``report.json``, with the
  half-pixel convention of ``usdworld/authoring/camera.py`` and Blender's shift unit (a
  fraction of the sensor width under horizontal fit), and its pose.

Without bpy the tests skip (and fail under CI): ``tools/setup_test_env.sh`` installs it.
"""

from __future__ import annotations

import functools
import importlib.util
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

PROBE = Path(__file__).with_name("blender_import.py")
FORMATS = ("usda", "usdz", "usdc", "glb")
MOVED, MOVED_BY, DELETED = "car_0002", (3.0, 0.0), "car_0003"
TOL_M = 1e-3  # Blender keeps float32 coordinates; the world spans ~250 m


def _require_bpy() -> None:
    if importlib.util.find_spec("bpy") is not None:
        return
    message = (
        "bpy (Blender 4.5 LTS as a Python module) is not installed: tools/setup_test_env.sh installs it "
        "(pip install --no-deps 'bpy>=4.5,<4.6', see README's dependency list)"
    )
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)


def _blender_import(path: Path, kind: str) -> dict:
    proc = subprocess.run(
        [sys.executable, str(PROBE), str(path), kind],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    line = next((s for s in proc.stdout.splitlines() if s.startswith("USDWORLD_BLENDER ")), None)
    assert proc.returncode == 0 and line is not None, (
        f"rc {proc.returncode}\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    )
    return json.loads(line.split(" ", 1)[1])


@pytest.fixture(scope="module")
def worlds(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The demo world and an edited copy of it, by name: their ``world.usda``."""
    _require_bpy()
    from usdworld.authoring.edits import WorldEditor
    from usdworld.demo import demo_request
    from usdworld.pipeline import build

    tmp = tmp_path_factory.mktemp("blender")
    demo = build(demo_request(tmp / "demo")).world
    edited = Path(shutil.copytree(demo.parent, tmp / "edited")) / demo.name
    with WorldEditor(edited) as editor:
        editor.move(MOVED, by=MOVED_BY)
        editor.delete(DELETED)
    return {"demo": demo, "edited": edited}


@pytest.fixture(scope="module")
def imported(worlds: dict[str, Path], tmp_path_factory: pytest.TempPathFactory):
    """``imported(world, fmt)``: Blender's facts for that world in that format (each import done once)."""
    from usdworld.export import export_world

    out = tmp_path_factory.mktemp("exports")

    @functools.cache
    def get(world: str, fmt: str) -> dict:
        root = worlds[world]
        if fmt == "usda":
            path = root
        else:
            path = export_world(root, fmt, out / world / f"{world}.{fmt}", validate=False).output
        return _blender_import(path, "glb" if fmt == "glb" else "usd")

    return get


def _stage_facts(root: Path) -> dict:
    """What pxr sees in the composed world: mesh count, exact bounds, object origins, camera pose."""
    from pxr import Usd, UsdGeom

    from usdworld.authoring.usd_geometry import scene_bounds

    stage = Usd.Stage.Open(str(root))
    count, box = scene_bounds(stage)
    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    objects = {
        p.GetName(): np.array(cache.GetLocalToWorldTransform(p).ExtractTranslation())
        for p in stage.GetPrimAtPath("/World/Objects").GetChildren()
    }
    camera = np.array(cache.GetLocalToWorldTransform(stage.GetPrimAtPath("/World/SourceCamera"))).T
    return {"meshes": count, "bounds": box, "objects": objects, "camera": camera}


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("world", ["demo", "edited"])
def test_blender_sees_the_stage_meshes_bounds_and_objects(worlds, imported, world: str, fmt: str) -> None:
    got = imported(world, fmt)
    want = _stage_facts(worlds[world])
    assert got["version"].startswith("4.5"), got["version"]
    assert got["meshes"] == want["meshes"]
    np.testing.assert_allclose(np.array(got["bounds"]), want["bounds"], atol=TOL_M)
    assert sorted(got["objects"]) == sorted(want["objects"])
    for name, origin in got["objects"].items():
        np.testing.assert_allclose(origin, want["objects"][name], atol=TOL_M, err_msg=name)


@pytest.mark.parametrize("fmt", FORMATS)
def test_blender_shows_the_edits(imported, fmt: str) -> None:
    before, after = imported("demo", fmt)["objects"], imported("edited", fmt)["objects"]
    assert DELETED in before and DELETED not in after
    np.testing.assert_allclose(
        np.subtract(after[MOVED], before[MOVED]), [*MOVED_BY, 0.0], atol=TOL_M
    )  # the road is flat there: z stays
    assert set(before) - set(after) == {DELETED}


@pytest.mark.parametrize("fmt", ["usda", "usdz", "usdc"])
def test_blender_camera_keeps_fov_and_principal_point(worlds, imported, fmt: str) -> None:
    report = json.loads((worlds["demo"].parent / "report.json").read_text())
    (fx, _, cx), (_, fy, cy), _ = report["camera"]["K"]
    width, height = report["image_size"]
    (camera,) = imported("demo", fmt)["cameras"].values()
    assert camera["sensor_fit"] in ("HORIZONTAL", "AUTO") and width >= height
    assert camera["lens_mm"] / camera["sensor_width_mm"] == pytest.approx(fx / width, rel=1e-5)
    assert camera["angle_x"] == pytest.approx(2.0 * math.atan(width / (2.0 * fx)), rel=1e-5)
    # Blender's shifts are fractions of the sensor width (horizontal fit), y up; image v runs down
    assert camera["shift_x"] == pytest.approx((width / 2.0 - (cx + 0.5)) / width, abs=1e-6)
    assert camera["shift_y"] == pytest.approx(((cy + 0.5) - height / 2.0) * (fx / fy) / width, abs=1e-6)
    np.testing.assert_allclose(camera["matrix_world"], _stage_facts(worlds["demo"])["camera"], atol=1e-5)
