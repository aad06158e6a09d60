"""End to end: ``usdworld serve`` in a subprocess, the page in a real headless Chromium.

Debian's ``chromium`` (``/usr/bin/chromium``) is driven by the Python ``playwright`` package
(its driver ships inside the wheel; ``playwright install`` is never run). The test loads the
page, reads the object count, clicks an object in the 3D view, drags it on the ground, tries
a drag the rules refuse, deletes another object from the list, undoes that, checks the edits
layer on disk, makes an edit from "another shell" and waits for the page to show it, and
saves a screenshot under the test's tmp folder (``USDWORLD_UPDATE_SCREENSHOT=1`` also copies
it to ``docs/serve_screenshot.png``). Without Chromium the test fails with the install hint.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from test_serve_support import CHROMIUM, CHROMIUM_ARGS, ServerProcess, demo_world, find_targets

from usdworld.authoring.edits import WorldEditor

REPO = Path(__file__).resolve().parents[1]
DOCS_SCREENSHOT = REPO / "docs" / "serve_screenshot.png"
TIMEOUT_MS = 20_000


def require_browser() -> None:
    """Fail (not skip) with the install hint when the browser or its driver is missing."""
    if not CHROMIUM.is_file():
        pytest.fail(
            f"Chromium not found at {CHROMIUM}: the browser test drives Debian's chromium; "
            "install it with `apt-get install -y chromium` (tools/setup_web.sh does this), "
            "or point USDWORLD_CHROMIUM at a Chromium binary"
        )
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        pytest.fail(
            "the browser test needs the playwright Python package: pip install 'playwright==1.63.0' "
            "(do not run `playwright install`: the system Chromium is used)"
        )


def drag_points(page, name: str, to: tuple[float, float]) -> dict:
    """Client points of a drag that moves ``name`` to ``to`` on the ground."""
    return page.evaluate(
        """([name, tx, ty]) => {
            const v = window.usdworld.viewer;
            const o = window.usdworld.state.world.objects.find((o) => o.name === name);
            const s = v.clientPointOf(name);
            const z = o.position_m[2];
            const g = v.groundPoint(s.x, s.y, z);
            const e = v.worldToClient(g.x + tx - o.position_m[0], g.y + ty - o.position_m[1], z);
            return { sx: s.x, sy: s.y, ex: e.x, ey: e.y };
        }""",
        [name, to[0], to[1]],
    )


def drag(page, points: dict) -> None:
    page.mouse.move(points["sx"], points["sy"])
    page.mouse.down()
    page.mouse.move(points["ex"], points["ey"], steps=12)
    page.mouse.up()


def wait_message(page, kind: str, starts: str) -> str:
    page.wait_for_function(
        "([kind, starts]) => { const m = document.getElementById('message');"
        " return m.dataset.kind === kind && m.textContent.startsWith(starts); }",
        arg=[kind, starts],
        timeout=TIMEOUT_MS,
    )
    return page.text_content("#message") or ""


def test_edit_a_world_with_the_mouse_in_chromium(tmp_path_factory, tmp_path):
    require_browser()
    from playwright.sync_api import sync_playwright

    from usdworld.render.camera import camera_from_usd

    world = demo_world(tmp_path_factory, tmp_path / "demo")
    t = find_targets(world)
    server = ServerProcess(world)
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, headless=True)
            # bypass_csp: Playwright's wait_for_function evaluates strings, which the page's CSP forbids
            context = browser.new_context(viewport={"width": 1400, "height": 860}, bypass_csp=True)
            page = context.new_page()
            errors: list[str] = []
            urls: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("request", lambda r: urls.append(r.url))

            page.goto(server.url)
            page.wait_for_function("window.usdworld && window.usdworld.ready", timeout=TIMEOUT_MS)
            assert page.text_content("#object-count") == f"{t.count} objects"
            assert page.locator("#object-list tbody tr").count() == t.count
            assert page.evaluate("window.usdworld.viewer.nodes.size") == t.count - sum(
                1 for o in page.evaluate("window.usdworld.state.world.objects") if not o["active"]
            )

            # The view starts at the source camera with its exact intrinsics.
            with WorldEditor(world) as editor:
                pose = camera_from_usd(editor.stage.GetPrimAtPath("/World/SourceCamera"), 1024, 512)
                points = np.array([o.position_world for o in editor.objects()[:6]])
            cam = (np.linalg.inv(pose.world_from_cam) @ np.column_stack([points, np.ones(len(points))]).T)[:3]
            uv = (pose.K @ cam)[:2] / (pose.K @ cam)[2]
            js = page.evaluate(
                "(pts) => pts.map(([x, y, z]) => { const p = window.usdworld.viewer.worldToImage(x, y, z); return [p.u, p.v]; })",
                points.tolist(),
            )
            np.testing.assert_allclose(np.array(js), uv.T, atol=1e-3)
            assert page.evaluate("window.usdworld.viewer.inSourceView") is True

            # Click the car in the 3D view: it is selected, with its provenance.
            pt = page.evaluate(f"window.usdworld.viewer.clientPointOf('{t.car}')")
            assert pt is not None, f"{t.car} is not visible in the source view"
            page.mouse.click(pt["x"], pt["y"])
            page.wait_for_function(
                f"document.getElementById('details-title').textContent.startsWith('{t.car} ')",
                timeout=TIMEOUT_MS,
            )
            assert page.get_attribute(f"#object-list tr[data-name='{t.car}']", "class") == "selected"
            assert "DLT error" in (page.text_content("#details-provenance") or "")
            assert "yaw source" in (page.text_content("#details-provenance") or "")
            assert page.locator("#depth-cues tbody tr").count() >= 1

            # Drag it on the ground to a free spot on the road.
            drag(page, drag_points(page, t.car, t.car_to))
            message = wait_message(page, "ok", f"moved {t.car} to ")
            assert message.endswith("on road [step 1]")

            # A drag the rules refuse: a car onto the sidewalk. The reason is shown, nothing moves.
            drag(page, drag_points(page, t.car, t.sidewalk))
            message = wait_message(page, "error", f"Refused: move {t.car} — ")
            assert "surface: car may stand on road, not sidewalk" in message
            assert page.evaluate(f"window.usdworld.viewer.nodes.get('{t.car}').position.length()") == 0

            # Delete another object, picked in the list.
            page.click(f"#object-list tr[data-name='{t.person}']")
            page.click("#btn-delete")
            wait_message(page, "ok", f"deleted {t.person} (inactive) [step 2]")
            page.wait_for_function(
                f"document.getElementById('object-count').textContent === '{t.count - 1} objects, 1 deleted'",
                timeout=TIMEOUT_MS,
            )
            assert (
                page.get_attribute(f"#object-list tr[data-name='{t.person}']", "class") == "deleted selected"
            )

            # Undo the delete.
            page.click("#btn-undo")
            wait_message(page, "ok", f"undid step 2: delete {t.person}")
            page.wait_for_function(
                f"document.getElementById('object-count').textContent === '{t.count} objects'",
                timeout=TIMEOUT_MS,
            )
            assert page.is_enabled("#btn-redo")

            # The edits layer on disk holds exactly the move.
            with WorldEditor(world) as editor:
                assert [(e.op, e.args["name"]) for e in editor.history()] == [("move", t.car)]
                state = {o.name: o for o in editor.objects()}
            assert state[t.car].position_world[:2] == pytest.approx(t.car_to, abs=0.3)
            assert state[t.car].status == "edited" and state[t.person].active
            text = (world.parent / "layers" / "edits.usda").read_text()
            assert f'over "{t.car}"' in text and "xformOp:translate" in text and "active = false" not in text

            # An edit made meanwhile by another editor (the CLI) shows up in the page.
            with WorldEditor(world) as other:
                other.rotate(t.other_car, 180.0)
            page.wait_for_function(
                f"document.querySelector(\"#object-list tr[data-name='{t.other_car}'] td:last-child\").textContent === 'edited'",
                timeout=TIMEOUT_MS,
            )
            wait_message(page, "info", "The world changed on disk")
            assert page.text_content("#history-count") == "2 edit(s)"
            assert not page.is_enabled("#btn-redo")  # the redo stack is void after someone else's edit

            # Orbit away (the photo backdrop goes, it only lines up in the source view) and come back.
            view = page.evaluate("window.usdworld.viewer.camera.matrixWorld.elements.slice()")
            box = page.locator("#canvas").bounding_box()
            assert box is not None
            page.mouse.move(box["x"] + box["width"] * 0.5, box["y"] + 12)
            page.mouse.down()
            page.mouse.move(box["x"] + box["width"] * 0.62, box["y"] + 40, steps=6)
            page.mouse.up()
            assert page.evaluate("window.usdworld.viewer.inSourceView") is False
            assert page.is_hidden("#backdrop")
            page.click("#btn-source-view")
            assert page.evaluate("window.usdworld.viewer.inSourceView") is True and page.is_visible(
                "#backdrop"
            )
            back = page.evaluate("window.usdworld.viewer.camera.matrixWorld.elements.slice()")
            np.testing.assert_allclose(back, view, atol=1e-9)

            # Add a car at a clicked ground point, then rotate, restyle and replace it with the buttons.
            page.select_option("#add-class", "car")
            page.click("#btn-add")
            at = page.evaluate(f"window.usdworld.viewer.worldToClient({t.add_at[0]}, {t.add_at[1]}, 0)")
            page.mouse.click(at["x"], at["y"])
            message = wait_message(page, "ok", "added car_")
            added = message.split()[1]
            assert page.evaluate("window.usdworld.viewer.inSourceView") is True  # a click is no orbit
            page.wait_for_function(
                f"document.getElementById('details-title').textContent.startsWith('{added} ')",
                timeout=TIMEOUT_MS,
            )
            page.click("#btn-rot-right")
            wait_message(page, "ok", f"rotated {added} to ")
            page.fill("#restyle-color", "#1e90ff")
            page.click("#btn-restyle")
            wait_message(page, "ok", f"restyled {added} #1e90ff")
            page.select_option("#replace-class", "car")
            variant = page.eval_on_selector("#replace-variant", "s => s.value")
            page.click("#btn-replace")
            wait_message(page, "ok", f"replaced {added} (car ")
            page.click("#btn-undo")
            wait_message(page, "ok", f"undid step 6: replace {added}")
            page.click("#btn-redo")
            wait_message(page, "ok", f"redid replace {added} [step 6]")
            with WorldEditor(world) as editor:
                assert [e.op for e in editor.history()] == [
                    "move",
                    "rotate",
                    "add",
                    "rotate",
                    "restyle",
                    "replace",
                ]
                new = next(o for o in editor.objects() if o.name == added)
            assert new.position_world[:2] == pytest.approx(t.add_at, abs=0.3)
            assert new.color == "#1e90ff" and new.variant == variant and new.status == "added"

            # A screenshot with the moved car selected.
            page.click(f"#object-list tr[data-name='{t.car}']")
            page.wait_for_timeout(300)
            shot = tmp_path / "serve_screenshot.png"
            page.screenshot(path=str(shot))
            assert shot.stat().st_size > 50_000
            if os.environ.get("USDWORLD_UPDATE_SCREENSHOT"):
                shutil.copyfile(shot, DOCS_SCREENSHOT)

            assert errors == []
            assert all(u.startswith((server.base, "data:")) for u in urls), urls  # offline
            assert any(u.startswith(server.base + "/static/vendor/three.bundle.js") for u in urls)
            browser.close()
    finally:
        code, _, err = server.stop()
    assert code == 0, err
