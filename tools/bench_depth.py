"""CPU inference time of the depth networks with random weights.

Times, per network, the median of ``--runs`` runs after ``--warmup`` runs:

* ``forward``: one forward pass at the network's resolution (monodepth 512x256,
  monodepth2 640x192), batch 1, ``torch.inference_mode``;
* ``predict``: the backend's whole ``predict()`` on a photo of ``--image`` size
  (resize in, monodepth's flip post-processing, which runs a batch of 2, resize out,
  depth conversion).

Weights are random, saved to a temporary folder and loaded through the backends'
real loading path. Prints a markdown table for BENCHMARKS.md.

Usage:
    python tools/bench_depth.py [--runs 10] [--warmup 2] [--image 2048x1024] [--device cpu]
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

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def _median_ms(fn: Callable[[], object], runs: int, warmup: int) -> float:
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1000.0 * statistics.median(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10, help="timed runs (>= 10 for BENCHMARKS.md)")
    parser.add_argument("--warmup", type=int, default=2, help="untimed runs first")
    parser.add_argument(
        "--image", default="2048x1024", help="photo size WxH for predict() (Cityscapes: 2048x1024)"
    )
    parser.add_argument("--device", default="cpu", help="torch device (default cpu)")
    args = parser.parse_args(argv)

    import torch

    from usdworld.perception.depth.monodepth import INPUT_HEIGHT, INPUT_WIDTH, MonodepthBackend, MonodepthNet
    from usdworld.perception.depth.monodepth2 import DepthDecoder, Monodepth2Backend, ResnetEncoder

    w, h = (int(v) for v in args.image.lower().split("x"))
    rgb = np.random.default_rng(0).integers(0, 256, (h, w, 3), dtype=np.uint8)
    torch.manual_seed(0)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        torch.save(
            {
                "state_dict": MonodepthNet().state_dict(),
                "meta": {"baseline_m": 0.22, "focal_px": 2262.0, "width": 2048},
            },
            folder / "monodepth.pth",
        )
        (folder / "md2").mkdir()
        enc = ResnetEncoder().state_dict()
        enc.update(height=192, width=640, use_stereo=True)
        torch.save(enc, folder / "md2" / "encoder.pth")
        torch.save(DepthDecoder().state_dict(), folder / "md2" / "depth.pth")

        md = MonodepthBackend(folder / "monodepth.pth", args.device)
        x = torch.rand(1, 3, INPUT_HEIGHT, INPUT_WIDTH, device=md.device)

        def md_forward() -> object:
            with torch.inference_mode():
                return md.net(x)[0]

        rows.append(
            (
                "monodepth (VGG, Godard 2017)",
                f"{INPUT_WIDTH}x{INPUT_HEIGHT}",
                _median_ms(md_forward, args.runs, args.warmup),
                _median_ms(lambda: md.predict(rgb), args.runs, args.warmup),
            )
        )

        md2 = Monodepth2Backend(folder / "md2", args.device)
        x2 = torch.rand(1, 3, md2.height, md2.width, device=md2.device)

        def md2_forward() -> object:
            with torch.inference_mode():
                return md2.decoder(md2.encoder(x2))[0]

        rows.append(
            (
                "monodepth2 (ResNet-18)",
                f"{md2.width}x{md2.height}",
                _median_ms(md2_forward, args.runs, args.warmup),
                _median_ms(lambda: md2.predict(rgb), args.runs, args.warmup),
            )
        )

    threads = torch.get_num_threads()
    print(
        f"<!-- torch {torch.__version__}, {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, {threads} threads, device {args.device}, "
        f"median of {args.runs} runs after {args.warmup} warm-up -->"
    )
    print(f"| network | input | forward ms | predict() ms on {w}x{h} | device / threads |")
    print("|---|---|---|---|---|")
    for name, size, fwd, pred in rows:
        print(f"| {name} | {size} | {fwd:.0f} | {pred:.0f} | {args.device} / {threads} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
