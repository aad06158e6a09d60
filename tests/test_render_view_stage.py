"""A large world composed for one view (usdworld.render.view_stage): the scene read from the
objects that may reach the view is the whole world's scene, ids, bounds and pixels included,
after edits of every kind; worlds the object index does not describe take the whole stage.

The world is ``tools/bench_scale.py``'s street: the synthetic seed-3 frame tiled into blocks
(1,200 objects, most of them out of the source camera's view), written with its object index.
"""

from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pxr import Sdf, Usd

from usdworld.authoring import asset_library
from usdworld.authoring.edits import WorldEditor
from usdworld.authoring.world import write_world
from usdworld.parameters.authoring import AuthoringParams
from usdworld.render import RenderScene
from usdworld.render.instancing import ViewCull
from usdworld.render.outputs import view_camera, world_image_size
from usdworld.render.view_stage import open_outside, scene_for_view, view_stage
from usdworld.render.world_lights import lighting_from_stage
from usdworld.world_files import BASE_CRATE_LAYER

_TOOL = Path(__file__).parents[1] / "tools" / "bench_scale.py"
_spec = importlib.util.spec_from_file_location("bench_scale", _TOOL)
bench_scale = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench_scale)

N_OBJECTS = 1200
SIZE = (512, 256)


@pytest.fixture(scope="module")
def template(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("view_stage")
    model = bench_scale.tiled_model(bench_scale.base_model(tmp, 3, 1024, 512), N_OBJECTS)
    libraries = asset_library.library_dirs(None)
    assets = asset_library.asset_files((p.obj.class_name for p in model.placements), libraries)
    write_world(model, tmp / "w", assets, None, AuthoringParams(large_world_min_objects=1))
    return tmp / "w"


@pytest.fixture()
def world(template, tmp_path) -> Path:
    shutil.copytree(template, tmp_path / "w")
    return tmp_path / "w"


def _cull(stage: Usd.Stage) -> tuple[ViewCull, object]:
    w, h = world_image_size(stage)
    pose = view_camera(stage, w, h)
    return ViewCull(pose.K, pose.world_from_cam, w, h, lighting_from_stage(stage).sun_direction_world), pose


def _scenes(world: Path) -> tuple[RenderScene, RenderScene | None, int]:
    """The whole stage's culled scene, the view stage's (or None) and how many objects it composed."""
    file = world / "world.usda"
    full_stage = Usd.Stage.Open(str(file))
    cull, _ = _cull(full_stage)
    full = RenderScene.from_stage(full_stage, cull=cull)
    outside = open_outside(file, 0)
    if outside is None:
        return full, None, 0
    opened = view_stage(file, outside, cull)
    composed = 0 if opened is None else int(opened[1].composed.sum())
    return full, scene_for_view(file, outside, cull), composed


def _assert_same(a: RenderScene, b: RenderScene) -> None:
    assert a.objects == b.objects
    assert a.part_order.tobytes() == b.part_order.tobytes()
    assert a.bounds_world().tobytes() == b.bounds_world().tobytes()
    assert len(a.batches) == len(b.batches)
    for x, y in zip(a.batches, b.batches):
        for name in ("world_from_local", "class_ids", "instance_ids", "object_ids"):
            assert getattr(x, name).tobytes() == getattr(y, name).tobytes(), name
        assert x.topology is y.topology or x.topology.points.tobytes() == y.topology.points.tobytes()
        for name in ("instance_colors", "vertex_colors"):
            u, v = getattr(x, name), getattr(y, name)
            assert (u is None and v is None) or u.tobytes() == v.tobytes(), name


def test_the_view_stage_gives_the_whole_worlds_scene_and_pixels(world):
    full, masked, composed = _scenes(world)
    assert masked is not None
    assert 0 < composed < N_OBJECTS * 3 // 4  # much of the street is out of view
    # the stage composes one object (the scope's first); the others are read from the index
    file = world / "world.usda"
    outside = open_outside(file, 0)
    stage, facts = view_stage(file, outside, _cull(outside)[0])
    assert [p.GetName() for p in stage.GetPrimAtPath("/World/Objects").GetChildren()] == [facts.order[0]]
    assert len(facts.virtual.names) == composed - 1
    assert len(full.objects) == N_OBJECTS
    _assert_same(full, masked)
    from usdworld.render import Renderer

    stage = Usd.Stage.Open(str(world / "world.usda"))
    _, pose = _cull(stage)
    w, h = world_image_size(stage)
    lighting = lighting_from_stage(stage)
    with Renderer(w // 4, h // 4, lighting=lighting) as r:
        k = pose.K.copy()
        k[:2] /= 4.0
        a = r.render(full, k, pose.world_from_cam)
        b = r.render(masked, k, pose.world_from_cam)
    for name in ("rgb", "class_ids", "instance_ids", "object_ids", "depth_m"):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name


def _names(world: Path) -> dict[str, list[str]]:
    """Objects by class in the view stage's facts: nearest the camera first; the farthest along x."""
    file = world / "world.usda"
    outside = open_outside(file, 0)
    cull, pose = _cull(outside)
    _, facts = view_stage(file, outside, cull)
    centre = 0.5 * (facts.lo + facts.hi)
    d = np.hypot(*(centre[:, :2] - pose.world_from_cam[:2, 3]).T)
    near = [facts.names[i] for i in np.argsort(d)]
    return {
        "far_car": [
            facts.names[i] for i in np.argsort(d) if facts.names[i].startswith("car_") and not facts.composed[i]
        ],
        "car": [n for n in near if n.startswith("car_")],
        "tree": [n for n in near if n.startswith("tree_")],
        "end": [facts.names[int(np.argmax(facts.hi[:, 0]))], facts.names[int(np.argmin(facts.lo[:, 0]))]],
    }


@pytest.mark.parametrize(
    "edit",
    ["move", "move_end_out", "delete", "delete_end", "add", "replace_class", "replace_variant", "restyle"],
)
def test_after_an_edit_the_view_stage_gives_the_same_scene(world, edit):
    names = _names(world)
    car, tree, end = names["car"][0], names["tree"][0], names["end"]
    editor = WorldEditor(world)
    try:
        if edit == "move":
            editor.move(car, by=(1.5, 0.5), force=True)
        elif edit == "move_end_out":
            editor.move(end[0], by=(40.0, 0.0), force=True)
        elif edit == "delete":
            editor.delete(car)
        elif edit == "delete_end":
            editor.delete(end[1])
        elif edit == "add":
            editor.add("car", (12.0, -3.0), force=True)
        elif edit == "replace_class":
            editor.replace(car, "person", force=True)
        elif edit == "replace_variant":
            state = next(o for o in editor.objects() if o.name == car)
            other = next(v for v in editor.variants("car") if v != state.variant)
            editor.replace(car, "car", variant=other, force=True)
        else:
            editor.restyle(tree, "#c03030")
    finally:
        editor.close()
    full, masked, _ = _scenes(world)
    assert masked is not None
    _assert_same(full, masked)


def test_worlds_the_index_does_not_describe_take_the_whole_stage(world):
    file = world / "world.usda"
    assert open_outside(file, N_OBJECTS + 1) is None  # a small world
    # a base object hidden by hand: the index (re-keyed by the editor) does not say so
    base = Sdf.Layer.FindOrOpen(str(world / BASE_CRATE_LAYER))
    name = _names(world)["far_car"][0]  # culled, not composed
    spec = base.GetPrimAtPath(f"/World/Objects/{name}")
    Sdf.AttributeSpec(spec, "visibility", Sdf.ValueTypeNames.Token).default = "invisible"
    base.Save()
    full, masked, _ = _scenes(world)
    assert masked is None  # no kept index for the changed base layer
    _rekey(world, base)  # the editor re-keys the index: it does not read visibility
    full, masked, _ = _scenes(world)
    assert masked is None
    assert f"/World/Objects/{name}" not in {o.path for o in full.objects}


def _rekey(world: Path, base: Sdf.Layer) -> None:
    """Save a hand-edited base layer and key the index to it (what the editor does)."""
    from usdworld.authoring.editing.index_file import lower_opinions

    base.Save()
    lower_opinions([Sdf.Layer.FindOrOpen(str(world / "layers" / "edits.usda")), base], 0)


def test_a_culled_object_that_widens_the_bounds_is_composed(world):
    """An object beyond the ground's end, out of view: the far plane and the shadow box reach it."""
    name = _names(world)["far_car"][-1]
    base = Sdf.Layer.FindOrOpen(str(world / BASE_CRATE_LAYER))
    attr = base.GetAttributeAtPath(f"/World/Objects/{name}.xformOp:translate")
    x, y, z = attr.default
    attr.default = type(attr.default)(x - 400.0, y, z + 30.0)  # under the camera's back, up high
    _rekey(world, base)
    full, masked, _ = _scenes(world)
    assert masked is not None
    assert full.culled_bounds_world is not None
    assert full.bounds_world()[0, 0] == np.float32(full.culled_bounds_world[0, 0])  # it sets the bounds
    _assert_same(full, masked)


def test_a_third_sublayer_takes_the_whole_stage(world):
    root = Sdf.Layer.FindOrOpen(str(world / "world.usda"))
    extra = Sdf.Layer.CreateNew(str(world / "layers" / "drive.usda"))
    extra.Save()
    root.subLayerPaths.insert(1, "./layers/drive.usda")
    root.Save()
    assert open_outside(world / "world.usda", 0) is None


def test_a_culled_object_with_a_child_in_view_takes_the_whole_stage(world):
    """A mesh added below a far base object (out of view with its asset's box) stands in
    front of the camera: the index says that object is not plain, so the whole world is read."""
    name = _names(world)["far_car"][0]
    file = world / "world.usda"
    full_stage = Usd.Stage.Open(str(file))
    _, pose = _cull(full_stage)
    from pxr import Gf, UsdGeom

    obj = full_stage.GetPrimAtPath(f"/World/Objects/{name}")
    world_from_obj = UsdGeom.Xformable(obj).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
    ahead = pose.world_from_cam[:3, 3] + 8.0 * pose.world_from_cam[:3, 2]  # 8 m in front of the camera
    at = world_from_obj.GetInverse().Transform(Gf.Vec3d(float(ahead[0]), float(ahead[1]), 0.0))
    base = Sdf.Layer.FindOrOpen(str(world / BASE_CRATE_LAYER))
    mesh = Sdf.PrimSpec(base.GetPrimAtPath(f"/World/Objects/{name}"), "Extra", Sdf.SpecifierDef, "Mesh")
    names = Sdf.ValueTypeNames
    Sdf.AttributeSpec(mesh, "points", names.Point3fArray).default = [
        Gf.Vec3f(at[0] + dx, at[1] + dy, dz) for dx, dy, dz in ((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1))
    ]
    Sdf.AttributeSpec(mesh, "faceVertexCounts", names.IntArray).default = [3, 3, 3, 3]
    faces = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]
    Sdf.AttributeSpec(mesh, "faceVertexIndices", names.IntArray).default = faces
    _rekey(world, base)
    full, masked, _ = _scenes(world)
    assert masked is None
    owner = next(o for o in full.objects if o.path == f"/World/Objects/{name}")
    assert any(owner.index in b.object_ids for b in full.batches)  # its child is drawn


_OPS = st.tuples(
    st.tuples(*[st.one_of(st.just(0.0), st.floats(-3000.0, 3000.0, allow_nan=False))] * 3),
    st.one_of(st.sampled_from([0.0, 90.0, -90.0, 180.0, -180.0, 45.0, 360.0]), st.floats(-720.0, 720.0)),
    st.tuples(*[st.one_of(st.just(1.0), st.floats(-3.0, 3.0, allow_nan=False, width=32))] * 3),
)


@settings(max_examples=300, deadline=None)
@given(ops=st.lists(_OPS, min_size=1, max_size=6))
def test_an_objects_transform_from_its_ops_is_the_xform_caches(ops):
    """The virtual objects' transforms, made for several objects at once, have the bits UsdGeom
    gives the composed objects (identity ops among others: skipped per object)."""
    from pxr import Gf, UsdGeom

    from usdworld.render.view_stage import _local_to_world

    stage = Usd.Stage.CreateInMemory()
    UsdGeom.Xform.Define(stage, "/World")
    UsdGeom.Scope.Define(stage, "/World/Objects")
    cache = UsdGeom.XformCache()
    want = []
    for k, (translate, yaw, scale) in enumerate(ops):
        obj = UsdGeom.Xform.Define(stage, f"/World/Objects/thing{k}")
        obj.AddTranslateOp().Set(Gf.Vec3d(*translate))
        obj.AddRotateZOp(UsdGeom.XformOp.PrecisionFloat).Set(yaw)
        obj.AddScaleOp(UsdGeom.XformOp.PrecisionFloat).Set(Gf.Vec3f(*scale))
        want.append(np.array(cache.GetLocalToWorldTransform(obj.GetPrim())).reshape(4, 4))
    translate = np.array([t for t, _, _ in ops], dtype=np.float64)
    yaw32 = np.array([y for _, y, _ in ops], dtype=np.float32).astype(np.float64)  # the float attribute
    scale = np.array([s for _, _, s in ops], dtype=np.float32).astype(np.float64)
    got = _local_to_world(translate, yaw32, scale)
    assert got.tobytes() == np.stack(want).tobytes()


@settings(max_examples=300, deadline=None)
@given(
    a=st.lists(st.floats(-1e4, 1e4, allow_nan=False), min_size=16, max_size=16),
    b=st.lists(st.floats(-1e4, 1e4, allow_nan=False), min_size=16, max_size=16),
)
def test_gf_product_has_gf_bits(a, b):
    """Matrices multiplied as rows in numpy (a prototype's parts for all its objects at once) give
    the bits of Gf's product, signed zeros included."""
    from pxr import Gf

    from usdworld.render.scene import gf_product, gf_rows

    want = gf_rows(Gf.Matrix4d(*a) * Gf.Matrix4d(*b))
    got = gf_product(np.array(a).reshape(4, 4)[None], np.stack([np.array(b).reshape(4, 4)] * 2))
    assert got[0].tobytes() == want.tobytes() and got[1].tobytes() == want.tobytes()


def test_virtual_objects_are_read_at_the_default_time_only(world):
    file = world / "world.usda"
    outside = open_outside(file, 0)
    stage, facts = view_stage(file, outside, _cull(outside)[0])
    with pytest.raises(ValueError, match="default time"):
        RenderScene.from_stage(
            stage, prototypes=dict(facts.prototypes), virtual=facts.virtual, time=Usd.TimeCode(1)
        )
