"""The ``usdworld report`` page in headless Chromium: it loads offline, every image shows, the table sorts.

Debian's ``chromium`` is driven by the Python ``playwright`` package (no ``playwright install``),
as in test_serve_e2e.py; without the browser the test fails with the install hint. The page is
opened from its file, and any request other than that file counts as a failure (the page must
be self-contained).
"""

from __future__ import annotations

import json

from test_serve_e2e import require_browser
from test_serve_support import CHROMIUM, CHROMIUM_ARGS

from usdworld.demo import demo_request
from usdworld.pipeline import build
from usdworld.report_html import write_report_page
from usdworld.report_html.page import COLUMNS

TIMEOUT_MS = 20_000

#: Per image: id, complete, natural size, whether it decoded, and the fraction of opaque pixels
#: and of distinct grey levels when drawn on a canvas (a truncated PNG still reports its size).
IMAGE_CHECK = """async () => Promise.all(Array.from(document.images).map(async (img) => {
    const decoded = await img.decode().then(() => true, () => false);
    const c = document.createElement('canvas');
    c.width = img.naturalWidth; c.height = img.naturalHeight;
    const g = c.getContext('2d');
    g.drawImage(img, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    let opaque = 0; const greys = new Set();
    for (let i = 0; i < d.length; i += 4) { if (d[i + 3] === 255) opaque++; greys.add((d[i] + d[i + 1] + d[i + 2]) >> 2); }
    return [img.id, img.complete, img.naturalWidth, img.naturalHeight, decoded, opaque / (d.length / 4), greys.size];
}))"""

SORT_KEYS = """(col) => Array.from(document.querySelectorAll('#objects tbody tr')).map(
    (tr) => tr.cells[col].getAttribute('data-sort') ?? tr.cells[col].textContent)"""


def test_report_page_in_chromium(tmp_path):
    require_browser()
    from playwright.sync_api import sync_playwright

    world = tmp_path / "demo"
    build(demo_request(world))
    page_file = write_report_page(world, tmp_path / "report.html")
    objects = json.loads((world / "report.json").read_text())["objects"]
    names = [c for c, _ in COLUMNS]

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, headless=True)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            problems: list[str] = []
            requests: list[str] = []
            page.on(
                "console",
                lambda m: problems.append(f"{m.type}: {m.text}") if m.type in ("error", "warning") else None,
            )
            page.on("pageerror", lambda e: problems.append(f"pageerror: {e}"))
            page.on("request", lambda r: requests.append(r.url))
            url = page_file.resolve().as_uri()
            page.goto(url, wait_until="load", timeout=TIMEOUT_MS)

            images = page.evaluate(IMAGE_CHECK)
            assert [i[0] for i in images] == [
                "img-photo",
                "img-render",
                "img-overlay",
                "wipe-bottom",
                "wipe-top",
            ]
            for image_id, complete, width, height, decoded, opaque, greys in images:
                assert complete and decoded and (width, height) == (1024, 512), image_id
                assert opaque == 1.0 and greys > 50, (image_id, opaque, greys)

            # The table: one row per object, in report.json order; sort by fused depth up, then down.
            depth_col = names.index("fused depth m")
            assert page.evaluate(SORT_KEYS, names.index("name")) == [o["name"] for o in objects]
            header = page.locator("#objects thead th").nth(depth_col)
            header.click()
            assert header.get_attribute("aria-sort") == "ascending"
            up = [float(v) for v in page.evaluate(SORT_KEYS, depth_col)]
            assert up == sorted(o["depth_m"] for o in objects) and up != [o["depth_m"] for o in objects]
            header.click()
            assert header.get_attribute("aria-sort") == "descending"
            assert [float(v) for v in page.evaluate(SORT_KEYS, depth_col)] == sorted(up, reverse=True)
            # a text column sorts as text; the other header loses its mark
            page.locator("#objects thead th").nth(names.index("class")).click()
            classes = page.evaluate(SORT_KEYS, names.index("class"))
            assert classes == sorted(classes) and header.get_attribute("aria-sort") is None

            # The wipe: the render covers the photo right of the slider.
            assert (
                page.evaluate("getComputedStyle(document.getElementById('wipe-top')).clipPath")
                == "inset(0px 0px 0px 50%)"
            )
            page.locator("#wipe-range").fill("20")
            assert (
                page.evaluate("getComputedStyle(document.getElementById('wipe-top')).clipPath")
                == "inset(0px 0px 0px 20%)"
            )

            # The plots are drawn: one row per object with a fused depth.
            assert page.locator("#depth-plot g.row").count() == sum(
                1 for o in objects if o["depth_m"] is not None
            )
            assert page.locator("#plan-view polygon.footprint").count() == len(objects)
            page.screenshot(path=str(tmp_path / "report.png"), full_page=True)
        finally:
            browser.close()
    assert problems == []
    assert requests == [url]
