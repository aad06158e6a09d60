"""Colours from the photo in a built world: base-layer override, provenance, restyle, render, GLB, evaluate."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from golden_scene import write_inputs
from pxr import Sdf, Usd, UsdShade

from usdworld.authoring.edits import WorldEditor
from usdworld.evaluation import evaluate_world
from usdworld.export.gltf import read_glb_json, write_glb
from usdworld.perception.colour_space import linear_to_srgb, srgb_to_linear, uint8_to_linear
from usdworld.pipeline import build
from usdworld.render.lighting import Lighting, albedo_for_photo, irradiance, sun_direction

OBJ = "/World/Objects"
#: The golden scene's two car boxes (xmin ymin xmax ymax) and the paint each gets in the photo (sRGB).
PAINTS = {(250, 170, 390, 242): (222, 184, 28), (100, 168, 170, 200): (40, 70, 150)}


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    folder = tmp_path_factory.mktemp("appearance")
    request = write_inputs(folder)
    image = cv2.imread(str(request.image))[:, :, ::-1].copy()
    for (x0, y0, x1, y1), paint in PAINTS.items():
        image[y0:y1, x0:x1] = paint
        h, w = y1 - y0, x1 - x0
        image[y0 + h // 10 : y0 + h * 4 // 10, x0 + w // 8 : x1 - w // 8] = (30, 32, 36)  # rear window
    cv2.imwrite(str(request.image), image[:, :, ::-1])
    build(request)
    return request.output / "world.usda", image


def _car(stage: Usd.Stage, box: tuple[int, ...]) -> Usd.Prim:
    for prim in stage.GetPrimAtPath(OBJ).GetChildren():
        bbox = prim.GetAttribute("usdworld:imageBBox").Get()
        if tuple(round(v) for v in bbox) == box:
            return prim
    raise AssertionError(f"no object with box {box}")


def _copy_with_car(root: Path, copy: Path, box: tuple[int, ...]) -> tuple[Path, str]:
    """A copy of the world (``root``'s folder) at ``copy``, and the name of its car with that box."""
    shutil.copytree(root.parent, copy)
    stage = Usd.Stage.Open(str(copy / "world.usda"))
    return copy, _car(stage, box).GetName()


def _paint_diffuse(prim: Usd.Prim) -> np.ndarray:
    looks = [
        UsdShade.Material(p)
        for p in Usd.PrimRange(prim)
        if p.GetName().startswith("paint_") and p.IsA(UsdShade.Material)
    ]
    assert looks, "the car asset has a paint material"
    shader, _, _ = looks[0].ComputeSurfaceSource()
    return np.array(shader.GetInput("diffuseColor").Get())


def test_irradiance_and_albedo_invert_the_colour_shader():
    light = Lighting(sun_direction_world=sun_direction(135.0, 45.0))
    up = irradiance(light, np.array([0.0, 0.0, 2.0]))
    np.testing.assert_allclose(up, light.sky_ambient + light.sun_color * np.sin(np.radians(45.0)))
    facing = np.array([-1.0, 0.0, 0.0])  # towards a camera looking along +X
    shown = srgb_to_linear(np.array([0.8, 0.6, 0.1]))
    albedo = albedo_for_photo(shown, facing, light)
    rendered = (albedo * irradiance(light, facing)) ** (1.0 / light.gamma)  # the shader, lit and unshadowed
    np.testing.assert_allclose(rendered, linear_to_srgb(shown), atol=1e-9)
    assert np.all(albedo_for_photo(np.ones(3), facing, light) == 1.0)  # brighter than white in that light


def test_measured_colour_is_a_base_layer_override_with_provenance(world):
    root, _ = world
    stage = Usd.Stage.Open(str(root))
    base = Sdf.Layer.FindOrOpen(str(root.parent / "layers" / "base.usda"))
    edits = Sdf.Layer.FindOrOpen(str(root.parent / "layers" / "edits.usda"))
    assert not edits.rootPrims  # nothing in the edits layer
    for box, paint in PAINTS.items():
        car = _car(stage, box)
        assert "UsdWorldAppearanceAPI" in car.GetAppliedSchemas()
        measured = np.array(car.GetAttribute("usdworld:measuredColor").Get())
        np.testing.assert_allclose(measured, uint8_to_linear(np.array(paint, np.uint8)), atol=0.01)
        assert car.GetAttribute("usdworld:measuredColorRegion").Get() == "box"
        assert car.GetAttribute("usdworld:measuredColorPixels").Get() > 100
        assert np.all(np.array(car.GetAttribute("usdworld:measuredColorSpread").Get()) < 0.01)
        albedo = np.array(car.GetAttribute("usdworld:albedo").Get())
        np.testing.assert_allclose(_paint_diffuse(car), albedo, atol=1e-6)
        specs = [s.path for s in _specs_below(base, car.GetPath()) if s.path.name == "inputs:diffuseColor"]
        assert specs, "the diffuseColor opinion is in the base layer"
    assert _car(stage, (250, 170, 390, 242)).GetAttribute("usdworld:albedo").Get()[0] > 0.5  # yellow
    terrain = stage.GetPrimAtPath("/World/Ground/Terrain")
    assert terrain.GetAttribute("usdworld:measuredColorRegion").Get() == "ground"


def test_the_base_layer_colours_the_selected_variant_only(world):
    """One variant body per coloured object, the built one: every other variant's materials
    keep the asset's opinions (an export then validates one variant's materials, not all)."""
    root, _ = world
    stage = Usd.Stage.Open(str(root))
    base = Sdf.Layer.FindOrOpen(str(root.parent / "layers" / "base.usda"))
    for box in PAINTS:
        car = _car(stage, box)
        selected = car.GetVariantSets().GetVariantSelection("model")
        assert len(car.GetVariantSets().GetVariantSet("model").GetVariantNames()) > 1
        colours = [s.path for s in _specs_below(base, car.GetPath()) if s.path.name == "inputs:diffuseColor"]
        assert colours
        assert all(re.findall(r"\{[^}]*\}", str(p)) == [f"{{model={selected}}}"] for p in colours)
        assert list(base.GetPrimAtPath(car.GetPath()).variantSets["model"].variants.keys()) == [selected]


def _specs_below(layer: Sdf.Layer, path: Sdf.Path) -> list[Sdf.Spec]:
    out = []
    layer.Traverse(path, lambda p: out.append(layer.GetObjectAtPath(p)) if p.IsPropertyPath() else None)
    return out


def test_restyle_wins_and_reset_brings_the_photo_colour_back(tmp_path, world):
    box = (250, 170, 390, 242)
    copy, name = _copy_with_car(world[0], tmp_path / "w", box)
    with WorldEditor(copy) as editor:
        editor.restyle(name, "#c03030")
    stage = Usd.Stage.Open(str(copy / "world.usda"))
    np.testing.assert_allclose(
        _paint_diffuse(_car(stage, box)), srgb_to_linear(np.array([0xC0, 0x30, 0x30]) / 255), atol=1e-6
    )
    with WorldEditor(copy) as editor:
        editor.reset(name)
    for p in ("layers/edits.usda", "layers/base.usda", "world.usda"):
        layer = Sdf.Layer.Find(str(copy / p))
        if layer is not None:
            layer.Reload(force=True)
    stage = Usd.Stage.Open(str(copy / "world.usda"))
    car = _car(stage, box)
    np.testing.assert_allclose(
        _paint_diffuse(car), np.array(car.GetAttribute("usdworld:albedo").Get()), atol=1e-6
    )


def test_render_from_the_source_camera_reproduces_the_photo_colours(world):
    root, photo = world
    stage = Usd.Stage.Open(str(root))
    result = evaluate_world(stage, photo=photo)
    rows = {r["name"]: r for r in result.colour_rows}
    big, small = (_car(stage, box).GetName() for box in PAINTS)
    # the big yellow car shows its lit rear; the small one its front, whose grille and shaded
    # sides the photo's flat paint does not have (the library colours were 50-70 away)
    assert rows[big]["delta_e76"] < 6.0, rows[big]
    assert rows[small]["delta_e2000"] < 10.0, rows[small]
    assert result.to_json()["colour"]["objects"] == len(rows)


def test_glb_export_carries_each_objects_own_colour(tmp_path, world):
    root, _ = world
    stage = Usd.Stage.Open(str(root))
    albedos = [np.array(_car(stage, box).GetAttribute("usdworld:albedo").Get()) for box in PAINTS]
    write_glb(root, tmp_path / "w.glb")
    doc = read_glb_json(tmp_path / "w.glb")
    colours = [
        np.array(m["pbrMetallicRoughness"]["baseColorFactor"][:3])
        for m in doc["materials"]
        if m["name"].startswith("paint_")
    ]
    for albedo in albedos:
        assert any(np.allclose(c, albedo, atol=1e-6) for c in colours), (albedo, colours)


@pytest.mark.parametrize("with_class, variant", [("car", "suv"), ("car", "hatchback"), ("bus", None)])
def test_replaced_objects_keep_the_photo_colour_and_leave_no_dangling_over(
    tmp_path, world, with_class, variant
):
    box = (250, 170, 390, 242)
    copy, name = _copy_with_car(world[0], tmp_path / "w", box)
    with WorldEditor(copy) as editor:
        if variant != "hatchback":
            editor.replace(name, with_class, variant=variant)
        else:
            editor.replace(name, "car", variant="suv")
            editor.replace(name, "car", variant="hatchback")
    stage = Usd.Stage.Open(str(copy / "world.usda"))
    car = _car(stage, box)
    undefined = [p.GetPath() for p in Usd.PrimRange(car, Usd.PrimAllPrimsPredicate) if not p.IsDefined()]
    assert undefined == []
    if with_class == "car":
        np.testing.assert_allclose(
            _paint_diffuse(car), np.array(car.GetAttribute("usdworld:albedo").Get()), atol=1e-6
        )


def test_render_scene_and_the_editors_scene_carry_the_photo_colour(world):
    """The renderer's triangles (which ``usdworld serve`` sends to the browser editor) use the override."""
    import trimesh

    from usdworld.render.scene import RenderScene
    from usdworld.serve.scene_glb import scene_glb

    root, _ = world
    stage = Usd.Stage.Open(str(root))
    scene = RenderScene.from_stage(stage)
    glb = trimesh.load(trimesh.util.wrap_as_stream(scene_glb(scene)), file_type="glb", force="scene")
    for box in PAINTS:
        car = _car(stage, box)
        albedo = np.array(car.GetAttribute("usdworld:albedo").Get())
        index = next(o.index for o in scene.objects if o.path == str(car.GetPath()))
        colours = scene.colors[scene.object_ids == index]
        assert np.any(np.all(np.abs(colours - albedo) < 1e-6, axis=1))
        node_colours = glb.geometry[car.GetName()].visual.vertex_colors[:, :3]
        assert np.any(np.all(np.abs(node_colours.astype(float) - np.round(albedo * 255)) <= 1, axis=1))
