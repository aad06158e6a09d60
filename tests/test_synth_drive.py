"""``usdworld synth --sequence``: a drive's frames, poses, timestamps, manifest and ground truth agree."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from usdworld.cli.main import main
from usdworld.views.manifest import read_views_manifest


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("drive")
    code = main(["synth", "-o", str(out), "--seed", "7", "--sequence", "3", "--size", "160x80", "--interval", "0.5"])
    assert code == 0
    return out


def test_manifest_has_timestamped_poses_moving_along_the_street(drive: Path) -> None:
    views = read_views_manifest(drive / "drive_000007_views.json").views
    assert [v.timestamp for v in views] == [0.0, 0.5, 1.0]
    x = [v.world_from_cam[0, 3] for v in views]
    assert np.diff(x) == pytest.approx([4.0, 4.0])  # default 8 m/s
    assert all(np.allclose(v.world_from_cam[1:, :], views[0].world_from_cam[1:, :]) for v in views)
    for v in views:
        assert v.image.is_file() and v.labels is not None and v.labels.is_file()


def test_ground_truth_tracks_are_constant_velocity_and_frames_agree(drive: Path) -> None:
    gt = json.loads((drive / "drive_000007_drive_gt.json").read_text())
    times = np.array(gt["times"])
    moving = [o for o in gt["objects"] if o["moving"]]
    static = [o for o in gt["objects"] if not o["moving"]]
    assert moving and static
    assert {o["role"] for o in moving} <= {"driving", "walking"}
    assert {o["role"] for o in static}.isdisjoint({"driving", "walking"})
    first = {o["name"]: o for o in json.loads((drive / "drive_000007_000000_gt.json").read_text())["objects"]}
    assert all((o["variant"], o["scale"]) == (first[o["name"]]["variant"], first[o["name"]]["scale"])
               for o in gt["objects"])  # what a trunk's foot needs (usdworld.evaluation.drive.foot_offset)
    for o in gt["objects"]:
        track = np.array(o["track"])
        v = np.array([*o["velocity_world"], 0.0])
        assert track == pytest.approx(track[0] + times[:, None] * v, abs=1e-5)
        assert len(o["visible_pixels"]) == len(times)
    for i, t in enumerate(times):  # each frame's own ground truth is the world shifted by the ego's x
        frame = json.loads((drive / f"drive_000007_{i:06d}_gt.json").read_text())
        by_name = {o["name"]: o for o in frame["objects"]}
        ego_x = np.array(gt["world_from_ego"][i])[0, 3]
        assert ego_x == pytest.approx(8.0 * t)
        for o in gt["objects"]:
            expected = np.array(o["track"][i]) - [ego_x, 0.0, 0.0]
            assert by_name[o["name"]]["centre_world"] == pytest.approx(expected, abs=1e-5)
            assert by_name[o["name"]]["visible_pixels"] == o["visible_pixels"][i]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--sequence", "0"], "error: --sequence must be >= 1, got 0"),
        (["--sequence", "2", "--interval", "0"], "error: --interval must be > 0 s, got 0.0"),
        (["--sequence", "2", "--speed", "-1"], "error: --speed must be >= 0 m/s, got -1.0"),
    ],
)
def test_bad_sequence_options_are_one_line_errors(tmp_path: Path, capsys, args: list[str], message: str) -> None:
    code = main(["synth", "-o", str(tmp_path / "o"), "--seed", "1", *args])
    assert code == 2
    assert capsys.readouterr().err.strip() == message
