"""The lit pass's shadow filter: four bilinear depth comparisons give the 3x3 PCF's weights."""

from __future__ import annotations

import re

import numpy as np
import pytest
from test_render import box, camera, new_stage

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.render import Lighting, Renderer, RenderScene, shaders, sun_direction

#: The filter as it was: nine bilinear comparisons at whole-texel offsets (the reference).
NINE_TAPS = """float sun_visibility(vec3 n) {
    vec4 p = u_sun_vp * vec4(v_pos + n * u_normal_offset, 1.0);
    vec3 s = p.xyz / p.w * 0.5 + 0.5;
    if (s.x < 0.0 || s.x > 1.0 || s.y < 0.0 || s.y > 1.0) return 1.0;
    float ref = s.z - 5e-4;
    float texel = 1.0 / u_map_size;
    float sum = 0.0;
    for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
            sum += texture(u_shadow_map, vec3(s.xy + vec2(dx, dy) * texel, ref));
    return sum / 9.0;
}
"""

W, H = 320, 200


def _shadowed_street() -> RenderScene:
    stage = new_stage()
    box(stage, "/World/Road", (-5, -10, -0.1), (60, 10, 0), color=(0.3, 0.3, 0.3), cls="road")
    box(stage, "/World/Wall", (12, -0.5, 0), (12.5, 0.5, 3.0), cls="building")
    box(stage, "/World/Post", (8, 2.0, 0), (8.2, 2.2, 2.0), cls="pole")
    return RenderScene.from_stage(stage)


def _render(lit_fs: str | None, monkeypatch: pytest.MonkeyPatch) -> np.ndarray:
    if lit_fs is not None:
        monkeypatch.setattr(shaders, "LIT_FS", lit_fs)
    cam = camera(K=np.array([[260.0, 0.0, 161.3], [0.0, 250.0, 83.6], [0.0, 0.0, 1.0]]), pitch=0.12, roll=0.0, yaw=0.0)
    # A coarse map (128 texels over the view's box) widens the penumbra to many pixels.
    lighting = Lighting(sun_direction_world=sun_direction(20.0, 20.0), shadow_map_size=128)
    with Renderer(W, H, lighting=lighting) as r:
        return r.render_rgb(_shadowed_street(), cam.K, cam.world_from_cam()).astype(int)


def test_four_tap_shadow_filter_matches_the_nine_tap_pcf(monkeypatch: pytest.MonkeyPatch) -> None:
    assert shaders.LIT_FS.count("texture(u_shadow_map") == 4  # one fetch per 2x2 texels
    reference_fs = re.sub(r"float sun_visibility\(vec3 n\) \{.*?\n\}\n", NINE_TAPS, shaders.LIT_FS, flags=re.S)
    assert reference_fs.count("texture(u_shadow_map") == 1
    new = _render(None, monkeypatch)
    reference = _render(reference_fs, monkeypatch)
    unshadowed_fs = shaders.LIT_FS.replace("? sun_visibility(n) :", "? 1.0 :")
    unshadowed = _render(unshadowed_fs, monkeypatch)
    shade = reference[..., 0] / np.maximum(unshadowed[..., 0], 1)  # 1 lit, lower in shadow
    in_shadow = shade < 0.98
    assert in_shadow.sum() > 500, "the scene must have shadows"
    assert len(np.unique(np.round(shade[in_shadow], 2))) > 20, "and penumbrae"
    diff = np.abs(new - reference)
    assert diff.max() <= 1  # float rounding of the weights only
    assert np.mean(diff > 0) < 0.01
