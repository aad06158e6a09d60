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


#: The 2x2 PCF written out: the four texels around the point, each compared at its centre (where
#: a bilinear comparison reads that texel alone), weighed bilinearly by the point's position.
TWO_BY_TWO = """float sun_visibility(vec3 n) {
    vec4 p = u_sun_vp * vec4(v_pos + n * u_normal_offset, 1.0);
    vec3 s = p.xyz / p.w * 0.5 + 0.5;
    if (s.x < 0.0 || s.x > 1.0 || s.y < 0.0 || s.y > 1.0) return 1.0;
    float ref = s.z - 5e-4;
    vec2 t = s.xy * u_map_size - 0.5;
    vec2 i = floor(t);
    vec2 f = t - i;
    vec2 c0 = (i + 0.5) / u_map_size;
    vec2 c1 = (i + 1.5) / u_map_size;
    return (1.0 - f.x) * (1.0 - f.y) * texture(u_shadow_map, vec3(c0.x, c0.y, ref))
         + f.x * (1.0 - f.y) * texture(u_shadow_map, vec3(c1.x, c0.y, ref))
         + (1.0 - f.x) * f.y * texture(u_shadow_map, vec3(c0.x, c1.y, ref))
         + f.x * f.y * texture(u_shadow_map, vec3(c1.x, c1.y, ref));
}
"""


def _render_taps(
    taps: int, monkeypatch: pytest.MonkeyPatch, one_tap_fs: str | None = None, lit_fs: str | None = None
) -> np.ndarray:
    """The shadowed street through ``Renderer(shadow_taps=taps)``, its lit shaders replaced if given."""
    with monkeypatch.context() as patch:
        if one_tap_fs is not None:
            patch.setattr(shaders, "LIT_BILINEAR_FS", one_tap_fs)
        if lit_fs is not None:
            patch.setattr(shaders, "LIT_FS", lit_fs)
        cam = camera(K=np.array([[260.0, 0.0, 161.3], [0.0, 250.0, 83.6], [0.0, 0.0, 1.0]]), pitch=0.12, roll=0.0, yaw=0.0)
        lighting = Lighting(sun_direction_world=sun_direction(20.0, 20.0), shadow_map_size=128)
        with Renderer(W, H, lighting=lighting, shadow_taps=taps) as r:
            return r.render_rgb(_shadowed_street(), cam.K, cam.world_from_cam()).astype(int)


def test_one_tap_shadow_filter_is_the_2x2_pcf(monkeypatch: pytest.MonkeyPatch) -> None:
    """The fly-through's filter (``shadow_taps=1``): one bilinear comparison gives the 2x2 PCF written
    out; it departs from the still's 3x3 PCF on the penumbrae only (wherever the 3x3 is fully lit it
    is within one level)."""
    assert shaders.LIT_BILINEAR_FS.count("texture(u_shadow_map") == 1
    one = _render_taps(1, monkeypatch)
    three = _render_taps(4, monkeypatch)
    unshadowed = _render_taps(4, monkeypatch, lit_fs=shaders.LIT_FS.replace("? sun_visibility(n) :", "? 1.0 :"))
    reference_fs = re.sub(r"float sun_visibility\(vec3 n\) \{.*?\n\}\n", TWO_BY_TWO, shaders.LIT_FS, flags=re.S)
    two_by_two = _render_taps(1, monkeypatch, one_tap_fs=reference_fs)
    assert np.abs(one - two_by_two).max() <= 1
    shade = three[..., 0] / np.maximum(unshadowed[..., 0], 1)  # the 3x3's: 1 lit, lower in shadow
    lit = shade > 0.995
    assert 0.5 < lit.mean() < 0.99, "the scene must have shadows"
    apart = np.abs(one - three).max(axis=2)
    assert apart[lit].max() <= 1
    assert np.mean(apart > 2) > 0.01  # the filters do differ (the penumbrae: 2x2 is a texel narrower)


def test_renderer_takes_one_or_four_shadow_taps() -> None:
    with pytest.raises(Exception, match="shadow_taps must be one of \\[1, 4\\], got 2"):
        Renderer(W, H, shadow_taps=2)
