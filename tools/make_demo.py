#!/usr/bin/env python
"""Build the bundled demo sample (``usdworld/demo_data/``), reproducibly.

Usage::

    python tools/make_demo.py            # rewrite usdworld/demo_data/
    python tools/make_demo.py --check    # exit 1 if usdworld/demo_data/ differs from a fresh build
    python tools/make_demo.py --out DIR  # write the sample into DIR instead

The sample is one synthetic street scene (seed ``SEED`` = 9, 1024x512) rendered from the built-in
asset library to Cityscapes-format files named ``demo_000000_000019_*``: the photo, label and
instance PNGs, the camera JSON and the ground-truth JSON. The same code and assets give the
same bytes on the same machine (Mesa llvmpipe); a GPU driver may round a few pixels differently.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.synth import make_street_scene, write_cityscapes_frame

SEED = 9
WIDTH, HEIGHT = 1024, 512
NAME = "demo_000000_000019"
DEFAULT_OUT = REPO / "usdworld" / "demo_data"
MAX_TOTAL_BYTES = 2 * 1024 * 1024


def build(out: Path) -> dict[str, Path]:
    """Write the demo sample into ``out``; returns the written paths by role."""
    scene = make_street_scene(np.random.default_rng(SEED), WIDTH, HEIGHT)
    # The demo shows the sunny street it always has (its seed draws an overcast sky since synth
    # samples overcast scenes): shadows show off the lighting.
    return write_cityscapes_frame(dataclasses.replace(scene, overcast=False), out, NAME)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--out", type=Path, default=DEFAULT_OUT, help="folder to write (default: %(default)s)"
    )
    parser.add_argument(
        "--check", action="store_true", help="compare a fresh build with --out; exit 1 on a difference"
    )
    args = parser.parse_args(argv)
    if args.check:
        with tempfile.TemporaryDirectory() as tmp:
            fresh = build(Path(tmp))
            stale = [
                p.name
                for p in fresh.values()
                if not (args.out / p.name).is_file() or (args.out / p.name).read_bytes() != p.read_bytes()
            ]
        if stale:
            print(
                f"{args.out}: out of date: {', '.join(stale)}; run python tools/make_demo.py", file=sys.stderr
            )
            return 1
        print(f"{args.out}: up to date")
        return 0
    paths = build(args.out)
    total = sum(p.stat().st_size for p in paths.values())
    for p in paths.values():
        print(f"{p.stat().st_size:>9,d}  {p.relative_to(REPO) if p.is_relative_to(REPO) else p}")
    print(f"{total:>9,d}  total")
    if total > MAX_TOTAL_BYTES:
        print(
            f"error: the demo sample is {total:,d} bytes, over the {MAX_TOTAL_BYTES:,d} byte budget",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
