"""End to end: known 3D objects -> label/instance images drawn by projection -> build."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from synthetic_scene import default_camera, default_objects, write_scene

from usdworld.authoring.validate import errors_only, validate_file
from usdworld.parameters import DEFAULT_PARAMETERS
from usdworld.pipeline import BuildRequest, build


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    # Cityscapes' own resolution: at half of it, one pixel of contact row is 0.4 m at 30 m.
    return write_scene(tmp_path_factory.mktemp("synth"), default_camera(2048, 1024))


@pytest.fixture(scope="module")
def built(scene, tmp_path_factory):
    out = tmp_path_factory.mktemp("worlds") / "w"
    return build(BuildRequest(output=out, **scene))


def test_every_object_placed_within_a_quarter_metre(built):
    truth = {o.instance_id: o for o in default_objects()}
    placed = {p.obj.instance_id: p for p in built.model.placements if p.obj.is_thing}
    assert set(placed) == set(truth)
    errors = [np.hypot(*(placed[i].position_world[:2] - np.array(truth[i].center_world))) for i in truth]
    assert np.median(errors) <= 0.25, errors
    assert max(errors) <= 1.0, errors


def test_cars_follow_the_road_and_face_by_side(built):
    for p in built.model.placements:
        if p.obj.class_name != "car":
            continue
        expected = 0.0 if p.position_world[1] < 0 else np.pi
        diff = abs((p.yaw - expected + np.pi) % (2 * np.pi) - np.pi)
        assert diff < np.radians(5), (p.name, np.degrees(p.yaw))
        assert p.yaw_source.startswith(("vanishing_point", "road_pca"))


def test_world_validates_and_is_reproducible(built, scene, tmp_path):
    assert errors_only(validate_file(built.world)) == []
    again = build(BuildRequest(output=tmp_path / "again", **scene))
    for rel in ("world.usda", "layers/base.usda", "layers/edits.usda", "report.json"):
        a = (built.world.parent / rel).read_bytes()
        b = (again.world.parent / rel).read_bytes()
        assert hashlib.sha256(a).digest() == hashlib.sha256(b).digest(), rel
    assert str(tmp_path) not in (again.world.parent / "layers/base.usda").read_text()


def test_ground_surfaces_stay_on_the_true_road(built):
    surfaces = {s.name: s for s in built.model.surfaces}
    assert set(surfaces) == {"road", "sidewalk", "terrain"}
    road = surfaces["road"].points_world
    top = road[np.isclose(road[:, 2], 0.0)]
    # The true road is |y| <= 6 m; outlines are traced at pixel accuracy.
    assert np.abs(top[:, 1]).max() <= 6.3 and top[:, 0].max() <= 80.5
    walk = surfaces["sidewalk"].points_world
    assert walk[:, 2].max() == pytest.approx(0.15)
    assert 5.7 <= np.abs(walk[:, 1]).min() and np.abs(walk[:, 1]).max() <= 9.8
    # What the camera sees of the road plus what hides right behind the cars.
    assert 450 < surfaces["road"].area_m2 < 12 * 80
    # The terrain fills the rest of the 100 x 160 m square without overlapping them.
    total = sum(s.area_m2 for s in surfaces.values())
    assert total == pytest.approx(100.0 * 160.0, rel=1e-6)


def test_report_records_the_parameters(built):
    assert built.report["parameters"] == DEFAULT_PARAMETERS.to_dict()
    assert built.report["parameters"]["scene"]["fill_reach_m"] == 8.0


def test_a_changed_parameter_changes_the_world(scene, built, tmp_path):
    params = DEFAULT_PARAMETERS.replace(scene={"fill_reach_m": 0.5})
    short = build(BuildRequest(output=tmp_path / "w", params=params, **scene))
    assert short.report["parameters"]["scene"]["fill_reach_m"] == 0.5
    area = {s.name: s.area_m2 for s in built.model.surfaces}
    short_area = {s.name: s.area_m2 for s in short.model.surfaces}
    # less of the road hidden behind the cars is filled in
    assert short_area["road"] < area["road"] - 1.0
    assert [p.name for p in short.model.placements] == [p.name for p in built.model.placements]


def test_the_perception_section_reaches_the_depth_fusion_of_placement(scene, built, tmp_path):
    """A contact cue made much less sure (perception.contact_rel_sigma) hands weight to the height cue:
    the things' depths change (the section is passed through placement to the fusion, not defaulted)."""
    params = DEFAULT_PARAMETERS.replace(perception={"contact_rel_sigma": 1.0})
    loose = build(BuildRequest(output=tmp_path / "w", params=params, **scene))
    assert loose.report["parameters"]["perception"]["contact_rel_sigma"] == 1.0
    before = {p.name: p.depth_m for p in built.model.placements if p.obj.is_thing}
    after = {p.name: p.depth_m for p in loose.model.placements if p.obj.is_thing}
    assert before.keys() == after.keys() and before
    assert any(abs(after[n] - before[n]) > 0.01 for n in before)
