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
