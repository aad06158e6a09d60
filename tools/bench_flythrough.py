"""Benchmark ``usdworld flythrough``: the whole command against rendering and encoding alone.

Builds a world from a synthetic 2048x1024 Cityscapes-format frame (``usdworld.synth``, seed 3),
then measures, interleaved over ``--repeat`` rounds (median of each):

* the whole command ``usdworld -q flythrough W -o OUT.mp4 --frames N --size WxH`` (a fresh
  process: imports, scene extraction, GL context, rendering, encoding), wall and CPU seconds;
* in this process, after a warm-up: :func:`~usdworld.render.flythrough.render_flythrough`
  (frames queued to ffmpeg while the next ones render), rendering the same N frames alone, and
  encoding N rendered frames alone (:class:`~usdworld.render.video.Mp4Writer`).

Rendering plus encoding alone is what the fly-through cost when they ran one after the other;
the larger of the two is the floor that overlapping them can reach. Prints the load average,
the machine and a markdown table for BENCHMARKS.md.

``--baseline CHECKOUT`` (e.g. ``/work/main``) also times, in the same rounds and alternating
with this checkout, the whole command and the rendering alone (a fresh process that renders
the N frames after one warm-up frame, wall and CPU) with that checkout's code.

``--quality`` also compares the video's frames (rendered with the fly-through's shading and
back-face culling, :class:`~usdworld.parameters.video.VideoParams`) with the same frames under
the still's full shading (``Renderer(shadow_taps=4)`` with every face drawn, as ``usdworld
render``), with the video's shading but every face drawn, and with the video's shading drawn
after a depth pre-pass (``near_first=False``): PSNR over RGB of all frames and
of the worst frame, luma SSIM (mean and worst frame), and the shares of pixels off by more than
8 levels and of pixels that differ at all. ``--repeat 0`` prints that alone.

Usage::

    python tools/bench_flythrough.py [--frames 120] [--size 1280x640] [--repeat 3] [--baseline /work/main] [--quality]
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bench_common import run_timed, synth_world

from usdworld.authoring.inspect import open_world
from usdworld.parameters.video import VideoParams
from usdworld.render import flythrough as fly
from usdworld.render.outputs import view_camera, world_image_size
from usdworld.render.renderer import Renderer
from usdworld.render.scene import RenderScene
from usdworld.render.video import Mp4Writer
from usdworld.render.world_lights import lighting_from_stage


#: Rendering the fly-through's frames alone in a fresh process (argv: world, frames, WxH): prints
#: the wall and CPU seconds of the N frames after one warm-up frame (the process's own CPU,
#: llvmpipe's threads included).
RENDER_ALONE = r"""
import sys, time
from pathlib import Path
from usdworld.authoring.inspect import open_world
from usdworld.render import flythrough as fly
from usdworld.render.outputs import view_camera, world_image_size
from usdworld.render.renderer import Renderer
from usdworld.render.scene import RenderScene
from usdworld.render.world_lights import lighting_from_stage
try:  # the fly-through's shading where the checkout has one (render_flythrough uses it)
    from usdworld.parameters.video import VideoParams
    shading = {"shadow_taps": VideoParams().shadow_taps} if hasattr(VideoParams(), "shadow_taps") else {}
    if hasattr(VideoParams(), "cull_back_faces"):
        shading["cull_back_faces"] = VideoParams().cull_back_faces
    if hasattr(VideoParams(), "near_first"):
        shading["near_first"] = VideoParams().near_first
except ImportError:
    shading = {}
world, frames = Path(sys.argv[1]), int(sys.argv[2])
width, height = (int(v) for v in sys.argv[3].split("x"))
stage = open_world(world)
size = world_image_size(stage)
source = view_camera(stage, *size)
K = fly.video_intrinsics(source.K, size, (width, height))
fly.add_source_vehicle(stage, fly.car_asset_for(world))
scene = RenderScene.from_stage(stage)
poses = fly.flythrough_poses(source.world_from_cam, frames, fly.clear_path(fly.FlythroughPath(), scene, source.world_from_cam))
with Renderer(width, height, lighting=lighting_from_stage(stage), **shading) as renderer:
    renderer.fix_shadow_box(scene, K, poses)
    renderer.render_rgb(scene, K, poses[0])
    t0, c0 = time.perf_counter(), time.process_time()
    for pose in poses:
        renderer.render_rgb(scene, K, pose)
    print(time.perf_counter() - t0, time.process_time() - c0)
"""


def _env(checkout: Path) -> dict[str, str]:
    """The environment that runs ``checkout``'s code: first on PYTHONPATH, and no current folder
    ahead of it (``python -m`` and ``-c`` put the current folder first unless PYTHONSAFEPATH is set)."""
    path = os.pathsep.join([str(checkout), *filter(None, [os.environ.get("PYTHONPATH")])])
    return dict(os.environ, PYTHONPATH=path, PYTHONSAFEPATH="1")


def _command(world: Path, out: Path, frames: int, width: int, height: int, checkout: Path = REPO) -> tuple[float, float]:
    """Wall and CPU seconds (the process and its ffmpeg) of the whole command."""
    args = [sys.executable, "-m", "usdworld", "-q", "flythrough", str(world), "-o", str(out)]
    args += ["--frames", str(frames), "--size", f"{width}x{height}"]
    wall, cpu, _ = run_timed(args, _env(checkout))
    return wall, cpu


def _render_alone_process(world: Path, frames: int, width: int, height: int, checkout: Path) -> tuple[float, float]:
    """Wall and CPU seconds of rendering the frames alone in a fresh process (:data:`RENDER_ALONE`)."""
    out = run_timed([sys.executable, "-c", RENDER_ALONE, str(world), str(frames), f"{width}x{height}"], _env(checkout))[2]
    wall, cpu = (float(v) for v in out.split())
    return wall, cpu


def _frames_alone(
    world: Path,
    frames: int,
    width: int,
    height: int,
    shadow_taps: int | None = None,
    cull: bool | None = None,
    near_first: bool | None = None,
) -> tuple[float, list[np.ndarray]]:
    """Seconds to render the fly-through's frames with no encoding, and the frames (with the
    fly-through's shading, or ``shadow_taps``, back-face culling ``cull`` and the drawing order
    ``near_first`` when given)."""
    stage = open_world(world)
    size = world_image_size(stage)
    source = view_camera(stage, *size)
    K = fly.video_intrinsics(source.K, size, (width, height))
    fly.add_source_vehicle(stage, fly.car_asset_for(world))
    scene = RenderScene.from_stage(stage)
    poses = fly.flythrough_poses(source.world_from_cam, frames, fly.clear_path(fly.FlythroughPath(), scene, source.world_from_cam))
    # the world's own sun and sky, as render_flythrough and the command use
    taps = VideoParams().shadow_taps if shadow_taps is None else shadow_taps
    cull = VideoParams().cull_back_faces if cull is None else cull
    near_first = VideoParams().near_first if near_first is None else near_first
    lighting = lighting_from_stage(stage)
    with Renderer(
        width, height, lighting=lighting, shadow_taps=taps, cull_back_faces=cull, near_first=near_first
    ) as renderer:
        renderer.fix_shadow_box(scene, K, poses)  # one shadow map for the path, as render_flythrough
        renderer.render_rgb(scene, K, poses[0])  # context, upload and shadow map, as the first frame
        t0 = time.perf_counter()
        images = [renderer.render_rgb(scene, K, pose) for pose in poses]
        return time.perf_counter() - t0, images


def _encode_alone(images: list[np.ndarray], out: Path) -> float:
    height, width = images[0].shape[:2]
    t0 = time.perf_counter()
    with Mp4Writer(out, width, height) as video:
        for image in images:
            video.write(image)
    return time.perf_counter() - t0


def _in_process(world: Path, out: Path, frames: int, width: int, height: int) -> float:
    t0 = time.perf_counter()
    fly.render_flythrough(open_world(world), out, n_frames=frames, width=width, height=height)
    return time.perf_counter() - t0


def _quality(world: Path, frames: int, width: int, height: int) -> None:
    """Print how far the video's frames are from the still's full shading and from the same frames
    with every face drawn (see the module docstring)."""
    _, video = _frames_alone(world, frames, width, height)
    _, full = _frames_alone(world, frames, width, height, shadow_taps=4, cull=False, near_first=False)
    _, whole = _frames_alone(world, frames, width, height, cull=False, near_first=False)
    _, prepass = _frames_alone(world, frames, width, height, near_first=False)
    params = VideoParams()
    print(
        f"\nThe video's frames (shadow_taps={params.shadow_taps}, cull_back_faces={params.cull_back_faces}, "
        f"near_first={params.near_first}), "
        f"{frames} frames at {width}x{height}, against:\n"
    )
    print(
        "| reference | PSNR dB (RGB, all) | worst frame dB (frame) | SSIM (luma, mean) "
        "| worst frame SSIM (frame) | pixels off by > 8 | pixels that differ |"
    )
    print("|---|---|---|---|---|---|---|")
    _quality_row("the still's shading (shadow_taps=4, no culling, depth pre-pass)", video, full)
    taps = params.shadow_taps
    same = f"the same shading with every face drawn (shadow_taps={taps}, no culling, depth pre-pass)"
    _quality_row(same, video, whole)
    _quality_row("the same frames drawn after a depth pre-pass (near_first=False)", video, prepass)


def _quality_row(name: str, video: list[np.ndarray], full: list[np.ndarray]) -> None:
    from bench_video import _luma, ssim

    mse = np.array([np.mean((v.astype(np.float64) - f) ** 2) for v, f in zip(video, full)])
    psnr = 10 * np.log10(255.0**2 / np.maximum(mse, 1e-12))
    s = np.array([ssim(_luma(v), _luma(f)) for v, f in zip(video, full)])
    off = np.mean([np.mean(np.abs(v.astype(int) - f).max(axis=2) > 8) for v, f in zip(video, full)])
    differ = np.mean([np.mean(np.any(v != f, axis=2)) for v, f in zip(video, full)])
    print(
        f"| {name} | {10 * np.log10(255.0**2 / max(mse.mean(), 1e-12)):.2f} | "
        f"{psnr.min():.2f} ({int(psnr.argmin())}) | {s.mean():.5f} | {s.min():.5f} ({int(s.argmin())}) | "
        f"{100 * off:.3f} % | {100 * differ:.4f} % |"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--size", default="1280x640")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--baseline", type=Path, default=None, help="another checkout timed in the same rounds")
    parser.add_argument("--quality", action="store_true", help="compare the frames with the still's shading")
    args = parser.parse_args(argv)
    checkouts = {"this": REPO} if args.baseline is None else {"baseline": args.baseline.resolve(), "this": REPO}
    width, height = (int(v) for v in args.size.lower().split("x"))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        world = synth_world(tmp)
        if args.quality:
            _quality(world, args.frames, width, height)
        if args.repeat < 1:
            return 0
        _in_process(world, tmp / "warm.mp4", 2, width, height)  # warm-up: imports, shaders
        runs: dict[str, list[float]] = {k: [] for k in ("cmd", "cmd_cpu", "inproc", "render", "encode")}
        compared: dict[tuple[str, str], list[float]] = {}
        loads = []
        for _ in range(args.repeat):
            loads.append(os.getloadavg()[0])
            for code, checkout in checkouts.items():
                wall, cpu = _command(world, tmp / "cmd.mp4", args.frames, width, height, checkout)
                compared.setdefault((code, "cmd"), []).append(wall)
                compared.setdefault((code, "cmd_cpu"), []).append(cpu)
                wall, cpu = _render_alone_process(world, args.frames, width, height, checkout)
                compared.setdefault((code, "alone"), []).append(wall)
                compared.setdefault((code, "alone_cpu"), []).append(cpu)
            runs["cmd"].append(compared[("this", "cmd")][-1])
            runs["cmd_cpu"].append(compared[("this", "cmd_cpu")][-1])
            runs["inproc"].append(_in_process(world, tmp / "inproc.mp4", args.frames, width, height))
            t_render, images = _frames_alone(world, args.frames, width, height)
            runs["render"].append(t_render)
            runs["encode"].append(_encode_alone(images, tmp / "encode.mp4"))
            del images
    med = {k: statistics.median(v) for k, v in runs.items()}
    serial = med["render"] + med["encode"]
    floor = max(med["render"], med["encode"])
    print(
        f"{datetime.date.today()}, {platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}; "
        f"1-minute load average at the start of each round: {', '.join(f'{v:.2f}' for v in loads)}"
    )
    print(f"| {args.frames} frames at {width}x{height}, median of {args.repeat} | seconds | per frame | / (render + encode) |")
    print("|---|---|---|---|")
    rows = [
        ("`usdworld flythrough`, whole command (wall)", med["cmd"]),
        ("the same, CPU (process and ffmpeg)", med["cmd_cpu"]),
        ("`render_flythrough` in process (rendering and encoding overlapped)", med["inproc"]),
        ("rendering alone (no encoding)", med["render"]),
        ("encoding alone (rendered frames into ffmpeg)", med["encode"]),
        ("rendering + encoding one after the other", serial),
        ("floor of the overlap: max(rendering, encoding)", floor),
    ]
    for name, seconds in rows:
        print(f"| {name} | {seconds:.2f} | {1000 * seconds / args.frames:.0f} ms | {seconds / serial:.2f} |")
    heads = {code: _head(checkout) for code, checkout in checkouts.items()}
    print(
        f"\nFresh processes, the same rounds ({', '.join(f'{c}: {checkouts[c]} ({h})' for c, h in heads.items())}); "
        f"median of {args.repeat}, seconds (per frame):\n"
    )
    print("| code | whole command wall | whole command CPU (with ffmpeg) | rendering alone wall | rendering alone CPU |")
    print("|---|---|---|---|---|")
    for code in checkouts:
        cells = [statistics.median(compared[(code, k)]) for k in ("cmd", "cmd_cpu", "alone", "alone_cpu")]
        print(f"| {code} | " + " | ".join(f"{v:.2f} ({1000 * v / args.frames:.0f} ms)" for v in cells) + " |")
    return 0


def _head(checkout: Path) -> str:
    """The checkout's commit, short (or '?' outside git)."""
    import subprocess

    proc = subprocess.run(["git", "-C", str(checkout), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    return proc.stdout.strip() or "?"


if __name__ == "__main__":
    sys.exit(main())
