"""Per-object colour error of worlds built from real frames: photo vs render from the source camera.

Frames: the KITTI object frames in ``DATA_DIR/kitti/training`` (built from the image, its
2D boxes (``label_2``) and its calibration (``calib``), as ``tools/eval_kitti.py`` does),
the nuScenes front camera in ``DATA_DIR/nuscenes/kitti_format`` (the same way) and the
Cityscapes frame in ``DATA_DIR/cityscapes`` (image, labelIds and instanceIds). Each world
is rendered from its source camera and compared with its photo by
:mod:`usdworld.evaluation.colour_errors` (central half of each object's box, visible
pixels; CIE76 and CIEDE2000). Printed per frame: objects compared, median CIE76 and
CIEDE2000; then the median over all KITTI objects and over the KITTI frames' medians.

Usage::

    python tools/eval_appearance.py [DATA_DIR] [--out DIR] [--build-only | --no-build] [--renders DIR] [--json]

``DATA_DIR`` defaults to ``$USDWORLD_DATA`` (``../shared/data`` when unset). ``--out``
keeps the built worlds (default: a temporary folder). ``--build-only`` builds and stops
(it needs only ``usdworld.pipeline``, so another checkout can build the worlds:
``PYTHONPATH=/path/to/other python tools/eval_appearance.py --out W --build-only``);
``--no-build`` evaluates the worlds already in ``--out``. ``--renders DIR`` writes each
frame's photo and render side by side as ``DIR/<frame>.png``.
With ``--json`` the last line printed is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from usdworld.resources import evaluation_data_dir


def frames(data: Path) -> list[tuple[str, dict[str, Path]]]:
    """(frame name, build inputs) of every frame found under ``data``."""
    out = []
    # KITTI and nuScenes CAM_FRONT in KITTI layout: image_2, label_2 and calib per frame.
    for prefix, root in (
        ("kitti", data / "kitti" / "training"),
        ("nuscenes", data / "nuscenes" / "kitti_format"),
    ):
        for image in sorted((root / "image_2").glob("*.png")):
            f = image.stem
            inputs = {
                "image": image,
                "detections": root / "label_2" / f"{f}.txt",
                "camera": root / "calib" / f"{f}.txt",
            }
            out.append((f"{prefix}_{f}", inputs))
    for image in sorted((data / "cityscapes").glob("*_leftImg8bit.png")):
        prefix = image.name[: -len("_leftImg8bit.png")]
        out.append(
            (
                f"cityscapes_{prefix}",
                {
                    "image": image,
                    "labels": image.with_name(f"{prefix}_gtFine_labelIds.png"),
                    "instances": image.with_name(f"{prefix}_gtFine_instanceIds.png"),
                },
            )
        )
    return out


def build_all(items: list[tuple[str, dict[str, Path]]], out: Path) -> None:
    """Build every frame's world into ``out/<frame>``."""
    from usdworld.pipeline import BuildRequest, build

    for name, inputs in items:
        build(BuildRequest(output=out / name, **inputs))  # type: ignore[arg-type]


def evaluate_all(items: list[tuple[str, dict[str, Path]]], out: Path, renders: Path | None) -> dict:
    """Colour errors of every world in ``out``: per frame and the KITTI medians."""
    from usdworld.authoring.inspect import open_world
    from usdworld.evaluation import evaluate_world
    from usdworld.render.outputs import read_photo, view_camera, world_image_size
    from usdworld.render.renderer import Renderer
    from usdworld.render.scene import RenderScene

    per_frame = {}
    kitti_rows: list[dict] = []
    for name, inputs in items:
        stage = open_world(out / name)
        photo = read_photo(inputs["image"])
        result = evaluate_world(stage, photo=photo)
        c = result.colour or {}
        per_frame[name] = {
            "objects": c.get("objects", 0),
            "median_delta_e76": c.get("median_delta_e76"),
            "median_delta_e2000": c.get("median_delta_e2000"),
            "rows": result.colour_rows,
        }
        if name.startswith("kitti_"):
            kitti_rows += result.colour_rows
        if renders is not None:
            import cv2

            w, h = world_image_size(stage)
            cam = view_camera(stage, w, h)
            with Renderer(w, h) as r:
                rgb = r.render_rgb(RenderScene.from_stage(stage), cam.K, cam.world_from_cam)
            renders.mkdir(parents=True, exist_ok=True)
            side = np.concatenate([photo, rgb], axis=0)
            cv2.imwrite(str(renders / f"{name}.png"), side[:, :, ::-1])

    def med(values: list[float]) -> float | None:
        return float(np.median(values)) if values else None

    kitti = [v for k, v in per_frame.items() if k.startswith("kitti_") and v["objects"]]
    return {
        "per_frame": per_frame,
        "kitti_objects": len(kitti_rows),
        "kitti_median_delta_e76": med([r["delta_e76"] for r in kitti_rows]),
        "kitti_median_delta_e2000": med([r["delta_e2000"] for r in kitti_rows]),
        "kitti_median_of_frame_medians_delta_e76": med([v["median_delta_e76"] for v in kitti]),
    }


def _fmt(x: float | None) -> str:
    return "-" if x is None else f"{x:.1f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="?", type=Path, default=None)
    ap.add_argument("--out", type=Path, default=None)
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--build-only", action="store_true")
    mode.add_argument("--no-build", action="store_true")
    ap.add_argument("--renders", type=Path, default=None)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    data = args.data if args.data is not None else evaluation_data_dir()
    items = frames(data)
    if not items:
        print(f"no frames under {data}", file=sys.stderr)
        return 2
    if args.no_build and args.out is None:
        print("--no-build needs --out (the folder holding the built worlds)", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out if args.out is not None else Path(tmp)
        if not args.no_build:
            build_all(items, out)
        if args.build_only:
            return 0
        summary = evaluate_all(items, out, args.renders)
    print(f"{'frame':<60} {'objects':>7} {'dE76':>6} {'dE2000':>6}")
    for name, v in summary["per_frame"].items():
        print(
            f"{name:<60} {v['objects']:>7} {_fmt(v['median_delta_e76']):>6} {_fmt(v['median_delta_e2000']):>6}"
        )
    print(
        f"KITTI, median over {summary['kitti_objects']} objects: CIE76 {_fmt(summary['kitti_median_delta_e76'])}, "
        f"CIEDE2000 {_fmt(summary['kitti_median_delta_e2000'])}; median of frame medians CIE76 "
        f"{_fmt(summary['kitti_median_of_frame_medians_delta_e76'])}"
    )
    if args.json:
        print(json.dumps(summary, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
