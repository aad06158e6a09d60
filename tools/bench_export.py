#!/usr/bin/env python
"""Time ``usdworld export`` of the demo world as usdz against the glb floor; print markdown tables.

Usage::

    python tools/bench_export.py [--repeats 5]

Whole commands (wall clock of a subprocess: interpreter start, imports, export, validation),
the variants interleaved in each of ``--repeats`` rounds, median wall and CPU time (user +
system of the child) reported with the load average:

* ``--format glb``: the floor of issue 21 (its validator, the Khronos one, runs where
  installed);
* ``--format usdz``: the target, at most 2.5 s; the world's own layers and prims are
  validated, the assets with a clean, current card are not (UsdValidation and
  omni-asset-validator where installed);
* ``--format usdz`` of a copy of the world whose cards record no validation: every asset is
  validated too (what every export did before the cards recorded it).

Then one export in a fresh process, step by step: imports, packaging, and the validation of
the package, scoped as the export does it and, as the reference in the same process, with no
card trusted.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

from bench_common import run_timed

REPO = Path(__file__).resolve().parents[1]

#: Issue 21's target for the usdz export, seconds.
TARGET_USDZ_S = 2.5

#: One export in a fresh process, timed step by step (argv: world folder, output folder).
BREAKDOWN = r"""
import sys, time
t0 = time.perf_counter()
from pathlib import Path
from usdworld.export.checks import check_usd_export
from usdworld.export.usd_formats import write_usdz
t1 = time.perf_counter()
world, out = Path(sys.argv[1]), Path(sys.argv[2])
write_usdz(world / "world.usda", out / "w.usdz")
t2 = time.perf_counter()
scoped = check_usd_export(out / "w.usdz", "usdz", cards_dir=world / "assets")
t3 = time.perf_counter()
full = check_usd_export(out / "w.usdz", "usdz", cards_dir=None)
t4 = time.perf_counter()
assert scoped.ok and full.ok, (scoped.errors, full.errors)
d = scoped.details
print(f"{t1 - t0} {t2 - t1} {t3 - t2} {t4 - t3} {len(d['trusted_assets'])} {d['layers_checked']} "
      f"{d['layers_skipped']} {d['prims_checked']}")
"""


def _unvouched_copy(world: Path, dest: Path) -> Path:
    """A copy of the world whose asset cards record no validation."""
    shutil.copytree(world, dest)
    for card_file in (dest / "assets").glob("*.card.json"):
        card = json.loads(card_file.read_text(encoding="utf-8"))
        card.pop("validation", None)
        card_file.write_text(json.dumps(card, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    return dest


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    usdworld = [sys.executable, "-m", "usdworld", "-q"]
    with tempfile.TemporaryDirectory() as scratch:
        tmp = Path(scratch)
        run_timed([*usdworld, "demo", "-o", str(tmp / "demo_world")], env)
        world = tmp / "demo_world"
        unvouched = _unvouched_copy(world, tmp / "unvouched")
        variants = {
            "glb (floor)": [*usdworld, "export", str(world), "--format", "glb", "-o", str(tmp / "o.glb")],
            "usdz": [*usdworld, "export", str(world), "--format", "usdz", "-o", str(tmp / "o.usdz")],
            "usdz, no card vouches": [
                *usdworld,
                "export",
                str(unvouched),
                "--format",
                "usdz",
                "-o",
                str(tmp / "u.usdz"),
            ],
        }
        times: dict[str, list[tuple[float, float]]] = {name: [] for name in variants}
        loads = [os.getloadavg()[0]]
        for _ in range(args.repeats):
            for name, command in variants.items():
                wall, cpu, _ = run_timed(command, env)
                times[name].append((wall, cpu))
            loads.append(os.getloadavg()[0])
        (tmp / "parts").mkdir()
        parts = run_timed([sys.executable, "-c", BREAKDOWN, str(world), str(tmp / "parts")], env)[2].split()
    median = {
        name: (statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs))
        for name, runs in times.items()
    }
    floor_wall, floor_cpu = median["glb (floor)"]
    print(
        f"`usdworld export` of the demo world, whole command; median of {args.repeats} interleaved rounds; "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {platform.node()}, {os.cpu_count()} CPUs, "
        f"load average (1 min) {min(loads):.1f}-{max(loads):.1f}. Target: usdz <= {TARGET_USDZ_S} s.\n"
    )
    print("| export | wall s | / glb | CPU s | / glb |")
    print("|---|---:|---:|---:|---:|")
    for name, (wall, cpu) in median.items():
        print(f"| {name} | **{wall:.2f}** | {wall / floor_wall:.2f} | {cpu:.2f} | {cpu / floor_cpu:.2f} |")
    imports, package, scoped, full = (1000 * float(v) for v in parts[:4])
    trusted, checked, skipped, prims = parts[4:]
    print(
        f"\nOne usdz export in a fresh process, milliseconds: imports {imports:.0f}, packaging {package:.0f}, "
        f"validation as exported {scoped:.0f} ({trusted} assets trusted: {skipped} layers skipped, {checked} "
        f"validated, {prims} prims through UsdValidation), the same package with no card trusted {full:.0f}."
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
