"""``usdworld serve`` on a multi-view world: each view's camera and photo, and edits, through the
API (Starlette's test client) and in headless Chromium (the view picker; as test_serve_e2e)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from starlette.testclient import TestClient
from test_serve_e2e import TIMEOUT_MS, require_browser
from test_serve_support import CHROMIUM, CHROMIUM_ARGS, ServerProcess
from views_support import CAMERAS, HEIGHT, WIDTH, write_rig

from usdworld.authoring.edits import WorldEditor
from usdworld.render.camera import camera_from_usd
from usdworld.serve.app import create_app
from usdworld.serve.session import WorldSession
from usdworld.views.build import ViewsRequest, build_views
from usdworld.views.manifest import read_views_manifest

TOKEN = "test-token-views"
HEADERS = {"X-Usdworld-Token": TOKEN}
#: Each view's photo gets its own grey, so the test can tell which one it was served.
GREY = {"front": 90, "left": 170}


@pytest.fixture(scope="module")
def rig_template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("serve_rig")
    manifest = write_rig(folder)
    for name, grey in GREY.items():
        cv2.imwrite(str(folder / f"{name}.png"), np.full((HEIGHT, WIDTH, 3), grey, np.uint8))
    build_views(ViewsRequest(read_views_manifest(manifest), folder / "world", jobs=1))
    return folder


@pytest.fixture()
def rig(rig_template: Path, tmp_path: Path) -> Path:
    """A fresh copy of the rig's folder (photos beside the world, as build --views leaves them)."""
    import shutil

    shutil.copytree(rig_template, tmp_path / "rig")
    return tmp_path / "rig" / "world" / "world.usda"


def _projected(camera: dict, point: np.ndarray) -> np.ndarray:
    """(2,) pixel (u, v) of a world point through a camera JSON of the page (three.js matrices)."""
    P = np.array(camera["projection"]).reshape(4, 4).T
    world_from_glcam = np.array(camera["world_from_glcam"]).reshape(4, 4).T
    clip = P @ np.linalg.inv(world_from_glcam) @ np.append(point, 1.0)
    ndc = clip[:3] / clip[3]
    return np.array([(ndc[0] + 1) / 2 * camera["width"] - 0.5, (1 - ndc[1]) / 2 * camera["height"] - 0.5])


def test_the_api_gives_each_views_camera_and_photo_and_edits_work(rig: Path) -> None:
    session = WorldSession(rig, clock=lambda: "")
    try:
        with TestClient(create_app(session, TOKEN), base_url="http://127.0.0.1:8765") as client:
            w = client.get("/api/world", headers=HEADERS).json()
            assert [v["name"] for v in w["views"]] == list(CAMERAS)
            assert all(v["photo"] for v in w["views"])
            with WorldEditor(rig) as editor:
                stage = editor.stage
                for v in w["views"]:
                    pose = camera_from_usd(stage.GetPrimAtPath(f"/World/Cameras/{v['name']}"), WIDTH, HEIGHT)
                    in_cam = np.array([1.0, 0.5, 10.0])  # 10 m ahead of the view's camera
                    point = pose.world_from_cam @ np.append(in_cam, 1.0)
                    expected = (pose.K @ in_cam)[:2] / in_cam[2]
                    assert _projected(v["camera"], point[:3]) == pytest.approx(expected, abs=1e-6)
            for name, grey in GREY.items():
                r = client.get(f"/api/photo?view={name}&token={TOKEN}")
                assert r.status_code == 200 and r.headers["content-type"] == "image/png"
                image = cv2.imdecode(np.frombuffer(r.content, np.uint8), cv2.IMREAD_COLOR)
                assert image.shape == (HEIGHT, WIDTH, 3) and int(image[0, 0, 0]) == grey
            r = client.get("/api/photo?view=back", headers=HEADERS)
            assert r.status_code == 404 and r.json()["error"] == "no view 'back' in this world"
            seen = {o["name"]: o["provenance"]["view_bboxes_px"] for o in w["objects"]}
            both = [n for n, boxes in seen.items() if set(boxes) == set(CAMERAS)]
            assert both and all(len(box) == 4 for n in both for box in seen[n].values())
            car = next(o for o in w["objects"] if o["class"] == "car")
            x, y = car["position_m"][:2]
            r = client.post("/api/move", json={"name": car["name"], "to": [x + 0.5, y]}, headers=HEADERS)
            assert r.status_code == 200, r.json()
            after = client.get("/api/world", headers=HEADERS).json()["objects"]
            moved = next(o for o in after if o["name"] == car["name"])
            assert moved["position_m"][:2] == pytest.approx([x + 0.5, y], abs=1e-6)
    finally:
        session.close()


def test_the_view_picker_looks_through_each_view_with_its_photo(rig: Path) -> None:
    require_browser()
    from playwright.sync_api import sync_playwright

    with WorldEditor(rig) as editor:
        prims = {n: editor.stage.GetPrimAtPath(f"/World/Cameras/{n}") for n in CAMERAS}
        poses = {n: camera_from_usd(prim, WIDTH, HEIGHT) for n, prim in prims.items()}
        objects = {o.name: np.array(o.position_world) for o in editor.objects()}
    server = ServerProcess(rig)
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, headless=True)
            context = browser.new_context(viewport={"width": 1400, "height": 860}, bypass_csp=True)
            page = context.new_page()
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(server.url)
            page.wait_for_function("window.usdworld && window.usdworld.ready", timeout=TIMEOUT_MS)
            assert page.is_visible("#view-picker")
            options = page.eval_on_selector_all("#view-picker option", "os => os.map((o) => o.value)")
            assert options == list(CAMERAS)
            points = np.array(list(objects.values()))
            for name in reversed(list(CAMERAS)):  # left first: the page starts on the first view
                page.select_option("#view-picker", name)
                page.wait_for_function(f"document.body.dataset.view === '{name}'", timeout=TIMEOUT_MS)
                pose = poses[name]
                cam = (np.linalg.inv(pose.world_from_cam) @ np.c_[points, np.ones(len(points))].T)[:3]
                ahead = cam[2] > 1.0
                uv = ((pose.K @ cam)[:2] / (pose.K @ cam)[2]).T[ahead]
                js = page.evaluate(
                    "(pts) => pts.map(([x, y, z]) => {"
                    " const p = window.usdworld.viewer.worldToImage(x, y, z); return [p.u, p.v]; })",
                    points[ahead].tolist(),
                )
                np.testing.assert_allclose(np.array(js), uv, atol=1e-3)
                for selector in ("#backdrop", "#photo"):
                    assert f"view={name}&token=" in (page.get_attribute(selector, "src") or "")
                assert page.is_visible("#backdrop")
            # an edit from the chosen view still works: delete an object picked in the list, undo it
            name = next(iter(objects))
            page.click(f"#object-list tr[data-name='{name}']")
            page.click("#btn-delete")
            page.wait_for_function(
                f"document.getElementById('message').textContent.startsWith('deleted {name}')",
                timeout=TIMEOUT_MS,
            )
            with WorldEditor(rig) as editor:
                assert [(e.op, e.args["name"]) for e in editor.history()] == [("delete", name)]
            assert errors == []
            browser.close()
    finally:
        code, _, err = server.stop()
    assert code == 0, err
