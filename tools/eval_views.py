"""Evaluate ``usdworld build --layout nuscenes --views INFO`` against the sample's boxes in BEV (issue 19).

The world is built from all the sample's cameras (each camera's 2D boxes as its
detections, its exact intrinsics and pose), then its objects, read from the composed
``world.usda`` (edits applied), are compared in bird's-eye view with the sample's LiDAR
boxes in the ego frame (:mod:`usdworld.evaluation.views`): of the boxes any camera sees,
how many are placed exactly once, more than once or not at all, the median and p90 BEV
error, the duplicate pairs (two objects of one class within 2 m), per class.

The same numbers for the views' objects *before* fusion (every view's placements in the
ego frame, one object per observation, from ``report.json``) say what the association
changed, and the per-observation BEV error says what bounds the result: the single-view
depth error, which fusion can only average where two views overlap.

Usage::

    python tools/eval_views.py [INFO] [--sample TOKEN] [--out DIR] [--jobs N] [--json]
    python tools/eval_views.py --drive DRIVE_views.json [--out DIR] [--jobs N] [--json]

``INFO`` defaults to ``$USDWORLD_DATA/nuscenes/demo/*.pkl.DERIVED.json``.

``--drive`` builds a synthetic drive (``usdworld synth --sequence N``) from its views
manifest and compares the world with the drive's ground truth
(:mod:`usdworld.evaluation.drive`): standing objects placed once and their ground (BEV)
error, moving objects' track error, objects wrongly moving, and the build time per frame.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np

from usdworld.evaluation.views import BevBox, box_identity, evaluate_bev, identity_duplicates, read_bev_boxes
from usdworld.resources import evaluation_data_dir


def _default_info() -> Path:
    found = sorted((evaluation_data_dir() / "nuscenes" / "demo").glob("*.pkl.DERIVED.json"))
    if not found:
        sys.exit("no nuScenes info JSON found under $USDWORLD_DATA/nuscenes/demo; pass INFO")
    return found[0]


def _world_objects(world: Path) -> list[tuple[str, str, np.ndarray]]:
    from pxr import Usd

    from usdworld.evaluation.world_objects import world_objects

    stage = Usd.Stage.Open(str(world / "world.usda"))
    return [(o.name, o.class_name, o.bottom_centre_world[:2].copy()) for o in world_objects(stage)]


def _unfused(report: dict) -> list[tuple[str, str, np.ndarray]]:
    out = []
    for name, entry in report["views"]["objects"].items():
        cls = name.rsplit("_", 1)[0]
        for ob in entry["observations"]:
            out.append((f"{ob['view']}:{name}", cls, np.array(ob["position_world"][:2])))
    return out


def _metres(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f} m"


def _observations(report: dict) -> dict[str, list[tuple[str, list[float]]]]:
    """Each fused object's observations as (view, image box), from ``report.json``."""
    return {
        name: [(ob["view"], ob["image_bbox"]) for ob in entry["observations"]]
        for name, entry in report["views"]["objects"].items()
    }


def _account(report: dict, result: dict, boxes: list[BevBox]) -> str:
    """Per seen box: how often it is placed, its error, and every view's observation of it
    (its error along and across the view's ray, in metres and in its stated sigmas)."""
    cameras = {c["name"]: np.array(c["world_from_cam"])[:2, 3] for c in report["views"]["cameras"]}
    by_index = {b.index: b for b in boxes}
    obs_of: dict[int, list[str]] = {}
    for name, entry in report["views"]["objects"].items():
        for ob in entry["observations"]:
            j = box_identity(ob["view"], ob["image_bbox"], boxes)
            if j is None:
                continue
            b = by_index[j]
            ray = b.centre_ego - cameras[ob["view"]]
            ray = ray / np.linalg.norm(ray)
            err = np.array(ob["position_world"][:2]) - b.centre_ego
            along, across = float(err @ ray), float(err @ np.array([-ray[1], ray[0]]))
            obs_of.setdefault(j, []).append(
                f"    {ob['view']:16s} -> {name:28s} along {along:+7.2f} m "
                f"({along / ob['sigma_range_m']:+5.1f} sigma), across {across:+6.2f} m "
                f"({across / ob['sigma_lateral_m']:+5.1f} sigma), "
                f"depth {ob['depth_m']:6.2f} m by {ob['depth_method']}"
            )
    lines = ["per box: index class range views count error (objects), then each observation of it"]
    for r in result["boxes"]:
        err = "-" if r["error_m"] is None else f"{r['error_m']:.2f} m"
        lines.append(
            f"{r['index']:3d} {r['class']:20s} {r['range_m']:6.1f} m {','.join(r['views']):30s} "
            f"placed {r['count']} error {err} ({', '.join(r['objects'])})"
        )
        lines.extend(obs_of.get(r["index"], []))
    return "\n".join(lines)


def _table(title: str, result: dict) -> str:
    lines = [f"{title}", f"{'class':22s} seen  once  more  missed  extra  median_m  p90_m"]
    for cls, r in [*result["per_class"].items(), ("ALL", result["overall"])]:
        med = "-" if r["median_bev_error_m"] is None else f"{r['median_bev_error_m']:.2f}"
        p90 = "-" if r["p90_bev_error_m"] is None else f"{r['p90_bev_error_m']:.2f}"
        lines.append(
            f"{cls:22s} {r['seen']:4d}  {r['placed_once']:4d}  {r['placed_more']:4d}  {r['missed']:6d}  "
            f"{r['unmatched_objects']:5d}  {med:>8s}  {p90:>5s}"
        )
    for label, lo, hi in (("within 30 m", 0.0, 30.0), ("beyond 30 m", 30.0, float("inf"))):
        sel = [r for r in result["boxes"] if lo <= r["range_m"] < hi]
        errors = [r["error_m"] for r in sel if r["error_m"] is not None]
        med = f"{np.median(errors):.2f} m" if errors else "-"
        lines.append(
            f"{label}: {len(sel)} boxes, {sum(r['count'] == 1 for r in sel)} placed once, median BEV error {med}"
        )
    o = result["overall"]
    share = o["placed_once"] / o["seen"] if o["seen"] else float("nan")
    lines.append(
        f"placed exactly once {o['placed_once']}/{o['seen']} = {100 * share:.1f} %; duplicate pairs (one class, "
        f"< 2 m) {result['duplicate_pairs']} (ground truth has {result['gt_pairs_within']} such pairs)"
    )
    return "\n".join(lines)


#: Classes a synthetic drive's build places as objects (the synthetic street's buildings are stuff).
DRIVE_CLASSES = ("car", "person", "tree", "pole", "traffic_sign", "traffic_light")


def _drive_objects(world: Path) -> list:
    """The world's objects; a trunk class's position at its foot, by the world's own asset measures."""
    from pxr import Usd, UsdGeom

    from usdworld.authoring.asset_measures import asset_catalogue
    from usdworld.evaluation.drive import TrackedWorldObject, foot_offset
    from usdworld.evaluation.world_objects import world_objects
    from usdworld.io.class_table import load_class_table

    stage = Usd.Stage.Open(str(world / "world.usda"))
    tcps = stage.GetTimeCodesPerSecond()
    placed = world_objects(stage)
    trunk = load_class_table().with_role("trunk")
    catalogue = asset_catalogue({o.class_name for o in placed if o.class_name in trunk}, (world / "assets",))
    out = []
    for o in placed:
        prim = stage.GetPrimAtPath(f"/World/Objects/{o.name}")
        moving = prim.GetAttribute("usdworld:moving")
        is_moving = bool(moving.Get()) if moving and moving.HasAuthoredValue() else False
        samples = {}
        if is_moving:
            translate = UsdGeom.Xformable(prim).GetPrim().GetAttribute("xformOp:translate")
            for code in translate.GetTimeSamples():
                samples[code / tcps] = np.array(translate.Get(code))[:2]
        position = o.bottom_centre_world[:2].copy()
        if o.class_name in trunk and not is_moving:
            yaw = float(np.arctan2(o.heading_world[1], o.heading_world[0]))
            position += foot_offset(catalogue[o.class_name], o.variant, o.scale, yaw)
        out.append(TrackedWorldObject(o.name, o.class_name, position, is_moving, samples, o.variant))
    return out


def _drive_ground_truth(gt_path: Path) -> dict:
    """The drive's ground truth; objects without ``variant`` / ``scale`` (drives written before the
    eighteenth session) take them from the first frame's ``_gt.json``, which lists every object."""
    gt = json.loads(gt_path.read_text())
    if all("variant" in o for o in gt["objects"]):
        return gt
    first = gt_path.with_name(gt_path.name.replace("_drive_gt.json", "_000000_gt.json"))
    frame = {o["name"]: o for o in json.loads(first.read_text())["objects"]}
    for o in gt["objects"]:
        if "variant" not in o and o["name"] in frame:
            o["variant"], o["scale"] = frame[o["name"]]["variant"], frame[o["name"]]["scale"]
    return gt


def _drive_main(manifest: Path, out_arg: Path | None, jobs: int | None, as_json: bool) -> int:
    from usdworld.authoring.asset_measures import asset_catalogue
    from usdworld.evaluation.drive import evaluate_drive
    from usdworld.io.class_table import load_class_table
    from usdworld.views.build import ViewsRequest, build_views
    from usdworld.views.manifest import read_views_manifest

    gt_path = manifest.with_name(manifest.name.replace("_views.json", "_drive_gt.json"))
    gt = _drive_ground_truth(gt_path)
    trunk = load_class_table().with_role("trunk") & set(DRIVE_CLASSES)
    with tempfile.TemporaryDirectory() as tmp:
        out = out_arg or Path(tmp) / "world"
        views = read_views_manifest(manifest)
        start = time.perf_counter()
        built = build_views(ViewsRequest(views, out, jobs=jobs))
        seconds = time.perf_counter() - start
        objects = _drive_objects(out)
    # the synthetic street is built from the built-in asset library
    result = evaluate_drive(objects, gt, DRIVE_CLASSES, catalogue=asset_catalogue(trunk), trunk_classes=trunk)
    n = len(views.views)
    spread = built.report["views"]["ground_spread_m"]
    print(
        f"{manifest.name}: {n} frames built in {seconds:.1f} s ({seconds / n:.2f} s per frame); "
        f"ground spread measured {spread:.2f} m"
    )
    print(_table("standing objects (seen in some frame)", result["standing"]))
    split = result["standing"]["error_split"]
    parts = [
        f"{name} {_metres(v['median_along_m'])} / {_metres(v['median_across_m'])}"
        for name, v in [("all", split["overall"]), *split["per_class"].items()]
    ]
    print("ground error along / across the viewing direction (median |.|): " + "; ".join(parts))
    variants = result["standing"]["variants"]
    print(
        "variant as the ground truth's (placed standing objects; poles, trees and signs are compared at their foot): "
        + ("; ".join(f"{c} {v['agree']}/{v['n']}" for c, v in variants.items()) or "-")
    )
    m = result["moving"]
    med = "-" if m["median_track_error_m"] is None else f"{m['median_track_error_m']:.2f} m"
    p90 = "-" if m["p90_track_error_m"] is None else f"{m['p90_track_error_m']:.2f} m"
    print(
        f"moving objects: {m['seen']} seen, {m['paired']} paired, {m['paired_moving']} of them moving in the world; "
        f"track error median {med}, p90 {p90}"
    )
    for name, c in m["per_class"].items():
        med = "-" if c["median_track_error_m"] is None else f"{c['median_track_error_m']:.2f} m"
        print(
            f"  {name}: {c['seen']} seen, {c['paired']} paired, {c['paired_moving']} moving; "
            f"track error median {med}"
        )
    print(f"world objects moving but paired with no moving object: {len(result['false_moving'])}")
    if as_json:
        print(json.dumps({"seconds": seconds, "frames": n, "ground_spread_m": spread, **result}))
    return 0


def main(argv: list[str] | None = None) -> int:
    """Build and evaluate; print the tables (and one JSON line with ``--json``)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("info", nargs="?", type=Path, default=None)
    parser.add_argument("--sample", default=None, help="sample token (default: the first)")
    parser.add_argument(
        "--out", type=Path, default=None, help="world folder to write (default: a temporary one)"
    )
    parser.add_argument("--jobs", type=int, default=None, help="worker processes for the views")
    parser.add_argument("--json", action="store_true", help="print the results as one JSON line at the end")
    parser.add_argument(
        "--boxes",
        action="store_true",
        help="print every seen box's placements and each view's observation of it",
    )
    parser.add_argument(
        "--drive", type=Path, default=None, help="a synthetic drive's views manifest (usdworld synth --sequence)"
    )
    args = parser.parse_args(argv)
    if args.drive is not None:
        return _drive_main(args.drive, args.out, args.jobs, args.json)

    from usdworld.views.build import ViewsRequest, build_views
    from usdworld.views.nuscenes import read_nuscenes_views

    info = args.info or _default_info()
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp) / "world"
        start = time.perf_counter()
        result = build_views(ViewsRequest(read_nuscenes_views(info, args.sample), out, jobs=args.jobs))
        seconds = time.perf_counter() - start
        fused = _world_objects(out)
    boxes = read_bev_boxes(info, args.sample)
    after = evaluate_bev(fused, boxes)
    unfused = _unfused(result.report)
    before = evaluate_bev(unfused, boxes)
    observed = _observations(result.report)
    identity = identity_duplicates([(n, c, xy, observed.get(n, [])) for n, c, xy in fused], boxes)
    print(
        f"{info.name}: {len(result.report['views']['cameras'])} views built in {seconds:.1f} s; "
        f"fusion {result.report['views']['fusion']}; ground spread measured "
        f"{result.report['views']['ground_spread_m']:.2f} m"
    )
    print(_table("before fusion (every view's objects)", before))
    print(_table("world (fused)", after))
    print(
        "by identity (each object's observations name their camera boxes): "
        f"{identity['boxes_placed_more']} boxes placed by more than one object, "
        f"{identity['objects_of_several_boxes']} objects fused from different boxes; "
        f"of the pairs within 2 m, {identity['pairs_one_box']} are one box twice, "
        f"{identity['pairs_two_boxes']} two boxes; placed once within the gate "
        f"{identity['placed_once_within_gate']}, median BEV error {_metres(identity['median_error_m'])}"
    )
    if args.boxes:
        print(_account(result.report, after, boxes))
    if args.json:
        print(json.dumps({"seconds": seconds, "fused": after, "before_fusion": before, "identity": identity}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
