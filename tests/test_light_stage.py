"""The light stage's casters: an object cut by the image's top casts a shadow of unknown length."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from layout_support import box_object

from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import load_class_table
from usdworld.layout.draft import DepthMethod
from usdworld.layout.placement import Placement
from usdworld.light_stage import ray_entry_depth, seen_height_m, shadow_casters
from usdworld.parameters.light import LightParams
from usdworld.perception.depth.fusion import DepthCue

#: Level camera 1.5 m above the ground looking along +X; the top row's rays rise 0.45 m per metre of depth.
CAMERA = PinholeCamera(
    width=640,
    height=360,
    K=np.array([[400.0, 0, 320], [0, 400.0, 180], [0, 0, 1]]),
    height_m=1.5,
    pitch=0.0,
    roll=0.0,
    yaw=0.0,
)
SQUARE = np.array([[1.0, -0.5], [2.0, -0.5], [2.0, 0.5], [1.0, 0.5]])


def test_ray_entry_depth_known_answers() -> None:
    directions = np.array([[1.0, 0.0], [2.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [1.0, 0.25]])
    t = ray_entry_depth(np.zeros(2), directions, SQUARE)
    assert t[:2] == pytest.approx([1.0, 0.5])
    assert np.isnan(t[2]) and np.isnan(t[3])  # beside it, away from it
    assert t[4] == pytest.approx(1.0)
    assert ray_entry_depth(np.array([1.5, 0.0]), directions[:1], SQUARE)[0] == 0.0  # from inside


@settings(max_examples=50, deadline=None)
@given(st.floats(-math.pi, math.pi), st.floats(3.0, 20.0))
def test_ray_entry_point_lies_on_the_footprint_outline(angle: float, distance: float) -> None:
    origin = np.array([1.5 - distance * math.cos(angle), -distance * math.sin(angle)])
    direction = np.array([[math.cos(angle), math.sin(angle)]])  # towards the square's centre
    t = ray_entry_depth(origin, direction, SQUARE)[0]
    entry = origin + t * direction[0]
    # on the outline: inside the square grown by a micrometre, not inside it shrunk by one
    assert np.all(np.abs(entry - [1.5, 0.0]) <= [0.5 + 1e-6, 0.5 + 1e-6])
    assert np.max(np.abs(entry - [1.5, 0.0]) - [0.5, 0.5]) >= -1e-6


def _facade(top_cut: bool, height_m: float = 25.0) -> Placement:
    # A building across the street's end, 15 to 27 m ahead, its front wall facing the camera.
    obj = box_object("building", (200, 0 if top_cut else 40, 440, 200), 1)
    obj = dataclasses.replace(obj, top_truncated=top_cut)
    return Placement(
        name="building_0001",
        obj=obj,
        variant="default",
        position_world=np.array([21.0, 0.0, 0.0]),
        yaw=0.0,
        yaw_source="face_road",
        scale=1.0,
        stretch=np.ones(3),
        scale_measured=float("nan"),
        size_m=np.array([12.0, 12.0, height_m]),
        depth_m=21.0,
        method=DepthMethod.CONTACT,
        cues=(DepthCue("contact", 21.0, 1.0),),
    )


def test_seen_height_of_a_facade_cut_by_the_image_top() -> None:
    # every top-row ray of its columns enters the front wall 15 m ahead, 1.5 + 15 * 0.45 m high
    assert seen_height_m(_facade(True), CAMERA) == pytest.approx(8.25)
    assert math.isnan(seen_height_m(_facade(False), CAMERA))


def test_a_top_cut_caster_spans_what_is_seen_to_its_class_tallest() -> None:
    table = load_class_table()
    prior = table["building"]
    (cut,) = shadow_casters([_facade(True)], CAMERA, table, LightParams())
    assert cut.height_m == pytest.approx(8.25)  # not the 25 m it was placed with
    assert cut.height_max_m == pytest.approx(prior.size_m[2] + 2.0 * prior.height_std_m)  # 24 m
    (whole,) = shadow_casters([_facade(False, 14.0)], CAMERA, table, LightParams())
    assert (whole.height_m, whole.height_max_m) == (14.0, None)
