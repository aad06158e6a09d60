"""Benchmark ``build --views``: is building near-linear in the number of views? (issue 19)

On the nuScenes sample, builds the world of the first k cameras (k = 1 .. 6) with
``build_views`` and, in the same run and interleaved with it, the floor: each of those
views built alone as a single image with the same camera and detections
(:func:`usdworld.views.build.view_model`, no fusion, no writing), summed. The ratio
``views / floor`` says what the rig adds (fusion, one ground, writing one world and its
cameras); a ratio that stays flat as k grows is linear building. With ``--jobs 2`` the
views run in a local process pool.

Usage::

    python tools/bench_views.py [INFO] [--runs 3] [--jobs 1]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from usdworld.resources import evaluation_data_dir
from usdworld.views.build import ViewsRequest, build_views, view_model
from usdworld.views.nuscenes import read_nuscenes_views


def main(argv: list[str] | None = None) -> int:
    """Print a markdown table of median seconds per view count."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("info", nargs="?", type=Path, default=None)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args(argv)
    info = args.info or min((evaluation_data_dir() / "nuscenes" / "demo").glob("*.pkl.DERIVED.json"))
    views = read_nuscenes_views(info)
    counts = range(1, len(views.views) + 1)
    rig_s: dict[int, list[float]] = {k: [] for k in counts}
    floor_s: dict[int, list[float]] = {k: [] for k in counts}
    with tempfile.TemporaryDirectory() as tmp:
        build_views(ViewsRequest(views, Path(tmp) / "warm", jobs=1))  # warm-up: imports, asset cards
        for run in range(args.runs):
            for k in counts:
                subset = dataclasses.replace(views, views=views.views[:k])
                t0 = time.perf_counter()
                build_views(ViewsRequest(subset, Path(tmp) / f"w{run}_{k}", jobs=args.jobs))
                rig_s[k].append(time.perf_counter() - t0)
                request = ViewsRequest(subset, Path(tmp) / "unused", jobs=1)
                t0 = time.perf_counter()
                for i in range(k):
                    view_model(request, i)
                floor_s[k].append(time.perf_counter() - t0)
    print(
        f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"load average {os.getloadavg()[0]:.1f}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
        f"jobs {args.jobs}, median of {args.runs}"
    )
    print("| views | objects (boxes) | build --views s | floor: views alone, summed s | ratio | s per view |")
    print("|---|---|---|---|---|---|")
    for k in counts:
        boxes = sum(len(v.detection_items.items) for v in views.views[:k])
        r, f = statistics.median(rig_s[k]), statistics.median(floor_s[k])
        print(f"| {k} | {boxes} | {r:.2f} | {f:.2f} | {r / f:.2f} | {r / k:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
