"""One shadow map for a camera path over a static scene (the fly-through's frames)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_render import H, W, box, camera, new_stage

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.render import Lighting, Renderer, RenderScene, sun_direction
from usdworld.render.flythrough import flythrough_poses
from usdworld.render.lighting import path_shadow, sun_view_projection

SUN = sun_direction(150.0, 40.0)
BOUNDS = np.array([[-5.0, -10.0, -0.1], [60.0, 10.0, 3.0]])


def _street(wall: bool = True) -> RenderScene:
    stage = new_stage()
    box(stage, "/World/Road", BOUNDS[0], (BOUNDS[1, 0], BOUNDS[1, 1], 0.0), color=(0.3, 0.3, 0.3), cls="road")
    if wall:
        box(stage, "/World/Wall", (12, -0.5, 0), (12.5, 0.5, 3.0), cls="building")
    return RenderScene.from_stage(stage)


def _path() -> tuple[np.ndarray, np.ndarray]:
    cam = camera(pitch=0.12, roll=0.0, yaw=0.0)
    return cam.K, flythrough_poses(cam.world_from_cam(), 8)


def _clip_square_world(sun_vp: np.ndarray) -> np.ndarray:
    """(8, 3) world corners of a sun box's clip cube."""
    cube = np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    pts = cube @ np.linalg.inv(sun_vp).T
    return pts[:, :3] / pts[:, 3:]


@settings(max_examples=40, deadline=None)
@given(
    x=st.lists(st.floats(-20.0, 80.0), min_size=1, max_size=5),
    yaw=st.floats(-np.pi, np.pi),
    distance=st.one_of(st.none(), st.floats(5.0, 200.0)),
    size=st.sampled_from([64, 512, 2048]),
)
def test_path_box_holds_every_view_box_with_texels_no_coarser_than_the_first(x, yaw, distance, size) -> None:
    lighting = Lighting(sun_direction_world=SUN, shadow_distance_m=distance, shadow_map_size=size)
    K, _ = _path()
    poses = []
    for i, xi in enumerate(x):
        T = np.eye(4)
        c, s = np.cos(yaw + 0.7 * i), np.sin(yaw + 0.7 * i)
        T[:3, :3] = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]).T  # looking along +X
        T[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ T[:3, :3]
        T[:3, 3] = (xi, 0.3 * i, 1.5)
        poses.append(T)
    shadow = path_shadow(lighting, BOUNDS, K, np.array(poses), W, H, max_map_size=16384)
    for T in poses:
        own, _ = sun_view_projection(lighting, BOUNDS, K, T, W, H)
        corners = _clip_square_world(own)
        clip = np.c_[corners, np.ones(8)] @ shadow.sun_vp.T
        assert np.all(np.abs(clip[:, :2] / clip[:, 3:]) <= 1.0 + 1e-6)
    assert size <= shadow.map_size <= 16384
    if shadow.map_size < 16384:  # else the texture limit binds (the next test)
        assert np.all(shadow.texel_m <= shadow.first_view_texel_m * (1.0 + 1e-9))
    if len(poses) == 1:  # one view: its own box, at its own size
        own, texel = sun_view_projection(lighting, BOUNDS, K, poses[0], W, H)
        assert shadow.map_size == size
        np.testing.assert_allclose(shadow.sun_vp, own, atol=1e-12)
        assert np.max(shadow.texel_m) == pytest.approx(texel)


def test_path_box_capped_by_the_texture_limit_says_so() -> None:
    K, poses = _path()
    lighting = Lighting(sun_direction_world=SUN, shadow_map_size=64)
    shadow = path_shadow(lighting, BOUNDS, K, poses, W, H, max_map_size=64)
    assert shadow.map_size == 64
    assert np.max(shadow.texel_m / shadow.first_view_texel_m) > 1.0


def test_fixed_shadow_box_draws_the_map_once_and_keeps_the_shadows(monkeypatch: pytest.MonkeyPatch) -> None:
    scene = _street()
    K, poses = _path()
    draws = []
    with Renderer(W, H, lighting=Lighting(sun_direction_world=SUN)) as r:
        per_view = [r.render_rgb(scene, K, T) for T in poses]
        road = [r.render_labels(scene, K, T)[0] == 7 for T in poses]
        bare = [r.render_rgb(_street(wall=False), K, T) for T in poses]
        original = r._draw_shadow_map
        monkeypatch.setattr(r, "_draw_shadow_map", lambda *a: (draws.append(1), original(*a)))
        shadow = r.fix_shadow_box(scene, K, poses)
        fixed = [r.render_rgb(scene, K, T) for T in poses]
        assert len(draws) == 1
        assert r._shadow_size == shadow.map_size >= 2048
        # another scene goes back to a box that follows the view, at the lighting's map size
        r.render_rgb(_street(), K, poses[0])
        assert len(draws) == 2 and r._shadow_size == 2048
    shaded = 0
    for a, b, lit, on_road in zip(per_view, fixed, bare, road):
        # the wall's shadow on the road: the same pixels but for a few on its edge
        in_a = on_road & (a.sum(axis=2) < 0.7 * lit.sum(axis=2))
        in_b = on_road & (b.sum(axis=2) < 0.7 * lit.sum(axis=2))
        assert np.sum(in_a != in_b) <= 0.1 * max(in_a.sum(), 10), (in_a.sum(), np.sum(in_a != in_b))
        shaded += int(in_b.sum())
        d = np.abs(a.astype(int) - b.astype(int))
        assert d.mean() < 0.2 and np.mean(d.max(axis=2) > 8) < 0.01, (d.mean(), np.mean(d.max(axis=2) > 8))
    assert shaded > 500  # the path sees the shadow


# -- the colour pass shades what is seen ---------------------------------------------------


class _CountingVao:
    """Stands in for a vertex array and counts the samples its draws pass (GL occlusion query)."""

    def __init__(self, ctx, vao) -> None:
        self.ctx, self.vao, self.samples = ctx, vao, []

    def render(self, **kwargs) -> None:
        query = self.ctx.query(samples=True)
        with query:
            self.vao.render(**kwargs)
        self.samples.append(query.samples)

    def release(self) -> None:
        self.vao.release()


def test_colour_pass_shades_each_seen_pixel_once_and_ties_go_to_the_first_surface() -> None:
    cam = camera(pitch=0.12, roll=0.0, yaw=0.0)
    stage = new_stage()
    box(stage, "/World/Road", (-5, -10, -0.1), (60, 10, 0), color=(0.3, 0.3, 0.3), cls="road")
    # drawn after the road, at exactly its height: a tie the road wins in every pass
    box(stage, "/World/Patch", (5, -3, -0.1), (20, 3, 0), color=(0.9, 0.1, 0.1), cls="sidewalk")
    # far wall first, near wall last: a near-to-far draw would shade the far one where hidden
    box(stage, "/World/Far", (30, -8, 0), (31, 8, 6), color=(0.1, 0.1, 0.9), cls="building")
    box(stage, "/World/Near", (10, -2, 0), (10.5, 2, 3), color=(0.1, 0.9, 0.1), cls="wall")
    scene = RenderScene.from_stage(stage)
    with Renderer(W, H, lighting=Lighting(sun_direction_world=SUN)) as r:
        labels = r.render_labels(scene, cam.K, cam.world_from_cam())[0]
        r.render_rgb(scene, cam.K, cam.world_from_cam())  # uploads the scene
        counting = []
        for batch in r._buffers.batches:  # one mesh each here: four draws
            counting.append(_CountingVao(r._ctx, batch.vaos["lit"]))
            batch.vaos["lit"] = counting[-1]
        rgb = r.render_rgb(scene, cam.K, cam.world_from_cam())
    seen = int(np.sum(labels > 0))
    # once each, but for the few pixels where two surfaces tie in depth (both pass "<=")
    shaded = [n for c in counting for n in c.samples]
    assert len(shaded) == 4 and seen <= sum(shaded) <= 1.005 * seen, (shaded, seen)
    # where the road and the patch tie in depth, the colour shows the surface the labels show
    red = (rgb[..., 0].astype(int) - rgb[..., 1]) > 60
    assert np.any(labels == 8) and np.any(labels == 7)
    assert np.array_equal(red[(labels == 7) | (labels == 8)], labels[(labels == 7) | (labels == 8)] == 8)
