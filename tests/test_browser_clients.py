"""Real clients nobody here wrote: three.js in headless Chromium loads our glb and usdz.

The page (``web/src``, three.js from npm bundled with esbuild; no CDN) is built into a temporary
folder and served on 127.0.0.1 by ``web/run_clients.mjs``, which drives Debian's chromium
through playwright-core with a fresh user-data-dir and software WebGL (SwiftShader).

three.js' ``GLTFLoader`` loads the glb and its ``USDLoader`` (``USDZLoader`` is a deprecated
alias of it since r179) loads the ``--flatten`` usdz: that loader composes neither sublayers
nor reference list ops stored in crate files, and ignores ``active``, so the layered and
baked packages are not for it. Each load must give the number of meshes of the composed USD
stage and its bounding box, turned to three.js' Y up: x -> x, z -> y, y -> -z.

Tolerance: 1 mm + 1e-6 x the box size (float32 positions and matrices on both sides).

Missing chromium, node or web/ npm packages fail the tests in CI (``CI`` set) and skip them
elsewhere, with the install hint.
"""

from __future__ import annotations

import json
import subprocess
import time

import numpy as np
import pytest
from pxr import Usd
from test_export_fixtures import WEB, add_edits, build_street_world, require_web_tools

from usdworld.authoring.usd_geometry import scene_bounds
from usdworld.export import export_world

NPM = ("three", "playwright-core", "esbuild")
#: Seconds the whole browser run may take.
BROWSER_TIMEOUT_S = 60


def _tolerance(box: np.ndarray) -> float:
    return 1e-3 + 1e-6 * float(np.ptp(box, axis=0).max())


def _y_up(box: np.ndarray) -> np.ndarray:
    """(2, 3) Z-up box -> the same box in glTF/three.js Y-up coordinates."""
    (x0, y0, z0), (x1, y1, z1) = box
    return np.array([[x0, z0, -y1], [x1, z1, -y0]])


@pytest.fixture(scope="module")
def clients(tmp_path_factory: pytest.TempPathFactory) -> dict:
    require_web_tools(NPM, chromium=True)
    work = tmp_path_factory.mktemp("browser")
    root = build_street_world(work / "street")
    edited = add_edits(root)
    glb = export_world(root, "glb", work / "exports" / "world.glb", validate=False).output
    usdz = export_world(root, "usdz", work / "exports" / "world.usdz", flatten=True, omni=False).output
    dist = work / "dist"
    build = subprocess.run(
        ["node", str(WEB / "build.mjs"), "--outdir", str(dist)], capture_output=True, text=True, timeout=60, check=False
    )
    assert build.returncode == 0, build.stderr
    shots = work / "screenshots"
    shots.mkdir()
    started = time.monotonic()
    proc = subprocess.run(
        ["node", str(WEB / "run_clients.mjs"), "--dist", str(dist), "--screenshots", str(shots), f"gltf={glb}", f"usdz={usdz}"],
        capture_output=True,
        text=True,
        timeout=BROWSER_TIMEOUT_S,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    report = json.loads(proc.stdout)
    report["seconds"] = time.monotonic() - started
    report["stage"] = Usd.Stage.Open(str(root))
    report["edited"] = edited
    report["screenshots"] = shots
    return report


def _result(clients: dict, kind: str) -> dict:
    result = next(r for r in clients["results"] if r["kind"] == kind)
    assert result["ok"], (result.get("error"), clients["console"][-20:])
    return result


@pytest.mark.parametrize("kind", ["gltf", "usdz"])
def test_three_js_sees_the_meshes_and_bounds_of_the_stage(clients: dict, kind: str) -> None:
    result = _result(clients, kind)
    count, box = scene_bounds(clients["stage"])
    assert result["meshCount"] == count
    want = _y_up(box)
    got = np.array([result["bboxMin"], result["bboxMax"]], dtype=np.float64)
    np.testing.assert_allclose(got, want, atol=_tolerance(box))
    assert result["render"]["drawCalls"] > 0 and result["render"]["webgl"].startswith("WebGL")
    assert (clients["screenshots"] / f"world.{'glb' if kind == 'gltf' else 'usdz'}.png").is_file()


def test_gltf_extras_reach_three_js_user_data(clients: dict) -> None:
    result = _result(clients, "gltf")
    stage = clients["stage"]
    swapped = clients["edited"]["swapped"]
    data = result["extras"][swapped]
    assert data["semanticLabels"] == {"class": ["car"]}
    assert data["variants"] == {"model": clients["edited"]["variant"]}
    assert data["usdworld"]["depth"] == pytest.approx(stage.GetPrimAtPath(swapped).GetAttribute("usdworld:depth").Get(), rel=1e-6)
    assert clients["edited"]["deleted"] not in result["extras"]


def test_browser_run_is_quick(clients: dict) -> None:
    assert clients["seconds"] < BROWSER_TIMEOUT_S
    assert clients["chromium"]
