"""Benchmark ``usdworld build`` on a 2048x1024 Cityscapes-format frame.

Makes a synthetic street frame (``usdworld.synth``, rendered headless), then measures
in-process, after one warm-up: the median wall time of the whole build (reading,
perception, layout, authoring, writing the world folder) and of merely decoding its
input files, over ``--runs`` runs each. Prints a markdown table row for BENCHMARKS.md.

Usage::

    python tools/bench_build.py [--runs 9] [--size 2048x1024] [--seed 3]
"""

from __future__ import annotations

import argparse
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from usdworld.authoring.asset_library import library_dirs
from usdworld.io.camera_files import read_camera
from usdworld.io.images import read_image
from usdworld.io.labels import read_segmentation
from usdworld.pipeline import BuildRequest, build, build_model
from usdworld.synth import make_street_scene, write_cityscapes_frame


def _median_s(fn, runs: int) -> float:
    fn()
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=9)
    parser.add_argument("--size", default="2048x1024")
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.lower().split("x"))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        scene = make_street_scene(np.random.default_rng(args.seed), width, height)
        files = write_cityscapes_frame(scene, tmp / "in", "bench_000000_000001")
        request = BuildRequest(
            image=files["image"], labels=files["labels"], instances=files["instances"], camera=files["camera"], output=tmp / "world"
        )
        libraries = library_dirs(None)

        def decode() -> None:
            image = read_image(request.image)
            read_segmentation(request.labels, request.instances, image)
            read_camera(request.camera, image)

        t_build = _median_s(lambda: build(request), args.runs)
        t_model = _median_s(lambda: build_model(request, libraries), args.runs)
        t_decode = _median_s(decode, args.runs)
        objects = len(build(request).model.placements)
    print(f"machine: {platform.machine()}, {platform.processor() or 'cpu'}, python {platform.python_version()}")
    print("| input | objects | build (median) | of which compute (no writing) | decode inputs only | build / decode |")
    print("|---|---|---|---|---|---|")
    print(
        f"| {width}x{height} Cityscapes-format, synth seed {args.seed} | {objects} | {t_build * 1000:.0f} ms "
        f"| {t_model * 1000:.0f} ms | {t_decode * 1000:.0f} ms | {t_build / t_decode:.1f}x |"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
