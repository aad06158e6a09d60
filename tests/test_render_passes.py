"""Renderer.render: the label pass's depth is the colour pass's depth pre-pass."""

from __future__ import annotations

import numpy as np
import pytest
from test_render import box, camera, new_stage

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.render import Lighting, Renderer, RenderScene, renderer as renderer_module, sun_direction

W, H = 320, 200


def _street_with_ties() -> RenderScene:
    """Boxes that hide each other, and two pairs that share a face (depth ties)."""
    stage = new_stage()
    box(stage, "/World/Road", (-5, -10, -0.1), (60, 10, 0), color=(0.3, 0.3, 0.3), cls="road")
    box(stage, "/World/Walk", (-5, 4, -0.1), (60, 10, 0), color=(0.5, 0.4, 0.3), cls="sidewalk")  # coplanar top
    box(stage, "/World/Wall", (12, -0.5, 0), (12.5, 0.5, 3.0), color=(0.6, 0.5, 0.5), cls="building")
    box(stage, "/World/Car", (8, -1.5, 0), (12, 1.0, 1.5), color=(0.2, 0.3, 0.8), cls="car")  # touches the wall
    box(stage, "/World/Post", (6, 2.0, 0), (6.2, 2.2, 2.0), color=(0.7, 0.7, 0.7), cls="pole")
    return RenderScene.from_stage(stage)


def test_render_shades_against_the_label_depth_and_matches_the_separate_passes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    cam = camera(K=np.array([[260.0, 0.0, 161.3], [0.0, 250.0, 83.6], [0.0, 0.0, 1.0]]), pitch=0.1, roll=0.02)
    scene = _street_with_ties()
    drawn: list[str] = []
    draw = renderer_module._SceneBuffers.draw
    monkeypatch.setattr(
        renderer_module._SceneBuffers, "draw", lambda self, ctx, name: (drawn.append(name), draw(self, ctx, name))
    )
    lighting = Lighting(sun_direction_world=sun_direction(20.0, 30.0))
    with Renderer(W, H, lighting=lighting, occlusion_cull=False) as r:
        together = r.render(scene, cam.K, cam.world_from_cam())
        assert drawn == ["label", "shadow", "lit"]  # no depth pre-pass of its own
        rgb = r.render_rgb(scene, cam.K, cam.world_from_cam())
        labels = r.render_labels(scene, cam.K, cam.world_from_cam())
    assert drawn[3:] == ["depth", "lit", "label"]
    assert np.array_equal(together.rgb, rgb)
    for mine, alone in zip(
        (together.class_ids, together.instance_ids, together.object_ids, together.depth_m), labels, strict=True
    ):
        assert mine.tobytes() == alone.tobytes()
    assert set(np.unique(together.class_ids)) >= {7, 8, 11, 17, 26}  # every box shows
    assert len(np.unique(together.rgb.reshape(-1, 3), axis=0)) > 50


def test_a_sun_of_no_light_draws_no_shadow_map_and_changes_no_pixel(monkeypatch: pytest.MonkeyPatch) -> None:
    cam = camera(K=np.array([[260.0, 0.0, 161.3], [0.0, 250.0, 83.6], [0.0, 0.0, 1.0]]), pitch=0.1, roll=0.02)
    scene = _street_with_ties()
    overcast = Lighting(sun_direction_world=sun_direction(20.0, 30.0), sun_color=np.zeros(3))
    drawn: list[str] = []
    draw = renderer_module._SceneBuffers.draw
    monkeypatch.setattr(
        renderer_module._SceneBuffers, "draw", lambda self, ctx, name: (drawn.append(name), draw(self, ctx, name))
    )
    with Renderer(W, H, lighting=overcast, occlusion_cull=False) as r:
        ambient = r.render(scene, cam.K, cam.world_from_cam())
    assert drawn == ["label", "lit_ambient"]
    # The full lit shader with its sun terms times a zero sun colour (and a drawn shadow map).
    monkeypatch.setattr(renderer_module.shaders, "LIT_AMBIENT_FS", renderer_module.shaders.LIT_FS)
    monkeypatch.setattr(renderer_module, "_sunlit", lambda lighting: True)
    with Renderer(W, H, lighting=overcast, occlusion_cull=False) as r:
        full = r.render(scene, cam.K, cam.world_from_cam())
    assert "shadow" in drawn[2:]
    assert np.array_equal(ambient.rgb, full.rgb)
    assert len(np.unique(ambient.rgb.reshape(-1, 3), axis=0)) > 20
