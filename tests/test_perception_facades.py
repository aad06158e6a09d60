"""Facade runs cut into buildings (perception.facades) and placed facing the road (layout)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.authoring.asset_library import asset_path, library_dirs
from usdworld.authoring.asset_measures import asset_catalogue
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import load_class_table
from usdworld.io.label_table import label_lookups
from usdworld.io.types import Segmentation
from usdworld.layout.cues import FACADE_HEIGHT_NOTE
from usdworld.layout.facades import out_of_view_frontage
from usdworld.layout.placement import place_objects
from usdworld.layout.yaw import RoadAxis, choose_yaw
from usdworld.parameters import PerceptionParams, PlacementParams
from usdworld.perception.facades import StreetView, base_frontage_m, facade_ranges
from usdworld.perception.objects import ImageObject, objects_from_segmentation

CURB_HEIGHT_M = PlacementParams().curb_height_m
TABLE = load_class_table()

W, H = 1024, 512
K = np.array([[800.0, 0.0, 512.0], [0.0, 800.0, 256.0], [0.0, 0.0, 1.0]])
CAM = PinholeCamera(W, H, K, 1.5)
VIEW = StreetView(horizon_v=256.0, focal_px=800.0, principal_u=512.0, camera_height_m=1.5)
#: The camera as the pipeline describes it: its height above the sidewalk the facades
#: stand on, and the street's vanishing point (straight ahead).
VIEW_VP = StreetView(256.0, 800.0, 512.0, 1.5 - CURB_HEIGHT_M, vanishing_u=512.0)
LEFT_Y = 8.0  # the left building line, metres left of the camera
FRONTAGE_M = PerceptionParams().frontage_m
ROOFLINE_FRONTAGE_M = PerceptionParams().roofline_frontage_m


def _objects(seg: Segmentation, view: StreetView | None = None) -> list[ImageObject]:
    """:func:`objects_from_segmentation` with the shipped class and label tables."""
    return objects_from_segmentation(seg, view, load_class_table(), label_lookups())


def _px(x: float, y: float, z: float) -> tuple[float, float]:
    px, _ = CAM.project(np.array([[x, y, z]]))
    return float(px[0, 0]), float(px[0, 1])


def _facade_labels(walls: list[tuple[float, float, float]]) -> np.ndarray:
    """Cityscapes label ids: sidewalk below the horizon, and building walls along the left
    building line, each ``(x_near, x_far, height_m)`` metres ahead of the camera."""
    lk = label_lookups()
    labels = np.full((H, W), lk.id_of("sky"), dtype=np.uint8)
    labels[257:] = lk.id_of("sidewalk")
    for x_near, x_far, height in walls:
        u_near, u_far = _px(x_near, LEFT_Y, CURB_HEIGHT_M)[0], _px(x_far, LEFT_Y, CURB_HEIGHT_M)[0]
        for u in range(max(0, int(np.ceil(u_near))), int(np.floor(u_far)) + 1):
            # the wall's point seen in this column: where its ray meets the building line
            x = LEFT_Y * 800.0 / (512.0 - (u + 0.5))
            _, v_base = _px(x, LEFT_Y, CURB_HEIGHT_M)  # on the raised sidewalk
            _, v_top = _px(x, LEFT_Y, CURB_HEIGHT_M + height)
            labels[max(0, round(v_top)) : round(v_base), u] = lk.id_of("building")
    return labels


def _ranges(
    labels: np.ndarray, view: StreetView = VIEW, on_ground: int | None = None
) -> list[tuple[int, int]]:
    """Column ranges of the building pieces; ``on_ground``: only that many of the nearest
    (leftmost) columns stand on the ground, the rest hidden (by parked cars)."""
    mask = labels == label_lookups().id_of("building")
    cols = np.nonzero(mask.any(axis=0))[0]
    rows = np.nonzero(mask.any(axis=1))[0]
    x0, y0 = int(cols[0]), int(rows[0])
    crop = mask[y0 : rows[-1] + 1, x0 : cols[-1] + 1]
    below = np.ones(crop.shape[1], dtype=bool)
    if on_ground is not None:
        below[on_ground:] = False
    out = facade_ranges(crop, x0, y0, below, view, min_area_px=50, image_width=W)
    assert out is not None
    return [(a + x0, b + x0) for a, b in out]


def _ahead_of_column(u: float) -> float:
    """Metres ahead of the camera where column u meets the left building line."""
    return LEFT_Y * 800.0 / (512.0 - u)


def test_base_frontage_sums_to_the_wall_length():
    xs = np.linspace(12.0, 48.0, 400)
    px = np.array([_px(x, LEFT_Y, 0.0) for x in xs])
    steps = base_frontage_m(px[:, 0], px[:, 1], VIEW)
    assert steps[:-1].sum() == pytest.approx(36.0, rel=1e-6)


def test_a_long_wall_of_one_height_is_cut_into_equal_frontages():
    ranges = _ranges(_facade_labels([(20.0, 20.0 + 3 * ROOFLINE_FRONTAGE_M, 7.0)]))
    assert len(ranges) == 3
    # each piece is about ROOFLINE_FRONTAGE_M long on the ground, though the far one is far
    # narrower in pixels
    lengths = [_ahead_of_column(b) - _ahead_of_column(a) for a, b in ranges]
    assert lengths == pytest.approx([ROOFLINE_FRONTAGE_M] * 3, rel=0.08)
    widths = [b - a for a, b in ranges]
    assert widths[0] > 3 * widths[2]


def test_a_wall_cut_by_the_top_is_cut_into_town_houses():
    # 60 m tall: its roofline is above the image, so nothing shows where one house ends
    ranges = _ranges(_facade_labels([(20.0, 20.0 + 3 * FRONTAGE_M, 60.0)]), VIEW_VP)
    lengths = [_ahead_of_column(b) - _ahead_of_column(a) for a, b in ranges]
    assert lengths == pytest.approx([FRONTAGE_M] * 3, rel=0.08)


def test_a_wall_running_out_of_the_image_is_cut_from_its_seen_end():
    # The left image edge meets the building line 12.5 m ahead; the wall runs from 5 m
    # (out of view) to 45 m: its seen end at 45 m is a building's end.
    edge = _ahead_of_column(0.0)
    ranges = _ranges(_facade_labels([(5.0, 45.0, 60.0)]), VIEW_VP)
    ends = [_ahead_of_column(b) for _, b in ranges]
    assert ends[-1] == pytest.approx(45.0, abs=0.5)
    assert ends[-2] == pytest.approx(45.0 - FRONTAGE_M, abs=0.6)
    assert ends[-3] == pytest.approx(45.0 - 2 * FRONTAGE_M, abs=0.6)
    # what is left at the edge is the seen part of one more building
    assert ranges[0][0] == 0 and ends[0] - edge == pytest.approx(45.0 - 2 * FRONTAGE_M - edge, abs=0.6)


def test_with_the_vanishing_point_one_column_on_the_ground_measures_the_wall():
    # A wall from 20 to 68 m whose base shows in its nearest 3 columns only: through the
    # vanishing point, its base line is known all the way down the street.
    labels = _facade_labels([(20.0, 20.0 + 3 * ROOFLINE_FRONTAGE_M, 7.0)])
    ranges = _ranges(labels, VIEW_VP, on_ground=3)
    lengths = [_ahead_of_column(b) - _ahead_of_column(a) for a, b in ranges]
    assert lengths == pytest.approx([ROOFLINE_FRONTAGE_M] * 3, rel=0.08)
    # a single column is enough with it, and not enough without it
    assert len(_ranges(labels, VIEW_VP, on_ground=1)) == 3
    mask = labels == label_lookups().id_of("building")
    cols = np.nonzero(mask.any(axis=0))[0]
    rows = np.nonzero(mask.any(axis=1))[0]
    crop = mask[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
    below = np.zeros(crop.shape[1], dtype=bool)
    below[0] = True
    assert facade_ranges(crop, int(cols[0]), int(rows[0]), below, VIEW, 50) is None


def test_a_roofline_step_starts_a_new_building():
    # two town houses of 8 m frontage, 7 m and 11 m tall: cut where they meet, not in the middle
    ranges = _ranges(_facade_labels([(30.0, 38.0, 7.0), (38.0, 46.0, 11.0)]))
    assert len(ranges) == 2
    assert _ahead_of_column(ranges[0][1]) == pytest.approx(38.0, abs=0.5)


def test_no_ground_below_the_facade_falls_back():
    mask = np.ones((40, 30), dtype=bool)
    assert facade_ranges(mask, 100, 100, np.zeros(30, dtype=bool), VIEW, 50) is None


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.tuples(st.integers(2, 30), st.integers(2, 40), st.integers(0, 10)), min_size=1, max_size=6),
    st.integers(0, 600),
)
def test_ranges_cover_every_column_once(columns: list[tuple[int, int, int]], x0: int):
    """Whatever the facade's shape, its pieces tile the crop's columns left to right."""
    heights = [h for w, h, _ in columns for _ in range(w)]
    tops = [t for w, _, t in columns for _ in range(w)]
    mask = np.zeros((60, len(heights)), dtype=bool)
    for c, (h, t) in enumerate(zip(heights, tops)):
        mask[t : t + h, c] = True
    ranges = facade_ranges(mask, x0, 300, np.ones(mask.shape[1], dtype=bool), VIEW, 20)
    assert ranges is not None
    assert ranges[0][0] == 0 and ranges[-1][1] == mask.shape[1]
    assert all(a < b for a, b in ranges)
    assert all(prev[1] == nxt[0] for prev, nxt in itertools.pairwise(ranges))


def test_buildings_face_the_road_from_either_side():
    axis = RoadAxis(0.0, np.zeros(2), "vanishing_point")
    left, _ = choose_yaw("face_road", np.array([20.0, 8.0]), axis)
    right, _ = choose_yaw("face_road", np.array([20.0, -8.0]), axis)
    assert np.degrees(left) == pytest.approx(-90.0)  # forward axis towards -y, the road
    assert np.degrees(right) == pytest.approx(90.0)


def test_a_facade_run_becomes_buildings_behind_their_fronts():
    labels = _facade_labels([(14.0, 14.0 + 3 * FRONTAGE_M, 14.0)])
    seg = Segmentation(labels, None, ())
    buildings = [o for o in _objects(seg, VIEW) if o.class_name == "building"]
    unsplit = [o for o in _objects(seg) if o.class_name == "building"]
    assert len(buildings) == 3 and len(unsplit) < 3
    sizes = asset_catalogue((o.class_name for o in buildings), library_dirs(None))
    ground_from_px = np.linalg.inv(CAM.px_from_ground())
    axis = RoadAxis(0.0, np.zeros(2), "vanishing_point")
    placements, _ = place_objects(
        buildings, CAM, ground_from_px, axis, sizes, load_class_table(), PlacementParams()
    )
    assert len(placements) == 3
    depth = TABLE["building"].facade_depth_m
    for p in sorted(placements, key=lambda p: p.position_world[0]):
        assert np.degrees(p.yaw) == pytest.approx(-90.0)
        # the footprint behind the wall takes the class's usual depth, whatever the
        # building's height: only its front is seen
        assert p.size_m[0] == pytest.approx(depth) and p.stretch[0] != 1.0
        assert p.size_m[1:] == pytest.approx(
            p.size_m[1:] / p.stretch[1:]
        )  # frontage and height: the uniform scale
        # the centre is half that depth behind the wall, away from the road
        assert p.position_world[1] == pytest.approx(LEFT_Y + depth / 2, abs=0.3)
        assert np.all(p.collision_displacement == 0.0)


def test_a_building_running_out_of_the_image_keeps_its_seen_end():
    # A wall from 2 to 20 m, too tall for its top to show; the image's left edge meets the
    # building line 12.5 m ahead, so 7.5 m of it are seen. The building keeps its seen end
    # at 20 m and runs on out of view: of the usual frontages (8-25 m), any at least 8 m
    # is as likely, so it is given their middle, 16.5 m.
    labels = _facade_labels([(2.0, 20.0, 60.0)])
    seg = Segmentation(labels, None, ())
    buildings = [o for o in _objects(seg, VIEW_VP) if o.class_name == "building"]
    assert len(buildings) == 1 and buildings[0].box_px[0] == 0
    sizes = asset_catalogue((o.class_name for o in buildings), library_dirs(None))
    axis = RoadAxis(0.0, np.zeros(2), "vanishing_point")
    (placed,), _ = place_objects(
        buildings,
        CAM,
        np.linalg.inv(CAM.px_from_ground()),
        axis,
        sizes,
        load_class_table(),
        PlacementParams(),
    )
    lo, hi = TABLE["building"].frontage_range_m
    assert (lo, hi) == (8.0, 25.0)
    assert placed.size_m[1] == pytest.approx(0.5 * (lo + hi), abs=0.3)
    assert placed.size_m[0] == pytest.approx(TABLE["building"].facade_depth_m)
    assert placed.position_world[0] + placed.size_m[1] / 2 == pytest.approx(20.0, abs=0.7)
    assert placed.position_world[0] == pytest.approx(
        20.0 - 16.5 / 2, abs=0.7
    )  # not the seen part's middle (16 m)


def test_stretched_buildings_are_authored_with_their_footprint(tmp_path):
    from pxr import Usd, UsdGeom

    from usdworld.authoring.world import define_objects
    from usdworld.evaluation.world_objects import world_objects

    labels = _facade_labels([(14.0, 14.0 + 2 * FRONTAGE_M, 20.0)])
    buildings = [
        o
        for o in _objects(Segmentation(labels, None, ()), VIEW)
        if o.class_name == "building"
    ]
    sizes = asset_catalogue((o.class_name for o in buildings), library_dirs(None))
    axis = RoadAxis(0.0, np.zeros(2), "vanishing_point")
    placements, _ = place_objects(
        buildings,
        CAM,
        np.linalg.inv(CAM.px_from_ground()),
        axis,
        sizes,
        load_class_table(),
        PlacementParams(),
    )
    stage = Usd.Stage.CreateNew(str(tmp_path / "w.usda"))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/World")
    UsdGeom.Scope.Define(stage, "/World/Objects")
    define_objects(
        stage.GetRootLayer(), placements, {"building": str(asset_path("building", library_dirs(None)))}, "x.png"
    )
    authored = {o.name: o for o in world_objects(stage)}
    for p in placements:
        prim = stage.GetPrimAtPath(f"/World/Objects/{p.name}")
        assert tuple(prim.GetAttribute("xformOp:scale").Get()) == pytest.approx(
            tuple(p.scale * p.stretch), rel=1e-6
        )
        assert prim.GetAttribute("usdworld:scaleFactor").Get() == pytest.approx(p.scale, rel=1e-6)
        assert authored[p.name].size_lwh == pytest.approx(p.size_m, rel=1e-4)


@settings(max_examples=200, deadline=None)
@given(
    st.floats(0.0, 60.0),
    st.floats(0.0, 60.0),
    st.tuples(st.floats(1.0, 20.0), st.floats(0.0, 20.0)).map(lambda t: (t[0], t[0] + t[1])),
)
def test_out_of_view_frontage_is_at_least_the_seen_and_grows_with_it(a: float, b: float, usual):
    lo, hi = usual
    fa, fb = out_of_view_frontage(a, usual), out_of_view_frontage(b, usual)
    assert fa >= a and fb >= b
    if a <= b:
        assert fa <= fb + 1e-9
    if a <= hi:
        assert lo <= fa <= hi + 1e-9
    else:
        assert fa == a
    assert np.isnan(out_of_view_frontage(float("nan"), usual))


def test_facade_priors_are_checked():
    import dataclasses

    from usdworld.errors import InputError

    building = TABLE["building"]
    with pytest.raises(InputError, match="facade_depth_m: must be > 0"):
        dataclasses.replace(building, facade_depth_m=0.0)
    with pytest.raises(InputError, match="frontage_range_m"):
        dataclasses.replace(building, frontage_range_m=(20.0, 10.0))
    assert TABLE["car"].facade_depth_m is None and TABLE["car"].frontage_range_m is None


def test_a_facade_whose_base_is_seen_is_not_placed_by_its_height():
    # A 20 m tall block 60-76 m ahead, roof in view: the class's usual height (12 m) would
    # put it far too near; its base says where it stands.
    labels = _facade_labels([(60.0, 76.0, 20.0)])
    buildings = [
        o
        for o in _objects(Segmentation(labels, None, ()), VIEW)
        if o.class_name == "building"
    ]
    assert buildings and not any(b.top_truncated for b in buildings)
    sizes = asset_catalogue((o.class_name for o in buildings), library_dirs(None))
    axis = RoadAxis(0.0, np.zeros(2), "vanishing_point")
    placements, _ = place_objects(
        buildings,
        CAM,
        np.linalg.inv(CAM.px_from_ground()),
        axis,
        sizes,
        load_class_table(),
        PlacementParams(),
    )
    for p in placements:
        height = next(c for c in p.cues if c.name == "height")
        assert not height.available and height.note == FACADE_HEIGHT_NOTE
        assert p.depth_method == "contact"
        assert 60.0 < p.position_world[0] < 76.0


def test_the_two_sides_joined_at_the_vanishing_point_are_cut_apart_there():
    # Walls on both sides (8 m left and right, 14 to 200 m ahead) and a far block across
    # the end of the street joining them in the labels: no building straddles the
    # vanishing point (column 512), and each side keeps its own pieces.
    lk = label_lookups()
    left = _facade_labels([(14.0, 200.0, 14.0)])
    labels = np.where(left[:, ::-1] == lk.id_of("building"), left[:, ::-1], left)
    labels[230:256, 480:544] = lk.id_of("building")
    seg = Segmentation(labels, None, ())
    buildings = [o for o in _objects(seg, VIEW_VP) if o.class_name == "building"]
    assert all(b.box_px[2] <= 512 or b.box_px[0] >= 512 for b in buildings)
    assert sum(b.box_px[2] <= 512 for b in buildings) >= 3 and sum(b.box_px[0] >= 512 for b in buildings) >= 3
