"""Benchmark ``build --views``: is building near-linear in the number of views? (issue 19)

On the nuScenes sample, builds the world of the first k cameras (k = 1 .. 6) with
``build_views`` and, in the same process, the floor: each of those views built alone as a
single image with the same camera and detections (:func:`usdworld.views.build.view_model`,
no fusion, no writing), summed. The ratio ``views / floor`` says what the rig adds (fusion,
one ground, writing one world and its cameras; a rig whose objects measure a ground spread
places its views again); a ratio that stays flat as k grows is linear building. ``--jobs``
lists the worker counts of the views' local process pool (1: none).

Every measurement runs in a fresh process (imports and a one-view warm-up build first, not
timed) and reports the wall and the CPU seconds of the build (this process's threads plus
its pool workers'). ``--baseline REPO`` times another checkout of usdworld (e.g. main,
``git worktree add`` or ``git archive``) the same way, interleaved with this one and in
alternating order, so the two compare within one run on a loaded machine.

Usage::

    python tools/bench_views.py [INFO] [--runs 3] [--jobs 1 2] [--views 1 2 3 4 5 6]
                                [--baseline REPO] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _cpu_s() -> float:
    """CPU seconds of this process (all threads) and of its reaped children (the pool's workers)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def _child(repo: Path, info: Path, k: int, jobs: int) -> dict[str, float]:
    """One measurement in this fresh process: the k-view build with ``jobs`` workers, then its floor."""
    sys.path.insert(0, str(repo))
    import dataclasses

    from usdworld.views.build import ViewsRequest, build_views, view_model
    from usdworld.views.nuscenes import read_nuscenes_views

    views = read_nuscenes_views(info)
    subset = dataclasses.replace(views, views=views.views[:k])
    with tempfile.TemporaryDirectory() as tmp:
        first = dataclasses.replace(views, views=views.views[:1])
        build_views(ViewsRequest(first, Path(tmp) / "warm", jobs=1))  # imports, asset cards, class table
        t0, c0 = time.perf_counter(), _cpu_s()
        build_views(ViewsRequest(subset, Path(tmp) / "w", jobs=jobs))
        wall, cpu = time.perf_counter() - t0, _cpu_s() - c0
        request = ViewsRequest(subset, Path(tmp) / "unused", jobs=1)
        t0 = time.perf_counter()
        for i in range(k):
            view_model(request, i)
        floor = time.perf_counter() - t0
    return {"wall_s": wall, "cpu_s": cpu, "floor_s": floor}


def _measure(repo: Path, info: Path, k: int, jobs: int) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": str(repo)}
    args = [sys.executable, str(Path(__file__).resolve()), "--child", str(repo), str(info), str(k), str(jobs)]
    done = subprocess.run(args, env=env, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        sys.exit(f"{repo}: the build of {k} views with {jobs} jobs failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    """Print a markdown table of median seconds per view count, worker count and checkout."""
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child"]:
        repo, info, k, jobs = Path(argv[1]), Path(argv[2]), int(argv[3]), int(argv[4])
        print(json.dumps(_child(repo, info, k, jobs)))
        return 0
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("info", nargs="?", type=Path, default=None)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--jobs", type=int, nargs="+", default=[1, 2], help="worker counts (1: no pool)")
    parser.add_argument("--views", type=int, nargs="+", default=None, help="view counts (default: 1 .. all)")
    parser.add_argument("--baseline", type=Path, default=None, help="another checkout timed alongside")
    parser.add_argument("--json", action="store_true", help="print every measurement as one JSON line")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(REPO))
    from usdworld.resources import evaluation_data_dir
    from usdworld.views.nuscenes import read_nuscenes_views

    info = args.info or min((evaluation_data_dir() / "nuscenes" / "demo").glob("*.pkl.DERIVED.json"))
    views = read_nuscenes_views(info)
    counts = args.views or list(range(1, len(views.views) + 1))
    repos = {"this": REPO} | ({"baseline": args.baseline.resolve()} if args.baseline else {})
    got: dict[tuple[str, int, int], list[dict[str, float]]] = {}
    loads = []
    order = list(repos)
    for run in range(args.runs):
        for k in counts:
            for jobs in args.jobs:
                for name in order if (run + k + jobs) % 2 == 0 else order[::-1]:
                    got.setdefault((name, k, jobs), []).append(_measure(repos[name], info, k, jobs))
                    loads.append(os.getloadavg()[0])
    print(
        f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"load average {min(loads):.1f}-{max(loads):.1f}, "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
        f"median of {args.runs}, each a fresh process; this = {REPO}"
        + (f", baseline = {repos['baseline']}" if "baseline" in repos else "")
    )

    def med(name: str, k: int, jobs: int, key: str) -> float:
        return statistics.median(m[key] for m in got[(name, k, jobs)])

    head = "| views | boxes | jobs | build s | CPU s | floor s | ratio | s per view |"
    line = "|---|---|---|---|---|---|---|---|"
    if "baseline" in repos:
        head += " baseline build s | baseline CPU s | this / baseline (wall) | (CPU) |"
        line += "---|---|---|---|"
    print(head)
    print(line)
    for jobs in args.jobs:
        for k in counts:
            boxes = sum(len(v.detection_items.items) for v in views.views[:k])
            r, c, f = (med("this", k, jobs, key) for key in ("wall_s", "cpu_s", "floor_s"))
            row = f"| {k} | {boxes} | {jobs} | {r:.2f} | {c:.2f} | {f:.2f} | {r / f:.2f} | {r / k:.2f} |"
            if "baseline" in repos:
                br, bc = med("baseline", k, jobs, "wall_s"), med("baseline", k, jobs, "cpu_s")
                row += f" {br:.2f} | {bc:.2f} | {r / br:.2f} | {c / bc:.2f} |"
            print(row)
    if args.json:
        print(json.dumps([{"repo": n, "views": k, "jobs": j, "runs": ms} for (n, k, j), ms in got.items()]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
