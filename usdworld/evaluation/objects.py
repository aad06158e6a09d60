"""Match placed objects to ground truth and measure their 3D errors.

Both sides are first put into the world frame: synth ground truth is already there;
camera-frame ground truth (KITTI, nuScenes) is moved with the world's own source camera
pose, so a camera height or pitch estimate that is off shows up as object error, as it
would in the world.

Matching, one to one, within compatible classes (:data:`CLASS_GROUPS`: any vehicle with
any vehicle, people with people, riders with bicycles and motorcycles, every other class
with itself):

1. by instance id, when the ground truth's ids are the ids the world was built with
   (``ids_match`` of :func:`match_objects`: the synth frame's Cityscapes instance ids, or
   a KITTI label file that was the world's detections input);
2. the rest greedily by bird's-eye-view (BEV) distance, nearest pair first (as the
   nuScenes detection benchmark matches), accepting a pair only within
   ``max(GATE_MIN_M, GATE_RELATIVE * ground range of the true object)``.

Errors of a matched pair:

* position: BEV distance of the bottom centres (world x, y);
* depth: difference of the bottom centres' depth along the world camera's optical axis;
* yaw: angle between the headings about the vertical, in [0, 180] degrees, and modulo
  180 (front and back confused counts as right); summarised over thing classes only
  (a tree or a pole has no meaningful heading);
* size: absolute differences of length, width and height.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from usdworld.evaluation.ground_truth import GroundTruth, GtObject
from usdworld.evaluation.world_objects import WorldObject

#: Classes that may be matched with each other (others match only themselves).
CLASS_GROUPS = {
    "car": "vehicle",
    "truck": "vehicle",
    "bus": "vehicle",
    "train": "vehicle",
    "person": "person",
    "rider": "cycle",
    "bicycle": "cycle",
    "motorcycle": "cycle",
}
#: Thing classes: their yaw is evaluated.
THING_CLASSES = frozenset(CLASS_GROUPS)
GATE_MIN_M = 2.0
GATE_RELATIVE = 0.25
#: Synth objects with fewer visible pixels are not counted (``usdworld build`` ignores
#: things below this area too: ``perception.objects.MIN_THING_AREA_PX``).
MIN_VISIBLE_PX = 10


def class_group(class_name: str) -> str:
    """The matching group of a class."""
    return CLASS_GROUPS.get(class_name, class_name)


@dataclass(frozen=True)
class TruthInWorld:
    """A ground-truth object moved into the world frame.

    Attributes:
        obj: the ground-truth object.
        bottom_centre_world: (3,) float64.
        heading_world: (3,) float64 unit vector.
    """

    obj: GtObject
    bottom_centre_world: np.ndarray
    heading_world: np.ndarray


def truth_in_world(gt: GroundTruth, world_from_cam: np.ndarray) -> list[TruthInWorld]:
    """The ground-truth objects that count (synth: visible >= :data:`MIN_VISIBLE_PX`), in the world frame.

    Args:
        gt: the ground truth.
        world_from_cam: (4, 4) float64 pose of the world's source camera (used for camera-frame truth).
    """
    T = np.asarray(world_from_cam, dtype=np.float64)
    out = []
    for o in gt.objects:
        if o.visible_px is not None and o.visible_px < MIN_VISIBLE_PX:
            continue
        if gt.frame == "world":
            p, h = np.array(o.bottom_centre), np.array(o.heading)
        else:
            p = T[:3, :3] @ o.bottom_centre + T[:3, 3]
            h = T[:3, :3] @ o.heading
        out.append(TruthInWorld(o, p, h))
    return out


@dataclass(frozen=True)
class ObjectMatch:
    """One ground-truth object and the placed object matched to it (None: not placed).

    Attributes:
        truth: the ground truth in the world frame.
        placed: the matched world object, or None.
        how: ``id``, ``distance`` or ``none``.
    """

    truth: TruthInWorld
    placed: WorldObject | None
    how: str


def _bev(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.hypot(a[0] - b[0], a[1] - b[1]))


def match_objects(
    truth: Sequence[TruthInWorld],
    placed: Sequence[WorldObject],
    camera_centre_world: np.ndarray,
    ids_match: bool,
) -> tuple[list[ObjectMatch], list[WorldObject]]:
    """One-to-one matching (see the module docstring).

    Args:
        truth: ground-truth objects in the world frame.
        placed: the world's objects.
        camera_centre_world: (3,) float64 camera centre (for the ground range of the gate).
        ids_match: the ground truth's instance ids are the ones the world was built with.

    Returns:
        One match per ground-truth object (in input order), and the placed objects left unmatched.
    """
    chosen: dict[int, tuple[int, str]] = {}
    used: set[int] = set()
    if ids_match:
        by_id: dict[tuple[int, str], int] = {}
        for j, w in enumerate(placed):
            if w.instance_id >= 0:
                by_id.setdefault((w.instance_id, class_group(w.class_name)), j)
        for i, t in enumerate(truth):
            if t.obj.instance_id < 0:
                continue
            hit = by_id.get((t.obj.instance_id, class_group(t.obj.class_name)))
            if hit is not None and hit not in used:
                chosen[i] = (hit, "id")
                used.add(hit)
    pairs = []
    c = np.asarray(camera_centre_world, dtype=np.float64)
    for i, t in enumerate(truth):
        if i in chosen:
            continue
        gate = max(GATE_MIN_M, GATE_RELATIVE * _bev(t.bottom_centre_world, c))
        for j, w in enumerate(placed):
            if j in used or class_group(w.class_name) != class_group(t.obj.class_name):
                continue
            d = _bev(t.bottom_centre_world, w.bottom_centre_world)
            if d <= gate:
                pairs.append((d, i, j))
    for d, i, j in sorted(pairs):
        if i in chosen or j in used:
            continue
        chosen[i] = (j, "distance")
        used.add(j)
    matches = [
        ObjectMatch(t, placed[chosen[i][0]], chosen[i][1]) if i in chosen else ObjectMatch(t, None, "none")
        for i, t in enumerate(truth)
    ]
    return matches, [w for j, w in enumerate(placed) if j not in used]


def _yaw(v: np.ndarray) -> float:
    return float(np.arctan2(v[1], v[0]))


def _angle_diff(a: float, b: float, period: float) -> float:
    d = (a - b) % period
    return float(min(d, period - d))


def match_errors(m: ObjectMatch, world_from_cam: np.ndarray) -> dict[str, Any]:
    """JSON-ready row of one match: names, classes, positions and (when placed) errors."""
    t = m.truth
    row: dict[str, Any] = {
        "truth": t.obj.name,
        "class": t.obj.class_name,
        "placed": m.placed is not None,
        "matched_by": m.how,
        "truth_position_world": [round(float(v), 4) for v in t.bottom_centre_world],
    }
    if m.placed is None:
        return row
    p = m.placed
    cam_from_world = np.linalg.inv(np.asarray(world_from_cam, dtype=np.float64))
    z_true = float(cam_from_world[2, :3] @ t.bottom_centre_world + cam_from_world[2, 3])
    z_pred = float(cam_from_world[2, :3] @ p.bottom_centre_world + cam_from_world[2, 3])
    yaw_true, yaw_pred = _yaw(t.heading_world), _yaw(p.heading_world)
    size_err = np.abs(p.size_lwh - t.obj.size_lwh)
    row.update(
        {
            "name": p.name,
            "placed_class": p.class_name,
            "position_world": [round(float(v), 4) for v in p.bottom_centre_world],
            "position_error_m": _bev(t.bottom_centre_world, p.bottom_centre_world),
            "depth_true_m": z_true,
            "depth_m": z_pred,
            "depth_error_m": abs(z_pred - z_true),
            "rel_depth_error": abs(z_pred - z_true) / z_true if z_true > 0 else None,
            "yaw_error_deg": float(np.degrees(_angle_diff(yaw_pred, yaw_true, 2 * np.pi))),
            "yaw_error_mod180_deg": float(np.degrees(_angle_diff(yaw_pred, yaw_true, np.pi))),
            "size_error_m": [float(v) for v in size_err],
            "mean_size_error_m": float(size_err.mean()),
        }
    )
    return row


def _median(values: Iterable[float | None]) -> float | None:
    v = [float(x) for x in values if x is not None and np.isfinite(x)]
    return float(np.median(v)) if v else None


def summarise_rows(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Counts and medians of match rows (``placed``/``total`` and the median errors)."""
    placed = [r for r in rows if r["placed"]]
    things = [r for r in placed if r["class"] in THING_CLASSES]
    return {
        "placed": len(placed),
        "total": len(rows),
        "placed_fraction": (len(placed) / len(rows)) if rows else None,
        "median_position_error_m": _median(r["position_error_m"] for r in placed),
        "median_depth_error_m": _median(r["depth_error_m"] for r in placed),
        "median_rel_depth_error": _median(r["rel_depth_error"] for r in placed),
        "median_yaw_error_deg": _median(r["yaw_error_deg"] for r in things),
        "median_yaw_error_mod180_deg": _median(r["yaw_error_mod180_deg"] for r in things),
        "median_size_error_m": _median(r["mean_size_error_m"] for r in placed),
    }


def summarise(rows: Sequence[dict[str, Any]], unmatched_placed: int) -> dict[str, Any]:
    """Overall, thing-class and per-class summaries, plus the count of placed objects with no truth."""
    by_class: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        by_class.setdefault(r["class"], []).append(r)
    out = summarise_rows(rows)
    out["things"] = summarise_rows([r for r in rows if r["class"] in THING_CLASSES])
    out["per_class"] = {k: summarise_rows(v) for k, v in sorted(by_class.items())}
    out["unmatched_placed"] = unmatched_placed
    return out
