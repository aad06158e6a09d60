"""Blender (Debian's ``blender`` package, run in background mode) opens our exports.

Debian 12's blender 3.4.1 is built without USD (``bpy.app.build_options.usd`` is False and
``bpy.ops.wm.usd_import`` does not exist), so the USD import test skips with that reason on
this machine kind; the glTF importer it does ship loads the glb, and the object count and the
bounding box (Blender converts glTF's Y up back to Z up) must match the USD stage.

Debian 12's blender 3.4.1 glTF importer calls ``np.bool``, which Debian 12's numpy 1.24 no
longer has; the import script puts it back before importing (a blender.org build needs no such
shim).

Blender is optional (``tools/setup_web.sh --with-blender`` installs it, ~640 MB): without it
both tests skip.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd
from test_export_fixtures import add_edits, build_street_world

from usdworld.authoring.usd_geometry import scene_bounds
from usdworld.export import export_world

PROBE = "import bpy, json; print('USDWORLD ' + json.dumps({'usd': bool(bpy.app.build_options.usd), 'version': bpy.app.version_string}))"

IMPORT = r"""
import bpy, json, sys
import numpy
if not hasattr(numpy, "bool"):  # Debian 12: blender 3.4.1's glTF importer uses np.bool, gone in numpy 1.24
    numpy.bool = bool
path, kind = sys.argv[sys.argv.index('--') + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
if kind == 'glb':
    bpy.ops.import_scene.gltf(filepath=path)
else:
    bpy.ops.wm.usd_import(filepath=path)
meshes = [o for o in bpy.context.scene.objects if o.type == 'MESH']
lo, hi = [float('inf')] * 3, [float('-inf')] * 3
for o in meshes:
    for v in o.data.vertices:
        w = o.matrix_world @ v.co
        lo = [min(a, b) for a, b in zip(lo, w)]
        hi = [max(a, b) for a, b in zip(hi, w)]
print('USDWORLD ' + json.dumps({'meshes': len(meshes), 'min': lo, 'max': hi}))
"""


def _blender(*args: str) -> dict:
    exe = shutil.which("blender")
    # Debian's blender embeds the system Python 3.11; started from another Python (pyenv, venv)
    # it would take that one's prefix from PATH and miss its own numpy: pin the system prefix
    env = dict(os.environ, PYTHONHOME="/usr")
    proc = subprocess.run(
        [exe, "--background", "--factory-startup", *args], capture_output=True, text=True, timeout=180, check=False, env=env
    )
    line = next((l for l in proc.stdout.splitlines() if l.startswith("USDWORLD ")), None)
    assert line is not None, proc.stdout[-2000:] + proc.stderr[-2000:]
    return json.loads(line[len("USDWORLD ") :])


@pytest.fixture(scope="module")
def blender() -> dict:
    if shutil.which("blender") is None:
        pytest.skip("Debian's blender is not installed (tools/setup_web.sh --with-blender installs it)")
    return _blender("--python-expr", PROBE)


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = build_street_world(tmp_path_factory.mktemp("blender"))
    add_edits(root)
    return root


def _check(result: dict, root: Path) -> None:
    count, box = scene_bounds(Usd.Stage.Open(str(root)))
    assert result["meshes"] == count
    np.testing.assert_allclose([result["min"], result["max"]], box, atol=1e-3 + 1e-6 * float(np.ptp(box, axis=0).max()))


def test_blender_imports_the_usd_exports(blender: dict, world: Path, tmp_path: Path) -> None:
    if not blender["usd"]:
        pytest.skip(
            f"Debian's blender {blender['version']} is built without USD (bpy.app.build_options.usd is False): "
            "it cannot import .usdc/.usdz on this machine; use the glb, or a blender.org build"
        )
    for fmt, name in (("usdc", "w.usdc"), ("usdz", "w.usdz")):
        out = export_world(world, fmt, tmp_path / fmt / name, validate=False).output
        script = tmp_path / "import.py"
        script.write_text(IMPORT)
        _check(_blender("--python", str(script), "--", str(out), "usd"), world)


def test_blender_imports_the_glb(blender: dict, world: Path, tmp_path: Path) -> None:
    out = export_world(world, "glb", tmp_path / "w.glb", validate=False).output
    script = tmp_path / "import.py"
    script.write_text(IMPORT)
    _check(_blender("--python", str(script), "--", str(out), "glb"), world)
