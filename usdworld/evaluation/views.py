"""Bird's-eye-view evaluation of a rig's world against a nuScenes sample's boxes (issue 19).

Ground truth: the sample's LiDAR-frame boxes (``instances``: gravity centre, [l, w, h],
yaw), moved into the ego frame with ``lidar_points -> lidar2ego``; classes mapped as the
build maps detector labels (barrier and traffic_cone are not placed and are left out). A
box is *seen* when some camera's ``cam_instances`` holds it (its centre, through
``lidar2cam``, within :data:`SAME_BOX_M` of the box's).

Matching: world objects and ground-truth boxes of one class are paired one to one,
minimising the summed BEV distance (Hungarian), pairs only within the gate
``max(gate_min_m, gate_rel * range)`` (range from the ego origin). An unpaired object
whose nearest box of its class within the gate is paired is a second placement of that
box; otherwise it is an extra (unmatched) object. A seen box is *placed once* when it is
paired and has no second placement, *placed more than once* when it has; its BEV error is
the distance to its paired object. *Duplicates* follow the issue:
pairs of objects of one class within ``duplicate_m`` of each other; the ground truth's own
pairs that close are counted beside them, since two real pedestrians may stand that close.
:func:`identity_duplicates` says which of those pairs are one box placed twice: the rig's
detections are the sample's camera boxes, so each object's observations name their boxes.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from usdworld.io.label_table import label_lookups
from usdworld.perception.classes import placed_class_for_label

#: Largest distance between a LiDAR box and a camera box of one annotation, metres (float32 round trip).
SAME_BOX_M = 0.05
#: Largest difference of a side between a camera box and the detection made of it, pixels (rounding).
SAME_BOX_PX = 1.0


@dataclass(frozen=True)
class BevBox:
    """One ground-truth box in the ego frame.

    Attributes:
        index: its index in the sample's ``instances``.
        class_name: the placed class.
        centre_ego: (2,) float64 BEV centre (x forward, y left), metres.
        seen_by: the cameras whose boxes hold it.
        range_m: its range for the matching gate, or None for its distance from the ego origin.
        boxes_px: each seeing camera's 2D box of it, ``(camera, (u0, v0, u1, v1))``: the
            detections a rig built from the sample's camera boxes places, so an object's
            observations name the boxes they are.
    """

    index: int
    class_name: str
    centre_ego: np.ndarray
    seen_by: tuple[str, ...]
    range_m: float | None = None
    boxes_px: tuple[tuple[str, tuple[float, float, float, float]], ...] = ()

    @property
    def gate_range_m(self) -> float:
        """The range the matching gate grows with, metres."""
        return float(np.linalg.norm(self.centre_ego)) if self.range_m is None else self.range_m


def _sample(doc: dict[str, Any], token: str | None) -> dict[str, Any]:
    for s in doc["data_list"]:
        if token is None or s.get("token") == token:
            return s
    raise KeyError(f"no sample with token {token!r}")


def read_bev_boxes(info: Path, token: str | None = None) -> list[BevBox]:
    """The placeable boxes of one sample of a nuScenes info JSON, in the ego frame (see the module docstring)."""
    doc = json.loads(Path(info).read_text())
    sample = _sample(doc, token)
    categories = {int(v): str(k) for k, v in doc["metainfo"]["categories"].items()}
    ego_from_lidar = np.array(sample["lidar_points"]["lidar2ego"], dtype=np.float64)
    seen_centres = []
    for cam, boxes in sample.get("cam_instances", {}).items():
        ego_from_cam = ego_from_lidar @ np.linalg.inv(
            np.array(sample["images"][cam]["lidar2cam"], dtype=np.float64)
        )
        for b in boxes:
            c = ego_from_cam @ np.array([*b["bbox_3d"][:3], 1.0])
            seen_centres.append((cam, c[:3], tuple(float(v) for v in b["bbox"])))
    lookups = label_lookups()
    out = []
    for i, inst in enumerate(sample["instances"]):
        cls = placed_class_for_label(categories.get(int(inst["bbox_label_3d"]), ""), lookups)
        if cls is None:
            continue
        centre = (ego_from_lidar @ np.array([*inst["bbox_3d"][:3], 1.0]))[:3]
        mine = [(cam, box) for cam, c, box in seen_centres if np.linalg.norm(c - centre) < SAME_BOX_M]
        seen = tuple(sorted({cam for cam, _ in mine}))
        out.append(BevBox(i, cls, centre[:2].copy(), seen, boxes_px=tuple(mine)))
    return out


def evaluate_bev(
    objects: Sequence[tuple[str, str, np.ndarray]],
    boxes: Sequence[BevBox],
    gate_min_m: float = 2.0,
    gate_rel: float = 0.15,
    duplicate_m: float = 2.0,
) -> dict[str, Any]:
    """Compare a world's objects with the ground-truth boxes in BEV.

    Args:
        objects: (name, class, (2,) float64 BEV position in the ego frame) of each world object.
        boxes: the ground truth (:func:`read_bev_boxes`).
        gate_min_m: smallest matching gate, metres.
        gate_rel: the gate's share of the box's range.
        duplicate_m: objects of one class closer than this count as a duplicate pair.

    Returns:
        JSON-ready: ``overall`` and ``per_class`` counts (seen, placed_once, placed_more,
        missed, unmatched objects, median and p90 BEV error), ``duplicate_pairs`` and
        ``gt_pairs_within``, and ``boxes`` (per seen box: class, views, count, error).
    """
    from scipy.optimize import linear_sum_assignment  # lazy: only the evaluation needs it

    gates = np.array([max(gate_min_m, gate_rel * b.gate_range_m) for b in boxes])
    dist = np.full((len(objects), len(boxes)), np.inf)
    for i, (_, cls, xy) in enumerate(objects):
        for j, b in enumerate(boxes):
            d = float(np.linalg.norm(np.asarray(xy) - b.centre_ego))
            if b.class_name == cls and d <= gates[j]:
                dist[i, j] = d
    cost = np.where(np.isfinite(dist), dist, 1e6)
    assigned: dict[int, list[tuple[str, float]]] = {b.index: [] for b in boxes}
    matched = set()
    for i, j in zip(*linear_sum_assignment(cost)) if len(objects) and len(boxes) else ():
        if np.isfinite(dist[i, j]):
            assigned[boxes[j].index].append((objects[i][0], float(dist[i, j])))
            matched.add(int(i))
    unmatched = []
    for i, (name, cls, _) in enumerate(objects):
        if i in matched:
            continue
        j = int(np.argmin(dist[i])) if len(boxes) else -1
        if j >= 0 and np.isfinite(dist[i, j]) and assigned[boxes[j].index]:
            assigned[boxes[j].index].append((name, float(dist[i, j])))  # a second object of a placed box
        else:
            unmatched.append((name, cls))
    rows = []
    for b in boxes:
        if not b.seen_by:
            continue
        hits = assigned[b.index]
        rows.append(
            {
                "index": b.index,
                "class": b.class_name,
                "views": list(b.seen_by),
                "range_m": b.gate_range_m,
                "count": len(hits),
                "error_m": hits[0][1] if hits else None,
                "objects": [n for n, _ in hits],
            }
        )

    def summary(sel: list[dict[str, Any]], cls: str | None) -> dict[str, Any]:
        errors = [r["error_m"] for r in sel if r["error_m"] is not None]
        return {
            "seen": len(sel),
            "placed_once": sum(r["count"] == 1 for r in sel),
            "placed_more": sum(r["count"] > 1 for r in sel),
            "missed": sum(r["count"] == 0 for r in sel),
            "unmatched_objects": sum(1 for _, c in unmatched if cls is None or c == cls),
            "median_bev_error_m": float(np.median(errors)) if errors else None,
            "p90_bev_error_m": float(np.percentile(errors, 90)) if errors else None,
        }

    classes = sorted({r["class"] for r in rows} | {c for _, c in unmatched})
    pairs = _pairs([(c, np.asarray(xy)) for _, c, xy in objects], duplicate_m)
    gt_pairs = _pairs([(b.class_name, b.centre_ego) for b in boxes if b.seen_by], duplicate_m)
    return {
        "overall": summary(rows, None),
        "per_class": {c: summary([r for r in rows if r["class"] == c], c) for c in classes},
        "duplicate_pairs": pairs,
        "gt_pairs_within": gt_pairs,
        "gate": {"min_m": gate_min_m, "rel": gate_rel},
        "boxes": rows,
        "unmatched": [n for n, _ in unmatched],
    }


def box_identity(
    view: str, box_px: Sequence[float], boxes: Sequence[BevBox], tolerance_px: float = SAME_BOX_PX
) -> int | None:
    """The ground-truth box whose camera box ``view`` saw as ``box_px`` (within ``tolerance_px``
    on every side: detections are rounded to whole pixels), or None."""
    best: tuple[float, int] | None = None
    for b in boxes:
        for cam, px in b.boxes_px:
            if cam != view:
                continue
            d = float(np.max(np.abs(np.asarray(px) - np.asarray(box_px, dtype=np.float64))))
            if d <= tolerance_px and (best is None or d < best[0]):
                best = (d, b.index)
    return None if best is None else best[1]


def identity_duplicates(
    objects: Sequence[tuple[str, str, np.ndarray, Sequence[tuple[str, Sequence[float]]]]],
    boxes: Sequence[BevBox],
    duplicate_m: float = 2.0,
    gate_min_m: float = 2.0,
    gate_rel: float = 0.15,
) -> dict[str, Any]:
    """Duplicates and errors by identity: which ground-truth box each object's observations are.

    A rig built from the sample's own camera boxes says, for every object, which boxes
    placed it (each observation's view and image box), so whether two objects are one box
    placed twice needs no distance: it is read off.

    Args:
        objects: (name, class, (2,) float64 BEV position, observations as (view, (4,) image box)).
        boxes: the ground truth (:func:`read_bev_boxes`).
        duplicate_m: the distance under which two objects of one class are a pair.
        gate_min_m: smallest gate of ``placed_once_within_gate``, metres (as :func:`evaluate_bev`).
        gate_rel: the gate's share of the box's range.

    Returns:
        JSON-ready: ``boxes_placed_more`` (boxes whose observations went to more than one
        object), ``objects_of_several_boxes`` (objects fused from observations of different
        boxes), ``pairs_one_box`` and ``pairs_two_boxes`` (the pairs within ``duplicate_m``:
        one box twice, or two boxes), ``unidentified`` (observations that name no box),
        ``placed_once_within_gate`` (seen boxes held by one object, that object within the
        gate of :func:`evaluate_bev`) and ``median_error_m`` (over every seen box some object
        holds, missed ones included, the BEV distance to the nearest that does; None if
        none): no matching, so no pairing of neighbours crosswise.
    """
    ids: list[set[int]] = []
    unidentified = 0
    for _, _, _, observations in objects:
        found = set()
        for view, box_px in observations:
            j = box_identity(view, box_px, boxes)
            if j is None:
                unidentified += 1
            else:
                found.add(j)
        ids.append(found)
    holders: dict[int, list[int]] = {}
    for i, found in enumerate(ids):
        for j in found:
            holders.setdefault(j, []).append(i)
    errors, once = [], 0
    for b in boxes:
        if not b.seen_by or b.index not in holders:
            continue
        d = min(float(np.linalg.norm(np.asarray(objects[i][2]) - b.centre_ego)) for i in holders[b.index])
        errors.append(d)
        once += len(holders[b.index]) == 1 and d <= max(gate_min_m, gate_rel * b.gate_range_m)
    one, two = 0, 0
    for a in range(len(objects)):
        for b in range(a + 1, len(objects)):
            if objects[a][1] != objects[b][1]:
                continue
            if float(np.linalg.norm(np.asarray(objects[a][2]) - np.asarray(objects[b][2]))) >= duplicate_m:
                continue
            if ids[a] & ids[b]:
                one += 1
            else:
                two += 1
    return {
        "boxes_placed_more": sum(len(h) > 1 for h in holders.values()),
        "objects_of_several_boxes": sum(len(f) > 1 for f in ids),
        "pairs_one_box": one,
        "pairs_two_boxes": two,
        "unidentified": unidentified,
        "placed_once_within_gate": once,
        "median_error_m": float(np.median(errors)) if errors else None,
    }


def _pairs(items: Sequence[tuple[str, np.ndarray]], within_m: float) -> int:
    """Pairs of items of one class closer than ``within_m``."""
    n = 0
    for i in range(len(items)):
        for j in range(i + 1, len(items)):
            if items[i][0] == items[j][0] and float(np.linalg.norm(items[i][1] - items[j][1])) < within_m:
                n += 1
    return n
