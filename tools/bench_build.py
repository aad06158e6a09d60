"""Benchmark ``usdworld build`` on a 2048x1024 Cityscapes-format frame.

Makes a synthetic street frame (``usdworld.synth``, rendered headless), then measures
in-process, after one warm-up: the median wall and CPU time of the whole build (reading,
perception, layout, authoring, writing the world folder), of its compute alone
(``build_model``: no writing) and of merely decoding its input files, over ``--runs`` runs
each, and where a build's time goes: each stage's share (cProfile's time of the calls
``usdworld/pipeline.py`` makes to the stage's functions, over ``--runs`` profiled builds; the
profiler slows Python code more than numpy and OpenCV calls).

The build runs its independent stages on ``BuildRequest.threads`` threads (default 2,
:mod:`usdworld.stage_threads`); the in-process table also gives the same build on one thread
(``threads=1``, the stages one after another) where the checkout has the field. The stage
table and the profile time one-thread builds (cProfile sees only the calling thread), each
stage by its own thread's CPU time.

With ``--command`` it also times the whole ``usdworld build`` command against its floor, a
Python process that imports ``pxr.Usd`` and ``cv2`` and decodes the three PNGs, the two taking
turns ``--runs`` times (median wall and CPU time of each; CPU time is the steadier of the two
on a shared machine). Both run with byte-compiled modules (``PYTHONPYCACHEPREFIX`` in a
temporary folder, filled by a warm-up run), as an installed package does: without them every
command compiles usdworld's modules again.

With ``--command`` it also splits the whole command's time (``--runs`` more fresh processes of each
checkout, in the same turns, median of each part, wall / CPU): the interpreter's start (Python and
``site``), the start-up (imports and the command line, until ``usdworld.pipeline.build`` is
called), the build itself (the first of the process), what follows until ``main`` returns (the
summary), and the teardown (after the exit handlers). The command runs through its console entry
point (``usdworld.cli.main.run``), as ``python -m usdworld`` does; a probe around it records the
process's CPU time and the clock at those marks (:data:`_PHASES_PROBE`).

With ``--compare CHECKOUT`` (another checkout of usdworld, e.g. main's) the same frame is
built in process by this checkout and by the other one, each in a fresh process, taking turns
``--rounds`` times, and the other's whole command joins the turns of ``--command``: before and
after in the same run.

Prints the load average, the machine, OpenCV's thread count, markdown tables for BENCHMARKS.md
and the issue's two targets (in process <= 150 ms, command <= 2.0x its floor) against the
medians, with the command line to re-measure them on an idle machine. Threads gain wall time
only where a core is free: on a loaded machine compare the CPU columns too.

Usage::

    python tools/bench_build.py [--runs 9] [--size 2048x1024] [--seed 3] [--command] [--compare ../main]
"""

from __future__ import annotations

import argparse
import cProfile
import dataclasses
import datetime
import json
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

import cv2
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

#: The stages of a build, as (name, [(module file suffix, function name), ...]): the functions
#: ``usdworld/pipeline.py`` calls, each timed only where pipeline.py calls it (cProfile's time of
#: that caller-callee edge), so a helper that a stage also calls inside is not counted twice.
STAGES = (
    (
        "decoding the inputs (image, labels, camera)",
        [("io/images.py", "read_image"), ("pipeline.py", "_read_segmentation"), ("io/camera_files.py", "read_camera"), ("pipeline.py", "_read_detections")],
    ),
    ("street vanishing point: LSD segments", [("geometry/vanishing.py", "detect_segments")]),
    ("street vanishing point: RANSAC (street and vertical)", [("geometry/vanishing.py", "find_vanishing_point"), ("geometry/vanishing.py", "find_vertical_vanishing_point")]),
    ("perception (objects from the labels)", [("pipeline.py", "_objects"), ("perception/objects.py", "segment_regions")]),
    ("asset catalogue", [("authoring/asset_measures.py", "asset_catalogue")]),
    (
        "camera estimate (street view, focal, lanes, roll, pose)",
        [("layout/camera_cues.py", "street_view"), ("layout/focal_cues.py", "estimate_focal"), ("geometry/lanes.py", "find_lane_markings"),
         ("geometry/roll.py", "roll_from_vertical"), ("pipeline.py", "_camera"), ("io/exif.py", "read_exif_focal")],
    ),
    ("dense depth", [("usdworld/depth_stage.py", "estimate_depth")]),
    ("ground homography and road axis", [("pipeline.py", "_ground_fit"), ("layout/yaw.py", "road_axis"), ("layout/surfaces.py", "surface_points"), ("pipeline.py", "_label_mask")]),
    ("placement", [("layout/placement.py", "place_objects")]),
    ("ground surfaces", [("layout/surfaces.py", "fill_hidden_ground"), ("layout/surfaces.py", "build_surfaces")]),
    ("light (sun from the shadows, sky)", [("usdworld/light_stage.py", "estimate_scene_light"), ("usdworld/light_stage.py", "world_lighting"), ("usdworld/light_stage.py", "light_rig")]),
    (
        "appearance (colours from the photo)",
        [("usdworld/appearance_stage.py", "photo_colours"), ("usdworld/appearance_stage.py", "appearances_for")],
    ),
    ("report (make_report)", [("usdworld/report.py", "make_report")]),
    ("authoring: write_world (the layers, assets)", [("authoring/world.py", "write_world")]),
    ("report.json (json.dumps, write)", [("json/__init__.py", "dumps"), ("pathlib.py", "write_text")]),
    ("output folder (prepare, swap in)", [("usdworld/output_dir.py", "prepare_output"), ("usdworld/output_dir.py", "swap_in"), ("tempfile.py", "mkdtemp")]),
)


def _median_s(fn, runs: int) -> tuple[float, float, float]:
    """Median wall and CPU seconds (this process, all threads) of ``runs`` calls after one warm-up,
    and the median CPU seconds of the calling thread alone: the work left on the build's critical
    path when its stages run on helper threads too (about its wall time with a free core per thread)."""
    fn()
    walls, cpus, own = [], [], []
    for _ in range(runs):
        t0, c0, m0 = time.perf_counter(), time.process_time(), time.thread_time()
        fn()
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
        own.append(time.thread_time() - m0)
    return statistics.median(walls), statistics.median(cpus), statistics.median(own)


def _frame(tmp: Path, width: int, height: int, seed: int) -> dict[str, Path]:
    scene = make_street_scene(np.random.default_rng(seed), width, height)
    return write_cityscapes_frame(scene, tmp / "in", "bench_000000_000001")


def _request(files: dict[str, Path], out: Path, threads: int | None = None) -> BuildRequest:
    """The frame's build request; ``threads`` where given (and the checkout has the field)."""
    extra = {} if threads is None else {"threads": threads}
    return BuildRequest(
        image=files["image"], labels=files["labels"], instances=files["instances"], camera=files["camera"], output=out, **extra
    )


def _has_threads() -> bool:
    """Whether this process's usdworld builds on several threads (``BuildRequest.threads``)."""
    return "threads" in {f.name for f in dataclasses.fields(BuildRequest)}


def _in_process(files: dict[str, Path], out: Path, runs: int) -> dict[str, tuple[float, float]]:
    """Median (wall, CPU) seconds of the whole build, of its compute alone and of decoding the inputs;
    and of the whole build on one thread (``build_1``) where the checkout has threads."""
    request = _request(files, out)
    libraries = library_dirs(None)

    def decode() -> None:
        image = read_image(request.image)
        read_segmentation(request.labels, request.instances, image)
        read_camera(request.camera, image)

    timings = {
        "build": _median_s(lambda: build(request), runs),
        "compute": _median_s(lambda: build_model(request, libraries), runs),
        "decode": _median_s(decode, runs),
    }
    if _has_threads():
        one = _request(files, out, threads=1)
        timings["build_1"] = _median_s(lambda: build(one), runs)
    return timings


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=9)
    parser.add_argument("--size", default="2048x1024")
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--command", action="store_true", help="also time the whole command against its floor")
    parser.add_argument(
        "--compare",
        type=Path,
        metavar="CHECKOUT",
        help="also time another checkout's build (e.g. main), in fresh processes taking turns with this one's, and its command",
    )
    parser.add_argument("--rounds", type=int, default=3, help="turns of --compare's in-process runs (default 3)")
    parser.add_argument("--in-process-json", type=Path, metavar="FRAME_DIR", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.in_process_json is not None:  # a child of --compare: this checkout's in-process medians as JSON
        files = {k: next(args.in_process_json.glob(f"*{suffix}")) for k, suffix in _SUFFIXES.items()}
        with tempfile.TemporaryDirectory() as tmp:
            print(json.dumps(_in_process(files, Path(tmp) / "world", args.runs)))
        return 0
    width, height = (int(v) for v in args.size.lower().split("x"))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        files = _frame(tmp, width, height, args.seed)
        timings = _in_process(files, tmp / "world", args.runs)
        request = _request(files, tmp / "world")
        objects = len(build(request).model.placements)
        # The stages one after another, on this thread: cProfile and the stage clocks see them all.
        sequential = _request(files, tmp / "world", threads=1) if _has_threads() else request
        shares = _profile(lambda: build(sequential), args.runs)
        stage_cpu = _stage_cpu(lambda: build(sequential), args.runs)
        pairs = _compare_in_process(files, args.compare, args.runs, args.rounds) if args.compare else None
        command, phases = _command_vs_floor(files, tmp, args.runs, args.compare) if args.command or args.compare else (None, None)
    threads = getattr(request, "threads", 1)
    print(
        f"{datetime.datetime.now():%Y-%m-%d %H:%M}, {platform.machine()}, {os.cpu_count()} cores, "
        f"python {platform.python_version()}, load average {os.getloadavg()[0]:.2f} at the end; "
        f"build threads {threads}, OpenCV threads {cv2.getNumThreads()}"
    )
    print(f"\n{width}x{height} Cityscapes-format frame, synth seed {args.seed}, {objects} objects; median of {args.runs}, wall / CPU:\n")
    print(
        "| checkout | build, wall / CPU / calling thread's CPU | of which compute (no writing) | decode inputs only "
        "| build / decode, wall | CPU | build on one thread, wall / CPU / calling thread's CPU |"
    )
    print("|---|---|---|---|---|---|---|")
    rows = [(f"this one ({REPO.name}), in this process", timings)]
    if pairs is not None:
        rows += [(f"{name}, fresh process, round {i + 1}", t) for i, round_ in enumerate(pairs) for name, t in round_]
    for name, t in rows:
        (bw, bc, bm), (mw, mc, _), (dw, dc, _) = t["build"], t["compute"], t["decode"]
        one = " / ".join(f"{v * 1000:.0f}" for v in t["build_1"]) + " ms" if "build_1" in t else "(no threads)"
        print(
            f"| {name} | {bw * 1000:.0f} / {bc * 1000:.0f} / {bm * 1000:.0f} ms | {mw * 1000:.0f} / {mc * 1000:.0f} ms "
            f"| {dw * 1000:.0f} / {dc * 1000:.0f} ms | {bw / dw:.1f}x | {bc / dc:.1f}x | {one} |"
        )
    print(f"\n| stage (build on one thread) | CPU per build (median of {args.runs}, no profiler) | share of the build (cProfile: its calls from pipeline.py) |")
    print("|---|---|---|")
    for name, share in shares:
        cpu = stage_cpu.get(name)
        print(f"| {name} | {'' if cpu is None else f'{cpu * 1000:.1f} ms'} | {100 * share:.0f} % |")
    if command is not None:
        print("\n| whole process, median of {0} taking turns | wall | CPU (user + system) | wall / floor | CPU / floor |".format(args.runs))
        print("|---|---|---|---|---|")
        (fw, fc) = next(iter(command.values()))
        for name, (wall, cpu) in command.items():
            print(f"| {name} | {wall:.2f} s | {cpu:.2f} s | {wall / fw:.2f}x | {cpu / fc:.2f}x |")
        print(f"\nWhere the whole command's time goes (fresh processes in the same turns, median of {args.runs}, wall / CPU ms):\n")
        print("| checkout | " + " | ".join(PHASES) + " |")
        print("|---|" + "---|" * len(PHASES))
        for name, parts in phases.items():
            print(f"| {name} | " + " | ".join(f"{w * 1000:.0f} / {c * 1000:.0f}" for w, c in (parts[p] for p in PHASES)) + " |")
    _print_targets(timings, command, width, height, args)
    return 0


def _print_targets(timings: dict, command: dict | None, width: int, height: int, args: argparse.Namespace) -> None:
    """The issue's two build targets against this checkout's medians (wall, as the issue sets them;
    CPU beside), and the command that re-measures them on an idle machine."""
    load = os.getloadavg()[0]
    (bw, bc, bm) = timings["build"]
    print(f"\nTargets (issue 21 item 1; wall on an idle machine; load average now {load:.2f} on {os.cpu_count()} cores):\n")
    print("| target | this checkout, wall | CPU (calling thread's) | met (wall) |")
    print("|---|---|---|---|")
    print(
        f"| build in process <= 150 ms at 2048x1024 ({width}x{height} here) | {bw * 1000:.0f} ms "
        f"| {bc * 1000:.0f} ms ({bm * 1000:.0f} ms) | {'yes' if bw <= 0.150 else 'no'} |"
    )
    if command is not None:
        (fw, fc) = next(iter(command.values()))
        (cw, cc) = next(v for k, v in command.items() if REPO.name in k and k.startswith("`usdworld build`"))
        print(
            f"| whole `usdworld build` <= 2.0x its floor | {cw / fw:.2f}x ({cw:.2f} / {fw:.2f} s) | {cc / fc:.2f}x "
            f"| {'yes' if cw / fw <= 2.0 else 'no'} |"
        )
    if load > 0.5 * (os.cpu_count() or 1):
        print(
            "\nThe machine is loaded: threads gain wall time only where a core is free; re-measure idle "
            "(the calling thread's CPU is what the build's critical path costs with a free core)."
        )
    print(
        "\nRe-measure idle: python -m compileall -q usdworld tools && "
        f"python tools/bench_build.py --runs {args.runs} --rounds {args.rounds} --size {width}x{height} --seed {args.seed} "
        "--command --compare /work/main"
    )


#: The frame's files by role, as their names end.
_SUFFIXES = {"image": "_leftImg8bit.png", "labels": "_gtFine_labelIds.png", "instances": "_gtFine_instanceIds.png", "camera": "_camera.json"}


def _compare_in_process(files: dict[str, Path], other: Path, runs: int, rounds: int) -> list[list[tuple[str, dict]]]:
    """Per round, the in-process medians of this checkout and of ``other``, each in a fresh process, taking turns."""
    frame = files["image"].parent
    out = []
    for _ in range(rounds):
        round_ = []
        for name, repo in ((f"this one ({REPO.name})", REPO), (f"{Path(other).resolve().name}", Path(other).resolve())):
            env = _env(repo, frame.parent)
            cmd = [sys.executable, str(Path(__file__).resolve()), "--runs", str(runs), "--in-process-json", str(frame)]
            result = subprocess.run(cmd, check=True, env=env, capture_output=True, text=True, cwd=frame.parent)
            round_.append((name, {k: tuple(v) for k, v in json.loads(result.stdout.strip().splitlines()[-1]).items()}))
        out.append(round_)
    return out


def _env(repo: Path, tmp: Path) -> dict[str, str]:
    """The environment of a child process running ``repo``'s usdworld with byte-compiled modules."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPYCACHEPREFIX"] = str(tmp / "pycache" / repo.name)
    env["PYTHONPATH"] = os.pathsep.join([str(repo), *filter(None, [os.environ.get("PYTHONPATH")])])
    return env


def _stage_cpu(fn, runs: int) -> dict[str, float]:
    """Each stage's CPU seconds per build (median over ``runs`` builds), timed without a profiler.

    The functions of :data:`STAGES` that ``usdworld/pipeline.py`` imports by name are wrapped
    in its namespace for the measurement (so only its own calls are timed, as in the profile);
    the stages it calls otherwise (``json.dumps``, ``tempfile``) are left blank and fall into
    the rest, which is the whole build's CPU less the stages'.
    """
    import usdworld.pipeline as pipeline

    spent: dict[str, float] = {}
    wrapped = {}
    timed_stages: set[str] = set()
    for name, functions in STAGES:
        for _, fn_name in functions:
            if not callable(getattr(pipeline, fn_name, None)):
                fn_name = f"_{fn_name}"  # imported under a private alias (``_prepare_output``)
            original = getattr(pipeline, fn_name, None)
            if original is None or not callable(original) or fn_name in wrapped:
                continue

            def timed(*args, __original=original, __stage=name, **kwargs):
                c0 = time.thread_time()  # this stage's own thread: a helper thread's stages run beside it
                try:
                    return __original(*args, **kwargs)
                finally:
                    spent[__stage] = spent.get(__stage, 0.0) + time.thread_time() - c0

            wrapped[fn_name] = original
            timed_stages.add(name)
            setattr(pipeline, fn_name, timed)
    per_build: dict[str, list[float]] = {}
    try:
        fn()
        for _ in range(runs):
            spent.clear()
            c0 = time.process_time()
            fn()
            total = time.process_time() - c0
            for name in timed_stages:
                per_build.setdefault(name, []).append(spent.get(name, 0.0))
            per_build.setdefault("everything else (pipeline.py's own lines)", []).append(total - sum(spent.values()))
            per_build.setdefault("the whole build", []).append(total)
    finally:
        for fn_name, original in wrapped.items():
            setattr(pipeline, fn_name, original)
    return {name: statistics.median(values) for name, values in per_build.items()}


#: Where a stage's calls are made: pipeline.py, or StageThreads.submit for the stages pipeline.py
#: hands it (the photo's decoding; on one thread submit calls them at once).
_CALLERS = ("usdworld/pipeline.py", "usdworld/stage_threads.py")


def _profile(fn, runs: int) -> list[tuple[str, float]]:
    """Each stage's share of the build's time, from cProfile over ``runs`` builds.

    A stage's time is that of its functions' calls from ``usdworld/pipeline.py`` or from
    :class:`~usdworld.stage_threads.StageThreads` (the caller-callee edges), so nested calls are
    not counted twice.
    """
    profile = cProfile.Profile()
    profile.enable()
    for _ in range(runs):
        fn()
    profile.disable()
    stats = pstats.Stats(profile).stats  # type: ignore[attr-defined]
    total = max(ct for (file, _, func), (_, _, _, ct, _) in stats.items() if func == "build" and file.endswith("usdworld/pipeline.py"))
    shares = []
    for name, functions in STAGES:
        spent = 0.0
        for (file, _, func), (_, _, _, _, callers) in stats.items():
            if any(file.endswith(f) and func == fn_name for f, fn_name in functions):
                spent += sum(edge[3] for (caller, _, _), edge in callers.items() if caller.endswith(_CALLERS))
        shares.append((name, spent / total))
    shares.append(("everything else (pipeline.py's own lines)", 1.0 - sum(share for _, share in shares)))
    shares.append(("the whole build", 1.0))
    return shares


#: The parts of a whole command that :data:`_PHASES_PROBE` tells apart, in order.
PHASES = ("interpreter start", "start-up: imports, command line", "the build", "summary", "teardown", "whole process")

#: Runs ``usdworld build`` (``sys.argv[1:]``) through the console entry point, as ``python -m usdworld``
#: does, and prints as JSON on stderr the process's CPU seconds and the clock (``time.time``) at its
#: marks: this probe's first line (the interpreter started), ``usdworld.pipeline.build`` called and
#: returned (wrapped when the command imports the module), and the exit handlers (``main`` returned;
#: the handlers registered first run last, so the teardown alone is left after this one).
_PHASES_PROBE = """
import atexit, importlib.machinery, json, resource, sys, time

def _mark():
    used = resource.getrusage(resource.RUSAGE_SELF)
    return [time.time(), used.ru_utime + used.ru_stime]

marks = {"started": _mark()}

class _WrapBuild:
    def find_spec(self, name, path, target=None):
        if name != "usdworld.pipeline":
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        run = spec.loader.exec_module

        def exec_module(module):
            run(module)
            inner = module.build

            def build(*args, **kwargs):
                marks["build"] = _mark()
                try:
                    return inner(*args, **kwargs)
                finally:
                    marks["built"] = _mark()

            module.build = build

        spec.loader.exec_module = exec_module
        return spec

sys.meta_path.insert(0, _WrapBuild())
atexit.register(lambda: print(json.dumps({**marks, "exit": _mark()}), file=sys.stderr))
sys.argv = ["usdworld", *sys.argv[1:]]
from usdworld.cli.main import run
run()
"""


def _phases(marks: dict[str, list[float]], t0: float, wall: float, cpu: float) -> dict[str, tuple[float, float]]:
    """The (wall, CPU) seconds of each of :data:`PHASES` from a probe's marks, the clock at the
    process's start ``t0`` and the whole process's wall and CPU seconds."""
    points = [(t0, 0.0), *(tuple(marks[k]) for k in ("started", "build", "built", "exit")), (t0 + wall, cpu)]
    parts = [(b[0] - a[0], b[1] - a[1]) for a, b in zip(points, points[1:])]
    return dict(zip(PHASES, [*parts, (wall, cpu)]))


def _command_vs_floor(
    files: dict, tmp: Path, runs: int, other: Path | None = None
) -> tuple[dict[str, tuple[float, float]], dict[str, dict[str, tuple[float, float]]]]:
    """Median (wall, CPU) seconds of the floor process and of the whole ``usdworld build`` (and ``other``'s),
    in turns; and per checkout the median (wall, CPU) seconds of each of :data:`PHASES`."""
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
    procs = {"floor: import pxr.Usd and cv2, decode the three PNGs": (floor, _env(REPO, tmp))}
    procs[f"`usdworld build`, whole command ({REPO.name})"] = (command, _env(REPO, tmp))
    if other is not None:
        procs[f"`usdworld build`, whole command ({Path(other).resolve().name})"] = (command, _env(Path(other).resolve(), tmp))
    probed = {REPO.name: _env(REPO, tmp)}
    if other is not None:
        probed[Path(other).resolve().name] = _env(Path(other).resolve(), tmp)
    probe = [sys.executable, "-c", _PHASES_PROBE, *command[3:]]

    def timed(args: list[str], env: dict[str, str]) -> tuple[float, float, float, str]:
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0, clock = time.perf_counter(), time.time()
        done = subprocess.run(args, check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=tmp)
        wall = time.perf_counter() - t0  # cwd: not the checkout, -m would import it from there
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return wall, (after.ru_utime - usage.ru_utime) + (after.ru_stime - usage.ru_stime), clock, done.stderr

    for args, env in [*procs.values(), *((probe, env) for env in probed.values())]:  # warm-up: byte-compile, file cache
        timed(args, env)
    results: dict[str, list[tuple[float, float]]] = {name: [] for name in procs}
    split: dict[str, list[dict[str, tuple[float, float]]]] = {name: [] for name in probed}
    for _ in range(runs):
        for name, (args, env) in procs.items():
            results[name].append(timed(args, env)[:2])
        for name, env in probed.items():
            wall, cpu, clock, err = timed(probe, env)
            split[name].append(_phases(json.loads(err.strip().splitlines()[-1]), clock, wall, cpu))
    medians = {name: (statistics.median(w for w, _ in r), statistics.median(c for _, c in r)) for name, r in results.items()}
    phases = {
        name: {p: (statistics.median(r[p][0] for r in rows), statistics.median(r[p][1] for r in rows)) for p in PHASES}
        for name, rows in split.items()
    }
    return medians, phases


if __name__ == "__main__":
    sys.exit(main())
