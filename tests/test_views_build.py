"""``build --views``: a synthetic two-camera rig built into one world (objects once, cameras, provenance)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd, UsdGeom
from views_support import CAMERAS, OBJECTS, seen_by, world_from_cam, write_rig

from usdworld.authoring.validate import errors_only, validate_file
from usdworld.cli.main import main
from usdworld.parameters.views import ViewsParams
from usdworld.views.build import ViewsRequest, build_views
from usdworld.views.manifest import read_views_manifest


@pytest.fixture(scope="module")
def rig(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("rig")
    manifest = write_rig(folder)
    build_views(ViewsRequest(read_views_manifest(manifest), folder / "world", jobs=1))
    return manifest, folder / "world"


def _objects(world: Path) -> dict[str, tuple[np.ndarray, list[str], str]]:
    """Name -> (ground position (2,), views, fusion method) of each object of a world."""
    stage = Usd.Stage.Open(str(world / "world.usda"))
    out = {}
    for prim in stage.GetPrimAtPath("/World/Objects").GetChildren():
        xy = np.array(UsdGeom.Xformable(prim).GetLocalTransformation().ExtractTranslation())[:2]
        views = list(prim.GetAttribute("usdworld:views").Get())
        out[prim.GetName()] = (xy, views, str(prim.GetAttribute("usdworld:fusionMethod").Get()))
    return out


def test_every_object_is_placed_once_near_its_truth(rig: tuple[Path, Path]) -> None:
    objects = _objects(rig[1])
    assert len(objects) == len(OBJECTS)
    for cls, x, y, _, _ in OBJECTS:
        near = [
            n
            for n, (xy, _, _) in objects.items()
            if n.startswith(cls) and np.hypot(*(xy - (x, y))) < 0.05 * np.hypot(x, y)
        ]
        assert len(near) == 1, (cls, x, y, near)
        _, views, method = objects[near[0]]
        assert sorted(views) == seen_by((cls, x, y))
        assert method == ("single" if len(views) == 1 else "fused")


def test_without_association_the_overlap_is_placed_twice(tmp_path: Path, rig: tuple[Path, Path]) -> None:
    """The fusion is what places the objects both views see once (gate 0: no merges)."""
    views = read_views_manifest(rig[0])
    build_views(
        ViewsRequest(views, tmp_path / "w", jobs=1, views_params=ViewsParams(association_gate_chi2=0.0))
    )
    both = sum(len(seen_by(o[:3])) == 2 for o in OBJECTS)
    assert len(_objects(tmp_path / "w")) == len(OBJECTS) + both


def test_cameras_sit_at_their_poses_and_the_source_camera_is_the_first_view(rig: tuple[Path, Path]) -> None:
    stage = Usd.Stage.Open(str(rig[1] / "world.usda"))
    for name, (position, heading) in CAMERAS.items():
        cam = UsdGeom.Camera(stage.GetPrimAtPath(f"/World/Cameras/{name}"))
        M = np.array(cam.ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T  # column-vector convention
        pose = world_from_cam(position, heading)
        assert M[:3, 3] == pytest.approx(pose[:3, 3], abs=1e-9)
        assert -M[:3, 2] == pytest.approx(pose[:3, 2], abs=1e-9)  # USD cameras look down -Z
        assert cam.GetFocalLengthAttr().Get() / cam.GetHorizontalApertureAttr().Get() == pytest.approx(
            600.0 / 800.0
        )
    source = UsdGeom.Camera(stage.GetPrimAtPath("/World/SourceCamera"))
    front = UsdGeom.Camera(stage.GetPrimAtPath("/World/Cameras/front"))
    t = Usd.TimeCode.Default()
    assert np.array(source.ComputeLocalToWorldTransform(t)) == pytest.approx(
        np.array(front.ComputeLocalToWorldTransform(t))
    )
    world = stage.GetPrimAtPath("/World")
    assert list(world.GetAttribute("usdworld:views").Get()) == ["front", "left"]
    assert list(world.GetAttribute("usdworld:viewImages").Get()) == ["front.png", "left.png"]


def test_the_world_validates_and_the_report_lists_every_view(rig: tuple[Path, Path]) -> None:
    for layer in ("world.usda", "layers/base.usda"):
        assert errors_only(validate_file(rig[1] / layer)) == []
    report = json.loads((rig[1] / "report.json").read_text())
    assert [c["name"] for c in report["views"]["cameras"]] == ["front", "left"]
    fused = [o for o in report["views"]["objects"].values() if len(o["observations"]) == 2]
    assert len(fused) == 2 and all(len(o["observations"][0]["image_bbox"]) == 4 for o in fused)


def test_a_process_pool_builds_the_same_world(tmp_path: Path, rig: tuple[Path, Path]) -> None:
    build_views(ViewsRequest(read_views_manifest(rig[0]), tmp_path / "w", jobs=2))
    for layer in ("world.usda", "layers/base.usda", "report.json"):
        assert (tmp_path / "w" / layer).read_bytes() == (rig[1] / layer).read_bytes()


def test_cli_builds_a_views_manifest_and_refuses_mixed_options(
    tmp_path: Path, rig: tuple[Path, Path], capsys
) -> None:
    assert main(["build", "--views", str(rig[0]), "-o", str(tmp_path / "w"), "--jobs", "1"]) == 0
    assert (tmp_path / "w" / "world.usda").is_file()
    capsys.readouterr()
    for args, message in (
        (
            ["--views", str(rig[0]), "--labels", "x.png"],
            "error: --labels: a views build takes each view's inputs from --views; drop --labels\n",
        ),
        (
            ["--sample", "abc"],
            "error: --layout, --sample and --jobs go with --views (several views, one world)\n",
        ),
        (
            [],
            "error: pass the photo (usdworld build IMAGE -o OUT), or several views with --views VIEWS.json\n",
        ),
        (
            ["--views", str(rig[0]), "--sample", "abc"],
            "error: --sample picks a sample of a nuScenes info file; use it with --layout nuscenes\n",
        ),
    ):
        assert main(["build", *args, "-o", str(tmp_path / "x")]) == 2
        assert capsys.readouterr().err == message


def test_render_camera_by_view_name_resolves_to_the_rig_camera(rig: tuple[Path, Path]) -> None:
    from usdworld.authoring.rig import rig_view

    stage = Usd.Stage.Open(str(rig[1] / "world.usda"))
    assert rig_view(stage, "left") == ("/World/Cameras/left", "left.png")
    assert rig_view(stage, None) == (None, None)
    assert rig_view(stage, "/World/SourceCamera") == ("/World/SourceCamera", None)


def test_people_on_a_raised_walkway_stand_where_their_height_says(tmp_path: Path, rig: tuple[Path, Path]) -> None:
    """Four pedestrians on the road ahead and three on a walkway 0.6 m above it to the left: their
    contacts put the raised ones 1.7x too far (the ray meets the road plane beyond them). The views'
    objects measure the ground's spread and every pedestrian stands within 1 m of its truth (the raised
    ones were 6-12 m off; the level ones, exact by their contacts before, now lean on their heights
    too and give up to 0.9 m); a rig on flat ground measures none."""
    from usdworld.views.build import build_rig_model

    size = (0.6, 0.6, 1.75)
    people = [(12.0, -3.0), (18.0, -2.0), (26.0, -4.0), (32.0, -2.5), (16.0, 4.0), (22.0, 5.0), (28.0, 6.0)]
    ground_z = (0.0, 0.0, 0.0, 0.0, 0.6, 0.6, 0.6)
    manifest = write_rig(tmp_path, tuple(("person", x, y, 0.0, size) for x, y in people), ground_z)
    model = build_rig_model(ViewsRequest(read_views_manifest(manifest), tmp_path / "world", jobs=1))
    assert 0.3 < model.ground_spread_m < 0.6
    placed = np.array([o.placement.position_world[:2] for o in model.objects])
    assert len(placed) == len(people)
    for truth in people:
        assert float(np.min(np.linalg.norm(placed - np.array(truth), axis=1))) < 1.0
    report = json.loads((rig[1] / "report.json").read_text())
    assert report["views"]["ground_spread_m"] == 0.0
