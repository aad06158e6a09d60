#!/usr/bin/env python
"""The automated T1 study: build worlds for K synthetic scenes and measure them.

For each of ``--count`` scenes (seeds ``--seed`` .. ``--seed + K - 1``, the same scenes
``usdworld synth`` makes) the Cityscapes-format files are written, a world is built from
the photo, labels, instances and camera JSON with :func:`usdworld.pipeline.build`, and the
world is evaluated against its synth ground truth (:func:`usdworld.evaluation.evaluate_world`).

Reported (``--json`` prints one JSON object, last):

* ``placed`` / ``total``: ground-truth objects (visible >= 10 px) matched by a placed
  object, over all classes; ``things`` the same over cars, people and other thing classes,
  which carry instance ids in the input (stuff such as buildings and vegetation has no
  instances in Cityscapes labels, so touching buildings arrive as one region);
* ``median_position_error_m``: median bird's-eye-view distance of matched bottom centres;
* ``miou``: mean over car, person, vegetation and building of the dataset-level IoU
  (intersections and unions summed over all scenes) of the rendered class map vs the
  input labels; ``miou_mean_of_scenes`` averages the per-scene four-class mIoU instead;
* ``t1_top1_accuracy``: for each world, all K source label maps are ranked by similarity
  (mIoU over the layout classes) to the world's rendered class map; top-1 is right when
  the world's own source ranks first. ``t1_4way_top1_accuracy`` repeats it as the paper's
  questionnaire did: the source plus the three other photos most similar to it by SSIM
  (computed on the photos shrunk to at most ``SSIM_WIDTH`` pixels wide, for speed).

Usage::

    python tools/eval_synth.py --count 50 --size 1024x512 --json [--out DIR] [--jobs 2]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)

#: Classes of the headline mIoU (Cityscapes label ids).
STUDY = {"car": 26, "person": 24, "vegetation": 21, "building": 11}
#: Classes the T1 ranking and the per-class table use: the study classes plus the ground and street furniture.
LAYOUT = {**STUDY, "road": 7, "sidewalk": 8, "pole": 17, "traffic light": 19, "traffic sign": 20}
#: Width of the photos the T1 distractors are chosen on (SSIM).
SSIM_WIDTH = 512


def _size(text: str) -> tuple[int, int]:
    w, h = text.lower().split("x")
    return int(w), int(h)


def run_scene(seed: int, size: tuple[int, int], out: str) -> dict[str, Any]:
    """Synthesise, build and evaluate one scene (runs in a worker process)."""
    from pxr import Usd

    from usdworld.evaluation import evaluate_world, read_ground_truth, read_label_ids
    from usdworld.pipeline import BuildRequest, build
    from usdworld.render.outputs import read_photo
    from usdworld.synth import make_street_scene, write_cityscapes_frame

    name = f"synth_000000_{seed:06d}"
    folder = Path(out)
    t0 = time.perf_counter()
    scene = make_street_scene(np.random.default_rng(seed), *size)
    files = write_cityscapes_frame(scene, folder / "frames", name)
    t1 = time.perf_counter()
    result = build(
        BuildRequest(
            image=files["image"],
            labels=files["labels"],
            instances=files["instances"],
            camera=files["camera"],
            output=folder / "worlds" / name,
        )
    )
    t2 = time.perf_counter()
    stage = Usd.Stage.Open(str(result.world))
    labels = read_label_ids(files["labels"])
    ev = evaluate_world(
        stage,
        labels=labels,
        photo=read_photo(files["image"]),
        gt=read_ground_truth(files["gt"]),
        classes=sorted(LAYOUT.values()),
    )
    t3 = time.perf_counter()
    rendered = folder / "rendered" / f"{name}_class.npy"
    rendered.parent.mkdir(parents=True, exist_ok=True)
    np.save(rendered, ev.rendered_class_ids.astype(np.uint8))
    return {
        "name": name,
        "seed": seed,
        "labels": str(files["labels"]),
        "photo": str(files["image"]),
        "rendered": str(rendered),
        "intersections": ev.intersections,
        "unions": ev.unions,
        "per_class_iou": ev.per_class_iou,
        "ssim": ev.ssim,
        "rows": ev.object_rows,
        "unmatched_placed": ev.objects["unmatched_placed"] if ev.objects else 0,
        "seconds": {"synth": t1 - t0, "build": t2 - t1, "evaluate": t3 - t2},
    }


def _median(values: list[float]) -> float | None:
    return float(np.median(values)) if values else None


def _objects_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    from usdworld.evaluation.objects import summarise_rows

    return summarise_rows(rows)


def t1_study(scenes: list[dict[str, Any]]) -> dict[str, Any]:
    """Rank every scene's labels against every world's render; top-1 accuracy, K-way and 4-way."""
    from usdworld.evaluation import ignored_mask, mean_iou, placeable_label_ids, read_label_ids, ssim
    from usdworld.evaluation.segmentation import confusion_matrix, counts_from_confusion
    from usdworld.render.outputs import read_photo

    classes = sorted(LAYOUT.values())
    raw = [read_label_ids(s["labels"]) for s in scenes]
    mapped = [placeable_label_ids(r) for r in raw]
    ignore = [ignored_mask(r) for r in raw]
    renders = [np.load(s["rendered"]) for s in scenes]
    k = len(scenes)

    def similarity(i: int, j: int) -> float:
        """mIoU of world i's render vs scene j's labels (what ``label_similarity`` computes)."""
        counts = counts_from_confusion(confusion_matrix(renders[i], mapped[j], ignore[j]), classes)
        m = mean_iou({c: v.iou for c, v in counts.items()})
        return 0.0 if not np.isfinite(m) else m

    sim = np.array([[similarity(i, j) for j in range(k)] for i in range(k)])
    ranks = [int((sim[i] > sim[i, i]).sum()) + 1 for i in range(k)]  # ties count in the world's favour
    strict = [int((sim[i] >= sim[i, i]).sum()) for i in range(k)]  # ties count against it
    photos = []
    for s in scenes:
        photo = read_photo(s["photo"])
        if photo.shape[1] > SSIM_WIDTH:
            h = round(photo.shape[0] * SSIM_WIDTH / photo.shape[1])
            photo = cv2.resize(photo, (SSIM_WIDTH, h), interpolation=cv2.INTER_AREA)
        photos.append(photo)
    photo_ssim = np.eye(k)
    for i in range(k):
        for j in range(i + 1, k):
            photo_ssim[i, j] = photo_ssim[j, i] = ssim(photos[i], photos[j])
    four_way = []
    distractor_ssim = []
    for i in range(k):
        others = [j for j in np.argsort(-photo_ssim[i]) if j != i][:3]
        distractor_ssim.extend(photo_ssim[i, others].tolist())
        options = [i] + others
        four_way.append(int(np.argmax(sim[i, options]) == 0 and sim[i, i] > max(sim[i, others])))
    return {
        "t1_top1_accuracy": float(np.mean([r == 1 for r in strict])),
        "t1_top1_accuracy_ties_favour": float(np.mean([r == 1 for r in ranks])),
        "t1_mean_rank": float(np.mean(strict)),
        "t1_ranks": strict,
        "t1_4way_top1_accuracy": float(np.mean(four_way)),
        "t1_4way_median_distractor_ssim": float(np.median(distractor_ssim)) if distractor_ssim else None,
        "t1_similarity_margin_median": float(
            np.median([sim[i, i] - max(np.delete(sim[i], i)) for i in range(k)]) if k > 1 else 0.0
        ),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=50, help="number of scenes (default 50)")
    parser.add_argument("--seed", type=int, default=1000, help="seed of the first scene (default 1000)")
    parser.add_argument("--size", default="1024x512", help="image size WxH (default 1024x512)")
    parser.add_argument(
        "--out", type=Path, help="keep frames and worlds in this folder (default: a temporary one)"
    )
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    parser.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    args = parser.parse_args(argv)
    if args.count < 2:
        parser.error("--count must be >= 2 (T1 needs candidates)")
    size = _size(args.size)
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        out = str(args.out) if args.out else tmp
        Path(out).mkdir(parents=True, exist_ok=True)
        seeds = list(range(args.seed, args.seed + args.count))
        if args.jobs > 1:
            os.environ.setdefault("LP_NUM_THREADS", "1")  # one llvmpipe thread per worker on a small machine
            with ProcessPoolExecutor(args.jobs) as pool:
                scenes = list(pool.map(run_scene, seeds, [size] * len(seeds), [out] * len(seeds)))
        else:
            scenes = []
            for i, seed in enumerate(seeds):
                scenes.append(run_scene(seed, size, out))
                print(f"[{i + 1}/{len(seeds)}] {scenes[-1]['name']}", file=sys.stderr)
        t_scenes = time.perf_counter()
        t1 = t1_study(scenes)
    t_end = time.perf_counter()

    rows = [r for s in scenes for r in s["rows"]]
    from usdworld.evaluation.objects import THING_CLASSES

    overall = _objects_summary(rows)
    things = _objects_summary([r for r in rows if r["class"] in THING_CLASSES])
    per_class_obj: dict[str, list] = {}
    for r in rows:
        per_class_obj.setdefault(r["class"], []).append(r)
    inter = {n: sum(s["intersections"][n] for s in scenes) for n in LAYOUT}
    union = {n: sum(s["unions"][n] for s in scenes) for n in LAYOUT}
    per_class_iou = {n: (inter[n] / union[n] if union[n] else None) for n in LAYOUT}
    miou = float(np.mean([per_class_iou[n] for n in STUDY if per_class_iou[n] is not None]))
    scene_mious = []
    for s in scenes:
        v = [s["per_class_iou"][n] for n in STUDY if np.isfinite(s["per_class_iou"][n])]
        scene_mious.append(float(np.mean(v)) if v else float("nan"))
    seconds = {k: statistics.median(s["seconds"][k] for s in scenes) for k in ("synth", "build", "evaluate")}
    summary = {
        "scenes": len(scenes),
        "size": list(size),
        "seed": args.seed,
        "placed": overall["placed"],
        "total": overall["total"],
        "placed_fraction": overall["placed_fraction"],
        "median_position_error_m": overall["median_position_error_m"],
        "median_depth_error_m": overall["median_depth_error_m"],
        "median_yaw_error_deg": overall["median_yaw_error_deg"],
        "median_size_error_m": overall["median_size_error_m"],
        "things": things,
        "objects_per_class": {k: _objects_summary(v) for k, v in sorted(per_class_obj.items())},
        "unmatched_placed": sum(s["unmatched_placed"] for s in scenes),
        "miou": miou,
        "miou_classes": list(STUDY),
        "miou_mean_of_scenes": float(np.nanmean(scene_mious)),
        "per_class_iou": per_class_iou,
        "median_ssim_photo_render": _median([s["ssim"] for s in scenes if s["ssim"] is not None]),
        **t1,
        "median_seconds_per_scene": seconds,
        "wall_seconds": {"scenes": t_scenes - t_start, "t1": t_end - t_scenes, "total": t_end - t_start},
        "jobs": args.jobs,
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}",
    }
    print(
        f"{len(scenes)} synthetic scenes at {size[0]}x{size[1]} (seeds {args.seed}..{args.seed + args.count - 1})"
    )
    print(
        f"placed / total (all classes): {overall['placed']}/{overall['total']} = {100 * (overall['placed_fraction'] or 0):.1f} %"
    )
    print(
        f"placed / total (things):      {things['placed']}/{things['total']} = {100 * (things['placed_fraction'] or 0):.1f} %"
    )
    print(
        f"median ground-position error: all {overall['median_position_error_m']:.2f} m, things {things['median_position_error_m']:.2f} m"
    )
    print(
        f"mIoU (car, person, vegetation, building): {miou:.3f}  "
        + ", ".join(f"{n} {per_class_iou[n]:.3f}" for n in STUDY)
    )
    print(
        f"T1 top-1: {100 * t1['t1_top1_accuracy']:.1f} % of {len(scenes)}-way; 4-way (SSIM-nearest distractors): {100 * t1['t1_4way_top1_accuracy']:.1f} %"
    )
    print(f"wall time {t_end - t_start:.0f} s")
    if args.json:
        print(json.dumps(summary, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
