"""BEV evaluation of a rig's world (tools/eval_views.py): matching, counts, duplicates; and the real sample."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from usdworld.evaluation.views import BevBox, evaluate_bev, identity_duplicates, read_bev_boxes

BOXES = [
    BevBox(0, "car", np.array([20.0, 0.0]), ("CAM_FRONT",)),
    BevBox(1, "car", np.array([20.0, 4.0]), ("CAM_FRONT", "CAM_FRONT_LEFT")),
    BevBox(2, "person", np.array([10.0, -3.0]), ("CAM_FRONT",)),
    BevBox(3, "person", np.array([-40.0, 0.0]), ()),  # seen by no camera: not counted
]


def test_counts_placed_once_more_than_once_missed_and_extra() -> None:
    objects = [
        ("car_0001", "car", np.array([20.5, 0.0])),  # box 0, 0.5 m off
        ("car_0002", "car", np.array([21.0, 4.0])),  # box 1, 1 m off
        (
            "car_0003",
            "car",
            np.array([20.0, 4.4]),
        ),  # box 1 again: nearer, so it takes box 1 and car_0002 is the second
        ("person_0001", "person", np.array([30.0, 10.0])),  # beyond every person's gate: extra; box 2 missed
        ("person_0002", "car", np.array([10.0, -3.0])),  # a car where a person is: classes must agree
    ]
    r = evaluate_bev(objects, BOXES)
    assert r["overall"] == {
        "seen": 3,
        "placed_once": 1,
        "placed_more": 1,
        "missed": 1,
        "unmatched_objects": 2,
        "median_bev_error_m": pytest.approx(0.45),
        "p90_bev_error_m": pytest.approx(0.49),
    }
    rows = {row["index"]: row for row in r["boxes"]}
    assert rows[1]["objects"] == ["car_0003", "car_0002"] and rows[1]["error_m"] == pytest.approx(0.4)
    assert r["per_class"]["person"]["missed"] == 1 and r["per_class"]["car"]["placed_more"] == 1
    assert r["duplicate_pairs"] == 1  # car_0002 and car_0003 are 1.1 m apart
    assert r["gt_pairs_within"] == 0


def test_the_gate_grows_with_range() -> None:
    far = [BevBox(0, "car", np.array([60.0, 0.0]), ("CAM_FRONT",))]
    assert (
        evaluate_bev([("c", "car", np.array([68.0, 0.0]))], far)["overall"]["placed_once"] == 1
    )  # 8 m < 0.15 * 60
    assert evaluate_bev([("c", "car", np.array([70.0, 0.0]))], far)["overall"]["missed"] == 1


def test_identity_tells_one_box_twice_from_two_neighbours() -> None:
    """Boxes 0 and 1 are two pedestrians 1 m apart (CAM_FRONT sees both); box 2 a car that two cameras see."""
    first, second = (100.0, 50.0, 120.0, 90.0), (130.0, 50.0, 150.0, 90.0)
    boxes = [
        BevBox(0, "person", np.array([20.0, 0.0]), ("CAM_FRONT",), boxes_px=(("CAM_FRONT", first),)),
        BevBox(1, "person", np.array([20.0, 1.0]), ("CAM_FRONT",), boxes_px=(("CAM_FRONT", second),)),
        BevBox(
            2,
            "car",
            np.array([30.0, -10.0]),
            ("CAM_FRONT", "CAM_FRONT_RIGHT"),
            boxes_px=(("CAM_FRONT", (600, 60, 700, 100)), ("CAM_FRONT_RIGHT", (10, 60, 90, 100))),
        ),
    ]
    objects = [
        ("person_0001", "person", np.array([20.2, 0.0]), [("CAM_FRONT", (100, 50, 120, 90))]),
        ("person_0002", "person", np.array([20.1, 1.1]), [("CAM_FRONT", (130, 50, 150, 91))]),  # rounded box
        ("car_0001", "car", np.array([30.0, -10.0]), [("CAM_FRONT", (600, 60, 700, 100))]),
        ("car_0002", "car", np.array([30.5, -10.5]), [("CAM_FRONT_RIGHT", (10, 60, 90, 100))]),  # box 2 again
        ("car_0003", "car", np.array([60.0, 0.0]), [("CAM_BACK", (10, 60, 90, 100))]),  # no such box
    ]
    r = identity_duplicates(objects, boxes)
    assert r == {
        "boxes_placed_more": 1,
        "objects_of_several_boxes": 0,
        "pairs_one_box": 1,  # car_0001 and car_0002
        "pairs_two_boxes": 1,  # the two pedestrians
        "unidentified": 1,
        "placed_once_within_gate": 2,  # the pedestrians; the car is held twice
        "median_error_m": pytest.approx(np.hypot(0.1, 0.1)),  # of 0.2, 0.14 and 0 m (the nearer car)
    }
    merged = [("person_0001", "person", np.array([20.0, 0.5]), [objects[0][3][0], objects[1][3][0]])]
    assert identity_duplicates(merged, boxes)["objects_of_several_boxes"] == 1


INFO_NAME = "n015-2018-07-24-11-22-45+0800.pkl.DERIVED.json"
#: The built sample: its world folder, its boxes and the build's report.
Sample = tuple[Path, list[BevBox], dict]


@pytest.fixture(scope="module")
def sample_world(shared_data: Path, tmp_path_factory: pytest.TempPathFactory) -> Sample:
    """The six-camera sample built once: its info file, its boxes and the build's report."""
    from usdworld.views.build import ViewsRequest, build_views
    from usdworld.views.nuscenes import read_nuscenes_views

    info = shared_data / "nuscenes" / "demo" / INFO_NAME
    out = tmp_path_factory.mktemp("sample") / "w"
    result = build_views(ViewsRequest(read_nuscenes_views(info), out, jobs=1))
    return out, read_bev_boxes(info), result.report


def _objects(world: Path) -> list[tuple[str, str, np.ndarray]]:
    from pxr import Usd

    from usdworld.evaluation.world_objects import world_objects

    stage = Usd.Stage.Open(str(world / "world.usda"))
    assert len(stage.GetPrimAtPath("/World/Cameras").GetChildren()) == 6
    return [(o.name, o.class_name, o.bottom_centre_world[:2]) for o in world_objects(stage)]


def test_the_real_sample_world(sample_world: Sample) -> None:
    """The six-camera sample as measured (BENCHMARKS.md, issue 19): no box placed twice, 88 % exactly once, median within 1.5 m."""
    world, boxes, _ = sample_world
    assert len(boxes) == 43 and all(b.seen_by for b in boxes)  # 69 boxes, 43 of placed classes, all seen
    r = evaluate_bev(_objects(world), boxes)["overall"]
    # 30 of 43 (median 2.26 m) while the contact cue took the plane under the car for the ground
    # under every object: the pedestrians 60-68 m ahead (ground 0.5-0.8 m up) and 18-29 m to the
    # left (0.6-0.8 m up) were placed 10-22 m too far, beyond the gate.
    assert r["placed_more"] == 0 and r["placed_once"] == 38
    # Issue 19's target, 1.5 m: 1.506 m while a box's height was read off its whole-pixel
    # rounding (a pedestrian 35 px tall 3 % near by its class height), 1.32 m on its own edges.
    assert r["median_bev_error_m"] <= 1.5


def test_the_rig_measures_the_samples_ground_spread(shared_data: Path, sample_world: Sample) -> None:
    """The objects' contact and height cues measure the ground's height spread about the plane under the
    car; the LiDAR boxes' bottoms (centre z - height / 2, ego frame) measure it independently: 0.50 m rms."""
    _, boxes, report = sample_world
    doc = json.loads((shared_data / "nuscenes" / "demo" / INFO_NAME).read_text())
    sample = doc["data_list"][0]
    ego_from_lidar = np.array(sample["lidar_points"]["lidar2ego"])
    bottoms = []
    for b in boxes:
        x, y, z, _, _, h = sample["instances"][b.index]["bbox_3d"][:6]
        bottoms.append((ego_from_lidar @ np.array([x, y, z, 1.0]))[2] - h / 2.0)
    truth = float(np.sqrt(np.mean(np.square(bottoms))))
    assert truth == pytest.approx(0.50, abs=0.01)
    assert report["views"]["ground_spread_m"] == pytest.approx(truth, abs=0.15)
    assert report["parameters"]["placement"]["ground_height_sigma_m"] == report["views"]["ground_spread_m"]


def test_a_person_two_cameras_see_is_placed_once_near_its_box(sample_world: Sample) -> None:
    """Box 1, a pedestrian 42.5 m ahead-right on level ground, seen by CAM_FRONT and CAM_FRONT_RIGHT:
    one object within 0.5 m (1.21 m while the contact cue alone decided both views' depths)."""
    world, boxes, report = sample_world
    rows = {row["index"]: row for row in evaluate_bev(_objects(world), boxes)["boxes"]}
    assert rows[1]["views"] == ["CAM_FRONT", "CAM_FRONT_RIGHT"]
    assert rows[1]["count"] == 1 and rows[1]["error_m"] < 0.5
    (name,) = rows[1]["objects"]
    assert sorted(o["view"] for o in report["views"]["objects"][name]["observations"]) == rows[1]["views"]


def test_no_box_is_placed_twice_by_identity(sample_world: Sample) -> None:
    """Every object's observations name their camera boxes: no box is held by two objects, no object
    holds two boxes, and every pair of one class within 2 m is two real neighbours (the ground truth
    has 11 such pairs: pedestrians walking together)."""
    world, boxes, report = sample_world
    observed = {
        name: [(o["view"], o["image_bbox"]) for o in entry["observations"]]
        for name, entry in report["views"]["objects"].items()
    }
    objects = _objects(world)
    identity = identity_duplicates([(n, c, xy, observed[n]) for n, c, xy in objects], boxes)
    assert identity["unidentified"] == 0
    assert identity["boxes_placed_more"] == 0 and identity["objects_of_several_boxes"] == 0
    assert identity["pairs_one_box"] == 0
    assert identity["pairs_two_boxes"] == evaluate_bev(objects, boxes)["duplicate_pairs"] > 0
    # Read off the boxes, not matched: 38 placed once within the gate (28 before the ground spread,
    # where the matching found 30 by pairing pedestrians of a group crosswise); the median over all
    # 43 boxes, the 5 missed included, 1.63 m (3.84 m before; 1.84 m with the boxes' heights
    # read off their whole-pixel rounding).
    assert identity["placed_once_within_gate"] == 38
    assert identity["median_error_m"] == pytest.approx(1.63, abs=0.1)
