"""``usdworld.evaluation.drive``: known answers of the drive comparison (moving tracks, standing objects)."""

from __future__ import annotations

import numpy as np
import pytest

from usdworld.evaluation.drive import TrackedWorldObject, evaluate_drive


def _gt() -> dict:
    eye = np.eye(4)
    poses = []
    for t in (0.0, 1.0, 2.0):
        T = eye.copy()
        T[0, 3] = 8.0 * t
        poses.append(T.tolist())
    return {
        "times": [0.0, 1.0, 2.0],
        "world_from_ego": poses,
        "objects": [
            {"name": "car_0000", "class": "car", "moving": True, "track": [[10, 0, 0], [20, 0, 0], [30, 0, 0]],
             "visible_pixels": [100, 100, 0]},
            {"name": "tree_0000", "class": "tree", "moving": False, "track": [[15, 5, 0]] * 3,
             "visible_pixels": [50, 50, 50]},
            {"name": "tree_0001", "class": "tree", "moving": False, "track": [[40, 5, 0]] * 3,
             "visible_pixels": [0, 5, 9]},  # never 10 px: not seen
            {"name": "building_0000", "class": "building", "moving": False, "track": [[20, 20, 0]] * 3,
             "visible_pixels": [900, 900, 900]},  # a class not compared
        ],
    }


def test_known_answers() -> None:
    car = TrackedWorldObject("car_0001", "car", np.array([10.0, 0.3]), True,
                             {0.0: np.array([10.0, 0.3]), 1.0: np.array([20.0, 0.5])})
    trees = [
        TrackedWorldObject("tree_0001", "tree", np.array([15.0, 5.4]), False, {}),
        TrackedWorldObject("tree_0002", "tree", np.array([15.2, 4.0]), False, {}),  # the same tree again
    ]
    building = TrackedWorldObject("building_0001", "building", np.array([0.0, 0.0]), False, {})
    result = evaluate_drive([car, *trees, building], _gt(), ("car", "tree"))
    moving = result["moving"]
    assert (moving["seen"], moving["paired"], moving["paired_moving"]) == (1, 1, 1)
    assert moving["median_track_error_m"] == pytest.approx(0.4)  # median of 0.3 and 0.5
    standing = result["standing"]["overall"]
    assert (standing["seen"], standing["placed_once"], standing["placed_more"]) == (1, 0, 1)
    assert standing["median_bev_error_m"] == pytest.approx(0.4)
    assert result["false_moving"] == []


def test_the_track_summary_splits_by_class() -> None:
    """A walker 2 m off its track and a car 0.4 m off: the overall median is theirs, each class keeps its own."""
    gt = _gt()
    gt["objects"].append(
        {"name": "person_0000", "class": "person", "moving": True, "track": [[12, 3, 0], [13, 3, 0], [14, 3, 0]],
         "visible_pixels": [40, 40, 40]}
    )
    car = TrackedWorldObject("car_0001", "car", np.array([10.0, 0.4]), True,
                             {0.0: np.array([10.0, 0.4]), 1.0: np.array([20.0, 0.4])})
    walker = TrackedWorldObject("person_0001", "person", np.array([12.0, 5.0]), True,
                                {0.0: np.array([12.0, 5.0]), 2.0: np.array([14.0, 5.0])})
    moving = evaluate_drive([car, walker], gt, ("car", "person"))["moving"]
    assert moving["median_track_error_m"] == pytest.approx(1.2)  # median of 0.4 and 2.0
    assert moving["per_class"]["car"]["median_track_error_m"] == pytest.approx(0.4)
    assert moving["per_class"]["person"]["median_track_error_m"] == pytest.approx(2.0)
    assert [moving["per_class"][c]["paired_moving"] for c in ("car", "person")] == [1, 1]


def test_a_standing_world_object_for_a_moving_car_is_held_in_place() -> None:
    parked = TrackedWorldObject("car_0001", "car", np.array([10.0, 0.0]), False, {})
    result = evaluate_drive([parked], _gt(), ("car", "tree"))
    assert result["moving"]["paired"] == 0  # median error 5 m over its two frames: outside the gate
    assert result["standing"]["overall"]["unmatched_objects"] == 1


def test_the_ground_error_splits_along_and_across_the_viewing_direction() -> None:
    """A tree 10 m straight ahead of the only frame that shows it, placed 0.6 m long and 0.3 m to the
    right: along +0.6, across -0.3 (across is positive to the left of the ray)."""
    gt = _gt()
    gt["objects"][1] = {"name": "tree_0000", "class": "tree", "moving": False, "track": [[10, 0, 0]] * 3,
                        "visible_pixels": [50, 0, 0]}
    tree = TrackedWorldObject("tree_0001", "tree", np.array([10.6, -0.3]), False, {})
    standing = evaluate_drive([tree], gt, ("tree",))["standing"]
    (row,) = standing["boxes"]
    assert (row["along_m"], row["across_m"]) == (pytest.approx(0.6), pytest.approx(-0.3))
    assert standing["error_split"]["overall"] == {"n": 1, "median_along_m": pytest.approx(0.6),
                                                  "median_across_m": pytest.approx(0.3)}
    assert standing["error_split"]["per_class"]["tree"]["n"] == 1


def test_the_split_keeps_the_error_and_follows_the_mean_viewing_direction() -> None:
    """Seen from (0, 0), (8, 0) and (16, 0), the tree at (15, 5) has its along and across parts
    summing in squares to its BEV error, along the normalised mean of the three unit rays."""
    tree = TrackedWorldObject("tree_0001", "tree", np.array([16.0, 4.5]), False, {})
    standing = evaluate_drive([tree], _gt(), ("tree",))["standing"]
    (row,) = standing["boxes"]
    assert row["along_m"] ** 2 + row["across_m"] ** 2 == pytest.approx(row["error_m"] ** 2)
    rays = np.array([[15.0, 5.0], [7.0, 5.0], [-1.0, 5.0]])
    u = (rays / np.linalg.norm(rays, axis=1, keepdims=True)).mean(axis=0)
    u /= np.linalg.norm(u)
    assert row["along_m"] == pytest.approx(float(np.array([1.0, -0.5]) @ u))


def _lamp_catalogue():
    from usdworld.io.asset_catalogue import AssetCatalogue, AssetSizes

    pole = AssetSizes({"plain": (0.3, 0.3, 6.0), "street_lamp": (2.05, 0.3, 7.96)}, "plain",
                      contact_offset_by_variant={"street_lamp": (-0.875, 0.0)})
    return AssetCatalogue({"pole": pole})


def _lamp_gt() -> dict:
    """A street lamp on the right kerb, arm over the road (yaw +90 deg: its +X points to +Y, the road),
    scale 1.1: origin (20, -4.3), its mast's foot 0.875 * 1.1 m farther from the road, at (20, -5.2625)."""
    gt = _gt()
    gt["objects"] = [{"name": "pole_0000", "class": "pole", "moving": False, "variant": "street_lamp",
                      "scale": [1.1, 1.1, 1.1], "yaw_rad": np.pi / 2, "track": [[20.0, -4.3, 0.15]] * 3,
                      "visible_pixels": [80, 80, 80]}]
    return gt


def test_a_pole_is_compared_at_its_post_s_foot() -> None:
    """The true lamp's mast at (20, -5.2625) and a world plain pole standing on it: a wrong variant,
    no ground error; compared at their origins (no catalogue) the same pole is 0.9625 m off."""
    plain = TrackedWorldObject("pole_0001", "pole", np.array([20.0, -5.2625]), False, {}, "plain")
    at_feet = evaluate_drive([plain], _lamp_gt(), ("pole",), catalogue=_lamp_catalogue(),
                             trunk_classes=("pole",))["standing"]
    (row,) = at_feet["boxes"]
    assert row["error_m"] == pytest.approx(0.0, abs=1e-9)
    assert (row["variant_truth"], row["variant_world"]) == ("street_lamp", "plain")
    assert at_feet["variants"] == {"pole": {"n": 1, "agree": 0}}
    (origins,) = evaluate_drive([plain], _lamp_gt(), ("pole",))["standing"]["boxes"]
    assert origins["error_m"] == pytest.approx(0.9625)


def test_foot_offset_turns_the_scaled_contact_offset() -> None:
    from usdworld.evaluation.drive import foot_offset

    pole = _lamp_catalogue()["pole"]
    assert foot_offset(pole, "street_lamp", (1.1, 1.1, 1.1), np.pi / 2) == pytest.approx([0.0, -0.9625])
    assert foot_offset(pole, "street_lamp", (1.0, 1.0, 1.0), -np.pi / 2) == pytest.approx([0.0, 0.875])
    assert foot_offset(pole, "plain", (1.2, 1.2, 1.2), 0.3) == pytest.approx([0.0, 0.0])


def test_a_trunk_s_truth_without_a_variant_is_an_input_error() -> None:
    from usdworld.errors import InputError

    gt = _lamp_gt()
    del gt["objects"][0]["variant"]
    with pytest.raises(InputError, match="pole_0000: no 'variant'"):
        evaluate_drive([], gt, ("pole",), catalogue=_lamp_catalogue(), trunk_classes=("pole",))


def test_eval_views_fills_an_old_drive_s_variants_from_its_first_frame(tmp_path) -> None:
    """A drive ground truth written before variants were: tools/eval_views.py takes each object's
    variant and scale from ``<name>_000000_gt.json``, which lists every object."""
    import importlib.util
    import json
    from pathlib import Path

    spec = importlib.util.spec_from_file_location(
        "eval_views", Path(__file__).resolve().parents[1] / "tools" / "eval_views.py"
    )
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    gt = _lamp_gt()
    del gt["objects"][0]["variant"], gt["objects"][0]["scale"]
    (tmp_path / "d_drive_gt.json").write_text(json.dumps(gt))
    frame = {"objects": [{"name": "pole_0000", "variant": "street_lamp", "scale": [1.1, 1.1, 1.1]}]}
    (tmp_path / "d_000000_gt.json").write_text(json.dumps(frame))
    (filled,) = tool._drive_ground_truth(tmp_path / "d_drive_gt.json")["objects"]
    assert (filled["variant"], filled["scale"]) == ("street_lamp", [1.1, 1.1, 1.1])
