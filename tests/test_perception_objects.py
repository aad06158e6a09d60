"""Objects from Cityscapes labels and from detection boxes."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.io.class_table import load_class_table
from usdworld.io.label_table import label_lookups
from usdworld.io.types import Detection, Detections, InputFile, Segmentation
from usdworld.parameters.perception import DEFAULT_PERCEPTION
from usdworld.perception.crowns import crown_ranges
from usdworld.perception.facades import StreetView, fill_through_occluders
from usdworld.perception.objects import (
    ImageObject,
    _components,
    _instance_groups,
    objects_from_detections,
    objects_from_segmentation,
)

ROAD, SIDEWALK, BUILDING, PERSON, CAR = 7, 8, 11, 24, 26
FILE = InputFile("labels", "x.png", "0" * 64)


def _objects(seg: Segmentation, view: StreetView | None = None) -> list[ImageObject]:
    """:func:`objects_from_segmentation` with the shipped class and label tables."""
    return objects_from_segmentation(seg, view, load_class_table(), label_lookups())


def _scene() -> Segmentation:
    labels = np.full((200, 400), 23, dtype=np.uint8)  # sky
    inst = labels.astype(np.int32)
    labels[100:, :] = ROAD
    labels[60:100, :] = BUILDING  # a wide facade along the whole image
    # car 26000: standing on the road, bottom visible
    labels[120:150, 50:110] = CAR
    inst[120:150, 50:110] = 26000
    # car 26001 behind person 24000: the person covers the car's bottom
    labels[110:140, 200:260] = CAR
    inst[110:140, 200:260] = 26001
    labels[125:170, 190:270] = PERSON
    inst[125:170, 190:270] = 24000
    # car 26002 cut by the bottom border
    labels[170:200, 300:380] = CAR
    inst[170:200, 300:380] = 26002
    inst[labels == ROAD] = ROAD
    inst[labels == BUILDING] = BUILDING
    return Segmentation(labels, inst, (FILE,))


def test_things_contacts_and_flags():
    objects = {o.instance_id: o for o in _objects(_scene()) if o.is_thing}
    assert set(objects) == {26000, 26001, 26002, 24000}
    visible = objects[26000]
    assert visible.class_name == "car" and visible.source_label == "car"
    np.testing.assert_allclose(visible.contact_px, [80.0, 149.5])  # box centre, lowest row + 0.5
    np.testing.assert_array_equal(visible.box_px, [50, 120, 110, 150])
    assert not (visible.bottom_truncated or visible.bottom_occluded) and visible.standing_on == "road"
    assert visible.mask_area == 30 * 60
    assert objects[26001].bottom_occluded and not objects[26001].bottom_truncated
    assert objects[26002].bottom_truncated
    assert objects[24000].class_name == "person" and not objects[24000].bottom_occluded


def test_wide_stuff_is_split_into_chunks():
    buildings = [o for o in _objects(_scene()) if o.class_name == "building"]
    # 400 px wide, 40 px tall facade, aspect 1.0 -> about 10 chunks of ~40 px.
    assert 6 <= len(buildings) <= 12
    widths = [o.width_px for o in buildings]
    assert sum(widths) == 400 and max(widths) <= 80
    assert all(o.instance_id == -1 for o in buildings)


def test_canonical_order():
    objects = _objects(_scene())
    keys = [(o.class_name, o.instance_id if o.instance_id >= 0 else 1 << 30, float(o.contact_px[0])) for o in objects]
    assert keys == sorted(keys)
    assert [o.class_name for o in objects][:1] == ["building"]


def test_detections_boxes_occlusion_and_truncation():
    dets = Detections(
        (
            Detection("Car", np.array([100.0, 50.0, 200.0, 120.0])),
            Detection("Car", np.array([120.0, 60.0, 220.0, 150.0])),  # lower, covers the first one's bottom
            Detection("Pedestrian", np.array([300.0, 40.0, 320.0, 199.5])),
            Detection("DontCareLikeUnknown", np.array([0.0, 0.0, 5.0, 5.0])),
        ),
        InputFile("detections", "d.txt", "0" * 64),
    )
    objects = objects_from_detections(dets, 400, 200, lookups=label_lookups())
    by_index = {o.instance_id: o for o in objects}
    assert set(by_index) == {0, 1, 2}
    assert by_index[0].bottom_occluded and not by_index[1].bottom_occluded
    assert by_index[2].class_name == "person" and by_index[2].bottom_truncated
    np.testing.assert_allclose(by_index[1].contact_px, [170.0, 150.0])


def test_amodal_box_bottom_is_its_contact_even_behind_another_box():
    # KITTI boxes are projected 3D boxes: the far car's box bottom is where it meets the
    # road although the near car hides it.
    near = np.array([100.0, 50.0, 260.0, 150.0])
    far = np.array([150.0, 55.0, 200.0, 90.0])
    file = InputFile("detections", "d.txt", "0" * 64)
    lookups = label_lookups()
    modal = objects_from_detections(
        Detections((Detection("Car", near), Detection("Car", far)), file), 400, 200, lookups=lookups
    )
    amodal = objects_from_detections(
        Detections((Detection("Car", near, amodal=True), Detection("Car", far, amodal=True)), file),
        400,
        200,
        lookups=lookups,
    )
    assert [o.bottom_occluded for o in sorted(modal, key=lambda o: o.instance_id)] == [False, True]
    assert not any(o.bottom_occluded for o in amodal)
    assert all(o.occluded_by == -1 for o in amodal)


VEGETATION, SIDEWALK_ID = 21, SIDEWALK


def _tree_over_sidewalk(trunk_hidden: bool) -> Segmentation:
    """A crown (rows 40-120, columns 120-200) over the sidewalk, on a trunk (columns 155-165)
    down to row 150; a car may hide the trunk's foot."""
    labels = np.full((200, 400), 23, dtype=np.uint8)  # sky
    labels[100:, :] = SIDEWALK_ID
    labels[40:120, 120:200] = VEGETATION
    labels[120:150, 155:165] = VEGETATION
    inst = labels.astype(np.int32)
    if trunk_hidden:
        labels[135:170, 130:190] = CAR
        inst[135:170, 130:190] = 26000
    return Segmentation(labels, inst, (FILE,))


def test_a_tree_stands_on_its_trunk_not_on_its_crown():
    (tree,) = [o for o in _objects(_tree_over_sidewalk(False)) if o.class_name == "tree"]
    # the crown's lower edge (row 119) hangs over sidewalk too; the trunk's foot is the contact:
    # the middle of its columns 155-164 (pixel centres at integers), its lowest row's edge
    np.testing.assert_allclose(tree.contact_px, [159.5, 149.5])
    assert not tree.bottom_occluded and tree.standing_on == "sidewalk"


def test_a_trunks_column_is_where_the_renderers_projection_puts_its_middle():
    # The renderer (usdworld/render/camera.py) puts a world point in the pixel whose index is its
    # OpenCV projection rounded: pixel centres at integers. A trunk spanning u = 157.6-162.4 (its
    # middle's projection 160.0) covers columns 158-162; its contact's column is 160.0, not half a
    # pixel to the right (which at f = 490 px turns every bearing of a drive by 1 mrad the same way).
    labels = np.full((200, 400), 23, dtype=np.uint8)  # sky
    labels[100:, :] = SIDEWALK
    labels[40:120, 120:200] = VEGETATION
    labels[120:150, 158:163] = VEGETATION
    (tree,) = [o for o in _objects(Segmentation(labels, labels.astype(np.int32), (FILE,))) if o.class_name == "tree"]
    assert tree.contact_px[0] == 160.0


def test_a_tree_whose_trunk_a_car_hides_has_no_contact():
    (tree,) = [o for o in _objects(_tree_over_sidewalk(True)) if o.class_name == "tree"]
    assert tree.bottom_occluded  # the crown over the sidewalk does not count as standing there


POLE = 17
TRAFFIC_SIGN = 20


def test_fill_through_joins_what_stands_in_front_and_nothing_else():
    wall = np.array([[1, 0, 0, 1, 0, 0, 1, 0, 0]], dtype=bool)
    front = np.array([[0, 1, 1, 0, 0, 1, 0, 1, 1]], dtype=bool)  # column 4 is sky: a gap
    np.testing.assert_array_equal(
        fill_through_occluders(wall, front), [[1, 1, 1, 1, 0, 0, 1, 0, 0]]
    )
    # runs reaching the image border stay open, and so does a run bounded by sky
    assert not fill_through_occluders(np.zeros((1, 3), bool), np.ones((1, 3), bool)).any()


def test_a_facade_split_by_a_pole_in_front_is_one_building():
    labels = np.full((200, 400), 23, dtype=np.uint8)
    labels[100:, :] = SIDEWALK
    labels[60:100, 100:140] = BUILDING
    labels[30:110, 119:122] = POLE  # the pole stands in front, from above the roof to the sidewalk
    seg = Segmentation(labels, labels.astype(np.int32), (FILE,))
    objects = _objects(seg)
    buildings = [o for o in objects if o.class_name == "building"]
    assert len(buildings) == 1
    assert buildings[0].mask_area == 40 * 40 - 3 * 40  # only the facade's own pixels
    assert [o.class_name for o in objects].count("pole") == 1


def test_a_pole_split_by_a_sign_and_a_car_in_front_is_one_pole():
    # A lamp post from row 30 to the sidewalk at row 150, hidden at rows 70-80 by a sign
    # plate in front and at rows 120-140 by a parked car: three pieces of one post, placed
    # once and standing where its lowest piece does.
    labels = np.full((200, 400), 23, dtype=np.uint8)
    labels[100:, :] = SIDEWALK
    labels[30:150, 200:203] = POLE
    labels[70:80, 190:215] = TRAFFIC_SIGN
    labels[120:140, 150:260] = CAR
    seg = Segmentation(labels, labels.astype(np.int32), (FILE,))
    poles = [o for o in _objects(seg) if o.class_name == "pole"]
    assert len(poles) == 1
    assert poles[0].mask_area == 3 * (120 - 10 - 20)  # only the post's own pixels
    assert poles[0].contact_px[1] == 149.5 and not poles[0].bottom_occluded


def _with_one_car(labels: np.ndarray) -> Segmentation:
    """The labels with their car pixels as one car instance (an object that hides what it covers)."""
    instances = labels.astype(np.int32)
    instances[labels == CAR] = CAR * 1000 + 1
    return Segmentation(labels, instances, (FILE,))


def test_a_lamp_post_hidden_by_a_car_stands_below_its_post_not_its_arm():
    # A post (columns 300-302) from row 30 down behind a parked car (rows 120-150), its
    # arm reaching 40 columns out over the road at rows 30-33 with sky below it: the
    # post's hidden foot is the contact, not the arm's lower edge.
    labels = np.full((200, 400), 23, dtype=np.uint8)
    labels[100:, :] = SIDEWALK
    labels[30:120, 300:303] = POLE
    labels[30:34, 260:300] = POLE
    labels[120:150, 250:350] = CAR
    (pole,) = [o for o in _objects(_with_one_car(labels)) if o.class_name == "pole"]
    assert pole.bottom_occluded
    assert 300 <= pole.contact_px[0] <= 303 and pole.contact_px[1] == 119.5


def test_a_sign_whose_post_a_car_hides_is_judged_by_its_post():
    # A plate (rows 40-70) on a post down to row 120, where a parked car hides the rest;
    # below the plate's right part the sidewalk far behind shows. The sign stands on its
    # hidden post, not on that ground.
    labels = np.full((200, 400), 23, dtype=np.uint8)
    labels[100:, :] = SIDEWALK
    labels[70:100, 130:141] = SIDEWALK
    labels[40:70, 100:141] = TRAFFIC_SIGN
    labels[70:120, 119:122] = TRAFFIC_SIGN
    labels[120:150, 80:160] = CAR
    (sign,) = [o for o in _objects(_with_one_car(labels)) if o.class_name == "traffic_sign"]
    assert sign.bottom_occluded
    assert 119 <= sign.contact_px[0] <= 122 and sign.contact_px[1] == 119.5


def _crowns(tops: list[int], trunks: list[int]) -> Segmentation:
    """Vegetation whose upper outline follows ``tops`` (one row per column from column
    100) down to row 120, with 4-px trunks down to the sidewalk (row 150) at ``trunks``."""
    labels = np.full((200, 400), 23, dtype=np.uint8)
    labels[100:, :] = SIDEWALK
    for c, top in enumerate(tops):
        labels[top:120, 100 + c] = VEGETATION
    for t in trunks:
        labels[120:150, t : t + 4] = VEGETATION
    return Segmentation(labels, labels.astype(np.int32), (FILE,))


def _cone(width: int, tip: int, base: int) -> list[int]:
    half = (width - 1) / 2
    return [round(tip + (base - tip) * abs(c - half) / half) for c in range(width)]


def test_merged_crowns_are_cut_at_the_dip_between_their_tops():
    tops = _cone(60, 30, 100) + _cone(50, 50, 100)  # a conifer and a lower one behind it
    trees = [o for o in _objects(_crowns(tops, [128, 183])) if o.class_name == "tree"]
    assert len(trees) == 2
    assert trees[0].box_px[2] in (159, 160, 161) and trees[1].box_px[0] == trees[0].box_px[2]
    np.testing.assert_allclose([t.contact_px[0] for t in trees], [129.5, 184.5])  # the trunks' middles


def test_two_signs_one_behind_the_other_are_two_signs():
    # Two triangular plates along the kerb run together in the labels (the nearer one
    # larger and lower), each on its own post down to the sidewalk: two signs, each
    # standing on its own post.
    labels = np.full((200, 400), 23, dtype=np.uint8)
    labels[100:, :] = SIDEWALK
    for left, width, tip, post_bottom in ((100, 41, 40, 150), (130, 31, 50, 140)):
        for c, top in enumerate(_cone(width, tip, tip + 30)):
            labels[top : tip + 30, left + c] = TRAFFIC_SIGN
        post = left + width // 2
        labels[tip + 30 : post_bottom, post : post + 2] = TRAFFIC_SIGN
    seg = Segmentation(labels, labels.astype(np.int32), (FILE,))
    signs = [o for o in _objects(seg) if o.class_name == "traffic_sign"]
    assert len(signs) == 2
    assert sorted(float(s.contact_px[1]) for s in signs) == [139.5, 149.5]  # each post's lowest row's edge


def test_one_crown_with_a_bumpy_outline_is_one_tree():
    tops = [40 + (3 if c % 7 < 3 else 0) + abs(c - 40) // 2 for c in range(80)]
    trees = [o for o in _objects(_crowns(tops, [138])) if o.class_name == "tree"]
    assert len(trees) == 1


def test_a_crown_split_by_a_pole_in_front_is_one_tree():
    seg = _crowns(_cone(70, 40, 110), [133])
    labels = np.asarray(seg.label_ids).copy()
    labels[20:150, 150:153] = POLE
    seg = Segmentation(labels, labels.astype(np.int32), (FILE,))
    assert [o.class_name for o in _objects(seg)].count("tree") == 1


def test_a_trunk_beside_a_low_hanging_crown_is_a_foot():
    # A broad crown hanging down to row 130 on its trunk to row 160; behind it a lower
    # crown (no summit of its own) hanging to row 128, whose trunk stands on the sidewalk
    # at row 136: 6-8 px below the hems beside it, under a tenth of the tree's height,
    # but a trunk on the ground all the same.
    labels = np.full((200, 400), 23, dtype=np.uint8)
    labels[100:, :] = SIDEWALK
    labels[40:130, 100:160] = VEGETATION
    labels[130:160, 128:132] = VEGETATION
    labels[50:128, 160:200] = VEGETATION
    labels[128:136, 180:183] = VEGETATION
    seg = Segmentation(labels, labels.astype(np.int32), (FILE,))
    trees = [o for o in _objects(seg) if o.class_name == "tree"]
    assert len(trees) == 2
    assert 132 <= trees[0].box_px[2] == trees[1].box_px[0] <= 180  # cut between the trunks


def test_two_crowns_with_a_facade_between_them_are_two_trees():
    # Two crowns of one height (rows 60-110, their trunks hidden) in front of a facade that
    # shows between them: the wall stands behind street trees and does not join them.
    labels = np.full((200, 400), 23, dtype=np.uint8)
    labels[100:, :] = SIDEWALK
    labels[40:130, 80:300] = BUILDING
    labels[110:130, 80:300] = CAR  # parked cars hide the trunks
    for c0 in (100, 200):
        labels[60:110, c0 : c0 + 50] = VEGETATION
    seg = Segmentation(labels, labels.astype(np.int32), (FILE,))
    trees = [o for o in _objects(seg) if o.class_name == "tree"]
    assert [(int(t.box_px[0]), int(t.box_px[2])) for t in trees] == [(100, 150), (200, 250)]


def test_a_small_far_crown_beside_a_big_near_one_is_a_tree_of_its_own():
    # A far crown (columns 0-19) stands higher in the image, 28 px tall, its top 6 px
    # above where it meets the flank of a near crown 100 px tall (columns 20-59). 6 px is
    # under MIN_PROMINENCE_FRACTION (7 %) of the region's height but well over that of its own.
    h = 110
    mask = np.zeros((h, 60), dtype=bool)
    for c in range(60):
        if c < 20:
            top, bottom = (68 - abs(c - 8) if c <= 14 else 62), 40
        else:
            top, bottom = (min(100, 62 + 2 * (c - 20)) if c < 40 else 100 - (c - 40)), 0
        mask[h - top : h - bottom, c] = True
    assert crown_ranges(mask) == [(0, 17), (17, 60)]  # cut where the dip begins


@settings(max_examples=50, deadline=None)
@given(st.lists(st.integers(0, 30), min_size=1, max_size=60))
def test_crown_ranges_cover_every_column_once(tops: list[int]):
    mask = np.zeros((40, len(tops)), dtype=bool)
    for c, top in enumerate(tops):
        mask[top:, c] = True
    ranges = crown_ranges(mask)
    assert ranges[0][0] == 0 and ranges[-1][1] == len(tops)
    assert all(a < b for a, b in ranges)
    assert all(ranges[i][1] == ranges[i + 1][0] for i in range(len(ranges) - 1))


def _fill_reference(mask: np.ndarray, front: np.ndarray) -> np.ndarray:
    """Row by row, pixel by pixel: what fill_through_occluders should give."""
    out = mask.copy()
    for r in range(mask.shape[0]):
        c = 0
        while c < mask.shape[1]:
            if front[r, c] and not mask[r, c]:
                e = c
                while e < mask.shape[1] and front[r, e] and not mask[r, e]:
                    e += 1
                if c > 0 and mask[r, c - 1] and e < mask.shape[1] and mask[r, e]:
                    out[r, c:e] = True
                c = e
            else:
                c += 1
    return out


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 6), st.integers(1, 12), st.data())
def test_fill_through_matches_a_pixel_by_pixel_reading(h: int, w: int, data):
    cells = st.lists(st.booleans(), min_size=h * w, max_size=h * w)
    mask = np.array(data.draw(cells), dtype=bool).reshape(h, w)
    front = np.array(data.draw(cells), dtype=bool).reshape(h, w)
    np.testing.assert_array_equal(fill_through_occluders(mask, front), _fill_reference(mask, front))


def test_a_tree_whose_top_hides_behind_a_nearer_crown_is_found_by_its_trunk():
    # One dome (columns 100-179) over two trunks: the near tree's (138-141, down to row
    # 150) and, further down the row, a smaller tree's whose crown stays inside the dome's
    # outline but whose trunk (104-106, down to row 135) reaches the sidewalk.
    seg = _crowns([round(40 + 30 * ((c - 40) / 40) ** 2) for c in range(80)], [138])
    labels = np.asarray(seg.label_ids).copy()
    labels[120:135, 104:107] = VEGETATION
    seg = Segmentation(labels, labels.astype(np.int32), (FILE,))
    trees = [o for o in _objects(seg) if o.class_name == "tree"]
    assert len(trees) == 2
    np.testing.assert_allclose(sorted(t.contact_px[1] for t in trees), [134.5, 149.5])
    assert trees[0].box_px[2] == trees[1].box_px[0]
    assert all(not t.bottom_occluded for t in trees)


def test_two_crowns_over_a_parked_car_are_two_trees():
    # Two crowns run together (columns 100-219), their tops cut by the image's top: one
    # summit. Their trunks (128-131 and 188-191) show only down to a parked car's roof.
    labels = np.full((200, 400), BUILDING, dtype=np.uint8)
    labels[115:, :] = SIDEWALK
    labels[0:100, 100:220] = VEGETATION
    for t in (128, 188):
        labels[100:115, t : t + 4] = VEGETATION
    labels[115:170, 90:230] = CAR
    inst = labels.astype(np.int32)
    inst[115:170, 90:230] = 26000
    trees = [o for o in _objects(Segmentation(labels, inst, (FILE,))) if o.class_name == "tree"]
    assert len(trees) == 2
    assert 132 <= trees[0].box_px[2] == trees[1].box_px[0] <= 188
    assert all(t.bottom_occluded for t in trees)
    np.testing.assert_allclose([t.contact_px[0] for t in trees], [129.5, 189.5])


def _occluders_pairwise(items: list[tuple[np.ndarray, bool]], fraction: float) -> list[tuple[bool, int]]:
    """The pairwise loop objects_from_detections used before its sweep (kept to compare): for each
    box, (bottom occluded, index of the occluder or -1)."""
    out = []
    for index, (fbox, amodal) in enumerate(items):
        bottom = float(fbox[3])
        occluders = 0.0
        occluder = -1
        for other_index, (obox, _) in enumerate(items):
            if amodal or other_index == index or obox[3] <= bottom + 1.0 or obox[1] >= bottom:
                continue
            overlap = (min(fbox[2], obox[2]) - max(fbox[0], obox[0])) / max(fbox[2] - fbox[0], 1e-9)
            if overlap > occluders:
                occluders, occluder = overlap, other_index
        out.append((occluders >= fraction, occluder if occluders >= fraction else -1))
    return out


# Coordinates on a coarse grid (half pixels) so that ties in cover, bottoms one pixel apart and
# identical boxes are common; a few boxes repeated verbatim.
_coord = st.integers(0, 40).map(lambda k: k * 2.5)
_box = st.tuples(_coord, _coord, st.integers(1, 16).map(lambda k: k * 2.5), st.integers(1, 12).map(lambda k: k * 2.5))


@settings(max_examples=300, deadline=None)
@given(
    boxes=st.lists(st.tuples(_box, st.booleans()), min_size=0, max_size=40),
    repeats=st.lists(st.integers(0, 39), max_size=8),
)
def test_detection_occluders_match_the_pairwise_loop(boxes, repeats):
    items = [(np.array([x, y, x + w, y + h]), amodal) for (x, y, w, h), amodal in boxes]
    items += [items[k] for k in repeats if k < len(items)]
    dets = Detections(
        tuple(Detection("Car", box, amodal=amodal) for box, amodal in items), InputFile("detections", "d.txt", "0" * 64)
    )
    lookups = label_lookups()
    objects = sorted(objects_from_detections(dets, 140, 120, lookups=lookups), key=lambda o: o.instance_id)
    # Every box lies inside the image and has a positive size: none is dropped.
    assert [o.instance_id for o in objects] == list(range(len(items)))
    from usdworld.parameters.perception import DEFAULT_PERCEPTION

    expected = _occluders_pairwise(items, DEFAULT_PERCEPTION.occluded_fraction)
    assert [(o.bottom_occluded, o.occluded_by) for o in objects] == expected


@settings(max_examples=200, deadline=None)
@given(boxes=st.lists(st.tuples(_box, st.booleans()), min_size=0, max_size=30), block=st.integers(1, 7))
def test_bottom_occluders_blocks_give_the_loops_cover_and_first_occluder(boxes, block):
    from usdworld.perception.objects import _bottom_occluders

    items = [(np.array([x, y, x + w, y + h]), amodal) for (x, y, w, h), amodal in boxes]
    arr = np.array([b for b, _ in items], dtype=np.float64).reshape(-1, 4)
    covered, occluder = _bottom_occluders(arr, np.array([a for _, a in items], dtype=bool), block=block)
    # With fraction 1e-300 the loop's flag is "covered at all" and its occluder the first largest.
    expected = _occluders_pairwise(items, 1e-300)
    assert [int(k) for k in occluder] == [k for _, k in expected]
    assert [bool(c > 0) for c in covered] == [flag for flag, _ in expected]


def _groups_reference(instance_ids: np.ndarray) -> list[tuple[int, list[int]]]:
    """Id by id, pixel by pixel: the boxes _instance_groups should give."""
    out = []
    for iid in sorted(int(v) for v in np.unique(instance_ids) if v >= 1000):
        ys, xs = np.nonzero(instance_ids == iid)
        out.append((iid, [int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1]))
    return out


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 8), st.integers(1, 12), st.sampled_from([1, 1 << 21]), st.data())
def test_instance_groups_match_a_pixel_by_pixel_reading(h: int, w: int, scale: int, data):
    # ``scale`` takes the ids past the counted range, to the sorted path.
    ids = st.sampled_from([0, 7, 999, 1000, 1001, 26000, 26003])
    instance_ids = np.array(data.draw(st.lists(ids, min_size=h * w, max_size=h * w)), dtype=np.int64)
    instance_ids = np.where(instance_ids >= 1000, instance_ids * scale, instance_ids).reshape(h, w)
    got = [(iid, box.tolist()) for iid, box in _instance_groups(instance_ids)]
    assert got == _groups_reference(instance_ids)
    assert all(box.dtype == np.int64 for _, box in _instance_groups(instance_ids))


def test_components_are_opencvs_whatever_their_count():
    # A checkerboard of isolated pixels has more components than 16-bit labels can number.
    rng = np.random.default_rng(0)
    for mask in (rng.random((60, 90)) < 0.4, (np.indices((600, 600)).sum(axis=0) % 2 == 0) & (np.arange(600) % 2 == 0)):
        n, comp, stats = _components(mask)
        n_ref, comp_ref, stats_ref, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
        assert n == n_ref
        np.testing.assert_array_equal(comp, comp_ref)
        np.testing.assert_array_equal(stats, stats_ref)
    assert n > np.iinfo(np.uint16).max


def test_contact_row_errs_by_the_quantisation_spread_the_cue_states():
    """A car whose bottom edge lies anywhere within one pixel row (OpenCV centres at integers: row
    i is covered when its centre is above the edge): the contact row read from the mask (lowest
    row + 0.5) is unbiased and errs by a uniform amount over one pixel, standard deviation
    1/sqrt(12) px, the row error the contact cue states (``contact_row_error_px``)."""
    errors = []
    for edge in np.linspace(140.0, 141.0, 200, endpoint=False) + 0.0025:
        labels = np.full((200, 400), 23, dtype=np.uint8)
        labels[100:, :] = ROAD
        covered = np.arange(200)
        covered = covered[(covered >= 120) & (covered < edge)]
        labels[covered[0] : covered[-1] + 1, 50:110] = CAR
        inst = labels.astype(np.int32)
        inst[labels == CAR] = 26000
        (car,) = [o for o in _objects(Segmentation(labels, inst, (FILE,))) if o.is_thing]
        errors.append(car.contact_px[1] - edge)
    errors = np.array(errors)
    assert abs(errors.mean()) < 0.01
    assert np.all(np.abs(errors) <= 0.5)
    assert errors.std() == pytest.approx(DEFAULT_PERCEPTION.contact_row_error_px, rel=0.01)
