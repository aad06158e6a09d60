#!/usr/bin/env python
"""How well ``build`` finds the sun and tells sunny from overcast, on synthetic scenes.

For each of ``--count`` scenes (seeds ``--seed`` .. ``--seed + K - 1``, the scenes
``usdworld synth`` and ``tools/eval_synth.py`` make; about 30 % of them overcast) the
Cityscapes-format files are written, the world's metric model is built from the photo,
labels, instances and camera JSON (:func:`usdworld.pipeline.build_model`), and its light
estimate is compared with the scene's ground truth (``sun_direction_world``, ``overcast``).

Reported (``--json`` prints one JSON object, last):

* ``azimuth_error_deg`` / ``elevation_error_deg``: median, mean and 90th percentile over
  the sunny scenes the estimate calls sunny (azimuth error wraps at 360 degrees), a weak
  fit's default sun counted with its error;
* ``weak_fits``: sunny scenes whose fit was too weak to trust (they got the default sun);
* ``trusted_azimuth_error_deg`` / ``trusted_elevation_error_deg``: the same over the
  trusted fits (``cast_shadows``) only;
* ``default_sun_azimuth_error_deg`` / ``default_sun_elevation_error_deg``: the errors the
  default sun alone would make on every sunny scene (what a fit must beat);
* ``overcast_recall``: overcast scenes called overcast, over the overcast scenes;
* ``false_overcast``: sunny scenes called overcast (or with no evidence), over the sunny scenes;
* ``scenes``: one row per scene (truth, estimate, errors, contrast, shadow share, seconds).

Usage::

    python tools/eval_light.py --count 50 --size 1024x512 --json [--jobs 1]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)


#: Light methods that give a sunny world: a trusted fit, or a weak one with the default sun.
SUNNY_METHODS = ("cast_shadows", "weak_fit")


def _size(text: str) -> tuple[int, int]:
    w, h = text.lower().split("x")
    return int(w), int(h)


def angle_difference_deg(a_deg: float, b_deg: float) -> float:
    """Absolute difference of two angles in degrees, wrapped into [0, 180]."""
    d = (a_deg - b_deg) % 360.0
    return min(d, 360.0 - d)


def run_scene(seed: int, size: tuple[int, int], out: str) -> dict[str, Any]:
    """Synthesise one scene, build its model and compare its light with the truth (a worker)."""
    from usdworld.authoring import asset_library
    from usdworld.pipeline import BuildRequest, build_model
    from usdworld.render.lighting import Lighting
    from usdworld.synth import make_street_scene, write_cityscapes_frame

    name = f"synth_000000_{seed:06d}"
    scene = make_street_scene(np.random.default_rng(seed), *size)
    files = write_cityscapes_frame(scene, Path(out) / "frames", name)
    t0 = time.perf_counter()
    model = build_model(
        BuildRequest(
            image=files["image"],
            output=Path(out) / name,
            labels=files["labels"],
            instances=files["instances"],
            camera=files["camera"],
        ),
        asset_library.library_dirs(None),
    )
    seconds = time.perf_counter() - t0
    light = model.light
    sun = scene.sun_direction_world
    true_az = math.degrees(math.atan2(sun[1], sun[0]))
    true_el = math.degrees(math.asin(sun[2]))
    est_az = math.degrees(light.sun_azimuth)
    est_el = math.degrees(light.sun_elevation)
    fitted = light.method in SUNNY_METHODS
    default = Lighting().sun_direction_world
    return {
        "seed": seed,
        "overcast": scene.overcast,
        "method": light.method,
        "true_azimuth_deg": round(true_az, 2),
        "true_elevation_deg": round(true_el, 2),
        "azimuth_deg": round(est_az, 2),
        "elevation_deg": round(est_el, 2),
        "azimuth_error_deg": round(angle_difference_deg(est_az, true_az), 2) if fitted else None,
        "elevation_error_deg": round(abs(est_el - true_el), 2) if fitted else None,
        "default_azimuth_error_deg": round(angle_difference_deg(math.degrees(math.atan2(default[1], default[0])), true_az), 2),
        "default_elevation_error_deg": round(abs(math.degrees(math.asin(default[2])) - true_el), 2),
        "shadow_contrast": None if not math.isfinite(light.shadow_contrast) else round(light.shadow_contrast, 3),
        "shadow_share": None if not math.isfinite(light.shadow_share) else round(light.shadow_share, 4),
        "fit_iou": None if not math.isfinite(light.fit_iou) else round(light.fit_iou, 3),
        "casters": light.casters,
        "fit_casters": light.fit_casters,
        "build_seconds": round(seconds, 2),
    }


def _stats(values: list[float]) -> dict[str, float | int | None]:
    if not values:
        return {"n": 0, "median": None, "mean": None, "p90": None}
    return {
        "n": len(values),
        "median": round(statistics.median(values), 2),
        "mean": round(statistics.fmean(values), 2),
        "p90": round(float(np.percentile(values, 90)), 2),
    }


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The headline numbers of the per-scene rows (see the module docstring)."""
    sunny = [r for r in rows if not r["overcast"]]
    overcast = [r for r in rows if r["overcast"]]
    fitted = [r for r in sunny if r["method"] in SUNNY_METHODS]
    trusted = [r for r in sunny if r["method"] == "cast_shadows"]
    return {
        "scenes": len(rows),
        "sunny": len(sunny),
        "overcast": len(overcast),
        "azimuth_error_deg": _stats([r["azimuth_error_deg"] for r in fitted]),
        "elevation_error_deg": _stats([r["elevation_error_deg"] for r in fitted]),
        "weak_fits": sum(r["method"] == "weak_fit" for r in sunny),
        "trusted_azimuth_error_deg": _stats([r["azimuth_error_deg"] for r in trusted]),
        "trusted_elevation_error_deg": _stats([r["elevation_error_deg"] for r in trusted]),
        "default_sun_azimuth_error_deg": _stats([r["default_azimuth_error_deg"] for r in sunny]),
        "default_sun_elevation_error_deg": _stats([r["default_elevation_error_deg"] for r in sunny]),
        "overcast_recall": round(sum(r["method"] == "overcast" for r in overcast) / len(overcast), 3)
        if overcast
        else None,
        "false_overcast": round(sum(r["method"] not in SUNNY_METHODS for r in sunny) / len(sunny), 3) if sunny else None,
        "median_build_seconds": round(statistics.median(r["build_seconds"] for r in rows), 2) if rows else None,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--count", type=int, default=50, help="number of scenes (default 50)")
    parser.add_argument("--seed", type=int, default=0, help="first seed (default 0; 100 for the held-out set)")
    parser.add_argument("--size", type=_size, default=(1024, 512), help="WxH (default 1024x512)")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    parser.add_argument("--json", action="store_true", help="print the summary and the rows as JSON, last")
    args = parser.parse_args(argv)
    if args.count < 1 or args.jobs < 1:
        parser.error("--count and --jobs must be >= 1")
    seeds = list(range(args.seed, args.seed + args.count))
    with tempfile.TemporaryDirectory(prefix="eval_light_") as tmp:
        if args.jobs == 1:
            rows = [run_scene(s, args.size, tmp) for s in seeds]
        else:
            with ProcessPoolExecutor(args.jobs) as pool:
                rows = list(pool.map(run_scene, seeds, [args.size] * len(seeds), [tmp] * len(seeds)))
    summary = summarise(rows)
    for r in rows:
        print(
            f"seed {r['seed']:3d} {'overcast' if r['overcast'] else 'sunny   '} -> {r['method']:12s} "
            f"az {r['azimuth_deg']:7.1f} (true {r['true_azimuth_deg']:7.1f}) "
            f"el {r['elevation_deg']:5.1f} (true {r['true_elevation_deg']:5.1f}) "
            f"share {r['shadow_share']} contrast {r['shadow_contrast']}",
            file=sys.stderr if args.json else sys.stdout,
        )
    if args.json:
        print(json.dumps({"summary": summary, "scenes": rows}))
    else:
        print(json.dumps(summary, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
