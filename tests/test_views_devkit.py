"""``build --layout nuscenes --dataroot DIR``: the official nuScenes layout through nuscenes-devkit.

The tables are a tiny fake dataroot of the test rig (tests/nuscenes_dataroot.py). The tests
that read it need the ``nuscenes`` extra (tools/setup_test_env.sh installs it) and are skipped
without it; the one-line error that names the extra is tested either way.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from nuscenes_dataroot import CHANNELS, SAMPLE, write_dataroot
from views_support import CAMERAS, OBJECTS, box_corners, image_box, world_from_cam, write_rig

from usdworld.cli.main import main


@pytest.fixture()
def dataroot(tmp_path: Path) -> Path:
    return write_dataroot(tmp_path / "nuscenes")


def _devkit() -> None:
    pytest.importorskip("nuscenes.nuscenes", reason="needs the nuscenes extra (tools/setup_test_env.sh)")


def test_the_devkit_views_are_the_rigs_cameras_and_its_boxes(dataroot: Path) -> None:
    _devkit()
    from usdworld.views.nuscenes_devkit import read_devkit_views

    views = read_devkit_views(dataroot, SAMPLE)
    assert [v.name for v in views.views] == list(CHANNELS)
    assert views.frame == f"ego frame of sample {SAMPLE}"
    for v in views.views:
        pose = world_from_cam(*CAMERAS[CHANNELS[v.name]])
        assert v.world_from_cam == pytest.approx(pose, abs=1e-9)  # through a non-identity global ego pose
        assert v.image.name == f"{v.name}_photo.jpg" and v.timestamp == pytest.approx(1.0, abs=0.02)
        expected = [b for o in OBJECTS if (b := image_box(pose, box_corners(*o[1:])))]
        got = [d.box_px for d in v.detection_items.items if d.truncated == 0.0]
        assert len(got) == len(expected)
        for box in expected:  # each box the rig's detections hold, to a tenth of a pixel
            assert min(float(np.abs(g - box).max()) for g in got) < 0.1
        assert {d.label for d in v.detection_items.items} <= {"car", "pedestrian"}


def test_build_from_the_dataroot_places_the_world_the_manifest_places(
    dataroot: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _devkit()
    out = tmp_path / "world"
    args = ["build", "--layout", "nuscenes", "--dataroot", str(dataroot), "--sample", SAMPLE, "-o", str(out)]
    assert main([*args, "--jobs", "1"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert [c["name"] for c in report["views"]["cameras"]] == list(CHANNELS)
    rig = tmp_path / "rig"
    rig.mkdir()
    assert main(["build", "--views", str(write_rig(rig)), "-o", str(rig / "world"), "--jobs", "1"]) == 0
    manifest = json.loads((rig / "world" / "report.json").read_text())

    def placed(r: dict) -> list[tuple[str, np.ndarray]]:
        return sorted(((o["class"], np.array(o["position_world"][:2])) for o in r["objects"]), key=lambda c: tuple(c[1]))

    got, want = placed(report), placed(manifest)
    assert len(got) == len(want) == len(OBJECTS)
    for (cls, xy), (cls_m, xy_m) in zip(got, want):  # the boxes agree to a tenth of a pixel
        assert cls == cls_m and np.linalg.norm(xy - xy_m) < 0.1


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        (["--sample", "nope"], "error: --sample nope: no such sample in v1.0-mini/; its samples are sample0"),
        (["--views", "v.json"], "error: --dataroot and --views: give one (--dataroot is a nuScenes dataset root)"),
    ],
)
def test_dataroot_errors_are_one_line(
    dataroot: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], expected: str
) -> None:
    if extra[0] == "--sample":
        _devkit()
    args = ["build", "--layout", "nuscenes", "--dataroot", str(dataroot), *extra, "-o", str(tmp_path / "o")]
    assert main(args) == 2
    assert capsys.readouterr().err.strip() == expected


def test_dataroot_needs_the_nuscenes_layout(dataroot: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["build", "--dataroot", str(dataroot), "-o", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.strip() == "error: --dataroot reads the nuScenes dataset layout; add --layout nuscenes"


def test_without_the_devkit_the_error_names_the_extra(
    dataroot: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "nuscenes", None)  # import nuscenes.nuscenes raises ImportError
    monkeypatch.setitem(sys.modules, "nuscenes.nuscenes", None)
    args = ["build", "--layout", "nuscenes", "--dataroot", str(dataroot), "-o", str(tmp_path / "o")]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: --dataroot: reading the nuScenes dataset layout needs nuscenes-devkit (")
    assert err.endswith("(as tools/setup_test_env.sh)") and "the nuscenes extra" in err
    assert "\n" not in err


def test_batch_builds_each_sample_of_a_dataroot(dataroot: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _devkit()
    out = tmp_path / "out"
    assert main(["batch", str(dataroot), "--layout", "nuscenes", "-o", str(out)]) == 0
    assert "built 1, unchanged 0, failed 0, cancelled 0 of 1 frames" in capsys.readouterr().out
    report = json.loads((out / SAMPLE / "report.json").read_text())
    assert [c["name"] for c in report["views"]["cameras"]] == list(CHANNELS)
    assert main(["batch", str(dataroot), "--layout", "nuscenes", "-o", str(out), "--resume"]) == 0
    assert "built 0, unchanged 1" in capsys.readouterr().out
