"""``Renderer(near_first=True)``: the colour pass without a depth pre-pass, near surfaces first."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom
from test_render import H, W, box, camera, label, new_stage, obj, quad

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.render import Lighting, Renderer, RenderScene, sun_direction

K = np.array([[200.0, 0.0, 121.3], [0.0, 190.0, 71.6], [0.0, 0.0, 1.0]])
LIGHTING = Lighting(sun_direction_world=sun_direction(20.0, 35.0), shadow_map_size=512)


def _asset(path, panel_first: bool) -> str:
    """A box with a panel lying on its front face (coplanar: the two tie in depth there)."""
    asset = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(asset, UsdGeom.Tokens.z)
    root = UsdGeom.Xform.Define(asset, "/thing").GetPrim()
    asset.SetDefaultPrim(root)
    label(root, "car")
    panel = np.array([[-1, -0.6, 0.4], [-1, 0.6, 0.4], [-1, 0.6, 1.4], [-1, -0.6, 1.4]], float)
    parts = [
        lambda: box(asset, "/thing/Body", (-1, -1, 0), (1, 1, 2), color=(0.8, 0.1, 0.1)),
        lambda: quad(asset, "/thing/Panel", panel, "car").CreateDisplayColorAttr([Gf.Vec3f(0.1, 0.2, 0.9)]),
    ]
    for make in parts[::-1] if panel_first else parts:
        make()
    asset.Save()
    return str(path)


def _street(tmp_path, panel_first: bool) -> RenderScene:
    """The road and five of the asset along it, the farthest first in the scene's order."""
    ref = _asset(tmp_path / f"thing_{panel_first}.usda", panel_first)
    stage = new_stage()
    box(stage, "/World/Road", (-5, -12, -0.1), (60, 12, 0), color=(0.3, 0.3, 0.3), cls="road")
    for i, x in enumerate((40.0, 9.0, 22.0, 14.0, 30.0)):
        xf = obj(stage, f"thing_{i}", "car", (x, -3.0 + 1.5 * i, 0.0))
        xf.AddRotateZOp().Set(8.0 * i - 10.0)
        xf.GetPrim().GetReferences().AddReference(ref)
    box(stage, "/World/Objects/wall", (50, -8, 0), (52, 8, 6), color=(0.6, 0.5, 0.4), cls="building")
    return RenderScene.from_stage(stage)


def _pose(yaw: float) -> np.ndarray:
    return camera(K=K, height_m=1.6, pitch=0.08, roll=0.0, yaw=yaw).world_from_cam()


def test_near_first_shows_the_same_pixels_as_the_depth_pre_pass(tmp_path) -> None:
    """Every pixel is the pre-pass's, also where the panel and its box tie in depth: whichever of
    the two comes first in the scene's order wins there, as after a pre-pass (one asset's parts
    are drawn together, last to first, under "<=")."""
    poses = [_pose(yaw) for yaw in (0.0, 0.15, -0.2)]
    frames = {}
    for panel_first in (True, False):
        scene = _street(tmp_path, panel_first)
        for near_first in (True, False):
            with Renderer(W, H, lighting=LIGHTING, cull_back_faces=True, near_first=near_first) as r:
                frames[panel_first, near_first] = np.array([r.render_rgb(scene, K, pose) for pose in poses])
        assert np.array_equal(frames[panel_first, True], frames[panel_first, False])
    # the ties are there: the scene's order of the two parts decides hundreds of pixels
    assert np.any(frames[True, True] != frames[False, True], axis=3).sum() > 100


def test_near_first_draws_the_nearest_asset_and_instance_first(tmp_path) -> None:
    """The asset's batches go before the farther wall (which is first in the scene's order among
    the objects), its parts last to first, and its instances nearest first."""
    scene = _street(tmp_path, panel_first=True)
    with Renderer(W, H, lighting=LIGHTING, near_first=True) as r:
        r.render_rgb(scene, K, _pose(0.0))
        buffers = r._buffers
        order = buffers.last_order
        names = [buffers.batches[i].batch.n_instances for i in order]
        assert names[:2] == [5, 5] and sorted(order[:2]) == order[:2][::-1]  # the asset, last to first
        asset = buffers.batches[order[0]]
        eye = _pose(0.0)[:3, 3]
        dist = np.linalg.norm(asset.centres_world() - eye, axis=1)
        drawn = np.frombuffer(asset._camera[1].read(), dtype=asset._records.dtype)
        expect = asset._records[np.argsort(dist)]
        assert np.array_equal(drawn["rows"], expect["rows"])
        assert np.all(np.diff(dist[np.argsort(dist)]) > 0)
        r.render_rgb(scene, K, _pose(0.0))
        assert r._buffers.last_order == order
    with Renderer(W, H, lighting=LIGHTING) as r:
        r.render_rgb(scene, K, _pose(0.0))
        assert r._buffers.last_order is None  # the pre-pass draws in the scene's order


def test_stills_and_near_first_frames_share_a_renderer(tmp_path) -> None:
    """``render`` (its label pass's depth, instances shown after the occlusion test) and
    ``render_rgb`` near first, one after the other on one renderer, give what fresh renderers do:
    the lit pass's instance order is put back for the still."""
    scene = _street(tmp_path, panel_first=False)
    pose = _pose(0.1)
    with Renderer(W, H, lighting=LIGHTING) as r:
        still = r.render(scene, K, pose)
    with Renderer(W, H, lighting=LIGHTING, near_first=True) as r:
        frame = r.render_rgb(scene, K, pose)
    with Renderer(W, H, lighting=LIGHTING, near_first=True) as r:
        for _ in range(2):
            assert np.array_equal(r.render(scene, K, pose).rgb, still.rgb)
            for b in r._buffers.batches:  # the still's lit pass draws the instances last to first
                assert b._camera[1].read() == b._records[::-1].tobytes()
            assert np.array_equal(r.render(scene, K, pose).object_ids, still.object_ids)
            assert np.array_equal(r.render_rgb(scene, K, pose), frame)
