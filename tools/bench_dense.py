"""Benchmark dense scenes: a KITTI frame with N random (or N identical) car boxes.

For each case a fresh Python process writes a KITTI ``label_2`` file of N ``Car`` lines
and builds the world in-process (``usdworld.pipeline.build``: reading, perception,
layout, authoring, writing); the parent reports its wall time, its CPU time
(``time.process_time``, which a loaded machine inflates far less than the wall time) and
peak resident memory (``ru_maxrss`` of the child). A case over ``--timeout`` seconds is stopped and reported
as such; the child's address space is capped at ``--max-gb`` so that a blow-up fails
there instead of swapping a shared machine.

Random boxes: widths 20-200 px, height 0.5-0.9 of the width, bottoms between the KITTI
horizon (row 180) and the image bottom, seeded. Identical boxes: N copies of the
frame's own first car box.

Usage::

    python tools/bench_dense.py [--kitti DIR (default $USDWORLD_DATA/kitti/training)] [--frame 000001]
        [--sizes 100,1000,10000] [--timeout 120] [--max-gb 4]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from usdworld.resources import evaluation_data_dir

#: The box every identical case repeats (KITTI training 000001, its first car), pixels.
IDENTICAL_BOX = (387.63, 181.54, 423.81, 203.12)


def write_labels(path: Path, n: int, identical: bool, width: int, height: int, seed: int = 0) -> None:
    """Write ``n`` KITTI ``Car`` label lines (2D boxes only; the 3D fields are placeholders)."""
    rng = np.random.default_rng(seed)
    lines = []
    for _ in range(n):
        if identical:
            x0, y0, x1, y1 = IDENTICAL_BOX
        else:
            bw = rng.uniform(20, 200)
            bh = bw * rng.uniform(0.5, 0.9)
            x0 = rng.uniform(0, width - bw)
            y1 = rng.uniform(180, height)
            x1, y0 = x0 + bw, max(0.0, y1 - bh)
        lines.append(f"Car 0.00 0 0.00 {x0:.2f} {y0:.2f} {x1:.2f} {y1:.2f} 1.50 1.60 3.90 0.00 1.60 10.00 0.00")
    path.write_text("\n".join(lines) + "\n")


def _child(image: str, calib: str, labels: str, out: str) -> None:
    """Build one case and print its timing as JSON (runs in the child process)."""
    from usdworld.errors import UsdWorldError
    from usdworld.pipeline import BuildRequest, build

    t0, c0 = time.perf_counter(), time.process_time()
    try:
        result = build(BuildRequest(image=Path(image), camera=Path(calib), detections=Path(labels), output=Path(out)))
        outcome = f"built, {len(result.model.placements)} objects"
    except UsdWorldError as exc:
        outcome = f"refused: {exc}"
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(json.dumps({"seconds": seconds, "cpu_seconds": cpu, "outcome": outcome}))


def _run_case(args: argparse.Namespace, image: Path, calib: Path, n: int, identical: bool, tmp: Path) -> dict:
    labels = tmp / f"{'identical' if identical else 'random'}_{n}.txt"
    write_labels(labels, n, identical, 1242, 375)
    limit = int(args.max_gb * 2**30)

    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    cmd = [sys.executable, __file__, "--child", str(image), str(calib), str(labels), str(tmp / f"world_{n}_{identical}")]
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout, preexec_fn=cap)
    except subprocess.TimeoutExpired:
        stopped = f"stopped after {args.timeout:.0f} s"
        return {"seconds": None, "cpu_seconds": None, "outcome": stopped, "rss_mb": None}
    wall = time.perf_counter() - t0
    rss_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # the largest child so far
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["?"])[-1]
        failed = f"failed (exit {proc.returncode}): {last[:120]}"
        return {"seconds": wall, "cpu_seconds": None, "outcome": failed, "rss_mb": rss_mb}
    row = json.loads(proc.stdout.strip().splitlines()[-1])
    row["rss_mb"] = rss_mb
    return row


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--child":
        _child(*argv[1:5])
        return 0
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kitti", type=Path, default=evaluation_data_dir() / "kitti" / "training")
    parser.add_argument("--frame", default="000001")
    parser.add_argument("--sizes", default="100,1000,10000")
    parser.add_argument("--timeout", type=float, default=120.0)
    parser.add_argument("--max-gb", type=float, default=4.0)
    args = parser.parse_args(argv)
    image = args.kitti / "image_2" / f"{args.frame}.png"
    calib = args.kitti / "calib" / f"{args.frame}.txt"
    if not image.is_file() or not calib.is_file():
        print(f"skipped: KITTI frame {args.frame} not found under {args.kitti} (pass --kitti)")
        return 0
    print(f"machine: {platform.machine()}, {os.cpu_count()} cpus, python {platform.python_version()}; load {os.getloadavg()}")
    print("| car boxes | kind | build | CPU | peak RSS | outcome |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for n in (int(v) for v in args.sizes.split(",")):
            for identical in (False, True):
                # A fresh parent-side maximum per case: run each case's child from a new helper process.
                row = _measure(args, image, calib, n, identical, Path(tmp))
                secs = "-" if row["seconds"] is None else f"{row['seconds']:.1f} s"
                cpu = "-" if row["cpu_seconds"] is None else f"{row['cpu_seconds']:.1f} s"
                rss = "-" if row["rss_mb"] is None else f"{row['rss_mb']:.0f} MB"
                kind = "identical" if identical else "random"
                print(f"| {n} | {kind} | {secs} | {cpu} | {rss} | {row['outcome']} |", flush=True)
    return 0


def _measure(args: argparse.Namespace, image: Path, calib: Path, n: int, identical: bool, tmp: Path) -> dict:
    """One case, measured from its own intermediate process so that RUSAGE_CHILDREN is that case's alone."""
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(read)
        row = _run_case(args, image, calib, n, identical, tmp)
        os.write(write, json.dumps(row).encode())
        os._exit(0)
    os.close(write)
    with os.fdopen(read) as f:
        data = f.read()
    os.waitpid(pid, 0)
    return json.loads(data)


if __name__ == "__main__":
    sys.exit(main())
