"""Editing the bundled demo world and a world built from the real Cityscapes frame."""

from __future__ import annotations

import pytest
from test_edit_support import sha256

from usdworld.authoring.edits import WorldEditor
from usdworld.authoring.validate import errors_only, validate_file
from usdworld.authoring.variations import make_variations
from usdworld.errors import EditRefused
from usdworld.pipeline import BuildRequest, build


def _exercise(root):
    """Every operation once (refusals allowed where the scene leaves no room); returns the ops applied."""
    base = sha256(root.parent / "layers/base.usda")
    applied = []
    with WorldEditor(root) as editor:
        objects = [o for o in editor.objects() if o.active]
        cars = [o for o in objects if o.class_name == "car"]
        people = [o for o in objects if o.class_name == "person"]
        ground = editor.ground()
        road = ground.triangles["road"]
        attempts = [
            lambda: editor.move(cars[0].name, by=(0.5, 0.0)),
            lambda: editor.rotate(cars[0].name, cars[0].yaw_deg + 3.0),
            lambda: editor.restyle(cars[-1].name, "#c03030"),
            lambda: editor.replace(cars[-1].name, "car", variant="sedan"),
            lambda: editor.delete(people[0].name),
            lambda: editor.add("car", tuple(road[len(road) // 2].mean(axis=0)[:2])),
        ]
        for attempt in attempts:
            try:
                applied.append(attempt().op)
            except EditRefused as exc:
                assert exc.reason == "not_permissible", exc
        assert editor.check() == []
        if applied:
            editor.undo()
    assert sha256(root.parent / "layers/base.usda") == base
    assert errors_only(validate_file(root)) == []
    return applied


def test_demo_world(tmp_path):
    from usdworld.demo import demo_dir, demo_request

    if not demo_dir().is_dir():
        pytest.skip(f"demo data not found in {demo_dir()}")
    root = build(demo_request(tmp_path / "demo")).world
    applied = _exercise(root)
    assert {"restyle", "delete"} <= set(applied)
    (v,) = make_variations(root, 1, 7, tmp_path / "vars")
    assert errors_only(validate_file(v.root)) == []


@pytest.mark.shared_data
def test_cityscapes_world(shared_data, tmp_path):
    frame = shared_data / "cityscapes" / "frankfurt_000000_000294"
    image = frame.with_name(frame.name + "_leftImg8bit.png")
    if not image.is_file():
        pytest.skip(f"{image} not found")
    root = build(
        BuildRequest(
            image=image,
            labels=frame.with_name(frame.name + "_gtFine_labelIds.png"),
            instances=frame.with_name(frame.name + "_gtFine_instanceIds.png"),
            output=tmp_path / "world",
        )
    ).world
    applied = _exercise(root)
    assert {"restyle", "delete"} <= set(applied)
