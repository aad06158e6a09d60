"""Evaluate ``usdworld build`` on KITTI object frames against their 3D labels.

For every frame in ``DATA_DIR/image_2`` the world is built from the image, its 2D
boxes (``label_2``, 3D fields ignored) and its calibration (``calib``, P2 only; add
``--planes`` to also give the road plane). Each placed object is matched to its label
line, and per class we report: objects placed / total, median and p90 relative depth
error, median bird's-eye-view centre error (metres, in the camera's x-z plane) and
median yaw error (degrees, and modulo 180 for front/back ambiguity).

Usage::

    python tools/eval_kitti.py ../shared/data/kitti/training [--planes | --level-camera 1.65] [--json]

With ``--json`` the last line printed is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

import numpy as np

from usdworld.errors import UsdWorldError
from usdworld.io.camera_files import read_kitti_projection
from usdworld.pipeline import BuildRequest, build


def read_gt(label_path: Path) -> list[dict]:
    """Non-DontCare label lines in file order (the order ``build`` numbers detections)."""
    rows = []
    for line in label_path.read_text().splitlines():
        f = line.split()
        if not f or f[0] == "DontCare":
            continue
        rows.append(
            {
                "type": f[0],
                "box": [float(v) for v in f[4:8]],
                "hwl": [float(v) for v in f[8:11]],
                "xyz": np.array([float(v) for v in f[11:14]]),
                "ry": float(f[14]),
            }
        )
    return rows


def angle_diff(a: float, b: float, period: float) -> float:
    """Smallest absolute difference of two angles modulo ``period`` (radians)."""
    d = (a - b) % period
    return float(min(d, period - d))


def _level_camera(calib: Path, height_m: float, out: Path) -> Path:
    """A plain camera JSON with P2's intrinsics, a fixed height and zero pitch and roll (the baseline)."""
    P2 = read_kitti_projection(calib)
    path = out / f"{calib.stem}_level_camera.json"
    path.write_text(json.dumps({"K": P2[:, :3].tolist(), "height_m": height_m, "pitch_deg": 0.0, "roll_deg": 0.0}))
    return path


def evaluate_frame(frame: str, data: Path, planes: bool, out: Path, level_height: float | None = None) -> list[dict]:
    """Build one frame and compare each placed object with its label."""
    calib = data / "calib" / f"{frame}.txt"
    request = BuildRequest(
        image=data / "image_2" / f"{frame}.png",
        output=out / frame,
        detections=data / "label_2" / f"{frame}.txt",
        camera=_level_camera(calib, level_height, out) if level_height is not None else calib,
        ground_plane=(data / "planes" / f"{frame}.txt") if planes else None,
    )
    result = build(request)
    gt = read_gt(request.detections)
    P2 = read_kitti_projection(calib)
    t_cam2 = np.linalg.solve(P2[:, :3], P2[:, 3])  # camera-2 offset from camera 0
    camera = result.model.camera.camera
    placed = {p.obj.instance_id: p for p in result.model.placements}
    rows = []
    for index, g in enumerate(gt):
        p = placed.get(index)
        row = {"frame": frame, "type": g["type"], "placed": p is not None}
        if p is not None:
            gt_cam = g["xyz"] + t_cam2
            z_gt = float(gt_cam[2])
            bottom_cam = camera.cam_from_world_points(p.position_world[None, :])[0]
            heading_world = np.array([np.cos(p.yaw), np.sin(p.yaw), 0.0])
            heading_cam = heading_world @ camera.rotation_world_from_cam
            yaw_pred = float(np.arctan2(heading_cam[2], heading_cam[0]))
            yaw_gt = float(np.arctan2(-np.sin(g["ry"]), np.cos(g["ry"])))
            row.update(
                {
                    "name": p.name,
                    "depth_pred": float(p.depth_m),
                    "depth_gt": z_gt,
                    "rel_depth_error": abs(float(p.depth_m) - z_gt) / z_gt,
                    "bev_error_m": float(np.hypot(bottom_cam[0] - gt_cam[0], bottom_cam[2] - gt_cam[2])),
                    "yaw_error_deg": float(np.degrees(angle_diff(yaw_pred, yaw_gt, 2 * np.pi))),
                    "yaw_error_mod180_deg": float(np.degrees(angle_diff(yaw_pred, yaw_gt, np.pi))),
                    "method": p.depth_method,
                }
            )
        rows.append(row)
    return rows


def summarise(rows: list[dict]) -> dict:
    """Per-class and overall statistics."""

    def stats(group: list[dict]) -> dict:
        placed = [r for r in group if r["placed"]]
        out = {"placed": len(placed), "total": len(group)}
        if placed:
            rel = np.array([r["rel_depth_error"] for r in placed])
            out.update(
                {
                    "median_rel_depth_error": float(np.median(rel)),
                    "p90_rel_depth_error": float(np.percentile(rel, 90)),
                    "median_bev_error_m": float(np.median([r["bev_error_m"] for r in placed])),
                    "median_yaw_error_deg": float(np.median([r["yaw_error_deg"] for r in placed])),
                    "median_yaw_error_mod180_deg": float(np.median([r["yaw_error_mod180_deg"] for r in placed])),
                }
            )
        return out

    by_class: dict[str, list[dict]] = defaultdict(list)
    for r in rows:
        by_class[r["type"]].append(r)
    summary = stats(rows)
    summary["per_class"] = {k: stats(v) for k, v in sorted(by_class.items())}
    return summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data_dir", type=Path, help="KITTI object folder with image_2, label_2, calib (planes)")
    parser.add_argument("--planes", action="store_true", help="also pass the road plane (planes/*.txt)")
    parser.add_argument(
        "--level-camera",
        type=float,
        metavar="HEIGHT_M",
        help="baseline: assume a level camera (zero pitch and roll) at this height instead of estimating",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    parser.add_argument("--verbose", action="store_true", help="print one line per object")
    args = parser.parse_args(argv)
    images = sorted((args.data_dir / "image_2").glob("*.png"))
    if not images:
        print(f"error: {args.data_dir}/image_2 holds no PNG frames; pass a KITTI object training folder", file=sys.stderr)
        return 2
    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        for image in images:
            try:
                rows.extend(evaluate_frame(image.stem, args.data_dir, args.planes, Path(tmp), args.level_camera))
            except UsdWorldError as exc:
                print(f"error: frame {image.stem}: {exc}", file=sys.stderr)
                return 2
    summary = summarise(rows)
    if args.verbose:
        for r in rows:
            if r["placed"]:
                print(
                    f"{r['frame']} {r['type']:<10} {r['name']:<10} depth {r['depth_pred']:6.2f} / {r['depth_gt']:6.2f} m "
                    f"({100 * r['rel_depth_error']:5.1f} %) bev {r['bev_error_m']:5.2f} m yaw {r['yaw_error_deg']:5.1f} deg {r['method']}"
                )
    print(f"{'class':<12}{'placed':>8}{'median rel depth':>18}{'p90 rel depth':>15}{'median BEV m':>14}{'median yaw deg':>16}")
    for name, s in list(summary["per_class"].items()) + [("all", summary)]:
        if "median_rel_depth_error" in s:
            print(
                f"{name:<12}{s['placed']:>4}/{s['total']:<3}{100 * s['median_rel_depth_error']:>17.1f}%"
                f"{100 * s['p90_rel_depth_error']:>14.1f}%{s['median_bev_error_m']:>14.2f}{s['median_yaw_error_deg']:>16.1f}"
            )
        else:
            print(f"{name:<12}{s['placed']:>4}/{s['total']:<3}")
    if args.json:
        print(json.dumps(summary, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
