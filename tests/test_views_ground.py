"""One ground for a rig: every view's road and sidewalk moved into the world and united, terrain around them."""

from __future__ import annotations

import math

import manifold3d
import numpy as np
import pytest

from usdworld.layout.surfaces import extrude_surface
from usdworld.views.ground import rig_surfaces, top_section


def _square(name: str, x0: float, y0: float, x1: float, y1: float, top: float = 0.0):
    section = manifold3d.CrossSection.square((x1 - x0, y1 - y0)).translate((x0, y0))
    return extrude_surface(name, section, top, -0.05)


def _pose(turn_deg: float, x: float, y: float) -> np.ndarray:
    T = np.eye(4)
    c, s = math.cos(math.radians(turn_deg)), math.sin(math.radians(turn_deg))
    T[:2, :2] = [[c, -s], [s, c]]
    T[:2, 3] = (x, y)
    return T


def test_top_section_recovers_the_region_of_an_extruded_surface() -> None:
    mesh = _square("road", 0.0, -2.0, 10.0, 2.0)
    section = top_section(mesh)
    assert section.area() == pytest.approx(40.0)
    assert section.bounds() == pytest.approx((0.0, -2.0, 10.0, 2.0))


def test_two_views_roads_unite_in_the_world_and_the_terrain_fills_the_rest() -> None:
    # each view sees a 10 x 4 m road ahead of it; the second view looks back from 5 m ahead
    road = _square("road", 0.0, -2.0, 10.0, 2.0)
    sidewalk = _square("sidewalk", 0.0, 2.0, 10.0, 4.0, top=0.15)
    out = rig_surfaces(
        [([road, sidewalk], _pose(0.0, 0.0, 0.0)), ([road], _pose(180.0, 5.0, 0.0))], 0.15, 50.0
    )
    by_name = {m.name: m for m in out}
    assert set(by_name) == {"road", "sidewalk", "terrain"}
    assert by_name["road"].area_m2 == pytest.approx(60.0)  # x from -5 to 10: 15 x 4 m
    assert by_name["road"].points_world[:, 0].min() == pytest.approx(-5.0)
    assert by_name["sidewalk"].area_m2 == pytest.approx(20.0) and by_name["sidewalk"].points_world[
        :, 2
    ].max() == pytest.approx(0.15)
    assert by_name["terrain"].area_m2 == pytest.approx(100.0 * 100.0 - 60.0 - 20.0)


def test_views_without_labels_give_terrain_around_the_world_origin() -> None:
    (terrain,) = rig_surfaces([([], _pose(90.0, 1.0, 0.5))], 0.15, 30.0)
    assert terrain.name == "terrain" and terrain.area_m2 == pytest.approx(60.0 * 60.0)
    assert terrain.points_world[:, :2].min(axis=0) == pytest.approx([-30.0, -30.0])
