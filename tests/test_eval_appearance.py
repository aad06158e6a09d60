"""tools/eval_appearance.py: frame discovery, and one real frame evaluated end to end."""

from __future__ import annotations

import importlib.util
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "eval_appearance", Path(__file__).parents[1] / "tools" / "eval_appearance.py"
)
eval_appearance = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(eval_appearance)  # type: ignore[union-attr]


def test_frames_finds_kitti_nuscenes_and_cityscapes_inputs(tmp_path):
    kitti = tmp_path / "kitti" / "training"
    for sub, ext in (("image_2", "png"), ("label_2", "txt"), ("calib", "txt")):
        (kitti / sub).mkdir(parents=True)
        (kitti / sub / f"000003.{ext}").write_text("")
    city = tmp_path / "cityscapes"
    city.mkdir()
    (city / "x_000001_leftImg8bit.png").write_text("")
    found = dict(eval_appearance.frames(tmp_path))
    assert list(found) == ["kitti_000003", "cityscapes_x_000001"]
    assert found["kitti_000003"]["detections"] == kitti / "label_2" / "000003.txt"
    assert found["cityscapes_x_000001"]["instances"] == city / "x_000001_gtFine_instanceIds.png"


def test_one_kitti_frame_end_to_end(shared_data, tmp_path):
    items = [i for i in eval_appearance.frames(shared_data) if i[0] == "kitti_000002"]
    assert items, "KITTI 000002 is in the evaluation data"
    eval_appearance.build_all(items, tmp_path)
    summary = eval_appearance.evaluate_all(items, tmp_path, tmp_path / "renders")
    frame = summary["per_frame"]["kitti_000002"]
    # The misc box is counted since inferred facades stand behind the boxes
    # they surround (layout.occlusion.behind_bordered_things): 2 objects, no thing, before.
    # The facades show since the crowns over the garages, hidden by no box, no longer stand
    # on the tree row 1 to 4 m ahead in the boxes' way (layout.rows): 3 objects before.
    # The car at the street's far end shows since the facade pieces of a few columns there,
    # smaller than any building at their depth, are not placed across the street
    # (layout.occlusion.sliver_facade): 10 objects before, four of them those pieces (dE 26-40).
    assert frame["objects"] == 6 and summary["kitti_objects"] == 6
    assert {"misc_0001", "car_0001"} <= {r["name"] for r in frame["rows"]}
    assert frame["median_delta_e76"] < 15.0  # main's library colours: 61
    assert (tmp_path / "renders" / "kitti_000002.png").is_file()
