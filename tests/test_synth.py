"""Tests for usdworld.synth: street sampling, USD authoring and Cityscapes-format output.

Rendering needs headless OpenGL; without it these tests fail with the RenderError
install hint (they never skip).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import ClassVar

import cv2
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdSemantics, Vt

import usdworld  # noqa: F401  (registers the schema plugin first)
from usdworld.authoring.validate import errors_only, validate_file
from usdworld.io.camera_files import read_camera
from usdworld.io.labels import read_segmentation
from usdworld.render import RenderScene, label_id_for_class, thing_label_ids
from usdworld.synth import (
    KERB_HEIGHT_M,
    SYNTH_CLASSES,
    author_stage,
    make_street_scene,
    sample_camera,
    write_cityscapes_frame,
)
from usdworld.synth.placement import footprint_aabb

W, H = 512, 256
SEED = 7


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> tuple[object, dict[str, Path]]:
    scene = make_street_scene(np.random.default_rng(SEED), W, H)
    paths = write_cityscapes_frame(scene, tmp_path_factory.mktemp("synth"), "test_000000_000007")
    return scene, paths


def _gt(paths: dict[str, Path]) -> dict:
    return json.loads(paths["gt"].read_text())


# -- sampling -----------------------------------------------------------------------------


def test_camera_ranges() -> None:
    for seed in range(40):
        cam = sample_camera(np.random.default_rng(seed), 640, 320)
        hfov = math.degrees(2 * math.atan(320 / cam.fx))
        assert 1.2 <= cam.height_m <= 1.7
        assert -2.0 <= math.degrees(cam.pitch) <= 5.0
        assert abs(math.degrees(cam.roll)) <= 1.0
        assert 50.0 <= hfov <= 90.0
        assert abs(cam.cx - 320) <= 6.4 and abs(cam.cy - 160) <= 3.2


def test_scene_layout_is_a_street() -> None:
    scene = make_street_scene(np.random.default_rng(SEED), W, H)
    st = scene.street
    classes = {o.class_name for o in scene.objects}
    assert {"car", "person", "building", "tree"} <= classes <= set(SYNTH_CLASSES)
    for o in scene.objects:
        x, y, z = o.centre_world
        if o.class_name == "car":  # on the road, along it
            assert st.kerb_right_y < y < st.kerb_left_y and z == 0.0
            assert min(abs(o.yaw), abs(abs(o.yaw) - math.pi)) < 0.2
            assert 4.0 <= x <= 62.0
        if o.role == "walking":  # on a sidewalk
            assert z == KERB_HEIGHT_M
            assert y < st.kerb_right_y or y > st.kerb_left_y
            assert st.outer_right_y < y < st.outer_left_y
        if o.class_name == "building":  # behind the sidewalks
            assert (
                y + 0.5 * o.size_m[0] < st.outer_right_y + 1e-6
                or y - 0.5 * o.size_m[0] > st.outer_left_y - 1e-6
            )


def test_objects_do_not_overlap() -> None:
    for seed in (1, 2, 3):
        scene = make_street_scene(np.random.default_rng(seed), W, H)
        boxes = np.array([o.footprint_aabb() for o in scene.objects])
        for i, b in enumerate(boxes):
            others = np.delete(boxes, i, axis=0)
            overlap = (others[:, 0] < b[2] - 1e-9) & (b[0] < others[:, 2] - 1e-9)
            overlap &= (others[:, 1] < b[3] - 1e-9) & (b[1] < others[:, 3] - 1e-9)
            assert not overlap.any(), scene.objects[i].name


def test_footprint_aabb_known_answer() -> None:
    np.testing.assert_allclose(footprint_aabb(np.array([1.0, 2.0]), 0.0, np.array([4.0, 2.0])), [-1, 1, 3, 3])
    np.testing.assert_allclose(
        footprint_aabb(np.array([0.0, 0.0]), math.pi / 2, np.array([4.0, 2.0]), 0.5), [-1.5, -2.5, 1.5, 2.5]
    )


# -- output files -------------------------------------------------------------------------


def test_files_are_cityscapes_format(frame) -> None:
    scene, paths = frame
    rgb = cv2.imread(str(paths["image"]), cv2.IMREAD_UNCHANGED)
    labels = cv2.imread(str(paths["labels"]), cv2.IMREAD_UNCHANGED)
    instances = cv2.imread(str(paths["instances"]), cv2.IMREAD_UNCHANGED)
    assert rgb.shape == (H, W, 3) and rgb.dtype == np.uint8
    assert labels.shape == (H, W) and labels.dtype == np.uint8
    assert instances.shape == (H, W) and instances.dtype == np.uint16
    spec = read_camera(paths["camera"])
    assert spec.source == "cityscapes"
    np.testing.assert_allclose(spec.K, scene.camera.K, atol=1e-6)
    assert spec.height_m == pytest.approx(scene.camera.height_m)
    assert spec.pitch == pytest.approx(scene.camera.pitch)
    seg = read_segmentation(paths["labels"], paths["instances"])
    assert np.array_equal(seg.label_ids, labels)
    present = set(np.unique(labels).tolist())
    for name in ("road", "sidewalk", "car", "building", "sky"):
        assert label_id_for_class(name) in present, name
    # Stuff pixels carry their label id as instance id; thing pixels class*1000+k.
    things = instances >= 1000
    assert np.array_equal(instances[~things], labels[~things])
    assert np.array_equal(instances[things] // 1000, labels[things])
    assert set(np.unique(labels[things]).tolist()) <= set(thing_label_ids())
    # The sky is blue-ish and at the top.
    sky = labels == label_id_for_class("sky")
    assert sky[0].mean() > 0.3 and np.all(rgb[sky][:, 0] > rgb[sky][:, 2])  # BGR: blue > red


def test_ground_truth_ids_match_the_instance_map(frame) -> None:
    _, paths = frame
    instances = cv2.imread(str(paths["instances"]), cv2.IMREAD_UNCHANGED).astype(np.int64)
    gt = _gt(paths)
    things = [o for o in gt["objects"] if o["instance_id"] >= 1000]
    assert len({o["instance_id"] for o in things}) == len(things), "thing instance ids are unique"
    for o in gt["objects"]:
        assert o["label_id"] == label_id_for_class(o["class"])
        if o["instance_id"] >= 1000:
            assert int((instances == o["instance_id"]).sum()) == o["visible_pixels"], o["name"]
    rendered_things = set(np.unique(instances[instances >= 1000]).tolist())
    assert rendered_things == {o["instance_id"] for o in things if o["visible_pixels"] > 0}
    assert any(o["visible_pixels"] == 0 for o in gt["objects"]), "objects behind the camera are flagged"
    total_obj = sum(o["visible_pixels"] for o in gt["objects"])
    assert 0 < total_obj < W * H


def test_projected_bottom_centres_agree_with_the_masks(frame) -> None:
    scene, paths = frame
    instances = cv2.imread(str(paths["instances"]), cv2.IMREAD_UNCHANGED).astype(np.int64)
    gt = _gt(paths)
    cam = scene.camera
    street_furniture = [label_id_for_class(c) for c in ("pole", "tree", "traffic_light", "traffic_sign")]
    considered, inside = 0, 0
    for o in gt["objects"]:
        if o["class"] not in ("car", "person") or o["visible_pixels"] < 30:
            continue
        (u, v), _ = (a[0] for a in cam.project(np.array([o["centre_world"]])))
        u_i, v_i = int(np.rint(u)), int(np.rint(v))
        if not (0 <= u_i < W and 0 <= v_i < H):
            continue
        considered += 1
        rows, cols = np.nonzero(instances == o["instance_id"])
        # Inside the mask's box, or just under it (the ground between wheels or feet).
        if cols.min() - 2 <= u <= cols.max() + 2 and rows.min() - 2 <= v <= rows.max() + 3:
            inside += 1
            continue
        # Otherwise another object right there must hide that part of it.
        window = instances[max(v_i - 6, 0) : v_i + 2, max(u_i - 3, 0) : u_i + 4]
        hidden = ((window >= 1000) & (window != o["instance_id"])) | np.isin(window, street_furniture)
        assert hidden.any(), (o["name"], (u, v), (cols.min(), cols.max(), rows.min(), rows.max()))
    assert considered >= 6 and inside >= 0.5 * considered, (considered, inside)


def test_same_seed_same_bytes_and_other_seed_differs(tmp_path: Path) -> None:
    outs = []
    for i, seed in enumerate((3, 3, 4)):
        scene = make_street_scene(np.random.default_rng(seed), 256, 128)
        paths = write_cityscapes_frame(scene, tmp_path / str(i), "f")
        outs.append({k: p.read_bytes() for k, p in paths.items()})
    assert outs[0] == outs[1]
    assert outs[0]["image"] != outs[2]["image"] and outs[0]["gt"] != outs[2]["gt"]


# -- USD --------------------------------------------------------------------------------------


def test_saved_stage_is_valid_and_renders_the_same(tmp_path: Path) -> None:
    scene = make_street_scene(np.random.default_rng(SEED), W, H)
    path = tmp_path / "street.usda"
    saved = author_stage(scene, path)
    text = path.read_text()
    assert "@/" not in text and "@../" in text, "asset references are relative"
    reopened = Usd.Stage.Open(str(path))
    assert UsdGeom.GetStageUpAxis(reopened) == UsdGeom.Tokens.z
    assert reopened.GetDefaultPrim().GetPath() == "/World"
    car = next(o for o in scene.objects if o.class_name == "car")
    prim = reopened.GetPrimAtPath(f"/World/Objects/{car.name}")
    assert prim.GetVariantSet("model").GetVariantSelection() == car.variant
    assert UsdSemantics.LabelsAPI(prim, "class").GetLabelsAttr().Get() == ["car"]
    a = RenderScene.from_stage(reopened)
    b = RenderScene.from_stage(author_stage(scene))
    assert a.n_triangles == b.n_triangles > 0
    np.testing.assert_allclose(a.bounds_world(), b.bounds_world(), atol=1e-4)
    assert [o.instance_id for o in a.objects] == [o.instance_id for o in b.objects]
    assert errors_only(validate_file(path, omni=False)) == []
    del saved


def _box_asset(path: Path, name: str, size: tuple[float, float, float]) -> None:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, f"/{name}").GetPrim()
    stage.SetDefaultPrim(root)
    UsdSemantics.LabelsAPI.Apply(root, "class").CreateLabelsAttr([name])
    vset = root.GetVariantSets().AddVariantSet("model")
    vset.AddVariant("box")
    vset.SetVariantSelection("box")
    l, w, h = size
    with vset.GetVariantEditContext():
        mesh = UsdGeom.Mesh.Define(stage, f"/{name}/body")
        corners = [(x, y, z) for x in (-l / 2, l / 2) for y in (-w / 2, w / 2) for z in (0.0, h)]
        mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*c) for c in corners]))
        mesh.CreateFaceVertexCountsAttr([4] * 6)
        mesh.CreateFaceVertexIndicesAttr(
            [0, 1, 3, 2, 4, 6, 7, 5, 0, 4, 5, 1, 2, 3, 7, 6, 0, 2, 6, 4, 1, 5, 7, 3]
        )
    stage.Save()


class _BoxLibrary:
    """A stand-in asset library of boxes with the class priors' sizes."""

    SIZES: ClassVar[dict[str, tuple[float, float, float]]] = {
        "building": (12.0, 10.0, 12.0),
        "tree": (4.0, 4.0, 7.0),
        "pole": (0.3, 0.3, 6.0),
        "traffic_sign": (0.7, 0.1, 2.8),
        "traffic_light": (0.5, 0.5, 4.5),
        "car": (4.2, 1.8, 1.5),
        "person": (0.6, 0.6, 1.75),
    }

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        for name, size in self.SIZES.items():
            _box_asset(folder / f"{name}.usda", name, size)

    def asset_path(self, class_name: str) -> Path:
        return self.folder / f"{class_name}.usda"

    def asset_info(self, class_name: str) -> dict:
        return {
            "variants": ("box",),
            "default_variant": "box",
            "size_by_variant": {"box": self.SIZES[class_name]},
        }


def test_any_asset_source_works(tmp_path: Path) -> None:
    library = _BoxLibrary(tmp_path)
    scene = make_street_scene(np.random.default_rng(11), 320, 160, assets=library)
    assert all(o.variant == "box" for o in scene.objects)
    for o in scene.objects:
        np.testing.assert_allclose(o.size_m, np.array(library.SIZES[o.class_name]) * o.scale)
    paths = write_cityscapes_frame(scene, tmp_path / "out", "boxes")
    gt = _gt(paths)
    cars = [o for o in gt["objects"] if o["class"] == "car" and o["visible_pixels"] > 0]
    assert cars and all(o["instance_id"] // 1000 == 26 for o in cars)
