"""Evaluation: IoU and SSIM known answers, ground-truth readers, matching, and evaluate of real worlds.

The world-level tests render with headless OpenGL; without it they fail with the
RenderError message naming the packages to install (they never skip).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd

from usdworld.cli.main import main
from usdworld.errors import InputError
from usdworld.evaluation import (
    evaluate_world,
    ids_match_world,
    ignored_mask,
    iou_per_class,
    label_similarity,
    mean_iou,
    placeable_label_ids,
    read_ground_truth,
    read_label_ids,
    ssim,
)
from usdworld.evaluation.ground_truth import GroundTruth, GtObject
from usdworld.evaluation.objects import match_errors, match_objects, truth_in_world
from usdworld.evaluation.ssim import gaussian_window, ssim_map
from usdworld.evaluation.world_objects import WorldObject
from usdworld.pipeline import BuildRequest, build
from usdworld.synth import make_street_scene, write_cityscapes_frame

CAR, PERSON, ROAD, SKY = 26, 24, 7, 23


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


# -- IoU ---------------------------------------------------------------------------------


def test_iou_known_answers() -> None:
    pred = np.array([[CAR, CAR, ROAD], [ROAD, ROAD, 0]])
    gt = np.array([[CAR, ROAD, ROAD], [ROAD, ROAD, ROAD]])
    ious = iou_per_class(pred, gt, [CAR, ROAD, PERSON])
    assert ious[CAR] == pytest.approx(1 / 2)  # |{(0,0)}| / |{(0,0),(0,1)}|
    assert ious[ROAD] == pytest.approx(3 / 5)
    assert np.isnan(ious[PERSON])  # in neither map
    assert mean_iou(ious) == pytest.approx((1 / 2 + 3 / 5) / 2)
    assert mean_iou({1: float("nan")}) != mean_iou({1: float("nan")})  # NaN when nothing is finite


def test_iou_ignores_pixels_and_checks_shapes() -> None:
    pred = np.array([[CAR, ROAD]])
    gt = np.array([[ROAD, ROAD]])
    assert (
        iou_per_class(pred, gt, [CAR], ignore=np.array([[True, False]]))[CAR]
        != iou_per_class(pred, gt, [CAR])[CAR]
    )
    assert np.isnan(iou_per_class(pred, gt, [CAR], ignore=np.array([[True, False]]))[CAR])
    with pytest.raises(InputError):
        iou_per_class(pred, gt.T, [CAR])


def test_labels_map_onto_placeable_classes_and_void_is_ignored() -> None:
    # wall -> fence, caravan -> truck, polegroup -> pole, parking -> road; ego vehicle (1) is void.
    labels = np.array([[12, 29, 18, 9, 1, 26]])
    assert placeable_label_ids(labels).tolist() == [[13, 27, 17, 7, 1, 26]]
    assert ignored_mask(labels).tolist() == [[False, False, False, False, True, False]]
    # The ego-vehicle pixel does not count against the rendered road.
    pred = np.full((1, 6), ROAD)
    pred[0, 5] = CAR
    assert label_similarity(pred, np.array([[7, 7, 7, 9, 1, 26]]), [ROAD, CAR]) == pytest.approx(1.0)


# -- SSIM --------------------------------------------------------------------------------


def test_ssim_identical_is_one_and_inverse_is_low() -> None:
    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, (48, 64, 3)).astype(np.uint8)
    assert ssim(img, img) == pytest.approx(1.0, abs=1e-12)
    assert ssim(img, 255 - img) < 0.1
    smooth = np.tile(np.linspace(0, 255, 64), (48, 1))
    assert ssim(smooth, 255 - smooth) < 0.1


def test_ssim_constant_images_known_answer() -> None:
    # No variance: SSIM = (2 a b + C1) / (a^2 + b^2 + C1) with C1 = (0.01 * 255)^2.
    a, b = 100.0, 150.0
    c1 = (0.01 * 255) ** 2
    expected = (2 * a * b + c1) / (a * a + b * b + c1)
    assert ssim(np.full((20, 20), a), np.full((20, 20), b)) == pytest.approx(expected, rel=1e-9)


def test_ssim_window_matches_the_formula_at_one_window() -> None:
    rng = np.random.default_rng(5)
    x = rng.uniform(0, 255, (11, 11))
    y = np.clip(x + rng.normal(0, 20, (11, 11)), 0, 255)
    w = gaussian_window()
    assert w.sum() == pytest.approx(1.0) and w.shape == (11, 11)
    mx, my = (w * x).sum(), (w * y).sum()
    vx, vy = (w * x * x).sum() - mx**2, (w * y * y).sum() - my**2
    cxy = (w * x * y).sum() - mx * my
    c1, c2 = (0.01 * 255) ** 2, (0.03 * 255) ** 2
    expected = (2 * mx * my + c1) * (2 * cxy + c2) / ((mx**2 + my**2 + c1) * (vx + vy + c2))
    got = ssim_map(x, y)
    assert got.shape == (1, 1) and got[0, 0] == pytest.approx(expected, rel=1e-9)


def test_ssim_rejects_bad_input() -> None:
    with pytest.raises(InputError):
        ssim(np.zeros((20, 20)), np.zeros((20, 21)))
    with pytest.raises(InputError):
        ssim(np.zeros((5, 5)), np.zeros((5, 5)))


# -- ground truth and matching ------------------------------------------------------------


def test_kitti_ground_truth_known_answer(tmp_path: Path) -> None:
    (tmp_path / "label_2").mkdir()
    (tmp_path / "calib").mkdir()
    label = tmp_path / "label_2" / "000001.txt"
    label.write_text(
        "DontCare -1 -1 -10 1 2 3 4 -1 -1 -1 -1000 -1000 -1000 -10\n"
        "Car 0.00 0 1.85 387.63 181.54 423.81 203.12 1.67 1.87 3.69 -16.53 2.39 58.49 1.57\n"
        "Pedestrian 0.00 0 0 10 20 30 40 1.70 0.60 0.80 1.0 1.6 10.0 0.0\n"
    )
    P2 = "721.5 0 609.6 44.85 0 721.5 172.9 0.2164 0 0 1 0.002746"
    (tmp_path / "calib" / "000001.txt").write_text(f"P2: {P2}\n")
    gt = read_ground_truth(label)
    assert (
        gt.kind == "kitti" and gt.frame == "cam" and [o.class_name for o in gt.objects] == ["car", "person"]
    )
    car = gt.objects[0]
    assert car.instance_id == 0 and gt.objects[1].instance_id == 1  # DontCare is not counted
    offset = np.linalg.solve(
        np.array([[721.5, 0, 609.6], [0, 721.5, 172.9], [0, 0, 1]]), [44.85, 0.2164, 0.002746]
    )
    assert np.allclose(car.bottom_centre, np.array([-16.53, 2.39, 58.49]) + offset)
    assert np.allclose(car.size_lwh, [3.69, 1.87, 1.67])
    assert np.allclose(car.heading, [np.cos(1.57), 0.0, -np.sin(1.57)])


def test_nuscenes_and_synth_ground_truth(tmp_path: Path) -> None:
    doc = {
        "metainfo": {"categories": {"car": 0, "pedestrian": 7, "barrier": 9}},
        "data_list": [
            {
                "cam_instances": {
                    "CAM_FRONT": [
                        {"bbox_label_3d": 0, "bbox_3d": [1.0, 0.5, 20.0, 4.0, 1.6, 1.8, 0.0]},
                        {"bbox_label_3d": 9, "bbox_3d": [2.0, 0.5, 10.0, 0.5, 1.0, 2.0, 0.0]},
                        {"bbox_label_3d": 7, "bbox_3d": [-3.0, 0.7, 15.0, 0.6, 1.8, 0.6, 1.0]},
                    ]
                }
            }
        ],
    }
    path = tmp_path / "info.json"
    path.write_text(json.dumps(doc))
    gt = read_ground_truth(path)
    assert gt.kind == "nuscenes" and [o.class_name for o in gt.objects] == ["car", "person"]
    assert np.allclose(gt.objects[0].bottom_centre, [1.0, 0.5 + 0.8, 20.0])  # gravity centre moved down h/2
    assert np.allclose(gt.objects[0].size_lwh, [4.0, 1.8, 1.6])
    with pytest.raises(InputError, match="CAM_BACK"):
        read_ground_truth(path, camera="CAM_BACK")
    bad = tmp_path / "other.json"
    bad.write_text("{}")
    with pytest.raises(InputError, match="not a recognised ground truth"):
        read_ground_truth(bad)
    with pytest.raises(InputError, match="no such ground-truth file"):
        read_ground_truth(tmp_path / "missing.json")


def _wo(name: str, cls: str, xy: tuple[float, float], inst: int = -1, yaw: float = 0.0) -> WorldObject:
    return WorldObject(
        name,
        cls,
        inst,
        np.array([xy[0], xy[1], 0.0]),
        np.array([np.cos(yaw), np.sin(yaw), 0.0]),
        np.array([4.0, 1.8, 1.5]),
    )


def _gt(name: str, cls: str, xy: tuple[float, float], inst: int = -1, yaw: float = 0.0) -> GtObject:
    return GtObject(
        name, cls, inst, [xy[0], xy[1], 0.0], [np.cos(yaw), np.sin(yaw), 0.0], [4.0, 1.8, 1.5], 100
    )


def test_matching_by_id_then_distance_with_gate_and_groups() -> None:
    truth_objects = (
        _gt("a", "car", (20.0, 0.0), 26000),
        _gt("b", "car", (30.0, 3.0), 26001),
        _gt("c", "tree", (10.0, -6.0)),
        _gt("d", "tree", (40.0, 8.0)),
        _gt("e", "truck", (15.0, -3.0)),
    )
    gt = GroundTruth("synth", "world", truth_objects, "x_gt.json", "0" * 64)
    truth = truth_in_world(gt, np.eye(4))
    placed = [
        _wo("car_0001", "car", (30.5, 3.0), 26000),  # id 26000 but sits where b is: ids win
        _wo("car_0002", "car", (21.0, 0.0), 26001),
        _wo("tree_0001", "tree", (11.0, -6.0)),  # 1 m from c: matched
        _wo("tree_0002", "tree", (60.0, 8.0)),  # 20 m from d: beyond the gate (max(2, 0.25 * 40.8))
        _wo("car_0003", "car", (15.5, -3.0)),  # a car may match a truck (both vehicles)
    ]
    matches, unmatched = match_objects(truth, placed, np.zeros(3), ids_match=True)
    got = {m.truth.obj.name: (m.placed.name if m.placed else None, m.how) for m in matches}
    assert got == {
        "a": ("car_0001", "id"),
        "b": ("car_0002", "id"),
        "c": ("tree_0001", "distance"),
        "d": (None, "none"),
        "e": ("car_0003", "distance"),
    }
    assert [w.name for w in unmatched] == ["tree_0002"]
    matches, _ = match_objects(truth, placed, np.zeros(3), ids_match=False)
    got = {m.truth.obj.name: m.placed.name for m in matches if m.placed}
    assert got["a"] == "car_0002" and got["b"] == "car_0001"  # nearest first without ids


def test_match_errors_known_answer() -> None:
    gt = GroundTruth("synth", "world", (_gt("a", "car", (20.0, 0.0), yaw=0.1),), "x_gt.json", "0" * 64)
    truth = truth_in_world(gt, np.eye(4))
    placed = [_wo("car_0001", "car", (23.0, 4.0), yaw=0.1 + np.pi)]
    matches, _ = match_objects(truth, placed, np.zeros(3), ids_match=False)
    # Camera at the origin looking along +X (OpenCV z = world x).
    world_from_cam = np.eye(4)
    world_from_cam[:3, :3] = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    row = match_errors(matches[0], world_from_cam)
    assert row["position_error_m"] == pytest.approx(5.0)
    assert row["depth_error_m"] == pytest.approx(3.0)
    assert row["yaw_error_deg"] == pytest.approx(180.0) and row["yaw_error_mod180_deg"] == pytest.approx(
        0.0, abs=1e-9
    )
    assert row["size_error_m"] == pytest.approx([0.0, 0.0, 0.0])


# -- whole worlds --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def synth_world(tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("eval")
    scene = make_street_scene(np.random.default_rng(21), 256, 128)
    files = write_cityscapes_frame(scene, root, "synth_000000_000021")
    result = build(
        BuildRequest(
            image=files["image"],
            labels=files["labels"],
            instances=files["instances"],
            camera=files["camera"],
            output=root / "world",
        )
    )
    return {**files, "world": result.world, "root": root}


def test_evaluate_against_its_own_rendered_labels_gives_iou_one(capsys, synth_world) -> None:
    out = synth_world["root"] / "render"
    code, _, err = _run(capsys, "render", str(synth_world["world"]), "-o", str(out))
    assert code == 0, err
    code, stdout, err = _run(
        capsys, "evaluate", str(synth_world["world"]), "--labels", str(out / "labelIds.png"), "--json"
    )
    assert code == 0, err
    doc = json.loads(stdout.strip().splitlines()[-1])
    assert doc["per_class_iou"] and all(v == 1.0 for v in doc["per_class_iou"].values()), doc["per_class_iou"]
    assert doc["miou"] == 1.0
    assert {"road", "car"} <= set(doc["per_class_iou"])


def test_evaluate_synth_world_with_ground_truth(capsys, synth_world) -> None:
    code, stdout, err = _run(
        capsys,
        "evaluate",
        str(synth_world["world"]),
        "--labels",
        str(synth_world["labels"]),
        "--gt",
        str(synth_world["gt"]),
        "--photo",
        str(synth_world["image"]),
        "--json",
    )
    assert code == 0, err
    doc = json.loads(stdout.strip().splitlines()[-1])
    assert 0.0 < doc["miou"] <= 1.0 and 0.0 < doc["ssim"] < 1.0
    assert doc["objects"]["matched_by_instance_id"] is True
    things = doc["objects"]["things"]
    assert things["total"] > 0 and things["placed"] == things["total"]
    assert doc["median_position_error_m"] is not None and doc["median_position_error_m"] >= 0
    # Human-readable form of the same evaluation.
    code, stdout, _ = _run(
        capsys,
        "evaluate",
        str(synth_world["world"]),
        "--labels",
        str(synth_world["labels"]),
        "--gt",
        str(synth_world["gt"]),
    )
    assert code == 0 and "mIoU" in stdout and "3D errors" in stdout


def test_evaluate_world_api_matches_ids_only_for_its_own_frame(synth_world, tmp_path) -> None:
    stage = Usd.Stage.Open(str(synth_world["world"]))
    gt = read_ground_truth(synth_world["gt"])
    assert ids_match_world(stage, gt)
    renamed = tmp_path / "other_frame_gt.json"
    renamed.write_bytes(Path(synth_world["gt"]).read_bytes())
    assert not ids_match_world(stage, read_ground_truth(renamed))
    ev = evaluate_world(stage, labels=read_label_ids(synth_world["labels"]), classes=[CAR, ROAD])
    assert set(ev.per_class_iou) == {"car", "road"} and ev.objects is None and ev.ssim is None


def test_evaluate_bad_input_exit_codes(capsys, synth_world, tmp_path) -> None:
    world = str(synth_world["world"])
    cases = [
        (["evaluate", str(tmp_path / "nope")], "no such file"),
        (["evaluate", world, "--labels", str(tmp_path / "x.png")], "no such label image"),
        (["evaluate", world, "--labels", str(synth_world["instances"])], "labels must be 8-bit"),
        (["evaluate", world, "--gt", str(tmp_path / "gt.json")], "no such ground-truth file"),
        (["evaluate", world, "--labels", str(synth_world["image"])], "labels must be 8-bit"),
    ]
    for args, expected in cases:
        code, _, err = _run(capsys, *args)
        assert code == 2, (args, err)
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: ") and expected in lines[0], (args, err)


@pytest.mark.shared_data
def test_evaluate_kitti_world_against_label_2(shared_data, tmp_path, capsys) -> None:
    kitti = shared_data / "kitti" / "training"
    result = build(
        BuildRequest(
            image=kitti / "image_2" / "000008.png",
            detections=kitti / "label_2" / "000008.txt",
            camera=kitti / "calib" / "000008.txt",
            output=tmp_path / "w",
        )
    )
    code, stdout, err = _run(
        capsys, "evaluate", str(result.world), "--gt", str(kitti / "label_2" / "000008.txt"), "--json"
    )
    assert code == 0, err
    doc = json.loads(stdout.strip().splitlines()[-1])
    assert doc["objects"]["matched_by_instance_id"] is True and doc["objects"]["total"] == 6
    assert doc["median_position_error_m"] < 5.0  # KITTI cars at 10-60 m from one image


def test_evaluate_warns_about_the_ground_truth_of_another_scene(capsys, synth_world, tmp_path) -> None:
    other = write_cityscapes_frame(make_street_scene(np.random.default_rng(22), 320, 160), tmp_path, "synth_000000_000022")
    code, stdout, err = _run(capsys, "evaluate", str(synth_world["world"]), "--gt", str(other["gt"]), "--json")
    warnings = [line for line in err.splitlines() if line.startswith("WARNING:")]
    prefix = "WARNING: synth_000000_000022_gt.json looks like the ground truth of another scene: "
    assert code == 0 and warnings and all(w.startswith(prefix) for w in warnings), err
    assert any("image size: the ground truth is of a 320x160 image, the world of a 256x128 one" in w for w in warnings)
    assert json.loads(stdout.strip().splitlines()[-1])["scene_warnings"] == [w[len(prefix) :] for w in warnings]
    code, stdout, err = _run(capsys, "evaluate", str(synth_world["world"]), "--gt", str(synth_world["gt"]), "--json")
    assert code == 0 and "WARNING" not in err and json.loads(stdout.strip().splitlines()[-1])["scene_warnings"] == []
