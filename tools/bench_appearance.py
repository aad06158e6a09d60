"""What measuring and authoring the photo's colours adds to ``usdworld build``.

Builds each frame with the appearance stage (``usdworld.appearance_stage``) and without it
(the stage replaced by one that returns no colours: the floor), interleaved, ``--repeat``
times each, and prints the median wall time of each and their ratio, with the load average.

Usage::

    python tools/bench_appearance.py [DATA_DIR] [--repeat 5]

Frames (under ``DATA_DIR``, default ``$USDWORLD_DATA``): the Cityscapes frame (labels and
instances), nuScenes front and KITTI 000008 (boxes and calibration).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

from usdworld import pipeline
from usdworld.appearance_stage import PhotoColours
from usdworld.resources import evaluation_data_dir


def _frames(data: Path) -> dict[str, dict[str, Path]]:
    city = data / "cityscapes"
    prefix = "frankfurt_000000_000294"
    kitti = data / "kitti" / "training"
    nus = data / "nuscenes" / "kitti_format"
    return {
        "cityscapes": {
            "image": city / f"{prefix}_leftImg8bit.png",
            "labels": city / f"{prefix}_gtFine_labelIds.png",
            "instances": city / f"{prefix}_gtFine_instanceIds.png",
        },
        "nuscenes_front": {
            "image": nus / "image_2/nus_front.png",
            "detections": nus / "label_2/nus_front.txt",
            "camera": nus / "calib/nus_front.txt",
        },
        "kitti_000008": {
            "image": kitti / "image_2/000008.png",
            "detections": kitti / "label_2/000008.txt",
            "camera": kitti / "calib/000008.txt",
        },
    }


def _build_seconds(inputs: dict[str, Path], out: Path, with_colours: bool) -> float:
    real = pipeline.photo_colours
    if not with_colours:  # nothing measured: no appearance is made
        pipeline.photo_colours = lambda *args, **kwargs: PhotoColours((), ())  # type: ignore[assignment]
    try:
        t0 = time.perf_counter()
        pipeline.build(pipeline.BuildRequest(output=out, **inputs))  # type: ignore[arg-type]
        return time.perf_counter() - t0
    finally:
        pipeline.photo_colours = real  # type: ignore[assignment]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="?", type=Path, default=None)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    data = args.data if args.data is not None else evaluation_data_dir()
    print(
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {platform.machine()}, {os.cpu_count()} cores, "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    print(f"{'frame':<16} {'floor s':>8} {'with colours s':>15} {'ratio':>6}")
    with tempfile.TemporaryDirectory() as tmp:
        for name, inputs in _frames(data).items():
            times: dict[bool, list[float]] = {False: [], True: []}
            for i in range(args.repeat):
                for on in (False, True) if i % 2 == 0 else (True, False):
                    times[on].append(_build_seconds(inputs, Path(tmp) / f"{name}_{on}_{i}", on))
            floor, cost = statistics.median(times[False]), statistics.median(times[True])
            print(f"{name:<16} {floor:>8.2f} {cost:>15.2f} {cost / floor:>6.2f}")
    print(f"load average at the end {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
