"""Placement of objects whose bottom is hidden (layout.placement)."""

from __future__ import annotations

import numpy as np
from layout_support import box_object, place_on_a_straight_road

from usdworld.geometry.camera import PinholeCamera
from usdworld.layout.placement import Skipped, SkipReason, skip_warnings
from usdworld.parameters.collision import CollisionParams
from usdworld.perception.objects import ImageObject

K = np.array([[800.0, 0.0, 512.0], [0.0, 800.0, 256.0], [0.0, 0.0, 1.0]])
CAM = PinholeCamera(1024, 512, K, 1.3)


def test_a_sliver_of_stuff_past_a_near_car_is_not_put_behind_it():
    car = box_object("car", (380, 280, 640, 420), 1)  # about 8 m away
    # Bottoms above the horizon (row 256): no ground point. The sliver's top row puts a
    # 7 m tree beyond the world's range; right behind the car it would be 0.15 x 0.7 m.
    sliver = box_object("tree", (500, 200, 512, 250), 2, hidden=True, by=1)
    crown = box_object("tree", (400, 60, 620, 250), 3, hidden=True, by=1)  # a whole crown: its top row places it
    objects = [car, sliver, crown]
    placements, skipped = place_on_a_straight_road(objects, CAM)
    placed = {p.obj.ref: p for p in placements}
    assert 2 not in placed and skipped == [Skipped("tree_0001", SkipReason.NO_DEPTH)]
    assert placed[3].depth_method == "top_row"
    assert placed[3].depth_m > placed[1].depth_m


def test_a_person_under_a_crown_does_not_push_the_tree():
    # 59 px tall: a 1.75 m person at the 24 m its contact row gives (so its cues agree)
    person = box_object("person", (560, 241, 580, 300), 1)
    tree = box_object("tree", (480, 120, 660, 300), 2)  # its crown overhangs the person
    # a trunk: only the middle columns reach the bottom
    mask = np.pad(np.ones((140, 180), bool), ((0, 40), (0, 0)))
    mask[140:, 45:55] = True  # 35-45 px (about 1.2 m) left of the person
    tree = ImageObject(**{**tree.__dict__, "mask": mask, "contact_px": np.array([530.0, 299.5])})
    objects = [person, tree]
    placements, _ = place_on_a_straight_road(objects, CAM)
    placed = {p.obj.ref: p for p in placements}
    assert set(placed) == {1, 2}
    crown = placed[2].size_m[:2].max() / 2
    gap = np.linalg.norm(placed[2].position_world[:2] - placed[1].position_world[:2])
    assert gap < crown  # the person stands under the crown ...
    assert np.all(placed[2].collision_displacement == 0.0)  # ... and nothing was moved


def test_each_skipped_object_is_named_once_with_its_reason(caplog):
    # Twelve copies of one car box and a sliver of tree past it (as above): with a 1 m
    # displacement bound, the first car stays, the rest of the pile is dropped as piled;
    # the sliver has no depth. Each one is named in exactly one warning, the one with its
    # reason, and placement itself logs nothing (it used to log the pile a second time).
    cars = [box_object("car", (380, 280, 640, 420), ref) for ref in range(1, 13)]
    tree = box_object("tree", (500, 200, 512, 250), 20, hidden=True, by=1)
    objects = [*cars, tree]
    collision = CollisionParams(max_displacement_m=1.0)
    with caplog.at_level("WARNING"):
        placements, skipped = place_on_a_straight_road(objects, CAM, collision=collision)
    assert caplog.records == []
    piled = [s.name for s in skipped if s.reason is SkipReason.PILED]
    assert [s for s in skipped if s.reason is SkipReason.NO_DEPTH] == [Skipped("tree_0001", SkipReason.NO_DEPTH)]
    assert 0 < len(piled) < len(cars) and len(placements) == len(cars) - len(piled)
    assert len({s.name for s in skipped}) == len(skipped)  # nobody twice
    warnings = skip_warnings(skipped, 80.0, collision)
    assert warnings == [
        "not placed (no visible ground contact, only a bound beyond 80 m, or smaller there than the smallest "
        "of its class): tree_0001",
        f"{len(piled)} objects not placed: each would have to move more than 1 m, or past 65536 candidate "
        "spots, to clear the objects already placed (a pile of contradictory boxes): " + ", ".join(piled),
    ]


def test_a_warning_names_at_most_twenty_skipped_objects() -> None:
    skipped = [Skipped(f"car_{k:04d}", SkipReason.PILED) for k in range(1, 26)]
    (warning,) = skip_warnings(skipped, 80.0, CollisionParams())
    assert warning.startswith("25 objects not placed")
    assert warning.endswith("car_0019, car_0020 and 5 more") and "car_0021" not in warning


def test_a_facade_piece_too_small_for_any_building_at_its_depth_is_not_placed():
    # Bases on row 320: 800 * 1.3 / 64 = 16.25 m ahead, where a pixel is 2 cm. The smallest
    # building (0.3 of the 12 x 10 x 12 m asset) has 3 m of frontage and is 3.6 m tall: a
    # piece 2 px (4 cm) wide and 70 px (1.4 m) tall is no building there; one 100 px wide
    # and 200 px (4.1 m) tall is. A piece as small but cut by the image's top is only a
    # lower bound on its building, and stays.
    sliver = box_object("building", (600, 250, 602, 320), 1, source_label="inferred:building")
    wall = box_object("building", (700, 120, 800, 320), 2, source_label="inferred:building")
    cut = box_object("building", (300, 0, 302, 320), 3, source_label="inferred:building")
    placements, skipped = place_on_a_straight_road([sliver, wall, cut], CAM)
    assert {p.obj.ref for p in placements} == {2, 3}
    assert [s.reason for s in skipped] == [SkipReason.NO_DEPTH]
    assert all(abs(p.depth_m - 16.25) < 8.0 for p in placements)
