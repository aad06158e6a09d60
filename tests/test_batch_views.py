"""``usdworld batch --layout views`` / ``--layout nuscenes``: a world per views manifest or sample."""

from __future__ import annotations

import json
import pickle
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from views_support import CAMERAS, K, write_rig
from views_support import world_from_cam as cam_pose

from usdworld.batch.discover import count_frames, discover
from usdworld.batch.frames import Frame
from usdworld.batch.views import ViewsBuild, views_key
from usdworld.cli.main import main


def _objects(world: Path) -> dict[str, list[float]]:
    report = json.loads((world / "report.json").read_text())
    return {o["name"]: o["position_world"] for o in report["objects"]}


@pytest.fixture(scope="module")
def rigs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with two views manifests of the test rig (``b`` without the left view) and their inputs."""
    folder = tmp_path_factory.mktemp("batch_rigs")
    manifest = write_rig(folder)
    doc = json.loads(manifest.read_text())
    manifest.unlink()
    (folder / "rig_a.json").write_text(json.dumps(doc))
    (folder / "rig_b.json").write_text(json.dumps({"views": doc["views"][:1]}))
    return folder


def test_each_views_manifest_of_a_folder_is_one_world_as_build_views_makes_it(
    rigs: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    items = list(discover(rigs, "views"))
    assert [(i.frame_id, i.source) for i in items if isinstance(i, Frame)] == [
        ("rig_a", "rig_a.json"),
        ("rig_b", "rig_b.json"),
    ]  # the views' detections files are not jobs
    assert count_frames(items) == (2, [])
    out = tmp_path / "out"
    assert main(["batch", str(rigs), "--layout", "views", "-o", str(out), "--workers", "2"]) == 0
    assert "built 2, unchanged 0, failed 0" in capsys.readouterr().out
    for name in ("rig_a", "rig_b"):
        single = tmp_path / f"single_{name}"
        assert main(["build", "--views", str(rigs / f"{name}.json"), "-o", str(single)]) == 0
        assert _objects(out / name) == _objects(single)
        report = json.loads((out / name / "report.json").read_text())
        names = [c["name"] for c in report["views"]["cameras"]]
        assert names == (list(CAMERAS) if name == "rig_a" else ["front"])
    batch = json.loads((out / "batch.json").read_text())
    assert batch["layout"] == "views" and [f["status"] for f in batch["frames"]] == ["built", "built"]
    assert main(["batch", str(rigs), "--layout", "views", "-o", str(out), "--resume"]) == 0
    assert "built 0, unchanged 2, failed 0" in capsys.readouterr().out


def test_the_resume_key_follows_every_file_a_view_names(rigs: Path, tmp_path: Path) -> None:
    folder = tmp_path / "rigs"
    shutil.copytree(rigs, folder)
    request = ViewsBuild(folder / "rig_b.json", "manifest", None, Path("rig_b"))
    before = views_key(request)
    assert views_key(request) == before
    cv2.imwrite(str(folder / "left.png"), np.zeros((4, 4, 3), np.uint8))  # not a view of rig_b
    assert views_key(request) == before
    cv2.imwrite(str(folder / "front.png"), np.zeros((4, 4, 3), np.uint8))
    changed = views_key(request)
    assert changed != before
    dets = json.loads((folder / "front_dets.json").read_text())
    (folder / "front_dets.json").write_text(json.dumps({"detections": dets["detections"][:1]}))
    assert views_key(request) != changed


def _info(folder: Path) -> Path:
    """An info JSON of three samples: t0 and t1 with a camera each (t1's photo missing), t2 with none."""
    cv2.imwrite(str(folder / "front.jpg"), np.full((450, 800, 3), 128, np.uint8))
    camera = {
        "cam2img": K.tolist(),
        "cam2ego": cam_pose((1.5, 0.0, 1.5), 0.0).tolist(),
    }
    box_3d = [2.0, 0.75, 20.0, 4.0, 1.5, 1.8, 0.0]  # on the ground, 20 m ahead
    box = {"bbox": [300.0, 200.0, 500.0, 280.0], "bbox_label": 0, "bbox_3d": box_3d}
    doc = {
        "metainfo": {"categories": {"car": 0}},
        "data_list": [
            {
                "token": "t0",
                "images": {"CAM_FRONT": {**camera, "img_path": "samples/CAM_FRONT/front.jpg"}},
                "cam_instances": {"CAM_FRONT": [box]},
            },
            {"token": "t1", "images": {"CAM_FRONT": {**camera, "img_path": "samples/CAM_FRONT/gone.jpg"}}},
            {"token": "t2", "images": {}},
        ],
    }
    path = folder / "info.json"
    path.write_text(json.dumps(doc))
    return path


def test_each_nuscenes_sample_is_one_world_and_incomplete_samples_are_listed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    info = _info(tmp_path)
    out = tmp_path / "out"
    assert main(["batch", str(info), "--layout", "nuscenes", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "built 1, unchanged 0, failed 0, cancelled 0 of 1 frames" in text
    assert "  t1: info.json -> data_list[1]: no photo of CAM_FRONT beside info.json" in text
    assert "  t2: info.json -> data_list[2]: no cameras (images is missing or empty)" in text
    single = tmp_path / "single"
    args = ["build", "--layout", "nuscenes", "--views", str(info), "--sample", "t0", "-o", str(single)]
    assert main(args) == 0
    assert _objects(out / "t0") == _objects(single) and len(_objects(single)) == 1
    report = json.loads((out / "t0" / "report.json").read_text())
    assert report["views"]["frame"] == "ego frame of sample t0"


def test_a_pickled_info_file_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "infos.pkl"
    path.write_bytes(pickle.dumps({"data_list": []}, protocol=4))
    assert main(["batch", str(path), "--layout", "nuscenes", "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: infos.pkl: a Python pickle (an mmdetection3d info file?);") and "\n" not in err
