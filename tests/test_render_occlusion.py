"""Renderer.render leaves hidden instances out of the camera's passes, and the pixels stay the same."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_render import box, camera, new_stage

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.parameters.rendering import RenderingParams
from usdworld.render import Lighting, Renderer, RenderScene, renderer as renderer_module, sun_direction
from usdworld.render.camera import gl_projection, gl_view
from usdworld.render.occlusion import DEPTH_MARGIN, DepthPyramid, hidden, occluders, project_boxes

W, H = 320, 200
K = np.array([[260.0, 0.0, 161.3], [0.0, 250.0, 83.6], [0.0, 0.0, 1.0]])
#: The boxes behind the wall, none of whose points the camera sees.
BEHIND = 7


def _walled_street(behind: bool = True) -> RenderScene:
    """A wall across the street with small boxes behind it (casting shadows beside it), a pole
    that shows above it, a box touching its back and one whose front is flush with its front."""
    stage = new_stage()
    box(stage, "/World/Road", (-5, -15, -0.1), (80, 15, 0), color=(0.3, 0.3, 0.3), cls="road")
    box(stage, "/World/Objects/wall", (10, -3, 0), (10.5, 3, 4), color=(0.6, 0.5, 0.5), cls="building")
    box(stage, "/World/Objects/pole", (20, -0.2, 0), (20.4, 0.2, 12), color=(0.7, 0.7, 0.7), cls="pole")
    box(stage, "/World/Objects/flush", (10, 2.5, 0), (10.4, 3.5, 1), color=(0.2, 0.7, 0.2), cls="car")
    # the same box again: every one of its pixels is a tie of depth, which the first drawn wins
    box(stage, "/World/Objects/twin", (10, 2.5, 0), (10.4, 3.5, 1), color=(0.9, 0.1, 0.9), cls="person")
    if behind:
        box(stage, "/World/Objects/touch", (10.5, -0.5, 0), (11, 0.5, 1), color=(0.8, 0.2, 0.2), cls="car")
        for k in range(BEHIND - 1):
            x, y = 14.0 + 3.0 * (k // 2), (-1.2, 0.4)[k % 2]
            lo, hi = (x, y, 0), (x + 2, y + 0.8, 1)
            box(stage, f"/World/Objects/car{k}", lo, hi, color=(0.2, 0.3, 0.8), cls="car")
    return RenderScene.from_stage(stage)


def test_hidden_instances_are_left_out_of_the_camera_passes_with_the_same_pixels(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    cam = camera(K=K, pitch=0.05, roll=0.0, yaw=0.0)
    low_sun = Lighting(sun_direction_world=sun_direction(60.0, 12.0))
    scene = _walled_street()
    drawn: list[str] = []
    kept: list[float] = []  # the nearest depth the label pass starts from
    renderers: list[Renderer] = []
    draw = renderer_module._SceneBuffers.draw

    def spy(self: renderer_module._SceneBuffers, ctx: object, name: str) -> None:
        drawn.append(name)
        if name.startswith("label"):
            raw = renderers[-1]._label_fbo.read(components=1, attachment=-1, dtype="f4", alignment=1)
            kept.append(float(np.frombuffer(raw, dtype=np.float32).min()))
        draw(self, ctx, name)

    monkeypatch.setattr(renderer_module._SceneBuffers, "draw", spy)
    every = RenderingParams(occlusion_min_triangles_per_px=0.0)
    with Renderer(W, H, lighting=low_sun, occlusion_cull=False) as r:
        renderers.append(r)
        full = r.render(scene, cam.K, cam.world_from_cam())
        without_behind = r.render(_walled_street(behind=False), cam.K, cam.world_from_cam())
    assert kept == [1.0, 1.0]  # drawn from a cleared depth buffer, first to last
    with Renderer(W, H, lighting=low_sun, rendering=every) as r:
        renderers.append(r)
        drawn.clear()
        kept.clear()
        culled = r.render(scene, cam.K, cam.world_from_cam())
        shown, total = r.last_shown
        # the occluders' depth first; the labels keep it (hidden fragments fail its test), last to first
        assert drawn == ["depth", "label_last_first", "shadow", "lit"]
        assert kept[0] < 1.0
        # the twin never wins a pixel (the car drawn before it ties with it everywhere): its object
        # wins none, and the colour pass leaves it out
        assert r.last_colored == shown - 1
        again = r.render_labels(scene, cam.K, cam.world_from_cam())  # every instance again
    assert total - shown == BEHIND  # the touching box and the six behind; the pole and the flush box stay
    for name in ("rgb", "class_ids", "instance_ids", "object_ids", "depth_m"):
        assert getattr(culled, name).tobytes() == getattr(full, name).tobytes(), name
    ids = (full.class_ids, full.instance_ids, full.object_ids, full.depth_m)
    for mine, alone in zip(ids, again, strict=True):
        assert mine.tobytes() == alone.tobytes()
    # the hidden boxes' shadows show beside the wall: the shadow map still holds them
    assert not np.array_equal(without_behind.rgb, full.rgb)
    assert np.array_equal(without_behind.object_ids, full.object_ids)
    assert set(np.unique(full.class_ids)) >= {7, 11, 17, 26}
    assert 24 not in full.class_ids  # the twin ties with the car drawn before it everywhere: the car shows


def test_the_occlusion_test_of_every_batch_at_once_gives_each_batch_its_own_answer() -> None:
    """One set of array operations over all the batches' boxes (``_SceneBuffers.instance_boxes``)
    gives, batch by batch, what testing each batch on its own against the same depth gives."""
    cam = camera(K=K, pitch=0.05, roll=0.0, yaw=0.0)
    T = cam.world_from_cam()
    scene = _walled_street()
    every = RenderingParams(occlusion_min_triangles_per_px=0.0)
    with Renderer(W, H, rendering=every) as r:
        buffers = r._upload(scene)
        corners, triangles = buffers.instance_boxes()
        assert len(buffers.batches) > 5
        per_batch = [b.corners_world() for b in buffers.batches]
        assert corners.tobytes() == np.concatenate(per_batch).tobytes()
        counts = [np.full(b.n_instances, b.batch.n_corners // 3) for b in buffers.batches]
        assert np.array_equal(triangles, np.concatenate(counts))
        shown = r._unhidden(scene, buffers, cam.K, T)
        raw = r._color_fbo.read(components=1, attachment=-1, dtype="f4", alignment=1)
        view_proj = r._view_proj(scene, cam.K, T)
        batches = list(buffers.batches)  # closing the renderer releases them
    pyramid = DepthPyramid(np.frombuffer(raw, dtype=np.float32).reshape(H, W)[::-1])
    assert shown is not None and len(shown) == len(batches)
    for b, mine in zip(batches, shown, strict=True):
        rect, depth, front = project_boxes(b.corners_world(), view_proj, W, H, r.near_m)
        occ = occluders(rect, front, b.batch.n_corners // 3, every.occluder_px_per_triangle, W * H)
        assert mine.dtype == bool and np.array_equal(mine, ~hidden(rect, depth, front, pyramid))
        assert not np.any(occ & ~mine)  # no occluder here (road, wall, flush, twin) is hidden
    assert sum(int((~m).sum()) for m in shown) == BEHIND


def test_a_scene_of_few_triangles_per_pixel_is_not_tested() -> None:
    cam = camera(K=K, pitch=0.05, roll=0.0, yaw=0.0)
    scene = _walled_street()
    assert scene.n_triangles < RenderingParams().occlusion_min_triangles_per_px * W * H
    with Renderer(W, H) as r:
        r.render(scene, cam.K, cam.world_from_cam())
        assert r.last_shown == (r.last_shown[1], len(scene.part_order))


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 40),
    st.integers(1, 40),
    st.integers(0, 2**31 - 1),
    st.lists(st.tuples(*[st.floats(0, 1)] * 4), min_size=1, max_size=20),
)
def test_the_pyramid_bounds_the_depth_over_every_rectangle(h: int, w: int, seed: int, rects: list) -> None:
    depth = np.random.default_rng(seed).random((h, w), dtype=np.float32)
    pyramid = DepthPyramid(depth)
    r = np.array(
        [
            [min(int(a * w), w - 1), min(int(b * h), h - 1), min(int(c * w), w - 1), min(int(d * h), h - 1)]
            for a, b, c, d in rects
        ]
    )
    r = np.concatenate([np.minimum(r[:, :2], r[:, 2:]), np.maximum(r[:, :2], r[:, 2:])], axis=1)
    bound = pyramid.max_over(r)
    exact = np.array([depth[y0 : y1 + 1, x0 : x1 + 1].max() for x0, y0, x1, y1 in r])
    assert np.all(bound >= exact)
    one = r[:, [0, 1, 0, 1]]
    assert np.array_equal(pyramid.max_over(one), depth[one[:, 1], one[:, 0]])  # a pixel is exact


def _corners(lo: tuple[float, ...], hi: tuple[float, ...]) -> np.ndarray:
    return np.array([[[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]])


def test_a_box_is_hidden_only_behind_the_depth_by_the_margin_and_in_front_of_the_near_plane() -> None:
    cam = camera(K=K, pitch=0.0, roll=0.0, yaw=0.0)
    T = cam.world_from_cam()
    near, far = 0.1, 100.0
    view_proj = gl_projection(K, W, H, near, far) @ gl_view(T)
    ahead = T[:3, 3] + T[:3, 2] * 20.0  # 20 m along the optical axis
    lo, hi = tuple(ahead - 0.5), tuple(ahead + 0.5)
    rect, d, front = project_boxes(_corners(lo, hi), view_proj, W, H, near)
    assert front[0] and rect[0, 0] <= W // 2 <= rect[0, 2]
    walls = ((d[0] - 1e-3, True), (d[0] - 0.5 * DEPTH_MARGIN, False), (d[0], False), (1.0, False))
    for wall, is_hidden in walls:
        pyramid = DepthPyramid(np.full((H, W), wall, dtype=np.float32))
        assert hidden(rect, d, front, pyramid)[0] == is_hidden
    # a box reaching behind the camera is never hidden; one wholly off the image always is
    wall = DepthPyramid(np.zeros((H, W), dtype=np.float32))
    rect, d, front = project_boxes(_corners(tuple(T[:3, 3] - 1.0), hi), view_proj, W, H, near)
    assert not front[0] and not hidden(rect, d, front, wall)[0]
    side = ahead + T[:3, 0] * 30.0  # 30 m to the right at 20 m: outside the image
    rect, d, front = project_boxes(_corners(tuple(side - 0.5), tuple(side + 0.5)), view_proj, W, H, near)
    assert front[0] and hidden(rect, d, front, DepthPyramid(np.ones((H, W), dtype=np.float32)))[0]


def _long_street() -> RenderScene:
    """A road 600 m long with boxes along it: the near ones inside the sun's shadow box (which
    follows the view up to 120 m), the far ones beyond its sides (the camera still sees them)."""
    stage = new_stage()
    box(stage, "/World/Road", (-5, -15, -0.1), (600, 15, 0), color=(0.3, 0.3, 0.3), cls="road")
    for k, x in enumerate((12.0, 25.0, 40.0, 60.0, 250.0, 320.0, 400.0, 480.0)):
        y = (-4.0, 3.0)[k % 2]
        lo, hi = (x, y, 0), (x + 4, y + 2, 6)
        box(stage, f"/World/Objects/b{k}", lo, hi, color=(0.5, 0.4, 0.3), cls="building")
    return RenderScene.from_stage(stage)


def test_instances_beyond_the_sides_of_the_suns_box_are_left_out_of_the_shadow_map_with_the_same_pixels(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    cam = camera(K=K, pitch=0.02, roll=0.0, yaw=0.0)
    sun = Lighting(sun_direction_world=sun_direction(150.0, 35.0))
    scene = _long_street()
    with Renderer(W, H, lighting=sun) as r:
        culled = r.render(scene, cam.K, cam.world_from_cam())
        sunlit = r.last_sunlit
    monkeypatch.setattr(renderer_module, "outside_clip_sides", lambda c, vp, m: np.zeros(len(c), dtype=bool))
    with Renderer(W, H, lighting=sun) as r:
        full = r.render(scene, cam.K, cam.world_from_cam())
        assert r.last_sunlit == sum(b.n_instances for b in scene.batches) > sunlit
    total = sum(b.n_instances for b in scene.batches)
    assert sunlit <= total - 4  # the four far boxes at least
    seen = set(np.unique(full.object_ids).tolist())
    assert {5, 6} <= seen  # far boxes the camera shows but the shadow map leaves out
    for name in ("rgb", "class_ids", "instance_ids", "object_ids", "depth_m"):
        assert getattr(culled, name).tobytes() == getattr(full, name).tobytes(), name
    # the near boxes' shadows show: a map without the instances inside the sun's box differs
    monkeypatch.setattr(renderer_module, "outside_clip_sides", lambda c, vp, m: np.ones(len(c), dtype=bool))
    with Renderer(W, H, lighting=sun) as r:
        assert not np.array_equal(r.render(scene, cam.K, cam.world_from_cam()).rgb, full.rgb)


@settings(max_examples=200, deadline=None)
@given(
    data=st.data(),
    lo=st.tuples(*[st.floats(-50.0, 50.0)] * 3),
    size=st.tuples(*[st.floats(0.01, 20.0)] * 3),
)
def test_a_box_beyond_a_side_of_the_clip_box_holds_only_points_beyond_it(data, lo, size) -> None:
    from usdworld.render.occlusion import outside_clip_sides

    scale = data.draw(st.floats(0.01, 0.1))
    shift = data.draw(st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)))
    vp = np.diag([scale, scale * 1.3, 0.01, 1.0])
    vp[:2, 3] = shift
    lo_a = np.array(lo)
    hi_a = lo_a + np.array(size)
    corners = np.array(
        [[x, y, z] for x in (lo_a[0], hi_a[0]) for y in (lo_a[1], hi_a[1]) for z in (lo_a[2], hi_a[2])]
    )
    out = outside_clip_sides(corners[None], vp, 0.0)[0]
    rng = np.random.default_rng(0)
    pts = lo_a + rng.random((64, 3)) * (hi_a - lo_a)
    clip = pts @ vp[:3, :3].T + vp[:3, 3]
    inside_any = np.any(np.all(np.abs(clip[:, :2]) <= 1.0, axis=1))
    if out:
        assert not inside_any
    if inside_any:
        assert not out


def test_a_surface_at_the_far_planes_depth_keeps_the_cleared_label_pass(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A wall 60 km out: its window depth lies within a step of the far plane's 1, where a "<=" test
    from the occluders' depth could pass what a "<" test from a cleared buffer does not; such a
    scene's labels are drawn from a cleared buffer, as without the occlusion test."""
    cam = camera(K=K, pitch=0.0, roll=0.0, yaw=0.0)
    stage = new_stage()
    box(stage, "/World/Road", (-5, -15, -0.1), (80, 15, 0), color=(0.3, 0.3, 0.3), cls="road")
    box(stage, "/World/Objects/wall", (10, -3, 0), (10.5, 3, 4), color=(0.6, 0.5, 0.5), cls="building")
    box(stage, "/World/Objects/far", (60000, -8000, -2000), (60010, 8000, 4000), cls="building")
    scene = RenderScene.from_stage(stage)
    drawn: list[str] = []
    draw = renderer_module._SceneBuffers.draw
    monkeypatch.setattr(
        renderer_module._SceneBuffers,
        "draw",
        lambda self, ctx, name: (drawn.append(name), draw(self, ctx, name)),
    )
    with Renderer(W, H, occlusion_cull=False) as r:
        full = r.render(scene, cam.K, cam.world_from_cam())
    with Renderer(W, H, rendering=RenderingParams(occlusion_min_triangles_per_px=0.0)) as r:
        drawn.clear()
        culled = r.render(scene, cam.K, cam.world_from_cam())
    assert drawn[:2] == ["depth", "label"]
    with Renderer(W, H) as r:
        assert not r._below_far(scene, cam.world_from_cam())
        assert r._below_far(_walled_street(), cam.world_from_cam())
    for name in ("rgb", "class_ids", "instance_ids", "object_ids", "depth_m"):
        assert getattr(culled, name).tobytes() == getattr(full, name).tobytes(), name
