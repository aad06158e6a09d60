"""Benchmark the fly-through's H.264 encoding: encoder CPU, file size and quality per setting.

Renders the fly-through's frames of the synthetic seed-3 world once (as
``tools/bench_flythrough.py`` does), then encodes them with :class:`~usdworld.render.video.Mp4Writer`
under each setting, interleaved over ``--repeat`` rounds, and prints one markdown row per setting:
ffmpeg's CPU seconds (user + system of the finished ffmpeg process, median), the wall seconds of the
encoding (median), the file's size, and its quality against the rendered frames (every frame
decoded): PSNR over RGB (all frames, and the worst frame), PSNR of the luma (BT.601, all frames) and
SSIM of the luma (mean over frames).
The PSNR includes what yuv420p's half-resolution chroma loses, the same for every setting.

Settings: ``default`` (:class:`~usdworld.parameters.video.VideoParams`), ``preset`` (the preset's own
motion search, as videos were written before session 12: ``-preset veryfast`` alone) and any
``--also NAME=FIELD:VALUE,FIELD:VALUE`` (e.g. ``--also ultrafast=preset:ultrafast``).

Usage::

    python tools/bench_video.py [--frames 120] [--size 1280x640] [--repeat 3] [--also NAME=preset:ultrafast]
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bench_common import children_cpu_s, synth_world
from bench_flythrough import _frames_alone

from usdworld.parameters.video import VideoParams
from usdworld.render.video import Mp4Writer, read_video_frames


def _setting(text: str) -> tuple[str, VideoParams]:
    """``NAME=FIELD:VALUE,...`` -> (name, VideoParams with those fields replaced)."""
    name, _, fields = text.partition("=")
    changes: dict[str, object] = {}
    for item in filter(None, fields.split(",")):
        key, _, value = item.partition(":")
        changes[key] = int(value) if value.lstrip("-").isdigit() else value
    return name, dataclasses.replace(VideoParams(), **changes)


def _encode(images: list[np.ndarray], out: Path, params: VideoParams) -> tuple[float, float]:
    """Wall and ffmpeg CPU seconds of encoding the frames into ``out``."""
    height, width = images[0].shape[:2]
    cpu0, t0 = children_cpu_s(), time.perf_counter()
    with Mp4Writer(out, width, height, params=params) as video:
        for image in images:
            video.write(image)
    return time.perf_counter() - t0, children_cpu_s() - cpu0


def _luma(rgb: np.ndarray) -> np.ndarray:
    """(H, W) float64 BT.601 luma of an (H, W, 3) uint8 RGB frame."""
    return rgb.astype(np.float64) @ np.array([0.299, 0.587, 0.114])


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """Mean SSIM (Wang et al. 2004: 11x11 Gaussian window, sigma 1.5) of two (H, W) lumas in [0, 255]."""
    c1, c2 = (0.01 * 255) ** 2, (0.03 * 255) ** 2

    def blur(x: np.ndarray) -> np.ndarray:
        return cv2.GaussianBlur(x, (11, 11), 1.5)

    mu_a, mu_b = blur(a), blur(b)
    var_a = blur(a * a) - mu_a**2
    var_b = blur(b * b) - mu_b**2
    cov = blur(a * b) - mu_a * mu_b
    s = ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) / ((mu_a**2 + mu_b**2 + c1) * (var_a + var_b + c2))
    return float(s.mean())


def quality(path: Path, images: list[np.ndarray]) -> tuple[float, float, float, float]:
    """PSNR over all frames (dB, RGB), the worst frame's PSNR, the luma's PSNR over all frames, and
    the mean luma SSIM of the decoded video."""
    _, decoded = read_video_frames(path)
    if len(decoded) != len(images):
        raise SystemExit(f"{path}: decoded {len(decoded)} frames, wrote {len(images)}")
    mse = [float(np.mean((d.astype(np.float64) - i) ** 2)) for d, i in zip(decoded, images)]
    psnr = 10 * np.log10(255.0**2 / np.mean(mse))
    worst = 10 * np.log10(255.0**2 / max(mse))
    luma_mse = statistics.fmean(float(np.mean((_luma(d) - _luma(i)) ** 2)) for d, i in zip(decoded, images))
    s = statistics.fmean(ssim(_luma(d), _luma(i)) for d, i in zip(decoded, images))
    return float(psnr), float(worst), float(10 * np.log10(255.0**2 / luma_mse)), s


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--size", default="1280x640")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--also", action="append", default=[], help="NAME=FIELD:VALUE,... another setting")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.lower().split("x"))
    preset_only = dataclasses.replace(VideoParams(), motion_search="hex", subpixel_refinement=2)
    settings = {"default": VideoParams(), "preset": preset_only, **dict(_setting(s) for s in args.also)}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        world = synth_world(tmp)
        _, images = _frames_alone(world, args.frames, width, height)
        runs: dict[str, list[tuple[float, float]]] = {name: [] for name in settings}
        loads = []
        for _ in range(args.repeat):
            loads.append(os.getloadavg()[0])
            for name, params in settings.items():
                runs[name].append(_encode(images, tmp / f"{name}.mp4", params))
        print(
            f"{datetime.date.today()}, {platform.machine()}, {os.cpu_count()} cores, "
            f"python {platform.python_version()}; "
            f"1-minute load average at the start of each round: {', '.join(f'{v:.2f}' for v in loads)}"
        )
        print(
            f"\n{args.frames} frames at {width}x{height}, median of {args.repeat}; "
            "quality against the rendered frames:\n"
        )
        print(
            "| setting | x264 arguments | ffmpeg CPU s | wall s | file MB | PSNR dB (RGB) | worst frame dB "
            "| PSNR dB (luma) | SSIM (luma) |"
        )
        print("|---|---|---|---|---|---|---|---|---|")
        for name, params in settings.items():
            wall = statistics.median(w for w, _ in runs[name])
            cpu = statistics.median(c for _, c in runs[name])
            path = tmp / f"{name}.mp4"
            psnr, worst, luma, s = quality(path, images)
            print(
                f"| {name} | `{' '.join(params.x264_arguments())}` | {cpu:.2f} | {wall:.2f} | "
                f"{path.stat().st_size / 1e6:.2f} | {psnr:.2f} | {worst:.2f} | {luma:.2f} | {s:.5f} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
