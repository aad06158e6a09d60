"""``usdworld build / demo / info / validate``: exit codes, one-line errors, untouched outputs."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from golden_scene import write_inputs

from usdworld.cli.main import main


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def inputs(tmp_path):
    request = write_inputs(tmp_path / "in")
    return {"image": str(request.image), "det": str(request.detections), "cam": str(request.camera), "dir": tmp_path}


def _build_args(inputs, out):
    return ["build", inputs["image"], "--detections", inputs["det"], "--camera", inputs["cam"], "-o", str(out)]


def test_build_info_validate(capsys, inputs):
    out = inputs["dir"] / "world"
    # The three boxes alone (the drawn frame is no street; streets have tests/test_perception_streets.py).
    code, stdout, _ = _run(capsys, *_build_args(inputs, out), "--no-infer-streets")
    assert code == 0 and "3 objects placed from frame.png" in stdout
    report = json.loads((out / "report.json").read_text())
    assert [o["name"] for o in report["objects"]] == ["car_0001", "car_0002", "person_0001"]
    code, stdout, _ = _run(capsys, "info", str(out / "world.usda"), "--json")
    info = json.loads(stdout)
    assert code == 0 and info["classes"] == {"car": 2, "person": 1} and info["objects_inactive"] == 0
    code, stdout, _ = _run(capsys, "validate", str(out))
    assert code == 0 and stdout.strip().endswith(": 0 error(s)")


def _tree_hash(folder: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            h.update(p.relative_to(folder).as_posix().encode() + p.read_bytes())
    return h.hexdigest()


def _one_line_error(code: int, err: str, expected: str) -> None:
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err
    assert expected in lines[0], lines[0]


def test_bad_inputs_leave_existing_world_untouched(capsys, inputs):
    out = inputs["dir"] / "world"
    assert _run(capsys, *_build_args(inputs, out))[0] == 0
    before = _tree_hash(out)
    d = inputs["dir"]
    corrupt = d / "corrupt.png"
    corrupt.write_bytes(Path(inputs["image"]).read_bytes()[:200])
    cam = json.loads(Path(inputs["cam"]).read_text())
    cam["K"][0][0] = -3.0
    bad_cam = d / "bad_cam.json"
    bad_cam.write_text(json.dumps(cam))
    missing = json.loads(Path(inputs["cam"]).read_text())
    del missing["K"]
    missing["fx"] = 500.0
    no_fy = d / "no_fy.json"
    no_fy.write_text(json.dumps(missing))
    labels8 = d / "labels.png"
    cv2.imwrite(str(labels8), np.zeros((100, 100), np.uint8))
    cases = [
        (["build", str(corrupt), "--detections", inputs["det"], "--camera", inputs["cam"]], "corrupt.png"),
        (["build", inputs["image"], "--detections", inputs["det"], "--camera", str(bad_cam)], "bad_cam.json"),
        (["build", inputs["image"], "--detections", inputs["det"], "--camera", str(no_fy)], "no_fy.json"),
        (["build", inputs["image"], "--labels", str(labels8)], "labels.png"),
        (["build", str(d / "nope.png"), "--camera", inputs["cam"]], "nope.png"),
    ]
    for args, expected in cases:
        code, _, err = _run(capsys, *args, "-o", str(out))
        _one_line_error(code, err, expected)
        assert _tree_hash(out) == before, args
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".world.")], "temporary folders left behind"


def test_too_few_ground_points(capsys, inputs):
    pts = inputs["dir"] / "points.json"
    pts.write_text(json.dumps({"pairs": [{"px": [0, 300], "ground": [5, 1]}, {"px": [100, 300], "ground": [5, 0]}]}))
    code, _, err = _run(capsys, *_build_args(inputs, inputs["dir"] / "w2"), "--ground-points", str(pts))
    _one_line_error(code, err, "points.json")
    assert not (inputs["dir"] / "w2").exists()


def test_unwritable_output(capsys, inputs):
    blocker = inputs["dir"] / "file"
    blocker.write_text("x")
    code, _, err = _run(capsys, *_build_args(inputs, blocker / "world"))
    _one_line_error(code, err, "file")
    code, _, err = _run(capsys, *_build_args(inputs, blocker))
    _one_line_error(code, err, "not a folder")


def test_refuses_to_replace_a_foreign_folder(capsys, inputs):
    foreign = inputs["dir"] / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    code, _, err = _run(capsys, *_build_args(inputs, foreign))
    _one_line_error(code, err, "holds no world.usda")
    assert (foreign / "notes.txt").read_text() == "keep me"


def test_rebuild_keeps_edits(capsys, inputs):
    out = inputs["dir"] / "world"
    assert _run(capsys, *_build_args(inputs, out))[0] == 0
    edits = out / "layers" / "edits.usda"
    edits.write_text('#usda 1.0\n\nover "World"\n{\n    over "Objects"\n    {\n        over "car_0001" (\n            active = false\n        )\n        {\n        }\n    }\n}\n\n')
    code, stdout, _ = _run(capsys, *_build_args(inputs, out))
    assert code == 0 and "kept the existing edits layer" in stdout
    assert "active = false" in edits.read_text()
    code, stdout, _ = _run(capsys, "info", str(out), "--json")
    assert json.loads(stdout)["objects_inactive"] == 1


def test_photo_alone_is_refused_naming_the_three_object_sources(capsys, tmp_path):
    image = tmp_path / "empty.png"
    cv2.imwrite(str(image), np.full((120, 200, 3), 128, np.uint8))
    for extra in ([], ["--depth", "ground"]):  # a depth backend finds no objects either
        code, _, err = _run(capsys, "build", str(image), *extra, "-o", str(tmp_path / "w"))
        _one_line_error(code, err, "empty.png: nothing to find objects in")
        assert all(flag in err for flag in ("--labels", "--polygons", "--detections", "--segment hf")), err
    assert not (tmp_path / "w").exists()


def test_labels_without_objects_give_valid_world_with_warning(capsys, tmp_path):
    image, labels = tmp_path / "empty.png", tmp_path / "empty_labelIds.png"
    cv2.imwrite(str(image), np.full((120, 200, 3), 128, np.uint8))
    cv2.imwrite(str(labels), np.full((120, 200), 7, np.uint8))  # all road: nothing to place
    code, _, err = _run(capsys, "build", str(image), "--labels", str(labels), "-o", str(tmp_path / "w"))
    assert code == 0 and "no objects found" in err
    assert _run(capsys, "validate", str(tmp_path / "w"), "--no-omni")[0] == 0


def test_debug_shows_traceback(capsys, inputs):
    code, _, err = _run(capsys, "--debug", "build", str(inputs["dir"] / "nope.png"), "-o", str(inputs["dir"] / "w"))
    assert code == 2 and "Traceback" in err


def test_validate_reports_errors(capsys, tmp_path):
    bad = tmp_path / "bad.usda"
    bad.write_text('#usda 1.0\ndef Xform "W"\n{\n}\n')
    code, stdout, err = _run(capsys, "validate", str(bad), "--no-omni")
    assert code == 1 and "StageMetadataChecker" in stdout and err.startswith("error: ")


def test_validate_names_a_deleted_asset_file_first_and_groups_by_rule(capsys, inputs):
    """One asset file deleted: a short report that starts with that file; --verbose lists every finding."""
    out = inputs["dir"] / "world"
    assert _run(capsys, *_build_args(inputs, out))[0] == 0
    (out / "assets" / "car.geom.usdc").unlink()
    code, stdout, err = _run(capsys, "validate", str(out))
    lines = stdout.splitlines()
    assert lines[0] == "missing file: assets/car.geom.usdc (needed by assets/car.usda)"
    assert lines[1].startswith("findings by rule") and len(lines) <= 12, stdout
    rules = [l.split()[2] for l in lines[2:-1]]
    assert len(rules) == len(set(rules)) and "usd:usdValidation:CompositionErrorTest" in rules
    assert "SchemaBaseId" not in stdout and "Warning:" not in err
    counts = sum(int(l.split()[1]) for l in lines[2:-1] if l.split()[0] == "error")
    assert lines[-1].endswith(f": {counts + 1} error(s); --verbose lists every finding")
    assert code == 1 and err.strip() == f"error: {counts + 1} validation error(s) in {out / 'world.usda'}"
    code, verbose, _ = _run(capsys, "validate", str(out), "--verbose")
    assert code == 1 and verbose.splitlines()[0] == lines[0]
    assert len(verbose.splitlines()) > counts and "--verbose" not in verbose.splitlines()[-1]
    code, as_json, _ = _run(capsys, "validate", str(out), "--json")
    report = json.loads(as_json)
    assert [(p["kind"], Path(p["path"]).name) for p in report["file_problems"]] == [("missing", "car.geom.usdc")]
    assert report["errors"] == counts + 1


def test_params_file_is_used_and_recorded_and_max_range_overrides_it(capsys, inputs):
    params = inputs["dir"] / "params.json"
    params.write_text(json.dumps({"scene": {"max_range_m": 30, "fill_reach_m": 4.0}}))
    default = inputs["dir"] / "default"
    assert _run(capsys, *_build_args(inputs, default))[0] == 0
    near = inputs["dir"] / "near"
    assert _run(capsys, *_build_args(inputs, near), "--params", str(params))[0] == 0
    recorded = json.loads((near / "report.json").read_text())["parameters"]["scene"]
    assert (recorded["max_range_m"], recorded["fill_reach_m"]) == (30.0, 4.0)
    terrain = {
        name: {s["name"]: s["area_m2"] for s in json.loads((d / "report.json").read_text())["surfaces"]}["terrain"]
        for name, d in (("default", default), ("near", near))
    }
    assert terrain["near"] < terrain["default"]  # the terrain square reaches 30 m, not 80 m
    nearer = inputs["dir"] / "nearer"
    assert _run(capsys, *_build_args(inputs, nearer), "--params", str(params), "--max-range", "20")[0] == 0
    scene = json.loads((nearer / "report.json").read_text())["parameters"]["scene"]
    assert (scene["max_range_m"], scene["fill_reach_m"]) == (20.0, 4.0)


@pytest.mark.parametrize(
    ("doc", "expected"),
    [
        ({"scene": {"max_range": 30}}, "error: params.json -> scene -> max_range: unknown parameter; known: "),
        ({"layout": {}}, "error: params.json -> layout: unknown parameter section; known: perception, camera, "),
        ({"scene": {"fill_reach_m": "far"}}, "error: params.json -> scene -> fill_reach_m: must be a number, got string"),
    ],
)
def test_bad_params_file_is_a_one_line_error(capsys, inputs, doc, expected):
    params = inputs["dir"] / "params.json"
    params.write_text(json.dumps(doc))
    out = inputs["dir"] / "w"
    code, _, err = _run(capsys, *_build_args(inputs, out), "--params", str(params))
    _one_line_error(code, err, expected)
    assert not out.exists()


def test_a_build_error_after_a_reader_warning_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The camera reader warns about its principal point, then the detections are refused: one line
    (tools/fuzz_build.py case 6); the same warning is printed when the build succeeds."""
    image = tmp_path / "img.png"
    cv2.imwrite(str(image), np.full((64, 96, 3), 90, np.uint8))
    calib = tmp_path / "calib.txt"
    calib.write_text("P2: 80 0 0.5 4 0 80 40 0 0 0 1 0\n")  # cx far from the centre
    bad = tmp_path / "d.json"
    bad.write_text(json.dumps({"detections": [{"class": "car", "box": [36, 32, -1, 26]}]}))
    args = ["build", str(image), "--camera", str(calib), "-o", str(tmp_path / "world")]
    assert main([*args, "--detections", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: d.json -> detections -> [0] -> box:"), err
    labels = tmp_path / "img_labelIds.png"
    cv2.imwrite(str(labels), np.full((64, 96), 7, np.uint8))  # all road (a photo alone is refused)
    assert main([*args, "--labels", str(labels)]) == 0
    assert "principal point (0.5, 40) is far from the centre" in capsys.readouterr().err


def test_quiet_build_prints_no_results(capsys, inputs):
    """`usdworld -q build` prints only warnings and errors: no results table on stdout."""
    out = inputs["dir"] / "world"
    code, stdout, _ = _run(capsys, "-q", *_build_args(inputs, out))
    assert code == 0 and stdout == "" and (out / "world.usda").is_file()
    code, stdout, _ = _run(capsys, *_build_args(inputs, out), "--no-infer-streets")
    assert code == 0 and "3 objects placed from frame.png" in stdout


def test_file_problems_names_missing_and_broken_layers(tmp_path):
    from usdworld.authoring.validate import file_problems

    (tmp_path / "broken.usda").write_text("#usda 1.0\nthis is not usda\n")
    root = tmp_path / "root.usda"
    root.write_text('#usda 1.0\n(\n    subLayers = [@./broken.usda@, @./gone.usdc@]\n)\n')
    problems = {(Path(p.path).name, p.kind, Path(p.needed_by).name) for p in file_problems(root)}
    assert problems == {("broken.usda", "broken", "root.usda"), ("gone.usdc", "missing", "root.usda")}
