"""BEV evaluation of a rig's world (tools/eval_views.py): matching, counts, duplicates; and the real sample."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from usdworld.evaluation.views import BevBox, evaluate_bev, read_bev_boxes

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


def test_the_real_sample_world(shared_data: Path, tmp_path: Path) -> None:
    """The six-camera sample as measured (BENCHMARKS.md, issue 19): every box placed at most once, 72 % exactly once."""
    from pxr import Usd

    from usdworld.evaluation.world_objects import world_objects
    from usdworld.views.build import ViewsRequest, build_views
    from usdworld.views.nuscenes import read_nuscenes_views

    info = shared_data / "nuscenes" / "demo" / "n015-2018-07-24-11-22-45+0800.pkl.DERIVED.json"
    boxes = read_bev_boxes(info)
    assert len(boxes) == 43 and all(b.seen_by for b in boxes)  # 69 boxes, 43 of placed classes, all seen
    build_views(ViewsRequest(read_nuscenes_views(info), tmp_path / "w", jobs=1))
    stage = Usd.Stage.Open(str(tmp_path / "w" / "world.usda"))
    assert len(stage.GetPrimAtPath("/World/Cameras").GetChildren()) == 6
    objects = [(o.name, o.class_name, o.bottom_centre_world[:2]) for o in world_objects(stage)]
    r = evaluate_bev(objects, boxes)["overall"]
    # 31 before the vehicles' span gave boxes-only views their traffic centre line (session 7): one
    # far car's turn changed line and its re-centred placement fell out of the gate, while the
    # median BEV error fell from 2.55 to 2.26 m (BENCHMARKS, "Several views, one world").
    assert r["placed_more"] == 0 and r["placed_once"] == 30
    assert r["median_bev_error_m"] < 2.3
