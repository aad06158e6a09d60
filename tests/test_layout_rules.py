"""One known answer per placement rule, on small hand-made scenes (layout.occlusion, layout.rows,
layout.street_lines, layout.placement).

The camera is level (pitch 0, yaw 0) 1.5 m above the ground at the origin, so a point's
optical depth is its world x, and pixel column u sees the ground at lateral offset
``y = -(u - cx) / fx * depth``: the expected numbers below follow from that.
"""

from __future__ import annotations

import numpy as np
import pytest
from layout_support import box_object

from usdworld.authoring.asset_library import library_dirs
from usdworld.authoring.asset_measures import asset_catalogue
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import load_class_table
from usdworld.io.types import DepthMap
from usdworld.layout.draft import DepthMethod, Draft, PlacementContext, depth_method_label, point_at_depth
from usdworld.layout.occlusion import drafts_by_ref, move_behind_occluders, place_behind_occluders
from usdworld.layout.placement import apply_ordering
from usdworld.layout.rows import off_its_row, onto_street_line
from usdworld.layout.street_lines import StreetLine, lone_rows_agreeing, sidewalk_lines
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.objects import ImageObject

FX, CX, CY = 800.0, 512.0, 256.0
K = np.array([[FX, 0.0, CX], [0.0, FX, CY], [0.0, 0.0, 1.0]])
LEVEL = PinholeCamera(1024, 512, K, 1.5)
FORWARD = RoadAxis(0.0, np.zeros(2), "camera_forward")
TABLE = load_class_table()
PARAMS = PlacementParams()


def _px(x: float, y: float, z: float = 0.0) -> tuple[float, float]:
    """Pixel of a world point seen by the level camera."""
    px, _ = LEVEL.project(np.array([[x, y, z]]))
    return float(px[0, 0]), float(px[0, 1])


def _ctx(objects: list[ImageObject], depth_map: DepthMap | None = None) -> PlacementContext:
    sizes = asset_catalogue((o.class_name for o in objects), library_dirs(None))
    ground_from_px = np.linalg.inv(LEVEL.px_from_ground())
    return PlacementContext(LEVEL, ground_from_px, FORWARD, sizes, TABLE, PARAMS, depth_map)


def _draft(obj: ImageObject, name: str, front: float, method: DepthMethod, back: float = 1.0) -> Draft:
    """A hand-made draft at front depth ``front`` on its contact pixel's ray."""
    size = np.array([4.0, 2.0, 1.5])
    upper = front if method is DepthMethod.CONTACT_PARTIAL else float("inf")
    return Draft(
        obj=obj,
        name=name,
        variant="default",
        ground=point_at_depth(LEVEL, *obj.contact_px, front + back),
        yaw=0.0,
        yaw_source="none",
        scale=1.0,
        stretch=np.ones(3),
        scale_measured=float("nan"),
        size=size,
        footprint=size[:2],
        depth_m=front + back,
        method=method,
        cues=(),
        confidence=0.5,
        front_depth_m=front,
        back_m=back,
        upper_m=upper,
    )


# --- occluder bounds: move behind occluders -------------------------------------------------

CAR = box_object("car", (400, 300, 600, 400), 1)
HIDDEN_TREE = box_object("tree", (450, 100, 550, 300), 2, hidden=True, by=1)


def test_a_contact_bound_short_of_its_occluder_moves_just_behind_it():
    car = _draft(CAR, "car_0001", 10.0, DepthMethod.CONTACT, back=2.0)
    tree = _draft(HIDDEN_TREE, "tree_0001", 6.0, DepthMethod.CONTACT_PARTIAL, back=0.5)
    _, moved = move_behind_occluders([car, tree], _ctx([CAR, HIDDEN_TREE]))
    # the car's centre stands at 12 m (front 10 m + 2 m), its back 2 m further, then the gap
    front = 14.0 + PARAMS.behind_gap_m
    assert moved.front_depth_m == pytest.approx(front)
    assert moved.depth_m == pytest.approx(front + 0.5)
    assert moved.method is DepthMethod.BEHIND and moved.behind == "car_0001"
    assert moved.depth_method == "behind_car_0001"
    assert moved.confidence == pytest.approx(PARAMS.confidence_behind)
    # level camera: the centre stands on the contact's ray at that depth
    u = float(HIDDEN_TREE.contact_px[0])
    np.testing.assert_allclose(moved.ground, [front + 0.5, -(u - CX) / FX * (front + 0.5)], atol=1e-9)


def test_a_contact_bound_beyond_its_occluder_stays_and_a_height_bound_is_replaced():
    ctx = _ctx([CAR, HIDDEN_TREE])
    car = _draft(CAR, "car_0001", 10.0, DepthMethod.CONTACT, back=2.0)
    far = _draft(HIDDEN_TREE, "tree_0001", 20.0, DepthMethod.CONTACT_PARTIAL)
    assert move_behind_occluders([car, far], ctx)[1] is far
    height = _draft(HIDDEN_TREE, "tree_0001", 20.0, DepthMethod.HEIGHT_PARTIAL)
    moved = move_behind_occluders([car, height], ctx)[1]
    assert moved.front_depth_m == pytest.approx(14.0 + PARAMS.behind_gap_m)


def test_an_occluder_whose_own_depth_is_only_an_upper_bound_does_not_bound():
    car = _draft(CAR, "car_0001", 10.0, DepthMethod.CONTACT_PARTIAL, back=2.0)
    tree = _draft(HIDDEN_TREE, "tree_0001", 6.0, DepthMethod.CONTACT_PARTIAL)
    assert move_behind_occluders([car, tree], _ctx([CAR, HIDDEN_TREE]))[1] is tree


def test_a_building_never_bounds_what_it_hides():
    building = box_object("building", (300, 50, 700, 400), 1)
    tree = box_object("tree", (450, 100, 550, 300), 2, hidden=True, by=1)
    ctx = _ctx([building, tree])
    drafts = [
        _draft(building, "building_0001", 10.0, DepthMethod.CONTACT),
        _draft(tree, "tree_0001", 6.0, DepthMethod.CONTACT_PARTIAL),
    ]
    assert move_behind_occluders(drafts, ctx)[1] is drafts[1]
    # ... nor places an object with no cue of its own
    placed, skipped = place_behind_occluders(drafts[:1], [(tree, "tree_0001")], ctx)
    assert len(placed) == 1 and skipped == ["tree_0001"]


def test_an_object_with_no_cue_goes_right_behind_its_occluder():
    person = box_object("person", (470, 150, 530, 300), 2, hidden=True, by=1)
    ctx = _ctx([CAR, person])
    car = _draft(CAR, "car_0001", 10.0, DepthMethod.CONTACT, back=2.0)
    (_, placed), skipped = place_behind_occluders([car], [(person, "person_0001")], ctx)
    assert skipped == []
    assert placed.front_depth_m == pytest.approx(14.0 + PARAMS.behind_gap_m)
    assert placed.depth_method == "behind_car_0001"
    assert placed.confidence == pytest.approx(PARAMS.confidence_behind)
    # a facade whose base the car hides could stand anywhere behind it: it is not put there
    facade = box_object("building", (100, 20, 900, 300), 3, hidden=True, by=1)
    placed, skipped = place_behind_occluders([car], [(facade, "building_0001")], _ctx([CAR, facade]))
    assert len(placed) == 1 and skipped == ["building_0001"]


# --- street rows ----------------------------------------------------------------------------


def test_an_object_whose_foot_is_hidden_stands_on_its_class_row():
    # A crown 4 m right of the camera: the row 4 m right meets its middle column's ray at
    # depth 4 fx / (u - cx).
    u_mid = _px(20.0, -4.0)[0]
    x0, x1 = round(u_mid) - 30, round(u_mid) + 30
    tree = box_object("tree", (x0, 150, x1, 260), 2, hidden=True)
    # its lowest pixel is off to one side (a hem of the crown), not below its trunk
    tree = ImageObject(**{**tree.__dict__, "contact_px": np.array([x1 - 5.5, 259.5])})
    ctx = _ctx([tree])
    row = StreetLine("tree", -1, -4.0, 3, 0.1)
    moved = onto_street_line(tree, "tree_0001", float("inf"), {}, [row], ctx)
    u = 0.5 * (x0 + x1)  # a crown's trunk stands below its middle
    assert moved is not None and moved.method is DepthMethod.STREET_LINE
    assert moved.front_depth_m == pytest.approx(4.0 * FX / (u - CX))
    cue = {c.name: c for c in moved.cues}["street_line"]
    assert cue.depth_m == pytest.approx(moved.depth_m) and "row of 3 trees" in cue.note
    # a row beyond its own upper bound (plus the slack) disagrees with it
    upper = (4.0 * FX / (u - CX) - PARAMS.line_bound_slack_m - 0.5) / (1.0 + PARAMS.line_bound_slack)
    assert onto_street_line(tree, "tree_0001", upper, {}, [row], ctx) is None


def test_a_crown_too_small_for_a_tree_at_its_rows_depth_does_not_stand_there():
    # Crowns centred on column 912: the row 4 m right meets that ray 8 m ahead, where a
    # pixel is 1 cm. The smallest tree (0.3 of the 4 m x 7 m asset) is 1.2 m wide and 2.1 m
    # tall: a crown seen 12 px (12 cm) wide and 10 px tall is a sliver of something farther,
    # one seen 160 px (1.6 m, scale 0.4) wide and 20 px tall is a small tree there.
    row = StreetLine("tree", -1, -4.0, 3, 0.1)
    assert 4.0 * FX / (912.0 - CX) == pytest.approx(8.0)
    small = box_object("tree", (906, 150, 918, 160), 2, hidden=True)
    assert onto_street_line(small, "tree_0001", float("inf"), {}, [row], _ctx([small])) is None
    tree = box_object("tree", (832, 150, 992, 170), 2, hidden=True)
    moved = onto_street_line(tree, "tree_0001", float("inf"), {}, [row], _ctx([tree]))
    assert moved is not None and moved.front_depth_m == pytest.approx(8.0)


def test_facades_stand_at_the_sidewalks_back_edge():
    # Sidewalk 2 m to 6 m right of the axis, evenly sampled: its 5th and 95th percentiles
    # are 2.2 m (the kerb) and 5.8 m (the back edge).
    xs, ys = np.meshgrid(np.linspace(10.0, 30.0, 20), np.linspace(-2.0, -6.0, 101))
    walk = np.column_stack([xs.ravel(), ys.ravel()])
    rows = {ln.class_name: ln for ln in sidewalk_lines(walk, FORWARD, TABLE, PARAMS)}
    assert rows["building"].offset_m == pytest.approx(-5.8)
    assert rows["tree"].offset_m == pytest.approx(-(2.2 + PARAMS.tree_kerb_setback_m))
    assert rows["pole"].offset_m == pytest.approx(-(2.2 + PARAMS.post_kerb_setback_m))
    # a facade whose base is hidden stands on that row below its contact pixel
    u, v = _px(25.0, -5.8)
    facade = box_object("building", (round(u) - 40, 60, round(u) + 40, round(v)), 3, hidden=True)
    moved = onto_street_line(facade, "building_0001", float("inf"), {}, [rows["building"]], _ctx([facade]))
    assert moved is not None
    assert moved.front_depth_m == pytest.approx(5.8 * FX / (float(facade.contact_px[0]) - CX))


def test_a_contact_beyond_its_row_by_more_than_the_outlier_distance_is_off_its_row():
    assert PARAMS.row_outlier_m == 2.0 * PARAMS.row_max_spread_m
    row = StreetLine("tree", -1, -4.0, 3, 0.1)
    ctx = _ctx([])
    for beyond, off in ((PARAMS.row_outlier_m + 0.2, True), (PARAMS.row_outlier_m - 0.2, False)):
        u, v = _px(20.0, -4.0 - beyond)
        tree = box_object("tree", (round(u) - 20, 150, round(u) + 20, 260), 2)
        tree = ImageObject(**{**tree.__dict__, "contact_px": np.array([u, v])})
        assert off_its_row(_draft(tree, "tree_0001", 20.0, DepthMethod.CONTACT), [row], ctx) is off
        # nearer than the row is never off it, nor is a car
        near = ImageObject(**{**tree.__dict__, "contact_px": np.array(_px(20.0, -4.0 + beyond))})
        assert not off_its_row(_draft(near, "tree_0001", 20.0, DepthMethod.CONTACT), [row], ctx)
    car = ImageObject(**{**tree.__dict__, "class_name": "car"})
    car_row = StreetLine("car", -1, -4.0, 3, 0.1)
    assert not off_its_row(_draft(car, "car_0001", 20.0, DepthMethod.CONTACT), [car_row], ctx)


def test_a_lone_row_off_the_sidewalks_gives_way_unless_it_is_a_facades():
    walk = [StreetLine(c, -1, -5.0, 0, 0.5, "sidewalk") for c in ("tree", "building")]
    tol = PARAMS.lone_row_tolerance_m
    lone_far = StreetLine("tree", -1, -5.0 - tol - 0.1, 1, 0.0)
    lone_near = StreetLine("tree", -1, -5.0 - tol + 0.1, 1, 0.0)
    two_far = StreetLine("tree", -1, -5.0 - tol - 0.1, 2, 0.0)
    facade = StreetLine("building", -1, -5.0 - tol - 0.1, 1, 0.0)
    assert lone_rows_agreeing([lone_far], walk, TABLE, PARAMS) == []
    for kept in (lone_near, two_far, facade):
        assert lone_rows_agreeing([kept], walk, TABLE, PARAMS) == [kept]


# --- depth methods and the ordering rules ----------------------------------------------------


def test_depth_method_strings_are_those_written_to_usd():
    assert depth_method_label(DepthMethod.CONTACT, None, "") == "contact"
    assert depth_method_label(DepthMethod.BEHIND, "car_0002", "") == "behind_car_0002"
    assert depth_method_label(DepthMethod.CNN, None, "rule1+rule2") == "cnn+rule1+rule2"
    assert DepthMethod.TOP_ROW.is_partial and DepthMethod.TOP_ROW.is_ordered
    assert not DepthMethod.CONTACT.is_ordered and DepthMethod.FUSED.is_seen_contact


def test_ordering_rules_change_only_the_depths_the_map_decided():
    # Three contacts on the same row: rule 1 gives the map's object the nearest depth; the
    # farther object placed by its seen contact keeps its own.
    a = box_object("car", (100, 300, 200, 400), 1)
    b = box_object("car", (400, 300, 500, 400), 2)
    c = box_object("car", (700, 300, 800, 400), 3)
    dm = DepthMap(np.ones((512, 1024), np.float32), np.ones((512, 1024), bool), "test")
    ctx = _ctx([a, b, c], depth_map=dm)
    near = _draft(a, "car_0001", 9.0, DepthMethod.CONTACT)
    cnn = _draft(b, "car_0002", 12.0, DepthMethod.CNN)
    far = _draft(c, "car_0003", 13.0, DepthMethod.FUSED)
    kept_near, moved, kept_far = apply_ordering([near, cnn, far], ctx)
    assert kept_near is near and kept_far is far
    assert moved.depth_m == pytest.approx(10.0) and moved.depth_method == "cnn+rule1"
    np.testing.assert_allclose(moved.ground, point_at_depth(LEVEL, *b.contact_px, 10.0))
    # without a map the rules do not apply
    assert all(x is y for x, y in zip(apply_ordering([near, cnn], _ctx([a, b])), [near, cnn]))


def test_drafts_by_ref_skips_objects_without_a_ref():
    anon = box_object("car", (0, 300, 50, 400), -1)
    d = _draft(anon, "car_0001", 10.0, DepthMethod.CONTACT)
    assert drafts_by_ref([d]) == {}
