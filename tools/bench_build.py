"""Benchmark ``usdworld build`` on a 2048x1024 Cityscapes-format frame.

Makes a synthetic street frame (``usdworld.synth``, rendered headless), then measures
in-process, after one warm-up: the median wall time of the whole build (reading,
perception, layout, authoring, writing the world folder) and of merely decoding its
input files, over ``--runs`` runs each, and where a build's time goes (cProfile's cumulative
time of each stage over ``--runs`` profiled builds, as shares: the profiler slows Python code
more than numpy and OpenCV calls).

With ``--command`` it also times the whole ``usdworld build`` command against its floor, a
Python process that imports ``pxr.Usd`` and ``cv2`` and decodes the three PNGs, the two taking
turns ``--runs`` times (median wall and CPU time of each; CPU time is the steadier of the two
on a shared machine). Both run with byte-compiled modules (``PYTHONPYCACHEPREFIX`` in a
temporary folder, filled by a warm-up run), as an installed package does: without them every
command compiles usdworld's modules again.

Prints the load average, the machine and markdown tables for BENCHMARKS.md.

Usage::

    python tools/bench_build.py [--runs 9] [--size 2048x1024] [--seed 3] [--command]
"""

from __future__ import annotations

import argparse
import cProfile
import datetime
import os
import platform
import pstats
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import usdworld
from usdworld.authoring.asset_library import library_dirs
from usdworld.io.camera_files import read_camera
from usdworld.io.images import read_image
from usdworld.io.labels import read_segmentation
from usdworld.pipeline import BuildRequest, build, build_model
from usdworld.synth import make_street_scene, write_cityscapes_frame

#: The checkout whose usdworld this process imported: the command runs the same one.
REPO = Path(usdworld.__file__).resolve().parents[1]

#: The stages of a build, as (name, [(module file suffix, function name), ...]) for the profile.
STAGES = (
    ("decoding the inputs (image, labels, camera)", [("io/images.py", "read_image"), ("io/labels.py", "read_segmentation"), ("io/camera_files.py", "read_camera")]),
    # LSD runs in a thread while the labels are decoded: the profile sees the wait for it.
    ("street vanishing point: waiting for LSD's segments", [("concurrent/futures/_base.py", "result")]),
    ("street vanishing point: RANSAC", [("geometry/vanishing.py", "find_vanishing_point")]),
    ("perception (objects from the labels)", [("perception/objects.py", "objects_from_segmentation")]),
    ("camera estimate", [("pipeline.py", "_camera")]),
    ("placement", [("layout/placement.py", "place_objects")]),
    ("ground surfaces", [("layout/surfaces.py", "fill_hidden_ground"), ("layout/surfaces.py", "build_surfaces"), ("layout/surfaces.py", "surface_points")]),
    ("report (make_report)", [("usdworld/report.py", "make_report")]),
    ("authoring: write_world (the layers, assets)", [("authoring/world.py", "write_world")]),
    ("report.json (json.dumps)", [("json/__init__.py", "dumps")]),
)


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
    parser.add_argument("--command", action="store_true", help="also time the whole command against its floor")
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
        shares = _profile(lambda: build(request), args.runs)
        command = _command_vs_floor(files, tmp, args.runs) if args.command else None
    print(
        f"{datetime.datetime.now():%Y-%m-%d %H:%M}, {platform.machine()}, {os.cpu_count()} cores, "
        f"python {platform.python_version()}, load average {os.getloadavg()[0]:.2f} at the end"
    )
    print("| input | objects | build (median) | of which compute (no writing) | decode inputs only | build / decode |")
    print("|---|---|---|---|---|---|")
    print(
        f"| {width}x{height} Cityscapes-format, synth seed {args.seed} | {objects} | {t_build * 1000:.0f} ms "
        f"| {t_model * 1000:.0f} ms | {t_decode * 1000:.0f} ms | {t_build / t_decode:.1f}x |"
    )
    print("\n| stage (cProfile, cumulative) | share of the build |")
    print("|---|---|")
    for name, share in shares:
        print(f"| {name} | {100 * share:.0f} % |")
    if command is not None:
        print("\n| whole process, median of {0} taking turns | wall | CPU (user + system) |".format(args.runs))
        print("|---|---|---|")
        for name, (wall, cpu) in command.items():
            print(f"| {name} | {wall:.2f} s | {cpu:.2f} s |")
        (fw, fc), (cw, cc) = command.values()
        print(f"| ratio command / floor | {cw / fw:.2f}x | {cc / fc:.2f}x |")
    return 0


def _profile(fn, runs: int) -> list[tuple[str, float]]:
    """Each stage's share of the build's time, from cProfile over ``runs`` builds."""
    profile = cProfile.Profile()
    profile.enable()
    for _ in range(runs):
        fn()
    profile.disable()
    stats = pstats.Stats(profile).stats  # type: ignore[attr-defined]
    total = max(ct for (file, _, func), (_, _, _, ct, _) in stats.items() if func == "build" and file.endswith("pipeline.py"))
    shares = []
    for name, functions in STAGES:
        spent = sum(
            ct for (file, _, func), (_, _, _, ct, _) in stats.items() if any(file.endswith(f) and func == fn_name for f, fn_name in functions)
        )
        shares.append((name, spent / total))
    shares.append(("everything else", 1.0 - sum(share for _, share in shares)))
    return shares


def _command_vs_floor(files: dict, tmp: Path, runs: int) -> dict[str, tuple[float, float]]:
    """Median (wall, CPU) seconds of the floor process and of the whole ``usdworld build``."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPYCACHEPREFIX"] = str(tmp / "pycache")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])
    pngs = [str(files[k]) for k in ("image", "labels", "instances")]
    floor = [
        sys.executable,
        "-c",
        "import sys; from pxr import Usd; import cv2\n"
        "for p in sys.argv[1:]: cv2.imread(p, cv2.IMREAD_UNCHANGED)",
        *pngs,
    ]
    command = [sys.executable, "-m", "usdworld", "build", pngs[0], "--labels", pngs[1], "--instances", pngs[2]]
    command += ["--camera", str(files["camera"]), "-o", str(tmp / "cmd_world")]

    def timed(args: list[str]) -> tuple[float, float]:
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(args, check=True, env=env, stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return wall, (after.ru_utime - usage.ru_utime) + (after.ru_stime - usage.ru_stime)

    timed(floor), timed(command)  # warm-up: byte-compile into the cache, warm the file cache
    results: dict[str, list[tuple[float, float]]] = {"floor: import pxr.Usd and cv2, decode the three PNGs": [], "`usdworld build`, whole command": []}
    for _ in range(runs):
        for name, args in zip(results, (floor, command)):
            results[name].append(timed(args))
    return {name: (statistics.median(w for w, _ in r), statistics.median(c for _, c in r)) for name, r in results.items()}


if __name__ == "__main__":
    sys.exit(main())
