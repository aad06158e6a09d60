#!/usr/bin/env python
"""Time the renderer's passes on a typical synthetic street world; print a markdown table.

Usage::

    python tools/bench_render.py [--seed 9] [--repeats 7] [--sizes 1024x512,2048x1024]
                                 [--flythrough-frames 120] [--flythrough-size 960x480]

The world is the synthetic street scene of ``--seed`` (the demo scene by default), authored
from the built-in asset library and read back with ``RenderScene.from_stage``. Each pass is
timed ``--repeats`` times after one warm-up render and the median is reported, in
milliseconds. "all passes" is one :meth:`Renderer.render` with the shadow map recomputed
(shadow + lit colour + labels and depth), i.e. the cost of a new view.

The fly-through is then timed once: ``--flythrough-frames`` frames at ``--flythrough-size``
of the same world with the red source vehicle, as ``usdworld flythrough`` renders them
(a shadow map per frame, lit colour, H.264 encoding into a temporary MP4); 0 frames skips it.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.render import Lighting, Renderer, RenderScene
from usdworld.synth import author_stage, make_street_scene


def _median_ms(fn: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1000.0 * statistics.median(times)


def _size(text: str) -> tuple[int, int]:
    w, h = text.lower().split("x")
    return int(w), int(h)


def _bench_size(
    world: RenderScene,
    lighting: Lighting,
    K: np.ndarray,
    T: np.ndarray,
    width: int,
    height: int,
    repeats: int,
) -> tuple[str, tuple[str, float, float, float, float, float]]:
    """(GL renderer name, table row) for one image size."""
    with Renderer(width, height, lighting=lighting) as r:
        t0 = time.perf_counter()
        r.render(world, K, T)  # warm-up: upload + every pass
        first_ms = 1000.0 * (time.perf_counter() - t0)

        def all_passes() -> None:
            r.update_shadow_map(world, K, T)
            r.render_rgb(world, K, T)
            r.render_labels(world, K, T)

        row = (
            f"{width}x{height}",
            _median_ms(lambda: r.update_shadow_map(world, K, T), repeats),
            _median_ms(lambda: r.render_rgb(world, K, T), repeats),
            _median_ms(lambda: r.render_labels(world, K, T), repeats),
            _median_ms(all_passes, repeats),
            first_ms,
        )
        return r.gl_renderer, row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=9)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--sizes", default="1024x512,2048x1024")
    parser.add_argument("--flythrough-frames", type=int, default=120)
    parser.add_argument("--flythrough-size", default="960x480")
    args = parser.parse_args(argv)
    if args.repeats < 5:
        parser.error("--repeats must be >= 5")

    scene = make_street_scene(np.random.default_rng(args.seed), 1024, 512)
    stage = author_stage(scene)
    t0 = time.perf_counter()
    world = RenderScene.from_stage(stage)
    extract_ms = 1000.0 * (time.perf_counter() - t0)
    lighting = Lighting(sun_direction_world=scene.sun_direction_world)

    rows = []
    renderer_name = "?"
    for size in args.sizes.split(","):
        width, height = _size(size)
        # The same view at another size: scale K about pixel corners (OpenCV centres are at +0.5).
        K = scene.camera.K.copy()
        K[0, :] *= width / scene.camera.width
        K[1, :] *= height / scene.camera.height
        K[0, 2] += 0.5 * (width / scene.camera.width - 1.0)
        K[1, 2] += 0.5 * (height / scene.camera.height - 1.0)
        T = scene.camera.world_from_cam()
        renderer_name, row = _bench_size(world, lighting, K, T, width, height, args.repeats)
        rows.append(row)

    print(
        f"Synthetic street world, seed {args.seed}: {world.n_triangles:,d} triangles, {len(world.objects)} objects; "
        f"RenderScene.from_stage {extract_ms:.0f} ms. {renderer_name}; {platform.processor() or platform.machine()}. "
        f"Median of {args.repeats} after one warm-up, milliseconds.\n"
    )
    print("| size | shadow map | lit colour | labels + depth | all passes | first render (upload + all) |")
    print("|---|---:|---:|---:|---:|---:|")
    for size, shadow, colour, labels, total, first in rows:
        print(f"| {size} | {shadow:.0f} | {colour:.0f} | {labels:.0f} | **{total:.0f}** | {first:.0f} |")
    if args.flythrough_frames:
        _bench_flythrough(scene, args.flythrough_frames, _size(args.flythrough_size))
    return 0


def _bench_flythrough(scene: object, frames: int, size: tuple[int, int]) -> None:
    """Time ``render_flythrough`` on the scene (saved to a temporary folder) and print one line."""
    from pxr import Usd

    from usdworld.render.flythrough import render_flythrough
    from usdworld.render.video import read_video_frames

    with tempfile.TemporaryDirectory() as tmp:
        stage_path = Path(tmp) / "world.usda"
        author_stage(scene, stage_path)  # type: ignore[arg-type]
        stage = Usd.Stage.Open(str(stage_path))
        lighting = Lighting(sun_direction_world=scene.sun_direction_world)  # type: ignore[attr-defined]
        result = render_flythrough(
            stage, Path(tmp) / "fly.mp4", n_frames=frames, width=size[0], height=size[1], lighting=lighting
        )
        decoded = len(read_video_frames(result.path)[1])
    print(
        f"\nFly-through, {frames} frames at {size[0]}x{size[1]} (source vehicle added, H.264 yuv420p): "
        f"**{result.total_s:.1f} s** in all, of which rendering {result.render_s:.1f} s "
        f"({1000.0 * result.render_s / frames:.0f} ms per frame); {decoded} frames decode."
    )


if __name__ == "__main__":
    sys.exit(main())
