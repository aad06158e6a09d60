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


def test_a_standing_world_object_for_a_moving_car_is_held_in_place() -> None:
    parked = TrackedWorldObject("car_0001", "car", np.array([10.0, 0.0]), False, {})
    result = evaluate_drive([parked], _gt(), ("car", "tree"))
    assert result["moving"]["paired"] == 0  # median error 5 m over its two frames: outside the gate
    assert result["standing"]["overall"]["unmatched_objects"] == 1
