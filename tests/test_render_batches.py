"""Instanced drawing (a batch per asset mesh) against drawing every placed triangle; the culling test."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade
from test_render import H, W, box, camera, label, new_stage, obj

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.authoring.mesh_reader import MeshTopology
from usdworld.render import Lighting, Renderer, RenderScene, ViewCull, sun_direction
from usdworld.render.batches import MeshBatch
from usdworld.render.instancing import box_corners


def _painted_asset(path) -> str:
    """A car of three meshes: a painted body, a grey roof, a two-coloured (per-face displayColor) bumper."""
    asset = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(asset, UsdGeom.Tokens.z)
    root = UsdGeom.Xform.Define(asset, "/thing").GetPrim()
    asset.SetDefaultPrim(root)
    label(root, "car")
    geom = UsdGeom.Xform.Define(asset, "/thing/Geom")
    geom.AddTranslateOp().Set(Gf.Vec3d(0.1, -0.2, 0.0))
    geom.AddRotateZOp().Set(9.0)
    body = box(asset, "/thing/Geom/body", (-2, -1, 0), (2, 1, 1.2))
    box(asset, "/thing/Geom/roof", (-1, -0.8, 1.2), (1.2, 0.8, 1.8), color=(0.2, 0.2, 0.2))
    bumper = box(asset, "/thing/Geom/bumper", (2, -1, 0.2), (2.3, 1, 0.6))
    faces = len(bumper.GetFaceVertexCountsAttr().Get())
    pv = bumper.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform)
    pv.Set([Gf.Vec3f(0.9, 0.9, 0.1) if f % 2 else Gf.Vec3f(0.1, 0.6, 0.9) for f in range(faces)])
    material = UsdShade.Material.Define(asset, "/thing/Looks/paint")
    shader = UsdShade.Shader.Define(asset, "/thing/Looks/paint/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.5, 0.5, 0.5))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(body.GetPrim()).Bind(material)
    asset.Save()
    return asset.GetRootLayer().identifier


def _street(tmp_path) -> Usd.Stage:
    """Nine cars of one asset: turned, scaled (one mirrored, one flattened), four painted their own colour."""
    ref = _painted_asset(tmp_path / "painted.usda")
    stage = new_stage()
    for i in range(9):
        place = (6.0, 1.0, 0.3) if i == 8 else (9.0 + 3.5 * i, -5.0 + 1.6 * i, 0.05 * i)
        xf = obj(stage, f"thing_{i}", "car", place)
        xf.AddRotateZOp().Set(17.0 * i)
        height = 0.0 if i == 8 else 0.9 + 0.05 * i  # the last one flattened
        xf.AddScaleOp().Set(Gf.Vec3f(1.0 + 0.08 * i, -1.0 if i == 5 else 1.0, height))
        xf.GetPrim().GetReferences().AddReference(ref)
        if i % 2:
            over = stage.OverridePrim(f"/World/Objects/thing_{i}/Looks/paint/PreviewSurface")
            colour = Gf.Vec3f(0.1 * i, 0.2, 0.9 - 0.1 * i)
            UsdShade.Shader(over).CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(colour)
    return stage


def _placed(scene: RenderScene) -> RenderScene:
    """The same scene with every part placed on the CPU, one batch each (what the renderer drew before)."""
    batches = []
    for b, i in scene.part_order:
        batch = scene.batches[b]
        local = batch.local_mesh(int(i))
        from usdworld.render.usd_mesh import place_mesh

        tris = place_mesh(local, batch.world_from_local[i])
        n = len(tris.positions_world)
        corners = np.arange(n).reshape(-1, 3)
        topology = MeshTopology(
            tris.positions_world.astype(np.float32).astype(np.float64),
            np.arange(n),
            corners,
            np.arange(len(corners)),
            len(corners),
            False,
        )
        batches.append(
            MeshBatch(
                topology,
                tris.normals_world.astype(np.float32).astype(np.float64),
                tris.colors,
                None,
                np.eye(4)[None],
                batch.class_ids[i : i + 1],
                batch.instance_ids[i : i + 1],
                batch.object_ids[i : i + 1],
            )
        )
    order = np.stack([np.arange(len(batches)), np.zeros(len(batches), dtype=int)], axis=1)
    return RenderScene(tuple(batches), order, scene.objects, scene.culled_bounds_world)


def test_instanced_draw_gives_the_image_of_the_placed_triangles(tmp_path) -> None:
    stage = _street(tmp_path)
    scene = RenderScene.from_stage(stage)
    placed = _placed(scene)
    # body (one colour: per instance, all eight cars), roof, bumper (two colours: per corner, shared)
    shared = sorted(b.n_instances for b in scene.batches)
    assert shared[-3:] == [9, 9, 9], shared
    assert np.array_equal(placed.bounds_world(), scene.bounds_world())
    cam = camera(pitch=0.1)
    lighting = Lighting(sun_direction_world=sun_direction(200.0, 35.0))
    with Renderer(W, H, lighting=lighting) as renderer:
        a = renderer.render(scene, cam.K, cam.world_from_cam())
        b = renderer.render(placed, cam.K, cam.world_from_cam())
    for name in ("class_ids", "instance_ids", "object_ids", "depth_m"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert len(np.unique(a.object_ids)) == 10  # every car is in view, the flat one too
    # normals by the inverse transpose, not the placed face: a level at most, in a few pixels
    diff = np.abs(a.rgb.astype(int) - b.rgb.astype(int))
    assert diff.max() <= 1 and np.count_nonzero(diff.max(axis=2)) <= 0.001 * W * H


def test_the_flat_arrays_are_the_placed_triangles_in_stage_order(tmp_path) -> None:
    stage = _street(tmp_path)
    scene = RenderScene.from_stage(stage)
    placed = _placed(scene)
    for name in ("positions_world", "normals_world", "colors", "class_ids", "instance_ids", "object_ids"):
        assert np.array_equal(getattr(scene, name), getattr(placed, name)), name
    p = scene.positions_world
    assert np.array_equal(scene.bounds_world(), np.stack([p.min(axis=0), p.max(axis=0)]).astype(np.float64))
    assert scene.n_triangles == len(p) // 3
    assert scene.label_ids_present() == sorted({int(c) for c in scene.class_ids})


def _boxes(data: st.DataObject, n: int) -> np.ndarray:
    centre = st.tuples(st.floats(-80, 80), st.floats(-80, 80), st.floats(-2, 10))
    centres = data.draw(st.lists(centre, min_size=n, max_size=n))
    sizes = data.draw(st.lists(st.tuples(*[st.floats(0.1, 20)] * 3), min_size=n, max_size=n))
    boxes = [np.array([np.subtract(c, h), np.add(c, h)]) for c, h in zip(centres, sizes)]
    return np.array([box_corners(b) for b in boxes])


def _outside_one_by_one(cull: ViewCull, pts: np.ndarray) -> bool:
    """The test for one box (as it was written before it took many): all corners and their
    shadows past one plane of the frustum (the plane through the eye and an image edge
    widened by 2 pixels, or the near plane)."""
    d = cull.sun_direction_world
    if d is not None and d[2] > 1e-6:
        pts = np.concatenate([pts, pts - np.outer((pts[:, 2] + 1.0) / d[2], d)])
    cam_from_world = np.linalg.inv(cull.world_from_cam)
    planes = [
        lambda c: c[2] < cull.near_m,
        lambda c: (cull.K[0] @ c) < -2.0 * c[2],
        lambda c: (cull.K[0] @ c) > (cull.width + 2.0) * c[2],
        lambda c: (cull.K[1] @ c) < -2.0 * c[2],
        lambda c: (cull.K[1] @ c) > (cull.height + 2.0) * c[2],
    ]
    cams = [cam_from_world[:3, :3] @ p + cam_from_world[:3, 3] for p in pts]
    return any(all(beyond(c) for c in cams) for beyond in planes)


@settings(max_examples=40, deadline=None)
@given(data=st.data(), elevation=st.floats(5.0, 85.0), azimuth=st.floats(0.0, 360.0))
def test_culling_many_boxes_at_once_is_culling_each(data, elevation, azimuth) -> None:
    cam = camera(pitch=0.08)
    cull = ViewCull(cam.K, cam.world_from_cam(), W, H, sun_direction(azimuth, elevation))
    boxes = _boxes(data, 12)
    assert cull.outside_all(boxes).tolist() == [cull.outside(b) for b in boxes]
    assert cull.outside_all(boxes).tolist() == [_outside_one_by_one(cull, b) for b in boxes]


def test_a_culled_scene_draws_exactly_the_objects_inside_the_view(tmp_path) -> None:
    stage = _street(tmp_path)
    ref = str(tmp_path / "painted.usda")
    places = [(-30.0, 0.0), (20.0, 90.0), (20.0, -90.0), (400.0, 0.0), (12.0, 2.0), (-3.0, 6.0)]
    for k, (x, y) in enumerate(places):
        obj(stage, f"far_{k}", "car", (x, y, 0.0)).GetPrim().GetReferences().AddReference(ref)
    cam = camera()
    cull = ViewCull(cam.K, cam.world_from_cam(), W, H, None)
    scene = RenderScene.from_stage(stage, cull=cull)
    bbox = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_])
    inside = set()
    for o in scene.objects:
        bound = bbox.ComputeWorldBound(stage.GetPrimAtPath(o.path))
        rng = bound.GetRange()
        m = np.array(bound.GetMatrix()).reshape(4, 4)
        corners = box_corners(np.array([rng.GetMin(), rng.GetMax()])) @ m[:3, :3] + m[3, :3]
        if not cull.outside(corners):
            inside.add(o.index)
    drawn = {int(i) for b in scene.batches for i in b.object_ids}
    assert drawn == inside
    names = {o.path.rsplit("/", 1)[1] for o in scene.objects if o.index in drawn}
    # behind, far to the sides and just behind the camera: out; far ahead and near: in
    assert {"far_3", "far_4", "thing_0"} <= names and not names & {"far_0", "far_1", "far_2", "far_5"}


def test_a_renderer_still_draws_after_another_was_made_and_closed() -> None:
    """Each Renderer makes its own GL context current before it draws and before it releases."""
    stage = new_stage()
    box(stage, "/World/Objects/wall", (8, -2, 0), (9, 2, 3), color=(0.8, 0.2, 0.1), cls="wall")
    scene = RenderScene.from_stage(stage)
    cam = camera()
    with Renderer(W, H) as first:
        before = first.render(scene, cam.K, cam.world_from_cam())
        with Renderer(W, H) as second:  # made current when it was created, released on exit
            second.render(scene, cam.K, cam.world_from_cam())
        after = first.render(scene, cam.K, cam.world_from_cam())
        first.update_shadow_map(scene, cam.K, cam.world_from_cam())
        again = first.render(scene, cam.K, cam.world_from_cam())
    assert np.any(before.class_ids == 12)
    for name in ("rgb", "class_ids", "instance_ids", "object_ids", "depth_m"):
        assert np.array_equal(getattr(before, name), getattr(after, name)), name
        assert np.array_equal(getattr(before, name), getattr(again, name)), name


def test_the_fly_through_clears_the_tallest_thing_near_its_circle(tmp_path) -> None:
    from usdworld.render.flythrough import FlythroughPath, clear_path

    stage = _street(tmp_path)
    # a 40 m tower near the circle (the cars' asset, stretched), another one beyond it
    for name, (x, y) in (("tower", (30.0, 10.0)), ("beyond", (120.0, 0.0))):
        xf = obj(stage, name, "building", (x, y, 0.0))
        xf.AddScaleOp().Set(Gf.Vec3f(1.0, 1.0, 40.0 / 1.8))
        xf.GetPrim().GetReferences().AddReference(str(tmp_path / "painted.usda"))
    scene = RenderScene.from_stage(stage)
    cam = camera(pitch=0.0, roll=0.0, yaw=0.0)
    cleared = clear_path(FlythroughPath(), scene, cam.world_from_cam())
    assert "_flat" not in vars(scene)  # read from the batches: no triangle placed on the CPU
    p = scene.positions_world
    focus = cam.world_from_cam()[:2, 3] + np.array([1.0, 0.0]) * 25.0
    near = np.linalg.norm(p[:, :2] - focus, axis=1) <= 29.0
    assert cleared.aerial_height_m == float(p[near, 2].max()) + 6.0
    assert abs(cleared.aerial_height_m - 46.0) < 1e-3  # the tower, not the one beyond


def test_a_batch_with_other_ids_keeps_its_places_and_bounds(tmp_path) -> None:
    scene = RenderScene.from_stage(_street(tmp_path))
    for b in scene.batches:
        n = b.n_instances
        other = b.with_ids(np.arange(n) + 26000, np.arange(n) + 1)
        assert other.instance_ids.tolist() == list(range(26000, 26000 + n))
        assert other.object_ids.tolist() == list(range(1, n + 1))
        assert other.world_from_local.tobytes() == b.world_from_local.tobytes()
        assert other.class_ids.tobytes() == b.class_ids.tobytes()
        fresh = MeshBatch(
            b.topology, b.normals_local, b.vertex_colors, b.instance_colors, b.world_from_local,
            b.class_ids, other.instance_ids, other.object_ids,
        )
        assert other.bounds_world().tobytes() == fresh.bounds_world().tobytes() == b.bounds_world().tobytes()
        assert other.bounds_world() is b.bounds_world()  # worked out once
