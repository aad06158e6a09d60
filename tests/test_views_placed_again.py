"""A rig whose objects measure a ground spread places its views again from what they perceived.

The split build (:func:`usdworld.pipeline.perceive`, :func:`~usdworld.pipeline.place_view`,
:func:`~usdworld.pipeline.finish_view`) must give exactly what a build from scratch with the
widened parameters gives, and the second placement must not perceive the photos again.
"""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import pytest
from synthetic_scene import default_camera, write_scene
from views_support import write_rig

import usdworld.pipeline
from usdworld.authoring.asset_library import library_dirs
from usdworld.layout.model import WorldModel
from usdworld.parameters import DEFAULT_PARAMETERS, Parameters
from usdworld.pipeline import BuildRequest, build_model, finish_view, perceive, place_view
from usdworld.report import make_report
from usdworld.views.build import ViewsRequest, _uneven_request, build_rig_model, view_model
from usdworld.views.manifest import read_views_manifest

#: Pedestrians ahead on the road and, to the left, on a walkway 0.6 m above it (x, y, ground z):
#: the raised ones' contacts are far off, so the rig measures a spread and places its views again.
PEOPLE = ((12.0, -3.0, 0.0), (18.0, -2.0, 0.0), (26.0, -4.0, 0.0), (16.0, 4.0, 0.6), (22.0, 5.0, 0.6))


def _report(model: WorldModel, params: Parameters) -> str:
    """Everything a world's ``report.json`` says of a model: placements, cues, camera, surfaces, light."""
    return json.dumps(make_report(model, params), sort_keys=True)


@pytest.fixture(scope="module")
def walkway(tmp_path_factory: pytest.TempPathFactory) -> ViewsRequest:
    folder = tmp_path_factory.mktemp("walkway")
    objects = tuple(("person", x, y, 0.0, (0.6, 0.6, 1.75)) for x, y, _ in PEOPLE)
    manifest = write_rig(folder, objects, tuple(z for _, _, z in PEOPLE))
    return ViewsRequest(read_views_manifest(manifest), folder / "world", jobs=1)


def test_a_rig_placed_again_equals_its_views_built_from_scratch_with_the_spread(
    walkway: ViewsRequest,
) -> None:
    rig = build_rig_model(walkway)
    assert rig.ground_spread_m > 0.3
    widened = _uneven_request(walkway, rig.ground_spread_m)
    assert widened.params.placement.ground_height_sigma_m > walkway.params.placement.ground_height_sigma_m
    for i, model in enumerate(rig.view_models):
        scratch = view_model(widened, i)  # perceived, placed and finished with the widened numbers
        assert _report(model, widened.parameters) == _report(scratch, widened.parameters)
        first = view_model(walkway, i)  # and the first pass's placements are not what the rig kept
        assert [p.depth_m for p in model.placements] != [p.depth_m for p in first.placements]


def test_placing_again_does_not_perceive_again(
    walkway: ViewsRequest, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = {"perceived": 0, "light": 0}
    read_scene_head = usdworld.pipeline.read_scene_head
    estimate_scene_light = usdworld.pipeline.estimate_scene_light

    def counted_head(*args, **kwargs):
        calls["perceived"] += 1
        return read_scene_head(*args, **kwargs)

    def counted_light(*args, **kwargs):
        calls["light"] += 1
        return estimate_scene_light(*args, **kwargs)

    monkeypatch.setattr(usdworld.pipeline, "read_scene_head", counted_head)
    monkeypatch.setattr(usdworld.pipeline, "estimate_scene_light", counted_light)
    rig = build_rig_model(walkway)
    assert rig.ground_spread_m > 0.0  # placed twice ...
    n = len(walkway.views.views)
    # ... perceived once, and its light found on the final placements only
    assert calls == {"perceived": n, "light": n}


def test_a_perceived_view_pickles_and_places_as_before(walkway: ViewsRequest) -> None:
    """The process pool sends perceived and placed views between processes."""
    from usdworld.views.build import perceive_view

    perceived = perceive_view(walkway, 1)
    placement = _uneven_request(walkway, 0.4).parameters.placement
    again = pickle.loads(pickle.dumps(place_view(pickle.loads(pickle.dumps(perceived)), placement)))
    params = perceived.params.replace(placement={"ground_height_sigma_m": placement.ground_height_sigma_m})
    direct = finish_view(place_view(perceived, placement))
    assert _report(finish_view(again), params) == _report(direct, params)


@pytest.fixture(scope="module")
def street(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return write_scene(tmp_path_factory.mktemp("street"), default_camera(1024, 512))


@pytest.mark.parametrize(
    "changes",
    [
        {"ground_height_sigma_m": 0.8},
        {"ground_height_sigma_m": 0.3, "road_axis_min_points": 10**9, "lane_width_m": 3.0},
    ],
)
def test_placing_a_perceived_photo_equals_building_it_with_those_numbers(
    street: dict[str, Path], tmp_path: Path, changes: dict[str, float]
) -> None:
    request = BuildRequest(output=tmp_path / "w", **street)
    params = DEFAULT_PARAMETERS.replace(placement=changes)
    perceived = perceive(request, library_dirs(None))
    direct = build_model(BuildRequest(output=tmp_path / "w", params=params, **street), library_dirs(None))
    assert _report(finish_view(place_view(perceived, params.placement)), params) == _report(direct, params)
    unchanged = build_model(request, library_dirs(None))
    again = finish_view(place_view(perceived))
    assert _report(again, DEFAULT_PARAMETERS) == _report(unchanged, DEFAULT_PARAMETERS)
    assert _report(unchanged, params) != _report(direct, params)  # the numbers do move the placements


def test_a_curb_height_the_photo_was_not_perceived_with_is_refused(
    street: dict[str, Path], tmp_path: Path
) -> None:
    perceived = perceive(BuildRequest(output=tmp_path / "w", **street), library_dirs(None))
    curb = DEFAULT_PARAMETERS.placement.curb_height_m + 0.05
    with pytest.raises(ValueError, match="curb_height_m"):
        place_view(perceived, DEFAULT_PARAMETERS.replace(placement={"curb_height_m": curb}).placement)
