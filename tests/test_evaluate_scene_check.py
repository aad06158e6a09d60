"""usdworld.evaluation.scene_check: a ground truth of another scene is recognised (known answers)."""

from __future__ import annotations

import numpy as np
import pytest

from usdworld.evaluation.ground_truth import GroundTruth, GtObject
from usdworld.evaluation.objects import match_objects, truth_in_world
from usdworld.evaluation.scene_check import image_box, scene_disagreements
from usdworld.evaluation.world_objects import WorldObject
from usdworld.geometry.camera import PinholeCamera

K = np.array([[100.0, 0.0, 100.0], [0.0, 100.0, 50.0], [0.0, 0.0, 1.0]])
SIZE = (200, 100)


def _pose(height: float = 1.5) -> np.ndarray:
    """Camera 1.5 m above the world origin looking along +X (OpenCV z = world x, x = -y, y = -z)."""
    world_from_cam = np.eye(4)
    world_from_cam[:3, :3] = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    world_from_cam[2, 3] = height
    return world_from_cam


def test_image_box_of_a_box_ahead_known_answer() -> None:
    # corners x in {9, 11}, y in {-1, 1}, z in {0, 3}: the near face (9 m) spans u = 100 -+ 100/9, v = 50 -+ 150/9
    box = image_box(
        np.array([10.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]), np.array([2.0, 2.0, 3.0]), K, _pose(), SIZE
    )
    assert box == pytest.approx([100 - 100 / 9, 50 - 150 / 9, 100 + 100 / 9, 50 + 150 / 9])
    behind = image_box(
        np.array([-10.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]), np.array([2.0, 2.0, 3.0]), K, _pose(), SIZE
    )
    assert behind is None


def _camera(width: int, height: int, f: float) -> PinholeCamera:
    return PinholeCamera(
        width, height, np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1.0]]), 1.5, 0.0, 0.0, 0.0
    )


def _scene(camera: PinholeCamera | None, placed_dy: float) -> tuple[GroundTruth, list]:
    cars = [(20.0, -3.0), (25.0, 3.0), (30.0, 0.0), (40.0, -3.0)]
    objects = tuple(
        GtObject(f"car_{i}", "car", -1, [x, y, 0.0], [1.0, 0.0, 0.0], [4.0, 1.8, 1.5], 500)
        for i, (x, y) in enumerate(cars)
    )
    gt = GroundTruth("synth", "world", objects, "x_gt.json", "0" * 64, camera)
    placed = [
        WorldObject(
            f"car_{i:04d}",
            "car",
            -1,
            np.array([x, y + placed_dy, 0.0]),
            np.array([1.0, 0.0, 0.0]),
            np.array([4.0, 1.8, 1.5]),
        )
        for i, (x, y) in enumerate(cars)
    ]
    matches, _ = match_objects(truth_in_world(gt, _pose()), placed, _pose()[:3, 3], ids_match=False)
    assert all(m.placed is not None for m in matches)  # within the 2 m / 25 % gate either way
    return gt, matches


def test_same_scene_gives_no_warning() -> None:
    gt, matches = _scene(_camera(200, 100, 100.0), 0.0)
    assert scene_disagreements(gt, SIZE, K, _pose(), matches, 4, ids_match=False) == ()


def test_image_size_and_camera_disagreements() -> None:
    gt, matches = _scene(
        _camera(400, 200, 200.0), 0.0
    )  # the same camera at twice the size: only the size differs
    notes = scene_disagreements(gt, SIZE, K, _pose(), matches, 4, ids_match=False)
    assert notes == ("image size: the ground truth is of a 400x200 image, the world of a 200x100 one",)
    gt, matches = _scene(_camera(200, 100, 150.0), 0.0)
    (note,) = scene_disagreements(gt, SIZE, K, _pose(), matches, 4, ids_match=False)
    assert note.startswith(
        "camera: the ground truth's focal length is 150 px and principal point (100, 50), the world's 100 px"
    )


def test_objects_that_do_not_overlap_in_the_image() -> None:
    gt, matches = _scene(
        None, 1.9
    )  # every car 1.9 m to the side of its truth: matched, but beside it in the image
    (note,) = scene_disagreements(gt, SIZE, K, _pose(), matches, 4, ids_match=False)
    assert note.startswith("objects: 0 of the ground truth's 4 vehicles and people overlap the placed object")
    assert scene_disagreements(gt, SIZE, K, _pose(), matches, 4, ids_match=True) == ()  # same ids: same scene
