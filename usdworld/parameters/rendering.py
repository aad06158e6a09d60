"""Tuned numbers of the renderer (:mod:`usdworld.render`) that change its speed, never its pixels.

A section of its own, not a field of :class:`~usdworld.parameters.Parameters`, so that the
build's ``report.json`` (which records every section) stays as it was: the renderer does not
run inside ``build``'s decisions, and these numbers only choose how much work a frame costs.
"""

from __future__ import annotations

from dataclasses import dataclass

from usdworld.parameters.base import param


@dataclass(frozen=True)
class RenderingParams:
    """How the renderer saves work; each field documents its unit, meaning and origin."""

    occluder_px_per_triangle: float = param(
        64.0,
        "px / triangle",
        "`Renderer.render` draws the depth of the occluders first (the instances whose box covers at "
        "least this many image pixels per triangle of their mesh) and leaves out of the label and "
        "colour passes the instances whose box lies behind that depth wherever it could cover a "
        "pixel (`usdworld.render.occlusion`). Any value gives the same pixels; lower draws more "
        "occluders, higher hides fewer instances.",
        "tuned: (for time only) tools/bench_scale.py's tiled worlds (synthetic seed-3 frame, 1,000 and "
        "10,000 objects, session 11): at 10,000 objects 16 / 64 / 256 / 1024 px per triangle give "
        "occluders of 166k / 58k / 19k / 1.4k triangles and leave 594k / 614k / 656k / 812k of the 2.23 M triangles "
        "to draw; the test itself cost 0.15 / 0.12 / 0.08 / 0.04 s of CPU",
    )

    occlusion_min_triangles_per_px: float = param(
        0.2,
        "triangles / px",
        "`Renderer.render` looks for hidden instances (above) only in a scene of at least this many "
        "triangles per image pixel: below it the occluders' depth, its read-back and the test cost "
        "more than the hidden instances would. Any value gives the same pixels.",
        "tuned: (for time only) in-process Renderer.render with the test on every scene and off, "
        "session 11: the single-photo worlds (demo at 1024x512 and 2048x1024, synthetic seeds 0-6; "
        "0.02-0.14 triangles per pixel) hide 2-11 of 212-273 instances and take 20-60 ms (16-34 %) "
        "more CPU with it; the 1,000-object tiled world (0.22) hides 1,191 of 2,101 instances, "
        "600 -> 557 ms; the 10,000-object one (1.07) 8,758 of 9,793, 1,414 -> 680 ms",
    )

    def __post_init__(self) -> None:
        v = self.occluder_px_per_triangle
        if not v > 0:
            raise ValueError(f"rendering.occluder_px_per_triangle must be > 0, got {v}")
        t = self.occlusion_min_triangles_per_px
        if not t >= 0:
            raise ValueError(f"rendering.occlusion_min_triangles_per_px must be >= 0, got {t}")
