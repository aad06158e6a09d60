"""Placement of objects whose bottom is hidden (layout.placement)."""

from __future__ import annotations

import numpy as np

from usdworld.authoring.asset_library import library_dirs
from usdworld.authoring.asset_measures import asset_catalogue
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import load_class_table
from usdworld.layout.placement import place_objects
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.objects import ImageObject

K = np.array([[800.0, 0.0, 512.0], [0.0, 800.0, 256.0], [0.0, 0.0, 1.0]])
CAM = PinholeCamera(1024, 512, K, 1.3)


def _obj(class_name: str, box: tuple[int, int, int, int], ref: int, **flags) -> ImageObject:
    x0, y0, x1, y1 = box
    return ImageObject(
        class_name=class_name,
        source_label=class_name,
        instance_id=ref if class_name == "car" else -1,
        box_px=np.array(box, dtype=np.int64),
        mask=np.ones((y1 - y0, x1 - x0), bool),
        contact_px=np.array([(x0 + x1) / 2.0, y1 - 0.5]),
        bottom_truncated=False,
        bottom_occluded=flags.get("hidden", False),
        top_truncated=False,
        occluded_by=flags.get("by", -1),
        ref=ref,
    )


def test_a_sliver_of_stuff_past_a_near_car_is_not_put_behind_it():
    car = _obj("car", (380, 280, 640, 420), 1)  # about 8 m away
    # Bottoms above the horizon (row 256): no ground point. The sliver's top row puts a
    # 7 m tree beyond the world's range; right behind the car it would be 0.15 x 0.7 m.
    sliver = _obj("tree", (500, 200, 512, 250), 2, hidden=True, by=1)
    crown = _obj("tree", (400, 60, 620, 250), 3, hidden=True, by=1)  # a whole crown: its top row places it
    objects = [car, sliver, crown]
    sizes = asset_catalogue((o.class_name for o in objects), library_dirs(None))
    ground_from_px = np.linalg.inv(CAM.px_from_ground())
    placements, skipped = place_objects(
        objects,
        CAM,
        ground_from_px,
        RoadAxis(0.0, np.zeros(2), "camera_forward"),
        sizes,
        load_class_table(),
        PlacementParams(),
    )
    placed = {p.obj.ref: p for p in placements}
    assert 2 not in placed and "tree_0001" in skipped
    assert placed[3].depth_method == "top_row"
    assert placed[3].depth_m > placed[1].depth_m


def test_a_person_under_a_crown_does_not_push_the_tree():
    # 59 px tall: a 1.75 m person at the 24 m its contact row gives (so its cues agree)
    person = _obj("person", (560, 241, 580, 300), 1)
    tree = _obj("tree", (480, 120, 660, 300), 2)  # its crown overhangs the person
    # a trunk: only the middle columns reach the bottom
    mask = np.pad(np.ones((140, 180), bool), ((0, 40), (0, 0)))
    mask[140:, 45:55] = True  # 35-45 px (about 1.2 m) left of the person
    tree = ImageObject(**{**tree.__dict__, "mask": mask, "contact_px": np.array([530.0, 299.5])})
    objects = [person, tree]
    sizes = asset_catalogue((o.class_name for o in objects), library_dirs(None))
    ground_from_px = np.linalg.inv(CAM.px_from_ground())
    placements, _ = place_objects(
        objects,
        CAM,
        ground_from_px,
        RoadAxis(0.0, np.zeros(2), "camera_forward"),
        sizes,
        load_class_table(),
        PlacementParams(),
    )
    placed = {p.obj.ref: p for p in placements}
    assert set(placed) == {1, 2}
    crown = placed[2].size_m[:2].max() / 2
    gap = np.linalg.norm(placed[2].position_world[:2] - placed[1].position_world[:2])
    assert gap < crown  # the person stands under the crown ...
    assert np.all(placed[2].collision_displacement == 0.0)  # ... and nothing was moved
