"""The vehicles the box-shape focal cue reads, and the sizes it gives them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from layout_support import box_object

from usdworld.io.class_table import load_class_table
from usdworld.layout.focal_cues import box_shapes
from usdworld.parameters.camera import CameraParams


def test_cars_take_the_published_proportions_and_other_vehicles_the_table():
    table = load_class_table()
    params = CameraParams()
    objects = [
        box_object("car", (100, 150, 180, 200), 1),
        box_object("truck", (300, 120, 420, 210), 2),
        box_object("car", (0, 150, 60, 200), 3),  # touches the left border: its width is cut
        box_object("person", (500, 100, 520, 180), 4),  # not aligned with the road
    ]
    shapes = box_shapes(objects, table, 1242, 375, params)
    assert len(shapes) == 2
    np.testing.assert_array_equal(shapes.box_px, [[100, 150, 180, 200], [300, 120, 420, 210]])
    assert tuple(shapes.size_m[0]) == pytest.approx(params.shape_car_size_m)
    assert tuple(shapes.size_m[1]) == pytest.approx(table["truck"].size_m)
    assert tuple(shapes.height_std_m) == (table["car"].height_std_m, table["truck"].height_std_m)


def test_a_detection_is_read_by_its_own_edges_not_the_pixels_it_touches():
    """A box-only detection's sub-pixel edges (``edges_px``) are what the cue's projected box
    predicts; its whole-pixel ``box_px`` reaches up to a pixel further on each side. The border
    test stays on the whole pixels (a box touching the border is cut)."""
    table = load_class_table()
    params = CameraParams()
    inside = replace(
        box_object("car", (100, 150, 181, 201), 1), box_edges_px=np.array([100.4, 150.3, 180.2, 200.6])
    )
    at_border = replace(
        box_object("car", (1180, 150, 1242, 200), 2), box_edges_px=np.array([1180.2, 150.1, 1241.7, 199.5])
    )
    shapes = box_shapes([inside, at_border], table, 1242, 375, params)
    assert len(shapes) == 1
    np.testing.assert_allclose(shapes.box_px, [[100.4, 150.3, 180.2, 200.6]])
