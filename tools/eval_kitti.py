"""Evaluate ``usdworld build`` on KITTI object frames against their 3D labels.

For every frame in ``DATA_DIR/image_2`` the world is built from the image, its 2D
boxes (``label_2``, 3D fields ignored) and its calibration (``calib``, P2 only; add
``--planes`` to also give the road plane where ``planes/<frame>.txt`` exists, or
``--no-camera`` to build without any calibration, as for a photo from an unknown camera).
Each placed object is matched to its label line, and per class and per frame we report:
objects placed / total, median and p90 relative depth error, median bird's-eye-view
centre error (metres, in the camera's x-z plane), median yaw error (degrees, and modulo
180 for front/back ambiguity), the fraction of vehicles (:data:`VEHICLES`) whose heading
is within 30 degrees, and the fraction of objects that *line up*.

Line-up criterion: the placed object's 3D box (its footprint centre, yaw and size, in
the frame of the camera the build used) is projected with the TRUE intrinsics (P2) and
its 2D bounding box, clipped to the image, must overlap the label's box with IoU >= 0.5
(:data:`LINEUP_IOU`, the PASCAL VOC / KITTI 2D detection threshold for pedestrians and
cyclists). With the calibration given this tests the placement; without it, it tests
whether the world built from the estimated camera still looks like the photo through
the real camera: a focal length off by a factor k scales every placed box's offset
from the principal point by 1/k under the true camera. Every build without calibration
puts the principal point at the image centre; KITTI's lies 11 px left and 15 px above it
(a 1.2 deg turn of the whole view), which alone moves most of KITTI's small boxes below
IoU 0.5 (measured: 22 of 82 line up with the exact focal length and the centred principal
point). So a second count, "(f only)" / ``lines_up_focal``, projects with the true focal
length and the principal point the build used: it measures the focal length and the
placement, not the principal point no photo cue here estimates. Without the calibration the
focal-length error ``|f_est - f_true| / f_true`` is reported per frame and as a median.

Usage::

    python tools/eval_kitti.py [DATA_DIR] [--planes | --no-camera | --level-camera 1.65] [--traffic left] [--json]

``--traffic`` is the build's: ``left`` for frames from left-hand traffic (nuScenes'
Singapore logs, ``n015-...+0800``; KITTI and nuScenes' Boston logs drive on the right).

``DATA_DIR`` defaults to ``$USDWORLD_DATA/kitti/training`` (``../shared/data/kitti/training``
when ``USDWORLD_DATA`` is unset).

With ``--json`` the last line printed is one JSON object (keys of the overall summary,
``per_class``, ``per_frame``, and with ``--no-camera`` ``median_focal_error``).
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
from usdworld.pipeline import BuildRequest, BuildResult, build
from usdworld.resources import evaluation_data_dir

#: KITTI and nuScenes (KITTI format) label types counted as vehicles for the heading score.
VEHICLES = frozenset({"Car", "Van", "Truck", "Tram", "Bus", "Trailer", "Construction_vehicle", "Motorcycle"})

#: IoU a projected placed box needs with its label box to "line up" (module docstring).
LINEUP_IOU = 0.5

#: A vehicle's heading counts as right within this many degrees.
HEADING_TOL_DEG = 30.0


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
                "truncated": float(f[1]),
                "occluded": int(float(f[2])),
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


def _box_iou(a: np.ndarray, b: np.ndarray) -> float:
    """IoU of two ``xmin, ymin, xmax, ymax`` boxes."""
    w = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    h = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = w * h
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return float(inter / union) if union > 0 else 0.0


def projected_box(placement, camera, K_true: np.ndarray, width: int, height: int) -> np.ndarray | None:
    """2D box of a placed object's 3D box seen through the true intrinsics, clipped to the image.

    The box's corners (footprint centre ``position_world``, ``yaw``, ``size_m``) are taken
    into the frame of the camera the build used and projected with ``K_true`` (3, 3).

    Returns:
        (4,) ``xmin, ymin, xmax, ymax`` pixels, or None when a corner is behind the camera.
    """
    length, wide, tall = (float(v) for v in placement.size_m)
    c, s = np.cos(placement.yaw), np.sin(placement.yaw)
    corners = []
    for dx in (-length / 2, length / 2):
        for dy in (-wide / 2, wide / 2):
            for dz in (0.0, tall):
                corners.append(placement.position_world + np.array([c * dx - s * dy, s * dx + c * dy, dz]))
    p_cam = camera.cam_from_world_points(np.array(corners))
    if np.any(p_cam[:, 2] < 0.1):
        return None
    uvw = p_cam @ K_true.T
    uv = uvw[:, :2] / uvw[:, 2:3]
    box = np.array([uv[:, 0].min(), uv[:, 1].min(), uv[:, 0].max(), uv[:, 1].max()])
    return np.clip(box, [0, 0, 0, 0], [width, height, width, height])


def build_frame(
    frame: str,
    data: Path,
    planes: bool,
    out: Path,
    level_height: float | None = None,
    no_camera: bool = False,
    traffic: str = "right",
) -> tuple[BuildResult, BuildRequest]:
    """Build one frame the way the evaluation does (module docstring) and return the build and its request."""
    calib = data / "calib" / f"{frame}.txt"
    plane = data / "planes" / f"{frame}.txt"
    if no_camera:
        camera_file = None
    elif level_height is not None:
        camera_file = _level_camera(calib, level_height, out)
    else:
        camera_file = calib
    request = BuildRequest(
        image=data / "image_2" / f"{frame}.png",
        output=out / frame,
        detections=data / "label_2" / f"{frame}.txt",
        camera=camera_file,
        ground_plane=plane if planes and plane.is_file() else None,
        traffic=traffic,
    )
    return build(request), request


def compare_frame(frame: str, data: Path, result: BuildResult, request: BuildRequest) -> tuple[list[dict], dict]:
    """Compare each object a build placed with its label.

    Returns:
        (one row per label object, in label order, the frame's camera record: true and used
        focal length, whether a road plane was given).
    """
    calib = data / "calib" / f"{frame}.txt"
    gt = read_gt(request.detections)
    P2 = read_kitti_projection(calib)
    t_cam2 = np.linalg.solve(P2[:, :3], P2[:, 3])  # camera-2 offset from camera 0
    camera = result.model.camera.camera
    f_true = float(P2[0, 0])
    frame_info = {
        "frame": frame,
        "f_true": f_true,
        "f_used": float(camera.fx),
        "focal_error": abs(float(camera.fx) - f_true) / f_true,
        "plane": request.ground_plane is not None,
        "camera_method": result.model.camera.method,
    }
    placed = {p.obj.instance_id: p for p in result.model.placements}
    rows = []
    for index, g in enumerate(gt):
        p = placed.get(index)
        row = {"frame": frame, "type": g["type"], "placed": p is not None}
        if p is not None:
            box = projected_box(p, camera, P2[:, :3], camera.width, camera.height)
            iou = _box_iou(box, np.array(g["box"])) if box is not None else 0.0
            K_focal = P2[:, :3].copy()
            K_focal[:2, 2] = camera.K[:2, 2]  # the true focal length, the principal point the build used
            box_f = projected_box(p, camera, K_focal, camera.width, camera.height)
            iou_f = _box_iou(box_f, np.array(g["box"])) if box_f is not None else 0.0
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
                    "iou_true_camera": iou,
                    "lines_up": iou >= LINEUP_IOU,
                    "iou_true_focal": iou_f,
                    "lines_up_focal": iou_f >= LINEUP_IOU,
                }
            )
        rows.append(row)
    return rows, frame_info


def evaluate_frame(
    frame: str,
    data: Path,
    planes: bool,
    out: Path,
    level_height: float | None = None,
    no_camera: bool = False,
    traffic: str = "right",
) -> tuple[list[dict], dict]:
    """Build one frame and compare each placed object with its label (:func:`build_frame`, :func:`compare_frame`)."""
    result, request = build_frame(frame, data, planes, out, level_height, no_camera, traffic)
    return compare_frame(frame, data, result, request)


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
        # Objects never placed do not line up and have no right heading: both are fractions of all.
        out["lines_up"] = sum(bool(r.get("lines_up")) for r in group)
        out["lines_up_fraction"] = out["lines_up"] / len(group) if group else 0.0
        out["lines_up_focal"] = sum(bool(r.get("lines_up_focal")) for r in group)
        vehicles = [r for r in group if r["type"] in VEHICLES]
        if vehicles:
            good = sum(r["placed"] and r["yaw_error_deg"] <= HEADING_TOL_DEG for r in vehicles)
            out["vehicles"] = len(vehicles)
            out["vehicle_heading_within_30"] = good / len(vehicles)
        return out

    by_class: dict[str, list[dict]] = defaultdict(list)
    by_frame: dict[str, list[dict]] = defaultdict(list)
    for r in rows:
        by_class[r["type"]].append(r)
        by_frame[r["frame"]].append(r)
    summary = stats(rows)
    summary["per_class"] = {k: stats(v) for k, v in sorted(by_class.items())}
    summary["per_frame"] = {k: stats(v) for k, v in sorted(by_frame.items())}
    return summary


def _table_line(name: str, s: dict, focal: float | None) -> str:
    if "median_rel_depth_error" in s:
        line = (
            f"{name:<12}{s['placed']:>4}/{s['total']:<3}{100 * s['median_rel_depth_error']:>9.1f}%"
            f"{100 * s['p90_rel_depth_error']:>9.1f}%{s['median_bev_error_m']:>8.2f}{s['median_yaw_error_deg']:>8.1f}"
        )
    else:
        line = f"{name:<12}{s['placed']:>4}/{s['total']:<3}{'':>34}"
    heading = f"{100 * s['vehicle_heading_within_30']:>5.0f}% of {s['vehicles']:<3}" if "vehicles" in s else f"{'-':>13}"
    line += f"{heading:>14}{s['lines_up']:>5}/{s['total']:<3}{s['lines_up_focal']:>5}/{s['total']:<3}"
    if focal is not None:
        line += f"{100 * focal:>8.1f}%"
    return line


def print_tables(summary: dict, frames: dict[str, dict], show_focal: bool) -> None:
    """Per-class and per-frame tables (stdout)."""
    head = (
        f"{'':<12}{'placed':>8}{'med rel':>10}{'p90 rel':>10}{'BEV m':>8}{'yaw deg':>8}"
        f"{'veh yaw<30':>14}{'lines up':>9}{'(f only)':>9}" + (f"{'f err':>9}" if show_focal else "")
    )
    print("per class")
    print(head)
    for name, s in list(summary["per_class"].items()) + [("all", summary)]:
        print(_table_line(name, s, summary.get("median_focal_error") if show_focal and name == "all" else None))
    print("per frame")
    print(head)
    for name, s in summary["per_frame"].items():
        print(_table_line(name, s, frames[name]["focal_error"] if show_focal else None))


def add_build_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments that say how each frame is built (:func:`build_frame`): the data folder,
    ``--planes``, ``--no-camera`` and ``--traffic``; shared with ``tools/account_kitti.py``."""
    parser.add_argument(
        "data_dir",
        type=Path,
        nargs="?",
        default=evaluation_data_dir() / "kitti" / "training",
        help="KITTI object folder with image_2, label_2, calib (planes); default $USDWORLD_DATA/kitti/training",
    )
    parser.add_argument(
        "--planes", action="store_true", help="also pass the road plane (planes/<frame>.txt, where it exists)"
    )
    parser.add_argument(
        "--no-camera",
        action="store_true",
        help="build without the calibration (intrinsics from the photo); report the focal-length error",
    )
    parser.add_argument(
        "--traffic",
        choices=("right", "left"),
        default="right",
        help="the side traffic keeps to where the frames were taken (build --traffic): right for KITTI "
        "(Karlsruhe) and nuScenes Boston, left for nuScenes Singapore",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object as the last line")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_build_arguments(parser)
    parser.add_argument(
        "--level-camera",
        type=float,
        metavar="HEIGHT_M",
        help="baseline: assume a level camera (zero pitch and roll) at this height instead of estimating",
    )
    parser.add_argument("--verbose", action="store_true", help="print one line per object")
    args = parser.parse_args(argv)
    if args.no_camera and (args.planes or args.level_camera is not None):
        parser.error("--no-camera cannot be combined with --planes or --level-camera (both need the calibration)")
    images = sorted((args.data_dir / "image_2").glob("*.png"))
    if not images:
        print(f"error: {args.data_dir}/image_2 holds no PNG frames; pass a KITTI object training folder", file=sys.stderr)
        return 2
    rows: list[dict] = []
    frames: dict[str, dict] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for image in images:
            try:
                frame_rows, info = evaluate_frame(
                    image.stem,
                    args.data_dir,
                    args.planes,
                    Path(tmp),
                    args.level_camera,
                    args.no_camera,
                    args.traffic,
                )
            except UsdWorldError as exc:
                print(f"error: frame {image.stem}: {exc}", file=sys.stderr)
                return 2
            rows.extend(frame_rows)
            frames[image.stem] = info
    summary = summarise(rows)
    for name, info in frames.items():
        if name in summary["per_frame"]:
            summary["per_frame"][name].update(
                {k: info[k] for k in ("f_true", "f_used", "focal_error", "plane")}
            )
    summary["median_focal_error"] = float(np.median([f["focal_error"] for f in frames.values()]))
    if args.planes:
        missing = sorted(name for name, info in frames.items() if not info["plane"])
        summary["frames_without_plane"] = len(missing)
        print(f"road plane given for {len(frames) - len(missing)} of {len(frames)} frames; none for: {' '.join(missing)}")
    if args.verbose:
        for r in rows:
            if r["placed"]:
                print(
                    f"{r['frame']} {r['type']:<10} {r['name']:<10} depth {r['depth_pred']:6.2f} / {r['depth_gt']:6.2f} m "
                    f"({100 * r['rel_depth_error']:5.1f} %) bev {r['bev_error_m']:5.2f} m yaw {r['yaw_error_deg']:5.1f} deg "
                    f"IoU {r['iou_true_camera']:.2f} {r['method']}"
                )
        if args.no_camera:
            for name, info in frames.items():
                print(f"{name} f {info['f_used']:7.1f} / {info['f_true']:7.1f} px: {info['camera_method']}")
    print_tables(summary, frames, args.no_camera)
    if args.json:
        print(json.dumps(summary, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
