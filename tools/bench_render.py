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

``--command-repeats N`` (instead of the above) times the whole ``usdworld render`` command (issue 21's
target: 1.0 s at 2048x1024) on two worlds: the demo world (``usdworld demo``, rendered at
2048x1024) and a synthetic 2048x1024 world (seed 3, built from its Cityscapes-format frame),
each with the default outputs (``--write data``) and with ``--write all``. The runs of all
variants are interleaved, N rounds, median wall and CPU time (user + system of the child)
reported, with the load average. A breakdown of one render in a fresh process follows:
imports, stage open, scene extraction, GL context, the passes, encoding (parallel, this
module's PNG settings) and writing, and, as the reference in the same process, encoding the
same files one after another at zlib level 6 (what the command did before).
``--baseline CHECKOUT`` (e.g. ``/work/main``) runs every variant and the breakdown with that
checkout's code too, alternating with this one's in the same rounds (fresh processes).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from bench_common import run_timed

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
    parser.add_argument("--command-repeats", type=int, default=0, help="rounds of the whole-command timing")
    parser.add_argument(
        "--baseline",
        type=Path,
        default=None,
        help="with --command-repeats: another checkout (e.g. /work/main) timed in the same rounds",
    )
    args = parser.parse_args(argv)
    if args.command_repeats:  # the whole command instead of the passes
        _bench_command(args.command_repeats, args.baseline)
        return 0
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


#: One render of a world in a fresh process, timed step by step (argv: world, size, output folder).
BREAKDOWN = r"""
import sys, time
t0 = time.perf_counter()
from pathlib import Path
import cv2
from usdworld.authoring.inspect import open_world
from usdworld.render import Renderer, RenderScene
from usdworld.render import outputs as o
t1 = time.perf_counter()
stage = open_world(Path(sys.argv[1]))
w, h = (int(v) for v in sys.argv[2].split("x"))
pose = o.view_camera(stage, w, h)
t2 = time.perf_counter()
scene = RenderScene.from_stage(stage)
t3 = time.perf_counter()
with Renderer(w, h) as r:
    t4 = time.perf_counter()
    c4 = time.process_time()
    result = r.render(scene, pose.K, pose.world_from_cam)
    t5 = time.perf_counter()
    c5 = time.process_time()
row = [t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4, c5 - c4]


def reference(outputs):  # zlib level 6, OpenCV's other defaults, one file after another (as before)
    o.PNG_PARAMS, fast = (cv2.IMWRITE_PNG_COMPRESSION, 6), o.PNG_PARAMS
    try:
        for make in o._encoders(result, None, outputs).values():
            make()
    finally:
        o.PNG_PARAMS = fast


for outputs in (o.DATA, o.OUTPUT_GROUPS["all"]):
    encode, write, ref = [], [], []
    for _ in range(3):  # interleaved; the best of three of each
        t6 = time.perf_counter()
        files = o.encode_render_outputs(result, None, outputs)
        t7 = time.perf_counter()
        out = o.ensure_output_dir(sys.argv[3])
        for role, data in files.items():
            o.write_bytes_atomic(out / o.OUTPUT_FILES[role], data)
        t8 = time.perf_counter()
        reference(outputs)
        encode.append(t7 - t6), write.append(t8 - t7), ref.append(time.perf_counter() - t8)
    row += [min(encode), min(write), min(ref)]
print(" ".join(f"{1000 * v:.0f}" for v in row))
"""


def _make_worlds(tmp: Path, env: dict[str, str]) -> dict[str, Path]:
    """The demo world and the synthetic 2048x1024 world of seed 3, built by the CLI."""
    usdworld = [sys.executable, "-m", "usdworld", "-q"]
    run_timed([*usdworld, "demo", "-o", str(tmp / "demo_world")], env)
    run_timed([*usdworld, "synth", "-o", str(tmp / "synth"), "--seed", "3", "--size", "2048x1024"], env)
    stem = str(tmp / "synth" / "synth_000000_000003")
    build = ["build", f"{stem}_leftImg8bit.png", "--labels", f"{stem}_gtFine_labelIds.png"]
    build += ["--instances", f"{stem}_gtFine_instanceIds.png", "--camera", f"{stem}_camera.json"]
    run_timed([*usdworld, *build, "-o", str(tmp / "synth_world")], env)
    return {"demo": tmp / "demo_world", "synth seed 3": tmp / "synth_world"}


def _env(checkout: Path) -> dict[str, str]:
    """The environment that runs ``checkout``'s code: first on PYTHONPATH, and no current folder
    ahead of it (``python -m`` and ``-c`` put the current folder first unless PYTHONSAFEPATH is set)."""
    path = os.pathsep.join([str(checkout), os.environ.get("PYTHONPATH", "")])
    return {**os.environ, "PYTHONPATH": path, "PYTHONSAFEPATH": "1"}


def _bench_command(repeats: int, baseline: Path | None = None) -> None:
    """Print the whole-command table and the breakdown (see the module docstring).

    With ``baseline`` (another checkout, e.g. main's), each round runs every variant with that
    checkout's code and then with this one's, in fresh processes, on the same worlds.
    """
    checkouts = {"this": REPO} if baseline is None else {"baseline": baseline.resolve(), "this": REPO}
    with tempfile.TemporaryDirectory() as scratch:
        tmp = Path(scratch)
        worlds = _make_worlds(tmp, _env(REPO))
        variants = [(code, name, write) for name in worlds for write in ("data", "all") for code in checkouts]
        times: dict[tuple[str, str, str], list[tuple[float, float]]] = {v: [] for v in variants}
        loads = [os.getloadavg()[0]]
        for _ in range(repeats):
            for code, name, write in variants:
                argv = [sys.executable, "-m", "usdworld", "-q", "render", str(worlds[name])]
                argv += ["-o", str(tmp / "out"), "--size", "2048x1024", "--write", write]
                wall, cpu, _ = run_timed(argv, _env(checkouts[code]))
                times[(code, name, write)].append((wall, cpu))
            loads.append(os.getloadavg()[0])
        breakdown = {}
        for _ in range(max(1, repeats // 2)):  # fresh processes; the median of each step
            for code in checkouts:
                for name, world in worlds.items():
                    argv = [sys.executable, "-c", BREAKDOWN, str(world), "2048x1024", str(tmp / "parts")]
                    row = [float(v) for v in run_timed(argv, _env(checkouts[code]))[2].split()]
                    breakdown.setdefault((code, name), []).append(row)
    print(
        f"`usdworld render` at 2048x1024, whole command; median of {repeats} interleaved rounds; "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {platform.node()}, {os.cpu_count()} CPUs, "
        f"load average (1 min) {min(loads):.1f}-{max(loads):.1f}."
    )
    if baseline is not None:
        print(f"baseline: {checkouts['baseline']} ({_head(checkouts['baseline'])}); this: {REPO} ({_head(REPO)})")
    print("\n| code | world | --write | files | wall s | CPU s |")
    print("|---|---|---|---:|---:|---:|")
    from usdworld.render.outputs import OUTPUT_GROUPS

    for (code, name, write), runs in times.items():
        wall = statistics.median(r[0] for r in runs)
        cpu = statistics.median(r[1] for r in runs)
        n_files = len(OUTPUT_GROUPS[write]) - (2 if write == "all" and name != "demo" else 0)
        print(f"| {code} | {name} | {write} | {n_files} | **{wall:.2f}** | {cpu:.2f} |")
    print(
        "\nOne render in a fresh process, milliseconds wall, the median of "
        f"{max(1, repeats // 2)} (encoding and writing: best of 3, parallel, fast PNG settings; reference: "
    )
    print("the same files one after another at zlib level 6, as before):\n")
    print(
        "| code | world | imports | open + camera | scene | GL context | passes | passes CPU | data: encode | write | "
        "reference encode | all (no photo): encode | write | reference encode |"
    )
    print("|---|---|" + "---:|" * 12)
    for (code, name), rows in breakdown.items():
        row = np.median(np.array(rows), axis=0)
        print(f"| {code} | {name} | " + " | ".join(f"{v:.0f}" for v in row) + " |")


def _head(checkout: Path) -> str:
    """The checkout's commit, short (or '?' outside git)."""
    import subprocess

    proc = subprocess.run(["git", "-C", str(checkout), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    return proc.stdout.strip() or "?"


if __name__ == "__main__":
    sys.exit(main())
