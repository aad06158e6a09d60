"""Tests for usdworld.render: camera exactness, depth, ids, shadows and stage composition.

These tests need headless OpenGL (EGL + Mesa). Without it they fail with the
RenderError message, which names the Debian packages to install; they never skip.
"""

from __future__ import annotations

from collections.abc import Iterator

import cv2
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSemantics, UsdShade, Vt

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.authoring.camera import define_camera
from usdworld.errors import UsdWorldError
from usdworld.geometry.camera import PinholeCamera
from usdworld.render import (
    INSTALL_HINT,
    Lighting,
    Renderer,
    RenderError,
    RenderScene,
    camera_from_usd,
    sun_direction,
)
from usdworld.render import context as render_context

W, H = 240, 160
BOX_FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]


# -- small stage builders -------------------------------------------------------------


def new_stage() -> Usd.Stage:
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    UsdGeom.Scope.Define(stage, "/World/Objects")
    return stage


def label(prim: Usd.Prim, name: str) -> None:
    UsdSemantics.LabelsAPI.Apply(prim, "class").CreateLabelsAttr([name])


def box(stage: Usd.Stage, path: str, lo, hi, color=(0.5, 0.5, 0.5), cls: str | None = None) -> UsdGeom.Mesh:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(corners.astype(np.float32)))
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr([i for f in BOX_FACES for i in f])
    mesh.CreateDisplayColorAttr([Gf.Vec3f(*color)])
    if cls:
        label(mesh.GetPrim(), cls)
    return mesh


def quad(stage: Usd.Stage, path: str, corners_world: np.ndarray, cls: str) -> UsdGeom.Mesh:
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(corners_world, dtype=np.float32)))
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    label(mesh.GetPrim(), cls)
    return mesh


def obj(stage: Usd.Stage, name: str, cls: str, translate=(0.0, 0.0, 0.0)) -> UsdGeom.Xform:
    xf = UsdGeom.Xform.Define(stage, f"/World/Objects/{name}")
    label(xf.GetPrim(), cls)
    xf.AddTranslateOp().Set(Gf.Vec3d(*translate))
    return xf


def camera(K=None, height_m=1.5, pitch=0.03, roll=0.01, yaw=-0.02) -> PinholeCamera:
    if K is None:
        # Off-centre principal point, fx != fy, a little skew-free asymmetry.
        K = np.array([[200.0, 0.0, 131.3], [0.0, 190.0, 71.6], [0.0, 0.0, 1.0]])
    return PinholeCamera(W, H, K, height_m, pitch=pitch, roll=roll, yaw=yaw)


@pytest.fixture(scope="module")
def renderer() -> Iterator[Renderer]:
    with Renderer(W, H) as r:  # raises RenderError with the install hint when GL is missing
        yield r


# -- GL availability -------------------------------------------------------------------


def test_missing_gl_raises_render_error_with_install_hint(monkeypatch: pytest.MonkeyPatch) -> None:
    import moderngl

    def broken(*args: object, **kwargs: object) -> None:
        raise Exception("eglGetDisplay failed")  # noqa: TRY002  (what glcontext raises)

    monkeypatch.setattr(moderngl, "create_standalone_context", broken)
    with pytest.raises(RenderError) as info:
        render_context.create_context()
    message = str(info.value)
    assert INSTALL_HINT in message and "eglGetDisplay failed" in message
    assert "\n" not in message
    assert isinstance(info.value, UsdWorldError)


def test_renderer_rejects_bad_sizes() -> None:
    with pytest.raises(UsdWorldError):
        Renderer(0, 10)


# -- camera ------------------------------------------------------------------------------


def _projected_cv(cam: PinholeCamera, points_world: np.ndarray) -> np.ndarray:
    R_cam_from_world = cam.rotation_world_from_cam.T
    rvec, _ = cv2.Rodrigues(R_cam_from_world)
    tvec = -R_cam_from_world @ cam.center_world
    px, _ = cv2.projectPoints(points_world.reshape(-1, 1, 3), rvec, tvec, cam.K, np.zeros(5))
    return px.reshape(-1, 2)


def _inside_convex(poly: np.ndarray, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which points lie strictly inside a convex polygon, and which are within 1e-3 px of an edge."""
    x, y = poly[:, 0], poly[:, 1]
    if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) < 0:  # make the winding positive
        poly = poly[::-1]
    signed = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        e = b - a
        signed.append((e[0] * (pts[:, 1] - a[1]) - e[1] * (pts[:, 0] - a[0])) / np.linalg.norm(e))
    s = np.stack(signed, axis=1)
    return np.all(s > 1e-3, axis=1), np.any(np.abs(s) <= 1e-3, axis=1)


def test_small_object_lands_on_the_opencv_pixels(renderer: Renderer) -> None:
    cam = camera()
    # A small upright quad 12 m ahead, off the optical axis, at a non-integer projection.
    centre = np.array([12.0, 1.37, 1.91])
    corners = centre + np.array([[0, -0.21, -0.17], [0, 0.19, -0.17], [0, 0.19, 0.23], [0, -0.21, 0.23]])
    stage = new_stage()
    quad(stage, "/World/Target", corners, "car")
    result = renderer.render(RenderScene.from_stage(stage), cam.K, cam.world_from_cam())
    poly = _projected_cv(cam, corners)
    np.testing.assert_allclose(poly, cam.project(corners)[0], atol=1e-9)
    v, u = np.mgrid[0:H, 0:W]
    centres = np.column_stack([u.ravel(), v.ravel()]).astype(float)
    inside, on_edge = _inside_convex(poly, centres)
    mask = (result.class_ids == 26).ravel()
    assert 20 < inside.sum() < 400, "the target should cover a handful of pixels"
    decided = ~on_edge
    assert np.array_equal(mask[decided], inside[decided])


def test_usd_camera_round_trip_and_same_pixels(renderer: Renderer) -> None:
    cam = camera()
    stage = new_stage()
    define_camera(stage, "/World/SourceCamera", cam)
    pose = camera_from_usd(stage.GetPrimAtPath("/World/SourceCamera"), W, H)
    np.testing.assert_allclose(pose.K, cam.K, atol=1e-9)
    np.testing.assert_allclose(pose.world_from_cam, cam.world_from_cam(), atol=1e-9)
    box(stage, "/World/Thing", (8, -1, 0), (9, 1, 2), cls="car")
    scene = RenderScene.from_stage(stage)
    a = renderer.render_labels(scene, cam.K, cam.world_from_cam())[0]
    b = renderer.render_labels(scene, pose.K, pose.world_from_cam)[0]
    assert np.array_equal(a, b) and (a == 26).sum() > 100


def test_camera_from_usd_rejects_non_cameras() -> None:
    stage = new_stage()
    with pytest.raises(UsdWorldError):
        camera_from_usd(stage.GetPrimAtPath("/World"), W, H)


# -- depth and ids -----------------------------------------------------------------------


def test_back_projected_depth_lies_on_the_mesh_within_1mm(renderer: Renderer) -> None:
    cam = camera()
    stage = new_stage()
    # A tilted plane: points p with n.p = d.
    n = np.array([-0.8, 0.3, 0.52])
    n /= np.linalg.norm(n)
    p0 = np.array([14.0, 0.0, 1.5])
    a = np.cross(n, [0, 0, 1.0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    corners = p0 + 9.0 * np.array([-a - b, a - b, a + b, -a + b])
    quad(stage, "/World/Plane", corners, "building")
    result = renderer.render(RenderScene.from_stage(stage), cam.K, cam.world_from_cam())
    hit = result.class_ids == 11
    assert hit.sum() > 2000
    v, u = np.nonzero(hit)
    z = result.depth_m[v, u].astype(np.float64)
    rays_cam = np.column_stack([u, v, np.ones(len(u))]) @ np.linalg.inv(cam.K).T
    p_world = (rays_cam * z[:, None]) @ cam.rotation_world_from_cam.T + cam.center_world
    distance = np.abs((p_world - p0) @ n)
    assert distance.max() < 1e-3, f"max distance {distance.max():.2e} m"
    assert np.all(result.depth_m[~hit] == 0.0), "no hit must read depth 0"


def test_ids_are_exact_with_no_blending(renderer: Renderer) -> None:
    cam = camera()
    stage = new_stage()
    box(stage, "/World/Road", (-5, -8, -0.1), (80, 8, 0), cls="road")
    for i, (x, y) in enumerate([(9.0, -1.5), (12.0, 1.8), (16.0, -0.5)]):
        obj(stage, f"car_{i}", "car", (x, y, 0))
        box(stage, f"/World/Objects/car_{i}/body", (-2, -0.9, 0), (2, 0.9, 1.5))
        box(stage, f"/World/Objects/car_{i}/roof", (-1, -0.8, 1.5), (1, 0.8, 2.0))
    obj(stage, "person_0", "person", (7.0, 3.0, 0))
    box(stage, "/World/Objects/person_0/body", (-0.3, -0.3, 0), (0.3, 0.3, 1.8))
    obj(stage, "tree_0", "tree", (20.0, -5.0, 0))
    box(stage, "/World/Objects/tree_0/crown", (-1.5, -1.5, 0), (1.5, 1.5, 6))
    obj(stage, "tree_1", "tree", (25.0, -5.0, 0))
    box(stage, "/World/Objects/tree_1/crown", (-1.5, -1.5, 0), (1.5, 1.5, 6))
    scene = RenderScene.from_stage(stage)
    assert [o.instance_id for o in scene.objects] == [26000, 26001, 26002, 24000, 21, 21]
    result = renderer.render(scene, cam.K, cam.world_from_cam())
    assert set(np.unique(result.class_ids)) == {0, 7, 21, 24, 26}
    assert set(np.unique(result.instance_ids)) == {0, 7, 21, 24000, 26000, 26001, 26002}
    assert set(np.unique(result.object_ids)) == {0, 1, 2, 3, 4, 5, 6}
    things = result.instance_ids >= 1000
    assert np.array_equal(result.instance_ids[things] // 1000, result.class_ids[things])
    assert np.array_equal(result.instance_ids[~things], result.class_ids[~things])
    for o in scene.objects:  # every object pixel carries its object's ids
        m = result.object_ids == o.index
        assert m.any()
        assert np.all(result.class_ids[m] == o.label_id) and np.all(result.instance_ids[m] == o.instance_id)
    assert np.all((result.class_ids == 0) == (result.depth_m == 0))
    # The sky and the lit pass agree with the labels: sky pixels are blue-ish.
    sky = result.class_ids == 0
    assert np.all(result.rgb[sky][:, 2] > result.rgb[sky][:, 0])


def test_shadowed_road_pixel_is_darker_than_a_lit_one() -> None:
    cam = camera(pitch=0.12, roll=0.0, yaw=0.0)
    sun = sun_direction(150.0, 40.0)
    stage = new_stage()
    box(stage, "/World/Road", (-5, -10, -0.1), (60, 10, 0), color=(0.3, 0.3, 0.3), cls="road")
    box(stage, "/World/Wall", (12, -0.5, 0), (12.5, 0.5, 3.0), cls="building")
    # A road point whose sun ray passes through the middle of the wall.
    through = np.array([12.25, 0.0, 1.5])
    shadow_pt = through - sun * (1.5 / sun[2])
    lit_pt = np.array([shadow_pt[0], shadow_pt[1] - 4.0, 0.0])
    with Renderer(W, H, lighting=Lighting(sun_direction_world=sun)) as r:
        result = r.render(RenderScene.from_stage(stage), cam.K, cam.world_from_cam())
    (us, vs), (ul, vl) = np.rint(cam.project(np.stack([shadow_pt, lit_pt]))[0]).astype(int)
    assert result.class_ids[vs, us] == 7 and result.class_ids[vl, ul] == 7
    dark, bright = result.rgb[vs, us].astype(int).sum(), result.rgb[vl, ul].astype(int).sum()
    assert dark < 0.75 * bright, (dark, bright)


def test_clearing_integer_targets_gives_zero(renderer: Renderer) -> None:
    cam = camera()
    stage = new_stage()
    box(stage, "/World/Near", (5, -20, -20), (6, 20, 20), cls="car")
    full = renderer.render_labels(RenderScene.from_stage(stage), cam.K, cam.world_from_cam())
    assert np.all(full[0] == 26)
    empty = renderer.render_labels(RenderScene.from_stage(new_stage()), cam.K, cam.world_from_cam())
    for image in empty:
        assert not image.any()


# -- composition -----------------------------------------------------------------------------


def test_inactive_invisible_and_variants(renderer: Renderer, tmp_path) -> None:
    cam = camera()
    asset = Usd.Stage.CreateNew(str(tmp_path / "thing.usda"))
    UsdGeom.SetStageUpAxis(asset, UsdGeom.Tokens.z)
    root = UsdGeom.Xform.Define(asset, "/thing").GetPrim()
    asset.SetDefaultPrim(root)
    label(root, "car")
    UsdGeom.Xform.Define(asset, "/thing/Geom")
    vset = root.GetVariantSets().AddVariantSet("model")
    for name, top in (("low", 0.5), ("tall", 3.0)):
        vset.AddVariant(name)
        vset.SetVariantSelection(name)
        with vset.GetVariantEditContext():
            box(asset, f"/thing/Geom/{name}_body", (-1, -1, 0), (1, 1, top))
    vset.SetVariantSelection("low")
    asset.Save()

    stage = new_stage()
    for i, y in enumerate((-2.5, 0.0, 2.5)):
        prim = obj(stage, f"thing_{i}", "car", (10.0, y, 0.0)).GetPrim()
        prim.GetReferences().AddReference(str(tmp_path / "thing.usda"))
    stage.GetPrimAtPath("/World/Objects/thing_1").SetActive(False)
    UsdGeom.Imageable(stage.GetPrimAtPath("/World/Objects/thing_2")).MakeInvisible()
    scene = RenderScene.from_stage(stage)
    assert [o.path for o in scene.objects] == ["/World/Objects/thing_0"]
    low = renderer.render_labels(scene, cam.K, cam.world_from_cam())
    assert set(np.unique(low[2])) == {0, 1}

    stage.GetPrimAtPath("/World/Objects/thing_0").GetVariantSet("model").SetVariantSelection("tall")
    tall = renderer.render_labels(RenderScene.from_stage(stage), cam.K, cam.world_from_cam())
    assert (tall[0] == 26).sum() > 1.5 * (low[0] == 26).sum()


def test_instance_proxies_render(renderer: Renderer) -> None:
    cam = camera()
    stage = new_stage()
    for i, y in enumerate((-2.0, 2.0)):
        xf = obj(stage, f"car_{i}", "car", (10.0, y, 0.0))
        xf.GetPrim().GetReferences().AddInternalReference("/Proto")
        xf.GetPrim().SetInstanceable(True)
    proto = stage.DefinePrim("/Proto", "Xform")
    proto.SetSpecifier(Sdf.SpecifierClass)
    box(stage, "/Proto/body", (-1, -0.8, 0), (1, 0.8, 1.4))
    scene = RenderScene.from_stage(stage)
    result = renderer.render_labels(scene, cam.K, cam.world_from_cam())
    assert set(np.unique(result[1])) == {0, 26000, 26001}


def test_material_diffuse_wins_over_display_color_and_units_convert() -> None:
    stage = new_stage()
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)  # centimetres
    mesh = box(stage, "/World/Box", (0, 0, 0), (100, 100, 100), color=(0.0, 1.0, 0.0))
    mat = UsdShade.Material.Define(stage, "/World/Looks/Red")
    shader = UsdShade.Shader.Define(stage, "/World/Looks/Red/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.8, 0.1, 0.05))
    mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    scene = RenderScene.from_stage(stage)
    np.testing.assert_allclose(scene.colors, np.tile([0.8, 0.1, 0.05], (36, 1)), atol=1e-6)
    np.testing.assert_allclose(scene.bounds_world(), [[0, 0, 0], [1, 1, 1]], atol=1e-6)
    assert np.all(scene.class_ids == 0)  # unlabelled -> void


def test_passes_do_not_leak_state_between_scenes(renderer: Renderer) -> None:
    # Regression: the shadow pass once left its 2048x2048 viewport on the label framebuffer.
    cam = camera()
    a, b = new_stage(), new_stage()
    box(a, "/World/A", (8, -1, 0), (9, 1, 2), cls="car")
    box(b, "/World/B", (10, -3, 0), (11, -1, 1), cls="building")
    scene_a, scene_b = RenderScene.from_stage(a), RenderScene.from_stage(b)
    K, T = cam.K, cam.world_from_cam()
    with Renderer(W, H) as fresh:
        expected = fresh.render(scene_b, K, T)
    renderer.render_labels(scene_a, K, T)
    renderer.render_rgb(scene_a, K, T)
    got = renderer.render(scene_b, K, T)
    assert np.array_equal(got.class_ids, expected.class_ids) and (got.class_ids == 11).sum() > 50
    assert np.array_equal(got.depth_m, expected.depth_m)
    assert np.array_equal(got.rgb, expected.rgb)
