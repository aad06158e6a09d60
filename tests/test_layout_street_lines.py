"""Rows of objects along the street (layout.street_lines) and their use in placement."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from layout_support import box_object

from usdworld.authoring.asset_library import library_dirs
from usdworld.authoring.asset_measures import asset_catalogue
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import load_class_table
from usdworld.layout.placement import place_objects
from usdworld.layout.rows import line_pixel
from usdworld.layout.street_lines import (
    StreetLine,
    depth_on_line,
    fit_street_lines,
    lateral_offsets,
    line_for,
    parked_car_lines,
    sidewalk_lines,
)
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.objects import ImageObject

K = np.array([[800.0, 0.0, 512.0], [0.0, 800.0, 256.0], [0.0, 0.0, 1.0]])
LEVEL = PinholeCamera(1024, 512, K, 1.5)
FORWARD = RoadAxis(0.0, np.zeros(2), "camera_forward")
TABLE = load_class_table()
PARAMS = PlacementParams()


def test_lateral_offsets_are_signed_distances_from_a_turned_axis():
    axis = RoadAxis(math.pi / 4, np.array([1.0, 1.0]), "vanishing_point")
    pts = np.array([[1.0, 1.0], [5.0, 5.0], [1.0, 3.0], [3.0, 1.0]])
    np.testing.assert_allclose(
        lateral_offsets(pts, axis), [0.0, 0.0, math.sqrt(2), -math.sqrt(2)], atol=1e-12
    )


def test_one_line_per_class_and_side_at_the_median_offset():
    names = ["tree", "tree", "tree", "building", "building", "car"]
    pts = np.array([[10, -4.0], [20, -4.2], [30, 5.0], [15, 12.0], [40, 12.4], [12, -1.0]])
    lines = fit_street_lines(names, pts, FORWARD, TABLE, PARAMS)
    got = {(ln.class_name, ln.side): (ln.offset_m, ln.support) for ln in lines}
    assert got == {
        ("building", 1): (pytest.approx(12.2), 2),
        ("tree", -1): (pytest.approx(-4.1), 2),
        ("tree", 1): (pytest.approx(5.0), 1),
    }


def test_objects_scattered_across_a_side_make_no_row():
    pts = np.array([[10, -2.0], [20, -5.0], [30, -9.0]])
    assert 2 * PARAMS.row_max_spread_m < 3.0
    assert fit_street_lines(["tree"] * 3, pts, FORWARD, TABLE, PARAMS) == []


def test_a_ray_meets_the_row_at_the_depth_of_the_point_it_came_from():
    point = np.array([[25.0, -4.0, 0.0]])
    px, _ = LEVEL.project(point)
    line = StreetLine("tree", -1, -4.0, 3, 0.1)
    assert depth_on_line(LEVEL, tuple(px[0]), line, FORWARD) == pytest.approx(25.0, rel=1e-9)


def test_a_ray_away_from_the_row_never_meets_it():
    left = StreetLine("tree", 1, 5.0, 2, 0.1)
    right_pixel = (900.0, 300.0)
    assert depth_on_line(LEVEL, right_pixel, left, FORWARD) is None
    assert line_for([left], "tree", LEVEL, right_pixel, FORWARD) is None
    assert line_for([left], "pole", LEVEL, (100.0, 300.0), FORWARD) is None


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(3.0, 120.0),
    offset=st.floats(2.0, 20.0).flatmap(lambda o: st.sampled_from([o, -o])),
    z=st.floats(0.0, 8.0),
    pitch_deg=st.floats(-3.0, 5.0),
    yaw_deg=st.floats(-10.0, 10.0),
    axis_deg=st.floats(-10.0, 10.0),
)
def test_depth_on_line_recovers_any_point_above_the_row(x, offset, z, pitch_deg, yaw_deg, axis_deg):
    cam = PinholeCamera(1024, 512, K, 1.4, math.radians(pitch_deg), 0.0, math.radians(yaw_deg))
    a = math.radians(axis_deg)
    axis = RoadAxis(a, np.array([0.5, -0.3]), "vanishing_point")
    along, across = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    ground = axis.center_ground + x * along + offset * across
    p = np.array([[ground[0], ground[1], z]])
    depth_true = float(cam.cam_from_world_points(p)[0, 2])
    if depth_true < 1.0:
        return
    px, _ = cam.project(p)
    line = StreetLine("building", 1 if offset > 0 else -1, offset, 2, 0.2)
    assert depth_on_line(cam, tuple(px[0]), line, axis) == pytest.approx(depth_true, rel=1e-6)


def _obj(
    box: tuple[int, int, int, int], ref: int, hidden: bool = False, by: int = -1, class_name: str = "tree"
) -> ImageObject:
    """A tree (or a car) whose mask fills its box; ``hidden``: its bottom is hidden by ``by``."""
    car = class_name == "car"
    return box_object(
        class_name,
        box,
        ref,
        hidden,
        by,
        source_label=class_name if car else "vegetation",
        instance_id=26000 + ref if car else -1,
    )


def _box_at(x: float, y: float, half_w: float, height: float) -> tuple[int, int, int, int]:
    """Image box of an upright object of that half width and height standing at (x, y)."""
    corners = np.array([[x, y - half_w, 0.0], [x, y + half_w, 0.0], [x, y, height]])
    px, _ = LEVEL.project(corners)
    u0, u1, v_top, v_base = px[:, 0].min(), px[:, 0].max(), px[2, 1], px[0, 1]
    return round(float(u0)), round(float(v_top)), round(float(u1)), round(float(v_base))


def _place(objects: list[ImageObject], sidewalk: np.ndarray | None = None) -> tuple[dict, list[str]]:
    """Placements by object ref, and the names not placed, seen by the level camera."""
    sizes = asset_catalogue((o.class_name for o in objects), library_dirs(None))
    ground_from_px = np.linalg.inv(LEVEL.px_from_ground())
    placements, skipped = place_objects(
        objects, LEVEL, ground_from_px, FORWARD, sizes, TABLE, PARAMS, sidewalk_ground=sidewalk
    )
    return {p.obj.ref: p for p in placements}, [s.name for s in skipped]


def test_a_tree_behind_a_parked_car_stands_in_the_row_of_the_trees_seen():
    # Trees at 4 m right of the camera, every 10 m; the one at 20 m has its trunk behind
    # a car parked at 17 m, so only its crown shows, down to the car's roof.
    seen = [_obj(_box_at(x, -4.0, 1.5, 6.0), ref) for ref, x in ((1, 10.0), (2, 30.0), (3, 40.0))]
    car_box = _box_at(17.0, -3.0, 2.0, 1.5)
    car = _obj(car_box, 9, class_name="car")
    x0, y0, x1, _ = _box_at(20.0, -4.0, 1.5, 6.0)
    hidden = _obj((x0, y0, x1, car_box[1]), 4, hidden=True, by=9)
    placed, skipped = _place([*seen, car, hidden])
    assert not skipped and set(placed) == {1, 2, 3, 4, 9}
    tree = placed[4]
    assert tree.depth_method == "street_line"
    assert abs(tree.position_world[1] - (-4.0)) < 0.3
    assert abs(tree.position_world[0] - 20.0) < 1.0
    cue = {c.name: c for c in tree.cues}["street_line"]
    assert "row of 3 trees" in cue.note and "right" in cue.note


def test_a_row_that_puts_the_object_in_front_of_its_occluder_is_not_used():
    # Trees stand 4 m right; a crown 8 m right at 40 m, hidden below by a car at 30 m,
    # is not in that row: its ray meets the row at 20 m, in front of the car hiding it.
    seen = [_obj(_box_at(x, -4.0, 1.5, 6.0), ref) for ref, x in ((1, 10.0), (2, 15.0))]
    car_box = _box_at(30.0, -6.5, 2.0, 1.5)
    car = _obj(car_box, 9, class_name="car")
    x0, y0, x1, _ = _box_at(40.0, -8.0, 1.5, 6.0)
    hidden = _obj((x0, y0, x1, car_box[1]), 4, hidden=True, by=9)
    placed, _ = _place([*seen, car, hidden])
    assert placed[4].depth_method != "street_line"
    assert placed[4].depth_m > placed[9].depth_m


def _sidewalk(kerb: float, back: float, side: int) -> np.ndarray:
    """Ground points covering a sidewalk from ``kerb`` to ``back`` metres off the axis."""
    x, y = np.meshgrid(np.linspace(5.0, 60.0, 40), np.linspace(kerb, back, 21))
    return np.column_stack([x.ravel(), side * y.ravel()])


def test_the_sidewalk_gives_rows_for_the_classes_no_object_measured():
    right = _sidewalk(4.0, 8.0, -1)
    measured = [StreetLine("tree", -1, -5.5, 2, 0.1)]
    lines = {(ln.class_name, ln.side): ln for ln in sidewalk_lines(right, FORWARD, TABLE, PARAMS, measured)}
    assert set(lines) == {("building", -1), ("pole", -1), ("traffic_sign", -1)}  # the trees' own row stands
    assert lines["building", -1].offset_m == pytest.approx(-7.8)  # the 95th percentile of 4..8 m
    assert lines["pole", -1].offset_m == pytest.approx(-(4.2 + PARAMS.post_kerb_setback_m))
    assert all(ln.support == 0 and ln.source == "sidewalk" for ln in lines.values())
    assert lines["pole", -1].spread_m == pytest.approx(0.25 * 3.6)
    assert sidewalk_lines(right[:10], FORWARD, TABLE, PARAMS) == []  # too few points to measure
    assert sidewalk_lines(None, FORWARD, TABLE, PARAMS) == []


def test_a_tree_with_no_row_of_its_own_stands_behind_the_kerb_at_its_measured_height():
    # No tree shows its trunk; the left sidewalk runs 6-9 m left of the camera, and a
    # crown whose trunk a car hides stands 1 m behind the kerb (7 m left) at 25 m.
    car_box = _box_at(20.0, 5.0, 2.0, 1.5)
    car = _obj(car_box, 9, class_name="car")
    x0, y0, x1, _ = _box_at(25.0, 7.0, 1.5, 6.0)
    hidden = _obj((x0, y0, x1, car_box[1]), 4, hidden=True, by=9)
    placed, _ = _place([car, hidden], sidewalk=_sidewalk(6.0, 9.0, 1))
    tree = placed[4]
    assert tree.depth_method == "street_line"
    assert abs(tree.position_world[1] - 7.0) < 0.3 and abs(tree.position_world[0] - 25.0) < 1.0
    assert "row from the sidewalk" in {c.name: c for c in tree.cues}["street_line"].note
    assert tree.size_m[2] == pytest.approx(6.0, rel=0.05)  # from its top row at that depth


def test_parked_cars_give_the_kerb_where_no_sidewalk_shows():
    # Right of the road: a car parked 5 m off the axis (1.8 m wide) and one driving at 2 m;
    # left: a car turned across the road (leaving a driveway), which parks along nothing,
    # and one driving ahead in the camera's lane.
    ground = np.array([[12.0, -5.0], [20.0, -2.0], [15.0, 4.0], [9.0, 0.5]])
    headings = np.array([math.pi, 0.0, math.pi / 2, 0.0])
    measured = [StreetLine("pole", -1, -6.5, 1, 0.1)]
    lines = {
        (ln.class_name, ln.side): ln
        for ln in parked_car_lines(
            ground, headings, np.full(4, 1.8), FORWARD, np.zeros(2), TABLE, PARAMS, measured
        )
    }
    assert set(lines) == {("tree", -1), ("traffic_sign", -1)}  # the poles' own row stands; no building line
    kerb = 5.0 + 0.9 + 0.3
    assert lines["tree", -1].offset_m == pytest.approx(-(kerb + PARAMS.tree_kerb_setback_m))
    assert all(ln.source == "parked_cars" and ln.support == 0 for ln in lines.values())
    assert (
        parked_car_lines(np.zeros((0, 2)), np.zeros(0), np.zeros(0), FORWARD, np.zeros(2), TABLE, PARAMS)
        == []
    )


def test_a_tree_behind_parked_cars_with_no_sidewalk_in_view_stands_behind_their_kerb():
    # A car parked 5 m left at 20 m hides a crown's trunk; no sidewalk or tree row is seen.
    car_box = _box_at(20.0, 5.0, 2.0, 1.5)
    car = _obj(car_box, 9, class_name="car")
    x0, y0, x1, _ = _box_at(28.0, 7.2, 1.5, 6.0)
    hidden = _obj((x0, y0, x1, car_box[1]), 4, hidden=True, by=9)
    placed, _ = _place([car, hidden])
    tree, parked = placed[4], placed[9]
    assert tree.depth_method == "street_line"
    assert "the parked cars line" in {c.name: c for c in tree.cues}["street_line"].note
    # the tree row: the car's kerb side (its centre + half its width) + 0.3 m + 1 m
    expected = parked.position_world[1] + parked.size_m[1] / 2 + 0.3 + PARAMS.tree_kerb_setback_m
    assert tree.position_world[1] == pytest.approx(expected, abs=0.1)


def test_a_tree_whose_contact_lies_far_beyond_its_row_stands_in_the_row():
    # Trees 4 m right at 10, 30 and 50 m show their trunks. A fourth "stands" 8 m right at
    # 40 m: what is seen below it is ground behind a crown's hem, not a trunk; its ray
    # meets the row at 20 m, so that is where it stands (its contact bounds it from above).
    seen = [_obj(_box_at(x, -4.0, 1.5, 6.0), ref) for ref, x in ((1, 10.0), (2, 30.0), (3, 50.0))]
    hem = _obj(_box_at(40.0, -8.0, 1.5, 6.0), 4)
    placed, _ = _place([*seen, hem])
    tree = placed[4]
    assert tree.depth_method == "street_line"
    assert abs(tree.position_world[1] + 4.0) < 0.3 and abs(tree.position_world[0] - 20.0) < 1.0
    # a tree 1 m off the row, within twice a row's spread, is a tree standing there
    near = _obj(_box_at(40.0, -5.0, 1.5, 6.0), 5)
    placed, _ = _place([*seen, near])
    assert placed[5].depth_method == "contact" and abs(placed[5].position_world[1] + 5.0) < 0.5
    # 2 m off, it is ground seen past a crown
    off = _obj(_box_at(40.0, -6.0, 1.5, 6.0), 6)
    placed, _ = _place([*seen, off])
    assert placed[6].depth_method == "street_line"


def test_a_lone_tree_off_the_sidewalk_row_does_not_make_a_row_of_its_own():
    # The only tree "stands" 8.5 m right at 40 m, where ground shows past its crown's hem;
    # the right sidewalk runs 4-8 m off the axis, so trees stand 1 m behind its kerb
    # (4.2 m, its 5th percentile). Its ray meets that row at 40 * 5.2 / 8.5 m.
    hem = _obj(_box_at(40.0, -8.5, 1.5, 6.0), 1)
    placed, _ = _place([hem], sidewalk=_sidewalk(4.0, 8.0, -1))
    tree = placed[1]
    assert tree.depth_method == "street_line"
    assert "row from the sidewalk" in {c.name: c for c in tree.cues}["street_line"].note
    assert abs(tree.position_world[1] + 5.2) < 0.3 and abs(tree.position_world[0] - 40.0 * 5.2 / 8.5) < 1.0
    # one 1 m off that row is believed: its own foot makes the row
    near = _obj(_box_at(30.0, -6.2, 1.5, 6.0), 2)
    placed, _ = _place([near], sidewalk=_sidewalk(4.0, 8.0, -1))
    assert placed[2].depth_method == "contact" and abs(placed[2].position_world[1] + 6.2) < 0.5


def test_a_hidden_post_is_found_on_its_row_below_its_post_a_crown_below_its_middle():
    tree = _obj((100, 50, 160, 120), 1, hidden=True)
    tree = ImageObject(**{**tree.__dict__, "contact_px": np.array([150.5, 119.5])})
    assert line_pixel(tree, 1000, TABLE).tolist() == [130.0, 119.5]  # a trunk stands below its crown
    lamp = ImageObject(**{**tree.__dict__, "class_name": "pole", "source_label": "pole"})
    assert line_pixel(lamp, 1000, TABLE).tolist() == [150.5, 119.5]  # a post where its lowest columns are


def _wall(x0: float, x1: float, y: float, height: float, ref: int, hidden_by: int = -1) -> ImageObject:
    """A facade piece from ``x0`` to ``x1`` metres ahead along the building line ``y``;
    its base hidden (by ``hidden_by``) or seen, its contact below its middle column."""
    near, far = (LEVEL.project(np.array([[x, y, 0.0], [x, y, height]]))[0] for x in (x0, x1))
    u0, u1 = sorted((float(near[0, 0]), float(far[0, 0])))
    box = (round(u0), round(float(near[1, 1])), round(u1), round(float(near[0, 1])))
    xm = 0.5 * (x0 + x1)
    base = LEVEL.project(np.array([[xm, y, 0.0]]))[0][0]
    hidden = hidden_by >= 0
    return ImageObject(
        class_name="building",
        source_label="building",
        instance_id=-1,
        box_px=np.array(box, dtype=np.int64),
        mask=np.ones((box[3] - box[1], box[2] - box[0]), bool),
        contact_px=np.array([float(base[0]), float(base[1]) - (20.0 if hidden else 0.0)]),
        bottom_truncated=False,
        bottom_occluded=hidden,
        top_truncated=False,
        occluded_by=hidden_by,
        ref=ref,
    )


def test_a_facade_behind_a_tree_placed_too_far_still_stands_in_the_facades_row():
    # Facades 10 m right, their bases seen from 20 to 50 m; the base of the one from 60 to
    # 76 m is hidden by a street tree that was placed (from ground seen under its crown)
    # at 100 m: the facades' row, not that tree, decides where the facade stands.
    walls = [_wall(x, x + 12.0, -10.0, 15.0, ref) for ref, x in ((1, 20.0), (2, 32.0), (3, 44.0))]
    tree = _obj(_box_at(100.0, -4.0, 1.5, 6.0), 9)
    hidden = _wall(60.0, 76.0, -10.0, 15.0, 4, hidden_by=9)
    placed, _ = _place([*walls, tree, hidden])
    assert placed[9].position_world[0] > 90.0  # the tree, as wrong as it was
    wall = placed[4]
    assert wall.depth_method == "street_line"
    assert 60.0 < wall.position_world[0] < 76.0


def test_an_occluder_known_only_from_above_does_not_bound_what_it_hides():
    # The facades' row as before; the base of the one from 60 to 76 m is hidden by a
    # sliver of car (6 px tall, its own bottom hidden too): its depth, hundreds of metres
    # from so few pixels, is only a bound from above and says nothing of how near the
    # facade is (the car itself is too far to place).
    walls = [_wall(x, x + 12.0, -10.0, 15.0, ref) for ref, x in ((1, 20.0), (2, 32.0), (3, 44.0))]
    car = _obj((600, 252, 640, 258), 9, hidden=True, class_name="car")
    hidden = _wall(60.0, 76.0, -10.0, 15.0, 4, hidden_by=9)
    placed, _ = _place([*walls, car, hidden])
    wall = placed[4]
    assert wall.depth_method == "street_line"
    assert 60.0 < wall.position_world[0] < 76.0
