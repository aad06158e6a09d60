"""Permissibility rules (usdworld.layout.permissible): known answers, refusals and properties."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.errors import InputError
from usdworld.layout import permissible as pm


def _fp(*rows):
    """Footprints from (name, class, x, y, l, w, yaw_deg[, scale]) rows."""
    return pm.Footprints(
        tuple(r[0] for r in rows),
        tuple(r[1] for r in rows),
        np.array([r[2:4] for r in rows], dtype=float).reshape(-1, 2),
        np.array([r[4:6] for r in rows], dtype=float).reshape(-1, 2),
        np.radians([r[6] for r in rows]),
        np.array([r[7] if len(r) > 7 else 1.0 for r in rows]),
    )


def _square_ground(half=50.0):
    """Road on y in [-5, 5], sidewalk on y in [5, 10], both for x in [0, 2*half]."""

    def quad(x0, x1, y0, y1, z):
        a, b, c, d = (x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)
        return np.array([[a, b, c], [a, c, d]], dtype=float)

    return pm.make_ground({"road": quad(0, 2 * half, -5, 5, 0.0), "sidewalk": quad(0, 2 * half, 5, 10, 0.15)})


def test_rectangle_corners_known_answer():
    c = pm.rectangle_corners(np.array([1.0, 2.0]), np.array([4.0, 2.0]), math.pi / 2)
    np.testing.assert_allclose(c, [[2, 4], [0, 4], [0, 0], [2, 0]], atol=1e-12)


def test_penetration_depth_axis_aligned_known_answer():
    a = pm.rectangle_corners(np.zeros(2), np.array([4.0, 2.0]), 0.0)
    b = pm.rectangle_corners(np.array([3.2, 0.0]), np.array([4.0, 2.0]), 0.0)
    assert pm.penetration_depth(a, b) == pytest.approx(0.8)
    far = pm.rectangle_corners(np.array([5.0, 0.0]), np.array([4.0, 2.0]), 0.0)
    assert pm.penetration_depth(a, far) == pytest.approx(-1.0)


def test_overlap_message_names_the_object_and_depth():
    others = _fp(("car_0005", "car", 0.0, 0.0, 4.0, 2.0, 0.0))
    cand = pm.Candidate("car", np.array([3.2, 0.5]), np.array([4.0, 2.0]), 0.0)
    assert [str(v) for v in pm.fit_violations(cand, others)] == ["fit: overlaps car_0005 by 0.80 m"]


def test_aabbs_overlap_but_rotated_footprints_do_not():
    # Two long thin diagonal boards side by side: their axis-aligned boxes overlap a lot,
    # the exact rectangles are 0.5 m apart.
    yaw = math.radians(45.0)
    normal = np.array([-math.sin(yaw), math.cos(yaw)])
    others = _fp(("fence_0001", "fence", 0.0, 0.0, 6.0, 0.2, 45.0))
    cand = pm.Candidate("fence", normal * 0.7, np.array([6.0, 0.2]), yaw)
    half = pm.footprint_half_extents(np.array([[6.0, 0.2]]), np.array([yaw]))[0]
    assert np.all(np.abs(cand.center) < 2 * half)  # the AABBs overlap
    assert pm.overlapping(cand, others) == []
    closer = pm.Candidate("fence", normal * 0.1, np.array([6.0, 0.2]), yaw)
    assert pm.overlapping(closer, others)[0][1] == pytest.approx(0.1, abs=1e-9)


def test_touching_within_tolerance_is_allowed():
    others = _fp(("car_0001", "car", 0.0, 0.0, 4.0, 2.0, 0.0))
    cand = pm.Candidate("car", np.array([3.995, 0.0]), np.array([4.0, 2.0]), 0.0)
    assert pm.fit_violations(cand, others) == []


def test_surface_at_and_height():
    ground = _square_ground()
    names, z = pm.surface_at(np.array([[10.0, 0.0], [10.0, 7.0], [10.0, 20.0], [0.0, 5.0]]), ground)
    assert names == ["road", "sidewalk", "other", "road"]  # a shared edge belongs to the first surface
    np.testing.assert_allclose(z, [0.0, 0.15, 0.0, 0.0])


def test_top_faces_keep_only_upward_triangles():
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, -1]], dtype=float)
    faces = np.array([[0, 1, 2], [0, 2, 1], [0, 1, 3]])
    np.testing.assert_array_equal(pm.top_faces(pts, faces), pts[[[0, 1, 2]]])


def test_extent_is_union_of_surface_bounds_and_refuses_outside():
    ground = _square_ground()
    np.testing.assert_allclose(ground.extent, [[0, -5], [100, 10]])
    inside = pm.Candidate("car", np.array([50.0, 0.0]), np.array([4.0, 2.0]), 0.0)
    assert pm.extent_violations(inside, ground) == []
    out = pm.Candidate("car", np.array([99.0, 0.0]), np.array([4.0, 2.0]), 0.0)
    (v,) = pm.extent_violations(out, ground)
    assert v.rule == "extent" and v.message.startswith("footprint reaches 1.00 m outside the ground extent")


def test_extent_falls_back_to_given_bounds_and_needs_something():
    ground = pm.make_ground({}, np.array([[0, 0], [10, 10]]))
    np.testing.assert_allclose(ground.extent, [[0, 0], [10, 10]])
    with pytest.raises(InputError, match="no ground meshes and no objects"):
        pm.make_ground({})


def test_extent_covers_the_objects_the_build_placed_beyond_the_meshes():
    tris = _square_ground().triangles
    # buildings stand behind the sidewalk (y 10..22), beyond the ground meshes
    ground = pm.make_ground(tris, None, np.array([[20.0, 10.0], [60.0, 22.0]]))
    np.testing.assert_allclose(ground.extent, [[0, -5], [100, 22]])


def test_surface_rule_refuses_car_on_sidewalk_with_message():
    rules = pm.load_surface_rules()
    (v,) = pm.surface_violations("car", "sidewalk", rules)
    assert str(v) == f"surface: car may stand on road, not sidewalk (rules: {rules.source})"
    assert pm.surface_violations("person", "road", rules) == []
    assert pm.surface_violations("unknown_class", "other", rules) == []  # _default allows all


def test_replacement_rule_groups():
    rules = pm.load_replacement_rules()
    assert rules.alternatives("car") == ["bus", "car", "truck"]
    assert rules.allows("person", "rider") and rules.allows("tree", "pole") and rules.allows("car", "car")
    (v,) = pm.replacement_violations("car", "tree", rules)
    assert str(v) == f"class: car may be replaced by bus, car, truck, not tree (rules: {rules.source})"


def test_check_placement_reports_every_rule():
    ground = _square_ground()
    others = _fp(("person_0001", "person", 20.0, 9.0, 0.6, 0.6, 0.0))
    cand = pm.Candidate("car", np.array([20.0, 9.5]), np.array([4.0, 2.0]), 0.0)
    rules = [v.rule for v in pm.check_placement(cand, others, ground, pm.load_surface_rules())]
    assert rules == ["fit", "extent", "surface"]
    assert [
        v.rule for v in pm.check_placement(cand, others, ground, pm.load_surface_rules(), surface=False)
    ] == ["fit", "extent"]


def test_neighbour_scale_median_of_nearest_same_class_clamped():
    objs = _fp(
        ("car_0001", "car", 0, 0, 4, 2, 0, 1.2),
        ("car_0002", "car", 10, 0, 4, 2, 0, 1.1),
        ("car_0003", "car", 20, 0, 4, 2, 0, 0.9),
        ("car_0004", "car", 90, 0, 4, 2, 0, 0.5),
        ("person_0001", "person", 1, 0, 0.6, 0.6, 0, 2.0),
    )
    assert pm.neighbour_scale("car", np.array([5.0, 0.0]), objs, (0.8, 1.3)) == pytest.approx(1.1)
    assert pm.neighbour_scale("car", np.array([95.0, 0.0]), objs, (0.8, 1.3)) == pytest.approx(0.9)
    assert pm.neighbour_scale("bus", np.array([0.0, 0.0]), objs, (0.7, 1.3), fallback=2.0) == pytest.approx(
        1.3
    )


def test_user_rule_tables_by_argument_and_environment(tmp_path, monkeypatch):
    mine = tmp_path / "surfaces.json"
    mine.write_text(json.dumps({"car": ["road", "sidewalk"]}))
    assert pm.load_surface_rules(mine).for_class("car") == ("road", "sidewalk")
    monkeypatch.setenv(pm.SURFACE_RULES_ENV, str(mine))
    assert pm.load_surface_rules().source == str(mine)
    groups = tmp_path / "groups.json"
    groups.write_text(json.dumps({"groups": {"anything": ["car", "tree"]}}))
    monkeypatch.setenv(pm.REPLACEMENT_RULES_ENV, str(groups))
    assert pm.load_replacement_rules().allows("car", "tree")


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("{not json", "not a readable JSON rule table"),
        ('{"car": ["lawn"]}', r"car: unknown surface\(s\) \['lawn'\]"),
        ('{"car": "road"}', "car: must be a list of surface names"),
    ],
)
def test_bad_surface_tables_are_refused(tmp_path, content, match):
    path = tmp_path / "rules.json"
    path.write_text(content)
    with pytest.raises(InputError, match=match):
        pm.load_surface_rules(path)


def test_missing_and_bad_replacement_tables(tmp_path):
    with pytest.raises(InputError, match="no such rule file; fix --replacement-rules"):
        pm.load_replacement_rules(tmp_path / "nope.json")
    bad = tmp_path / "r.json"
    bad.write_text('{"vehicles": ["car"]}')
    with pytest.raises(InputError, match='needs "groups"'):
        pm.load_replacement_rules(bad)


rects = st.tuples(
    st.floats(-10, 10), st.floats(-10, 10), st.floats(0.2, 6), st.floats(0.2, 3), st.floats(-math.pi, math.pi)
)


@settings(max_examples=40)
@given(rects, rects)
def test_penetration_is_symmetric_and_matches_separation(a, b):
    ca = pm.rectangle_corners(np.array(a[:2]), np.array(a[2:4]), a[4])
    cb = pm.rectangle_corners(np.array(b[:2]), np.array(b[2:4]), b[4])
    d = pm.penetration_depth(ca, cb)
    assert d == pytest.approx(pm.penetration_depth(cb, ca), abs=1e-9)
    if d > 1e-6:  # moving b's points by d along some axis separates them: at least the AABB test agrees
        ha = pm.footprint_half_extents(np.array([a[2:4]]), np.array([a[4]]))[0]
        hb = pm.footprint_half_extents(np.array([b[2:4]]), np.array([b[4]]))[0]
        assert np.all(np.abs(np.array(a[:2]) - np.array(b[:2])) < ha + hb)


@settings(max_examples=40)
@given(rects, st.floats(0, 2 * math.pi))
def test_overlap_does_not_depend_on_a_common_rotation(a, spin):
    # Rotating the whole scene about the origin changes no overlap depth.
    base = _fp(("x_0001", "x", 0.0, 0.0, 3.0, 1.5, 10.0))
    cand = pm.Candidate("x", np.array(a[:2]), np.array(a[2:4]), a[4])
    r = np.array([[math.cos(spin), -math.sin(spin)], [math.sin(spin), math.cos(spin)]])
    base2 = pm.Footprints(base.names, base.classes, base.centers @ r.T, base.size_lw, base.yaw + spin)
    cand2 = pm.Candidate("x", r @ cand.center, cand.size_lw, a[4] + spin)
    d1 = pm.overlapping(cand, base, tol=-1e9)
    d2 = pm.overlapping(cand2, base2, tol=-1e9)
    if d1 and d2:
        assert d1[0][1] == pytest.approx(d2[0][1], abs=1e-6)
