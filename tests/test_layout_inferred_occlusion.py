"""Stuff inferred around detection boxes stands behind the things it is seen around (layout.occlusion)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from layout_support import box_object, place_on_a_straight_road

from usdworld.geometry.camera import PinholeCamera
from usdworld.layout.occlusion import borders_box
from usdworld.perception.objects import ImageObject

K = np.array([[800.0, 0.0, 512.0], [0.0, 800.0, 256.0], [0.0, 0.0, 1.0]])
CAM = PinholeCamera(1024, 512, K, 1.3)
CAR_BOX = (100, 280, 300, 420)  # about 8 m ahead, 2.6 m to the left


def _facade_around_the_car(source_label: str) -> ImageObject:
    """A facade drawn around the car's box: above and beside it, and a 10 px strip under it
    (a box a little short of the car's bottom leaves such a strip to the inferred stuff),
    so that its foot, seen right of the car's middle, seems nearer than the car: drafted
    there, the building (running along the street on the left) stands in the car's way."""
    x0, y0, x1, y1 = 0, 0, 420, 430
    mask = np.ones((y1 - y0, x1 - x0), bool)
    mask[CAR_BOX[1] - y0 : CAR_BOX[3] - y0, CAR_BOX[0] - x0 : CAR_BOX[2] - x0] = False
    facade = box_object("building", (x0, y0, x1, y1), 7, source_label=source_label)
    return ImageObject(**{**facade.__dict__, "mask": mask, "contact_px": np.array([260.0, 429.5])})


def _place(objects: list[ImageObject]) -> dict[int, object]:
    placements, _ = place_on_a_straight_road(objects, CAM)
    return {p.obj.ref: p for p in placements}


def test_an_inferred_facade_around_a_car_box_stands_behind_the_car():
    car = box_object("car", CAR_BOX, 1)
    placed = _place([car, _facade_around_the_car("inferred:building")])
    assert placed[7].depth_method == "behind_car_0001"
    assert placed[7].depth_m > placed[1].depth_m + 0.5 * placed[1].size_m[0]
    # The pass is for inferred stuff only: a facade from given labels keeps its foot's depth.
    labelled = _place([car, _facade_around_the_car("building")])
    assert labelled[7].depth_method == "contact"
    assert labelled[7].depth_m < labelled[1].depth_m


@given(st.integers(-5, 5), st.integers(-5, 5))
def test_a_mask_borders_a_box_when_a_pixel_touches_it(dx: int, dy: int):
    """A one-pixel mask at (110 + dx, 110 + dy) next to the box 100..110 x 100..110."""
    stuff = box_object("building", (110 + dx, 110 + dy, 111 + dx, 111 + dy), 1)
    touches = -11 <= dx <= 0 and -11 <= dy <= 0
    assert borders_box(stuff, np.array([100, 100, 110, 110])) == touches


# A car 30 m ahead and 6 m to the left (its box 320..385 x 250..291), a sidewalk 2 m to 6 m
# to the left from 5 m to 40 m ahead (the tree row: 1 m behind its kerb) and two inferred
# crowns whose foot is hidden, whose middle columns' rays meet that row about 17 m ahead:
# on the row, either would stand between the camera and the car.
FAR_CAR_BOX = (320, 250, 385, 291)
_XS, _YS = np.meshgrid(np.linspace(5.0, 40.0, 36), np.linspace(2.0, 6.0, 41))
LEFT_WALK = np.column_stack([_XS.ravel(), _YS.ravel()])


def _crown(box: tuple[int, int, int, int], ref: int) -> ImageObject:
    return box_object("tree", box, ref, hidden=True, source_label="inferred:vegetation")


def _placed_with_the_walk(objects: list[ImageObject]) -> dict[int, object]:
    placements, _ = place_on_a_straight_road(objects, CAM, sidewalk_ground=LEFT_WALK)
    return {p.obj.ref: p for p in placements}


def test_a_crown_clear_of_a_car_box_is_not_stood_on_its_row_in_the_cars_way():
    car = box_object("car", FAR_CAR_BOX, 1)
    apart = _crown((300, 150, 420, 235), 2)  # 15 px above the car's box: not seen over it
    touching = _crown((330, 170, 400, 250), 3)  # its lowest row meets the box's top
    placed = _placed_with_the_walk([car, apart, touching])
    # The crown seen around the box stands just behind the car (behind_bordered_things) ...
    assert placed[3].depth_method == "behind_car_0001"
    # ... and the one clear of the box, which the row would put 17 m ahead in the car's way,
    # keeps its own depth (from its top row): behind the car, not on the row.
    assert placed[2].depth_method == "top_row"
    assert placed[2].depth_m - 0.5 * placed[2].size_m[0] > placed[1].depth_m
    # Stuff from given labels is not affected: the photo's own labels put the crown there.
    labelled = _placed_with_the_walk([car, box_object("tree", (300, 150, 420, 235), 2, hidden=True)])
    assert labelled[2].depth_method == "street_line"
    assert labelled[2].depth_m < labelled[1].depth_m
