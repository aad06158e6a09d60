"""``usdworld report``: the HTML page's table, numbers, images, evaluation and errors.

The page is parsed with the standard library's HTML parser and compared with the world's
``report.json``, with :func:`usdworld.evaluation.evaluate_world` and with the stage after
edits. The browser test (the page in headless Chromium) is in test_report_html_browser.py.
"""

from __future__ import annotations

import base64
import json
import math
import shutil
from html.parser import HTMLParser
from pathlib import Path

import pytest

from usdworld.authoring.edits import WorldEditor
from usdworld.cli.main import main
from usdworld.demo import demo_dir, demo_request
from usdworld.pipeline import build
from usdworld.report_html import collect, render_page, write_report_page
from usdworld.report_html.page import COLUMNS
from usdworld.report_html.svg import depth_cue_plot, log_ticks, nice_step, plan_view

GT = demo_dir() / "demo_000000_000019_gt.json"


class PageParser(HTMLParser):
    """Elements of the report page: the objects table's rows and cells, images, ids and text."""

    def __init__(self) -> None:
        super().__init__()
        self.ids: dict[str, str] = {}
        self.images: list[dict[str, str]] = []
        self.rows: list[dict] = []
        self.meta: list[dict[str, str]] = []
        self._table = False
        self._cell: dict | None = None
        self._id_text: str | None = None

    def handle_starttag(self, tag, attrs):
        a = {k: v or "" for k, v in attrs}
        if "id" in a:
            self.ids[a["id"]] = ""
            if tag in ("b", "h2"):
                self._id_text = a["id"]
        if tag == "img":
            self.images.append(a)
        elif tag == "meta":
            self.meta.append(a)
        elif tag == "table" and a.get("id") == "objects":
            self._table = True
        elif self._table and tag == "tr" and "data-name" in a:
            self.rows.append({"name": a["data-name"], "class": a.get("class", ""), "cells": []})
        elif self._table and tag == "td":
            self._cell = {"sort": a.get("data-sort"), "text": ""}
            self.rows[-1]["cells"].append(self._cell)

    def handle_endtag(self, tag):
        if tag == "table":
            self._table = False
        elif tag == "td":
            self._cell = None
        elif tag in ("b", "h2"):
            self._id_text = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell["text"] += data
        if self._id_text is not None:
            self.ids[self._id_text] += data


def parse(html: str) -> PageParser:
    p = PageParser()
    p.feed(html)
    return p


def column(name: str) -> int:
    return [c for c, _ in COLUMNS].index(name)


@pytest.fixture(scope="module")
def demo(tmp_path_factory) -> Path:
    """The demo world, built once for the module (tests copy it before editing)."""
    out = tmp_path_factory.mktemp("report_demo") / "demo"
    build(demo_request(out))
    return out


@pytest.fixture(scope="module")
def page(demo, tmp_path_factory) -> tuple[str, dict]:
    """The demo's page with the demo's ground truth, and the report.json it was made from."""
    out = tmp_path_factory.mktemp("report_page") / "sub" / "report.html"
    assert write_report_page(demo, out, gt=GT) == out
    return out.read_text(encoding="utf-8"), json.loads((demo / "report.json").read_text())


def test_table_rows_are_the_objects_with_their_numbers(page):
    html, report = page
    rows = parse(html).rows
    assert [r["name"] for r in rows] == [o["name"] for o in report["objects"]]
    assert len(report["objects"]) > 20
    for row, o in zip(rows, report["objects"], strict=True):
        cells = row["cells"]
        assert len(cells) == len(COLUMNS)
        assert cells[column("class")]["text"] == o["class"]
        assert cells[column("variant")]["text"] == (o["variant"] or "")
        assert cells[column("state")]["text"] == "built"
        for axis, value in zip(("x m", "y m", "z m"), o["position_world"], strict=True):
            assert float(cells[column(axis)]["sort"]) == value
        assert float(cells[column("fused depth m")]["sort"]) == o["depth_m"]
        assert float(cells[column("yaw °")]["sort"]) == o["yaw_deg"]
        assert cells[column("yaw source")]["text"] == o["yaw_source"]
        assert float(cells[column("scale")]["sort"]) == o["scale"]
        assert cells[column("depth method")]["text"] == o["depth_method"]
        cues = cells[column("depth cues (m ± σ)")]["text"]
        for name, cue in o["depth_cues"].items():
            expected = (
                f"{name} {cue['depth_m']:.2f} ± {cue['sigma_m']:.2f}"
                if cue["depth_m"] is not None
                else f"{name} -"
            )
            assert expected in cues, (o["name"], cues)
        shift = math.hypot(*o["collision_displacement_m"])
        assert float(cells[column("collision shift m")]["sort"]) == pytest.approx(shift)
        if o["standing_on"]:
            assert f"on {o['standing_on']}" in cells[column("contact")]["text"]


def test_ground_truth_errors_match_the_evaluation(page, demo):
    from usdworld.authoring.inspect import open_world
    from usdworld.evaluation import evaluate_world, read_ground_truth, read_label_ids
    from usdworld.render.outputs import read_photo

    html, _ = page
    p = parse(html)
    name = "demo_000000_000019"
    ev = evaluate_world(
        open_world(demo),
        labels=read_label_ids(demo_dir() / f"{name}_gtFine_labelIds.png"),
        photo=read_photo(demo_dir() / f"{name}_leftImg8bit.png"),
        gt=read_ground_truth(GT),
    ).to_json()
    assert p.ids["miou"] == f"{ev['miou']:.3f}"
    assert p.ids["ssim"] == f"{ev['ssim']:.3f}"
    assert "gt-table" in p.ids and "iou-table" in p.ids
    errors = {r["name"]: r["position_error_m"] for r in ev["object_rows"] if r["placed"]}
    assert errors
    col = column("GT position error m")
    shown = {r["name"]: r["cells"][col]["sort"] for r in p.rows}
    for obj, err in errors.items():
        assert float(shown[obj]) == pytest.approx(err)
    assert all(shown[n] == "" for n in shown if n not in errors)


def test_page_is_self_contained(page):
    html, _ = page
    p = parse(html)
    roles = [img["id"] for img in p.images]
    assert roles == ["img-photo", "img-render", "img-overlay", "wipe-bottom", "wipe-top"]
    for img in p.images:
        assert img["src"].startswith("data:image/png;base64,")
        assert base64.b64decode(img["src"].split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    csp = [m["content"] for m in p.meta if m.get("http-equiv") == "Content-Security-Policy"]
    assert csp and "default-src 'none'" in csp[0]
    lowered = html.lower()
    assert "http://" not in lowered.replace('xmlns="http://www.w3.org/2000/svg"', "")
    assert "https://" not in lowered and "<link" not in lowered and "<script src" not in lowered
    # the photo is embedded as found on disk
    photo = (demo_dir() / "demo_000000_000019_leftImg8bit.png").read_bytes()
    assert base64.b64decode(p.images[0]["src"].split(",", 1)[1]) == photo


def test_edits_show_as_moved_deleted_and_added(demo, tmp_path):
    world = tmp_path / "w"
    shutil.copytree(demo, world)
    with WorldEditor(world / "world.usda") as editor:
        editor.move("car_0002", by=(3.0, 0.0), force=True)
        editor.delete("person_0002")
        editor.add("tree", (12.0, 9.0), force=True)
    inputs = collect(world)
    assert inputs.states["car_0002"] == "moved"
    assert inputs.states["person_0002"] == "deleted"
    assert sum(1 for s in inputs.states.values() if s == "built") == len(inputs.states) - 2
    assert [o["class"] for o in inputs.added] == ["tree"]
    html = render_page(inputs)
    assert "edits since: 1 moved, 1 deleted, 1 added" in html
    rows = {r["name"]: r for r in parse(html).rows}
    assert rows["car_0002"]["class"] == "moved" and rows["person_0002"]["class"] == "deleted"
    new = rows[inputs.added[0]["name"]]
    assert new["class"] == "added" and new["cells"][column("class")]["text"] == "tree"


def test_without_rendering_the_page_says_so_and_shows_the_photo(demo, tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "moderngl", None)  # as if the render extra were not installed
    out = tmp_path / "r.html"
    write_report_page(demo, out)
    html = out.read_text(encoding="utf-8")
    p = parse(html)
    assert [img["id"] for img in p.images] == ["img-photo"]
    assert "no render, overlay or evaluation: rendering needs the Python package moderngl" in html
    assert "no evaluation: it renders the world" in html
    assert len(p.rows) == len(json.loads((demo / "report.json").read_text())["objects"])


def test_without_the_photo_render_only(demo, tmp_path):
    world = tmp_path / "w"
    shutil.copytree(demo, world)
    report = json.loads((world / "report.json").read_text())
    report["source_image"] = "missing.png"
    (world / "report.json").write_text(json.dumps(report))
    inputs = collect(world)
    assert inputs.images.photo is None and inputs.images.overlay is None and inputs.images.render
    assert any("missing.png not found" in n for n in inputs.images.notes)
    assert any(n.startswith("no SSIM") for n in inputs.evaluation_notes)
    assert inputs.evaluation is not None and inputs.evaluation["ssim"] is None


def _one_line_error(capsys, args: list[str], expected: str) -> None:
    code = main(["report", *args])
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err
    assert expected in lines[0], lines[0]


def test_cli_writes_the_page_and_refuses_bad_worlds(demo, tmp_path, capsys):
    out = tmp_path / "page.html"
    assert main(["report", str(demo), "-o", str(out)]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {out}"
    assert len(parse(out.read_text(encoding="utf-8")).rows) > 20
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]

    _one_line_error(capsys, [str(tmp_path / "nope"), "-o", str(out)], "nope")
    world = tmp_path / "w"
    shutil.copytree(demo, world)
    (world / "report.json").write_text("{not json")
    _one_line_error(capsys, [str(world), "-o", str(out)], "report.json: not valid JSON")
    (world / "report.json").write_text("[]")
    _one_line_error(capsys, [str(world), "-o", str(out)], "is it a usdworld report.json")
    (world / "report.json").unlink()
    _one_line_error(capsys, [str(world), "-o", str(out)], "report.json: no such file")
    _one_line_error(capsys, [str(demo), "-o", str(tmp_path)], "is a folder")
    _one_line_error(capsys, [str(demo), "-o", str(out), "--gt", str(tmp_path / "gt.json")], "gt.json")


def test_default_output_is_beside_the_world(demo, tmp_path, capsys):
    world = tmp_path / "w"
    shutil.copytree(demo, world)
    assert main(["-q", "report", str(world / "world.usda")]) == 0
    assert capsys.readouterr().out == ""
    assert (world / "report.html").is_file()


# -- the SVG plots ------------------------------------------------------------------------


def test_ticks_known_answers():
    assert nice_step(47.0) == 10.0 and nice_step(0.8) == pytest.approx(0.2) and nice_step(120.0) == 20.0
    assert log_ticks(3.0, 60.0) == [5.0, 10.0, 20.0, 50.0]
    assert log_ticks(1.0, 1.0) == [1.0]


def _obj(name: str, depth: float | None, cues: dict, **kw) -> dict:
    return {
        "name": name,
        "class": "car",
        "depth_m": depth,
        "depth_method": "contact",
        "depth_cues": {k: {"depth_m": d, "sigma_m": s, "note": ""} for k, (d, s) in cues.items()},
        **kw,
    }


def test_depth_cue_plot_marks_every_cue_and_fused_depth():
    objects = [
        _obj("far", 80.0, {"contact": (82.0, 9.0), "height": (None, None), "cnn": (None, None)}),
        _obj("near", 5.0, {"contact": (5.1, 0.2), "height": (4.0, 1.5)}),
        _obj("unplaced", None, {"contact": (3.0, 1.0)}),
    ]
    svg = depth_cue_plot(objects)
    assert svg.count('class="cue"') == 3  # "unplaced" has no fused depth, "far" no height cue
    assert svg.count('<line class="fused"') == 2
    assert svg.index('data-name="near"') < svg.index('data-name="far"')  # ordered by fused depth
    assert "near height: 4.00 m ± 1.50 m" in svg
    assert "contact ± σ" in svg and "cnn ± σ" not in svg  # the legend lists the cues that give a depth
    assert ">2<" in svg and ">100<" in svg and ">1000<" not in svg  # log axis from 2 to 100 m
    assert depth_cue_plot([_obj("x", None, {})]).startswith("<p")


def test_plan_view_draws_each_footprint():
    objects = [
        _obj("a", 5.0, {}, position_world=[10.0, 2.0, 0.0], size_m=[4.0, 2.0, 1.5], yaw_deg=90.0),
        _obj("b", 5.0, {}, position_world=[20.0, -3.0, 0.0], size_m=[4.0, 2.0, 1.5], yaw_deg=0.0),
        _obj("c", 5.0, {}, position_world=None, size_m=None, yaw_deg=None),
    ]
    svg = plan_view(objects, {"car": "#00008e"}, (0.7, 0.7))
    assert svg.count('class="footprint"') == 2 and 'fill="#00008e"' in svg
    assert 'class="fov"' in svg
    assert plan_view(objects[2:], {}).startswith("<p")


def test_object_warnings_name_the_object_as_a_word():
    from usdworld.report_html.page import object_warnings

    warnings = ["not placed (no visible ground contact): car_00011, pole_0002", "car_0001: moved 2.0 m"]
    o = {"name": "car_0001", "bottom_truncated": True, "bottom_occluded": False}
    assert object_warnings(o, warnings) == ["bottom cut by the image edge", "car_0001: moved 2.0 m"]
    assert object_warnings({"name": "pole_0002"}, warnings) == [warnings[0]]
