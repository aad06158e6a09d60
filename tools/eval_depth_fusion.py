"""Does a dense depth map help? Per-object depth with ``--depth ground`` versus fused cues.

For K synthetic street scenes (``usdworld.synth``), the renderer's exact depth map is
degraded like a monocular network's output (a global scale error plus smooth, spatially
correlated relative noise), saved as ``.npy`` and given to ``build --depth file``. Each
scene is built twice, without and with the map, and every car and person is compared with
its ground-truth centre depth. Objects whose bottom is cut by the image border or hidden
by another object are reported apart: they have no ground-contact cue.

Usage::

    python tools/eval_depth_fusion.py [--count 30] [--size 1024x512] [--noise 0.10] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

from usdworld.pipeline import BuildRequest, build
from usdworld.synth import make_street_scene, write_cityscapes_frame
from usdworld.synth.cityscapes import render_scene

THING_CLASSES = ("car", "person", "truck", "bus", "rider", "bicycle", "motorcycle")


def degraded_depth(depth_m: np.ndarray, rng: np.random.Generator, noise: float) -> np.ndarray:
    """A network-like depth map: global scale error and smooth multiplicative noise; 0 stays invalid."""
    h, w = depth_m.shape
    field = rng.normal(0.0, 1.0, size=(h // 16 + 1, w // 16 + 1)).astype(np.float32)
    field = cv2.resize(field, (w, h), interpolation=cv2.INTER_CUBIC)
    field = cv2.GaussianBlur(field, (0, 0), sigmaX=8.0)
    field /= max(float(field.std()), 1e-6)
    scale = float(np.exp(rng.normal(0.0, noise / 2)))
    out = depth_m * scale * np.exp(noise * field)
    return np.where(depth_m > 0, out, 0.0).astype(np.float32)


def _camera_depth(camera, centre_world: list[float], size_m: list[float]) -> float:
    centre = np.array([centre_world[0], centre_world[1], centre_world[2] + size_m[2] / 2.0])
    return float(camera.cam_from_world_points(centre[None, :])[0, 2])


def evaluate(count: int, size: tuple[int, int], noise: float, seed: int) -> dict:
    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for i in range(count):
            rng = np.random.default_rng(seed + i)
            scene = make_street_scene(rng, *size)
            name = f"fusion_000000_{seed + i:06d}"
            files = write_cityscapes_frame(scene, tmp / name, name)
            _, result = render_scene(scene)
            depth_file = tmp / name / f"{name}_depth.npy"
            np.save(depth_file, degraded_depth(result.depth_m, rng, noise))
            gt = json.loads(Path(files["gt"]).read_text())
            truth = {
                o["instance_id"]: o
                for o in gt["objects"]
                if o["class"] in THING_CLASSES and o["visible_pixels"] >= 10
            }
            base = dict(image=files["image"], labels=files["labels"], instances=files["instances"], camera=files["camera"])
            ground = build(BuildRequest(output=tmp / name / "ground", **base))
            fused = build(BuildRequest(output=tmp / name / "fused", depth="file", depth_map=depth_file, **base))
            with_map = {p.obj.instance_id: p for p in fused.model.placements}
            for p in ground.model.placements:
                o = truth.get(p.obj.instance_id)
                q = with_map.get(p.obj.instance_id)
                if o is None or q is None:
                    continue
                z = _camera_depth(scene.camera, o["centre_world"], o["size_m"])
                rows.append(
                    {
                        "cut": bool(p.obj.bottom_truncated or p.obj.bottom_occluded),
                        "ground": abs(p.depth_m - z) / z,
                        "fused": abs(q.depth_m - z) / z,
                        "method": q.depth_method,
                    }
                )
    return summarise(rows, count, size, noise)


def summarise(rows: list[dict], count: int, size: tuple[int, int], noise: float) -> dict:
    def stats(group: list[dict]) -> dict:
        if not group:
            return {"objects": 0}
        g = np.array([r["ground"] for r in group])
        f = np.array([r["fused"] for r in group])
        return {
            "objects": len(group),
            "median_rel_error_ground": float(np.median(g)),
            "median_rel_error_fused": float(np.median(f)),
            "p90_rel_error_ground": float(np.percentile(g, 90)),
            "p90_rel_error_fused": float(np.percentile(f, 90)),
        }

    return {
        "scenes": count,
        "size": list(size),
        "noise": noise,
        "all": stats(rows),
        "visible_bottom": stats([r for r in rows if not r["cut"]]),
        "cut_or_hidden_bottom": stats([r for r in rows if r["cut"]]),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=30)
    parser.add_argument("--size", default="1024x512")
    parser.add_argument("--noise", type=float, default=0.10, help="relative depth noise of the degraded map")
    parser.add_argument("--seed", type=int, default=2000)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    summary = evaluate(args.count, size, args.noise, args.seed)
    print(f"{args.count} scenes at {size[0]}x{size[1]}, depth map with {args.noise:.0%} noise")
    print("| objects | n | median rel. error, ground | median, fused with the map | p90 ground | p90 fused |")
    print("|---|---:|---:|---:|---:|---:|")
    for key, label in (("all", "all cars and people"), ("visible_bottom", "bottom visible"), ("cut_or_hidden_bottom", "bottom cut or hidden")):
        s = summary[key]
        if s["objects"]:
            print(
                f"| {label} | {s['objects']} | {100 * s['median_rel_error_ground']:.1f} % | {100 * s['median_rel_error_fused']:.1f} % "
                f"| {100 * s['p90_rel_error_ground']:.1f} % | {100 * s['p90_rel_error_fused']:.1f} % |"
            )
    if args.json:
        print(json.dumps(summary, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
