#!/usr/bin/env python
"""Streets from boxes: road, sidewalk and building IoU of worlds built from a photo and its boxes only.

For each Cityscapes frame in DATA (``*_leftImg8bit.png`` with ``*_gtFine_instanceIds.png``
and ``*_gtFine_labelIds.png`` beside it), the thing instances of the instance map are turned
into a detections JSON as a detector would give them (class name and the tight box of the
instance's visible pixels; no masks, no labels), the world is built from the photo and
those detections alone (no camera file: it is estimated), rendered from its source camera,
and the rendered class map is compared with the frame's labelIds
(:func:`usdworld.evaluation.evaluate_world`: Cityscapes void pixels ignored, parking counts
as road).

Usage::

    python tools/eval_streets.py DATA [--out DIR] [--json] [--renders DIR]

``--renders DIR`` also writes ``NAME_class.png`` (the rendered class map in the Cityscapes
colours) for looking at.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)

#: Classes reported (Cityscapes label ids).
CLASSES = {"road": 7, "sidewalk": 8, "building": 11, "vegetation": 21, "car": 26, "person": 24}


def detections_from_instances(instance_ids: np.ndarray) -> dict[str, Any]:
    """A detections JSON document from a Cityscapes instance map: one box per thing instance.

    Args:
        instance_ids: (H, W) int32 Cityscapes instance ids (``class*1000+k`` for things).

    Returns:
        ``{"detections": [{"class", "box", "score"}, ...]}``, boxes ``[xmin, ymin, xmax, ymax]``
        with exclusive max edges, in instance-id order.
    """
    from usdworld.io.label_table import by_id

    dets = []
    for iid in sorted(int(i) for i in np.unique(instance_ids) if i >= 1000):
        vs, us = np.nonzero(instance_ids == iid)
        name = by_id(iid // 1000).name
        box = [int(us.min()), int(vs.min()), int(us.max()) + 1, int(vs.max()) + 1]
        dets.append({"class": name, "box": box, "score": 1.0})
    return {"detections": dets}


def evaluate_frame(photo: Path, out: Path, renders: Path | None) -> dict[str, Any]:
    """Build one frame from its photo and instance boxes, and measure the rendered classes."""
    import cv2

    from usdworld.authoring.inspect import open_world
    from usdworld.evaluation import evaluate_world
    from usdworld.evaluation.evaluate import read_label_ids
    from usdworld.pipeline import BuildRequest, build

    stem = photo.name.replace("_leftImg8bit.png", "")
    instances = cv2.imread(str(photo.with_name(f"{stem}_gtFine_instanceIds.png")), cv2.IMREAD_UNCHANGED)
    labels = read_label_ids(photo.with_name(f"{stem}_gtFine_labelIds.png"))
    det_path = out / f"{stem}_detections.json"
    det_path.write_text(json.dumps(detections_from_instances(instances.astype(np.int32))))
    result = build(BuildRequest(image=photo, output=out / stem, detections=det_path))
    stage = open_world(result.world)
    ev = evaluate_world(stage, labels=labels, classes=sorted(CLASSES.values()))
    if renders is not None:
        from usdworld.render.outputs import colorize_labels

        renders.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(renders / f"{stem}_class.png"), colorize_labels(ev.rendered_class_ids)[:, :, ::-1])
    return {
        "frame": stem,
        "iou": {k: (None if not np.isfinite(v) else round(float(v), 4)) for k, v in ev.per_class_iou.items()},
        "objects": len(result.model.placements),
        "classes": sorted({p.obj.class_name for p in result.model.placements}),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("data", type=Path, help="folder with Cityscapes *_leftImg8bit.png, instanceIds and labelIds")
    parser.add_argument("--out", type=Path, default=None, help="folder for the worlds (default: a temporary one)")
    parser.add_argument("--renders", type=Path, default=None, help="folder for the rendered class maps")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    photos = sorted(args.data.glob("*_leftImg8bit.png"))
    if not photos:
        print(f"error: {args.data}: no *_leftImg8bit.png", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        rows = [evaluate_frame(p, out, args.renders) for p in photos]
    if args.json:
        print(json.dumps({"frames": rows}, indent=2))
    else:
        for row in rows:
            ious = "  ".join(f"{k} {v if v is not None else '-'}" for k, v in row["iou"].items())
            print(f"{row['frame']}: {ious}  ({row['objects']} objects: {', '.join(row['classes'])})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
