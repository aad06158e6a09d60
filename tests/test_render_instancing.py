"""Shared asset meshes and view culling in RenderScene.from_stage: the same triangles, fewer reads."""

from __future__ import annotations

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom
from test_render import H, W, box, camera, label, new_stage, obj

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.render import Lighting, Renderer, RenderScene, sun_direction
from usdworld.render.instancing import ViewCull, local_layer_ids, prototype_key
from usdworld.render.scene import matrix_from_gf
from usdworld.render.usd_mesh import mesh_triangles


def _asset(path) -> str:
    asset = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(asset, UsdGeom.Tokens.z)
    root = UsdGeom.Xform.Define(asset, "/thing").GetPrim()
    asset.SetDefaultPrim(root)
    label(root, "car")
    geom = UsdGeom.Xform.Define(asset, "/thing/Geom")
    geom.AddTranslateOp().Set(Gf.Vec3d(0.1, 0.2, 0.05))
    geom.AddRotateZOp().Set(7.0)
    vset = root.GetVariantSets().AddVariantSet("model")
    for name, top in (("low", 0.5), ("tall", 3.0)):
        vset.AddVariant(name)
        vset.SetVariantSelection(name)
        with vset.GetVariantEditContext():
            box(asset, f"/thing/Geom/{name}_body", (-1, -1, 0), (1, 1, top), color=(0.8, 0.1, 0.1))
            box(asset, f"/thing/Geom/{name}_rider", (-0.2, -0.2, top), (0.2, 0.2, top + 1), cls="rider")
    vset.SetVariantSelection("low")
    asset.Save()
    return str(path)


def _stage(tmp_path) -> Usd.Stage:
    ref = _asset(tmp_path / "thing.usda")
    stage = new_stage()
    for i in range(6):
        xf = obj(stage, f"thing_{i}", "car", (10.0 + 3.0 * i, -4.0 + 1.7 * i, 0.1 * i))
        xf.AddRotateZOp().Set(13.0 * i)
        xf.AddScaleOp().Set(Gf.Vec3f(1.0 + 0.1 * i, 1.0, 0.9))
        xf.GetPrim().GetReferences().AddReference(ref)
    stage.GetPrimAtPath("/World/Objects/thing_2").GetVariantSet("model").SetVariantSelection("tall")
    # an override below an object (as a restyle writes) makes it read on its own
    UsdGeom.Mesh(stage.OverridePrim("/World/Objects/thing_3/Geom/low_body")).CreateDisplayColorAttr(
        [Gf.Vec3f(0.0, 0.0, 1.0)]
    )
    # two objects referencing two different prototypes in the stage's own layer
    for name, top in (("ProtoA", 1.0), ("ProtoB", 2.0)):
        proto = stage.DefinePrim(f"/{name}", "Xform")
        proto.SetSpecifier(Sdf.SpecifierClass)
        box(stage, f"/{name}/body", (-1, -0.5, 0), (1, 0.5, top))
    for i, name in enumerate(("ProtoA", "ProtoB")):
        xf = obj(stage, f"proto_{i}", "bus", (25.0, 4.0 * i, 0.0))
        xf.GetPrim().GetReferences().AddInternalReference(f"/{name}")
    return stage


def _one_by_one(stage: Usd.Stage) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, normals and colours of every mesh, read on its own (what the scene did before)."""
    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    out = []
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        if prim.IsA(UsdGeom.Mesh) and not str(prim.GetPath()).startswith("/Proto"):
            tris = mesh_triangles(UsdGeom.Mesh(prim), matrix_from_gf(cache.GetLocalToWorldTransform(prim)))
            out.append(tris)
    return tuple(
        np.concatenate([getattr(t, k) for t in out]) for k in ("positions_world", "normals_world", "colors")
    )


def test_shared_asset_meshes_give_the_same_triangles_as_reading_each_mesh(tmp_path) -> None:
    stage = _stage(tmp_path)
    scene = RenderScene.from_stage(stage)
    positions, normals, colors = _one_by_one(stage)
    assert np.array_equal(scene.positions_world, positions.astype(np.float32))
    assert np.array_equal(scene.normals_world, normals.astype(np.float32))
    assert np.array_equal(scene.colors, colors.astype(np.float32))
    tall = scene.object_by_path()["/World/Objects/thing_2"].index
    assert scene.positions_world[scene.object_ids == tall][:, 2].max() > 3.0  # its own variant
    blue = scene.object_by_path()["/World/Objects/thing_3"].index
    assert np.any(np.all(scene.colors[scene.object_ids == blue] == [0.0, 0.0, 1.0], axis=1))
    # riders: one instance per object, counted in stage order
    riders = [int(i) for i in np.unique(scene.instance_ids[scene.class_ids == 25])]
    assert riders == [25000 + k for k in range(6)]


def test_prototype_keys(tmp_path) -> None:
    stage = _stage(tmp_path)
    ids, layers = local_layer_ids(stage), list(stage.GetLayerStack())
    key = {
        n: prototype_key(stage.GetPrimAtPath(f"/World/Objects/{n}"), ids, layers)
        for n in ("thing_0", "thing_1", "thing_2", "thing_3", "proto_0", "proto_1")
    }
    assert key["thing_0"] == key["thing_1"] and key["thing_0"] is not None
    assert key["thing_2"] != key["thing_0"]  # another variant
    assert key["thing_3"] is None  # overridden below the object
    assert key["proto_0"] != key["proto_1"]


def test_view_cull_keeps_what_is_seen_and_what_casts_a_shadow_into_view() -> None:
    cam = camera(pitch=0.0, roll=0.0, yaw=0.0)
    K, world_from_cam = cam.K, cam.world_from_cam()
    box_at = lambda x, y, h=2.0: np.array(
        [[x + dx, y + dy, z] for dx in (-1, 1) for dy in (-1, 1) for z in (0.0, h)]
    )
    overhead = ViewCull(K, world_from_cam, W, H, None)
    assert not overhead.outside(box_at(10.0, 0.0))  # in front
    assert overhead.outside(box_at(-10.0, 0.0))  # behind
    assert overhead.outside(box_at(10.0, 60.0))  # far to the left
    # a sun low behind the camera: a tall box behind it throws its shadow forward, into view
    low_sun = ViewCull(K, world_from_cam, W, H, sun_direction(180.0, 10.0))
    assert not low_sun.outside(box_at(-3.0, 0.0, h=10.0))
    assert low_sun.outside(box_at(-60.0, 0.0, h=1.0))


def test_culled_scene_renders_the_same_and_keeps_the_ids(tmp_path) -> None:
    stage = _stage(tmp_path)
    behind = obj(stage, "thing_9", "car", (-40.0, 0.0, 0.0))
    behind.GetPrim().GetReferences().AddReference(str(tmp_path / "thing.usda"))
    after = obj(stage, "thing_10", "car", (12.0, 3.0, 0.0))
    after.GetPrim().GetReferences().AddReference(str(tmp_path / "thing.usda"))
    cam = camera()
    lighting = Lighting()
    cull = ViewCull(cam.K, cam.world_from_cam(), W, H, lighting.sun_direction_world)
    whole, culled = RenderScene.from_stage(stage), RenderScene.from_stage(stage, cull=cull)
    assert [o.instance_id for o in culled.objects] == [o.instance_id for o in whole.objects]
    gone = whole.object_by_path()["/World/Objects/thing_9"].index
    assert gone not in culled.object_ids and gone in whole.object_ids
    assert culled.n_triangles < whole.n_triangles
    assert np.array_equal(
        culled.bounds_world(), whole.bounds_world()
    )  # the box of the culled one is exact here
    with Renderer(W, H, lighting=lighting) as renderer:
        a = renderer.render(whole, cam.K, cam.world_from_cam())
        b = renderer.render(culled, cam.K, cam.world_from_cam())
    for name in ("rgb", "class_ids", "instance_ids", "object_ids", "depth_m"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_culling_an_empty_scene() -> None:
    stage = new_stage()
    cam = camera()
    scene = RenderScene.from_stage(stage, cull=ViewCull(cam.K, cam.world_from_cam(), W, H, None))
    assert scene.n_triangles == 0 and scene.objects == ()


def test_objects_with_their_own_paint_share_one_read_of_the_asset_meshes(tmp_path, monkeypatch) -> None:
    """As a world's base layer writes them: each object's variant body paints the asset's material."""
    from pxr import UsdShade

    import usdworld.render.usd_mesh as usd_mesh

    asset = Usd.Stage.CreateNew(str(tmp_path / "painted.usda"))
    UsdGeom.SetStageUpAxis(asset, UsdGeom.Tokens.z)
    root = UsdGeom.Xform.Define(asset, "/thing").GetPrim()
    asset.SetDefaultPrim(root)
    label(root, "car")
    body = box(asset, "/thing/Geom/body", (-1, -1, 0), (1, 1, 1.5))
    box(asset, "/thing/Geom/roof", (-0.8, -0.8, 1.5), (0.8, 0.8, 1.8), color=(0.2, 0.2, 0.2))
    material = UsdShade.Material.Define(asset, "/thing/Looks/paint")
    shader = UsdShade.Shader.Define(asset, "/thing/Looks/paint/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.5, 0.5, 0.5))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(body.GetPrim()).Bind(material)
    asset.Save()
    stage = new_stage()
    for i in range(4):
        xf = obj(stage, f"thing_{i}", "car", (8.0 + 4.0 * i, -3.0 + 2.0 * i, 0.0))
        xf.GetPrim().GetReferences().AddReference(asset.GetRootLayer().identifier)
        paint = UsdShade.Shader(stage.OverridePrim(f"/World/Objects/thing_{i}/Looks/paint/PreviewSurface"))
        paint.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.2 * i, 0.1, 0.9 - 0.2 * i))
    reads = []
    real = usd_mesh.read_topology
    monkeypatch.setattr(usd_mesh, "read_topology", lambda mesh, *a: (reads.append(1), real(mesh, *a))[1])
    scene = RenderScene.from_stage(stage)
    assert len(reads) == 2  # body and roof, once for the four objects
    positions, normals, colors = _one_by_one(stage)
    assert np.array_equal(scene.positions_world, positions.astype(np.float32))
    assert np.array_equal(scene.normals_world, normals.astype(np.float32))
    assert np.array_equal(scene.colors, colors.astype(np.float32))
    painted = scene.colors[scene.class_ids > 0].astype(np.float64)
    bodies = {tuple(np.round(c, 4).tolist()) for c in painted}
    assert {(round(0.2 * i, 4), 0.1, round(0.9 - 0.2 * i, 4)) for i in range(4)} <= bodies
