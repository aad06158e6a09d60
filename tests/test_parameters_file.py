"""``io/parameters_file``: a ``{section: {field: value}}`` file over the defaults, and docs/parameters.md."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from usdworld.errors import InputError
from usdworld.io.parameters_file import parse_parameters, read_parameters
from usdworld.parameters import DEFAULT_PARAMETERS, Parameters

REPO = Path(__file__).resolve().parents[1]
SCENE_FIELDS = (
    "dlt_grid, dlt_horizon_margin, fill_reach_m, max_range_m, occluder_min_front_m, "
    "road_top_min_fraction, road_top_min_px, surface_stride_px"
)
#: The collision section's fields, as the message lists them (sorted).
COLLISION_FIELDS = ", ".join(sorted(DEFAULT_PARAMETERS.to_dict()["collision"]))


def _write(tmp_path: Path, doc: object) -> Path:
    path = tmp_path / "p.json"
    path.write_text(json.dumps(doc))
    return path


def test_a_file_changes_only_the_fields_it_names(tmp_path):
    params = read_parameters(_write(tmp_path, {"scene": {"fill_reach_m": 5, "dlt_grid": [3, 6]}}))
    assert params.scene.fill_reach_m == 5.0 and isinstance(params.scene.fill_reach_m, float)
    assert params.scene.dlt_grid == (3, 6)
    assert params.scene.max_range_m == DEFAULT_PARAMETERS.scene.max_range_m
    assert params.placement == DEFAULT_PARAMETERS.placement
    assert read_parameters(_write(tmp_path, {})) == Parameters()


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ([1], "p.json: must be an object {section: {field: value}}, got array"),
        (
            {"scenery": {}},
            "p.json -> scenery: unknown parameter section; known: perception, camera, placement, collision, scene, light",
        ),
        ({"scene": 3}, "p.json -> scene: must be an object, got number"),
        ({"scene": {"range_m": 60}}, f"p.json -> scene -> range_m: unknown parameter; known: {SCENE_FIELDS}"),
        ({"collision": {"x": 1}}, f"p.json -> collision -> x: unknown parameter; known: {COLLISION_FIELDS}"),
        ({"scene": {"max_range_m": "far"}}, "p.json -> scene -> max_range_m: must be a number, got string"),
        ({"scene": {"max_range_m": True}}, "p.json -> scene -> max_range_m: must be a number, got boolean"),
        ({"scene": {"road_top_min_px": 2.5}}, "p.json -> scene -> road_top_min_px: must be a whole number, got number 2.5"),
        ({"scene": {"dlt_grid": [4]}}, "p.json -> scene -> dlt_grid: must hold 2 values, got 1"),
        ({"scene": {"dlt_grid": [4, "5"]}}, "p.json -> scene -> dlt_grid -> [1]: must be a whole number, got string '5'"),
        ({"scene": {"max_range_m": -1}}, "p.json: scene.max_range_m must be > 0 m, got -1.0"),
    ],
)
def test_bad_files_are_one_line_errors_naming_the_key(tmp_path, doc, message):
    with pytest.raises(InputError) as info:
        read_parameters(_write(tmp_path, doc))
    assert str(info.value) == message


def test_unreadable_or_invalid_files(tmp_path):
    with pytest.raises(InputError, match=r"nope.json: no such file \(the parameters file\)"):
        read_parameters(tmp_path / "nope.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{scene: 1}")
    with pytest.raises(InputError, match=r"^bad.json: not valid JSON \(line 1 column 2"):
        read_parameters(bad)


def test_parse_builds_on_the_given_base():
    base = DEFAULT_PARAMETERS.replace(scene={"fill_reach_m": 3.0})
    params = parse_parameters({"scene": {"max_range_m": 50.0}}, "x.json", base)
    assert (params.scene.fill_reach_m, params.scene.max_range_m) == (3.0, 50.0)


def test_parameters_doc_is_current():
    result = subprocess.run(
        [sys.executable, str(REPO / "tools/gen_parameters_doc.py"), "--check"], capture_output=True, text=True
    )
    assert result.returncode == 0, result.stderr


def test_parameters_doc_lists_every_field():
    sys.path.insert(0, str(REPO / "tools"))
    try:
        from gen_parameters_doc import render
    finally:
        sys.path.pop(0)
    text = render(Parameters())
    for row in Parameters().rows():
        assert f"| `{row['name']}` |" in text
    assert "| `fill_reach_m` | `8.0` | m |" in text
    assert "| `fill_reach_m` | `5.0` | m |" in render(DEFAULT_PARAMETERS.replace(scene={"fill_reach_m": 5.0}))
