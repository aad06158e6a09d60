"""A drive's world against the synthetic drive's ground truth (``usdworld synth --sequence``), in bird's-eye view.

Ground truth (``<name>_drive_gt.json``): every object's class, whether it moves, its
position per frame and its visible pixels per frame. An object is *seen* when some frame
shows at least :data:`MIN_VISIBLE_PX` pixels of it (as ``tools/eval_synth.py`` counts).

Moving objects first: each seen moving object is paired one to one (Hungarian, per class)
with a world object, the cost being the median over the frames that show it of the BEV
distance between its true position and the world object's position at that frame's time
(a standing world object: its one position); pairs only within the gate
``max(gate_min_m, gate_rel * range)``, the range being the median distance from the ego
over those frames (as :func:`usdworld.evaluation.views.evaluate_bev` gates). Its
*track error* is that median; whether its world object moves is counted.

Standing objects then: the seen standing objects against the remaining world objects
(their default positions), as :func:`usdworld.evaluation.views.evaluate_bev` compares a
rig's world with its boxes (placed once, more than once, missed; median BEV error = the
*ground error*), the gate's range being the distance from the nearest ego position of a
frame that shows the object. Each placed standing object's error is also split along and
across its *viewing direction*, the mean of the unit vectors from the ego to the object
over the frames that show it (:func:`error_split`): a single view's depth errs along its
ray, its bearing across it, so the split says which of the two a drive's fusion left.

Where each object stands: a standing object of a *trunk* class (a pole, a tree, a sign;
the class table's ``trunk`` role) is compared at its **foot**, the centre of its post's or
trunk's ground contact, on both sides (:func:`foot_offset`), not at its origin. An asset's
origin is the centre of its whole footprint: a street lamp's spans its arm, so its origin
lies 0.875 m (times its scale) from its post, over the road. The build measures the post's
foot and places a lamp's origin that far from it; comparing origins would count a plain pole
built as a lamp (or a lamp as a plain pole) ~0.8 m across its ray although its post stands
where the true one does. The variant each side chose is kept in the box rows
(``variant_truth`` / ``variant_world``) and counted per class (``variants``), so a wrong
variant shows as a wrong variant, not as a ground error.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from usdworld.errors import InputError
from usdworld.evaluation.views import BevBox, evaluate_bev
from usdworld.geometry.rotation import turned
from usdworld.io.asset_catalogue import AssetCatalogue, AssetSizes

#: Fewest visible pixels in some frame for a ground-truth object to count as seen.
MIN_VISIBLE_PX = 10


@dataclass(frozen=True)
class TrackedWorldObject:
    """One object of a drive's world.

    Attributes:
        name: prim name.
        class_name: its class.
        position: (2,) float64 its default BEV position, metres: the foot of a trunk class's
            post or trunk (its origin plus :func:`foot_offset`), else its origin.
        moving: whether the world says it moves.
        samples: time (seconds) -> (2,) float64 BEV position, for a moving object.
        variant: its asset's ``model`` variant ('' when unknown).
    """

    name: str
    class_name: str
    position: np.ndarray
    moving: bool
    samples: Mapping[float, np.ndarray]
    variant: str = ""

    def at(self, t: float) -> np.ndarray:
        """(2,) BEV position at time ``t``: linear between samples, held outside them."""
        if not self.moving or not self.samples:
            return self.position
        ts = np.array(sorted(self.samples))
        xy = np.array([self.samples[k] for k in sorted(self.samples)])
        return np.array([np.interp(t, ts, xy[:, 0]), np.interp(t, ts, xy[:, 1])])


def foot_offset(sizes: AssetSizes, variant: str, scale: Sequence[float], yaw: float) -> np.ndarray:
    """(2,) float64 world offset from a placed asset's origin to its foot (its ground contact's centre).

    Args:
        sizes: the class asset's measures (:class:`~usdworld.io.asset_catalogue.AssetSizes`).
        variant: the placed variant.
        scale: (>= 2,) float64 the placement's scale along the asset's X and Y.
        yaw: the placement's yaw about +Z, radians.

    Returns:
        ``contact_offset(variant) * scale`` turned by ``yaw``, metres: (0, 0) for an asset whose
        contact is centred (a plain pole), the way to the mast for a street lamp.

    Example:
        >>> lamp = AssetSizes({"street_lamp": (2.05, 0.3, 7.96)}, "street_lamp",
        ...                   contact_offset_by_variant={"street_lamp": (-0.875, 0.0)})
        >>> (foot_offset(lamp, "street_lamp", (1.0, 1.0, 1.0), np.pi / 2).round(3) + 0.0).tolist()
        [0.0, -0.875]
    """
    offset = sizes.contact_offset(variant) * np.asarray(scale, dtype=np.float64)[:2]
    return turned(offset, yaw)


def _truth_foot(o: Mapping[str, Any], catalogue: AssetCatalogue) -> np.ndarray:
    """(2,) the foot of a ground-truth object of a trunk class, from its variant, scale and yaw."""
    if "variant" not in o:
        raise InputError(
            f"drive ground truth -> {o['name']}: no 'variant'; a trunk class's foot needs its variant "
            "and scale (written since the eighteenth session; tools/eval_views.py fills them from the "
            "first frame's _gt.json)"
        )
    scale = o.get("scale", (1.0, 1.0, 1.0))
    return np.array(o["track"][0][:2], dtype=np.float64) + foot_offset(
        catalogue[o["class"]], str(o["variant"]), scale, float(o["yaw_rad"])
    )


def variant_summary(rows: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, int]]:
    """Per class: placed standing rows whose both variants are known (``n``) and how many agree.

    Args:
        rows: the standing rows of :func:`evaluate_drive`.

    Example:
        >>> variant_summary([{"class": "pole", "variant_truth": "plain", "variant_world": "plain"},
        ...                  {"class": "pole", "variant_truth": "plain", "variant_world": "street_lamp"},
        ...                  {"class": "pole", "variant_truth": "plain", "variant_world": None}])
        {'pole': {'n': 2, 'agree': 1}}
    """
    out: dict[str, dict[str, int]] = {}
    for r in rows:
        if r.get("variant_truth") and r.get("variant_world"):
            c = out.setdefault(r["class"], {"n": 0, "agree": 0})
            c["n"] += 1
            c["agree"] += int(r["variant_truth"] == r["variant_world"])
    return dict(sorted(out.items()))


def viewing_direction(xy: np.ndarray, egos: np.ndarray) -> np.ndarray:
    """(2,) unit mean viewing direction of a ground point from ego positions.

    Args:
        xy: (2,) float64 the point, metres.
        egos: (F, 2) float64 the ego positions of the frames that show it, metres.

    Returns:
        The normalised mean of the unit vectors from each ego position to the point.

    Example:
        >>> viewing_direction(np.array([10.0, 10.0]), np.array([[0.0, 10.0], [10.0, 0.0]])).round(4).tolist()
        [0.7071, 0.7071]
    """
    d = xy[None, :] - egos
    u = (d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)).mean(axis=0)
    return u / max(float(np.linalg.norm(u)), 1e-9)


def error_split(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Median absolute along- and across-ray errors of placed standing objects, overall and per class.

    Args:
        rows: the standing rows of :func:`evaluate_drive` (``along_m`` / ``across_m`` set where placed).

    Returns:
        JSON-ready: ``overall`` and ``per_class``, each ``{"n", "median_along_m", "median_across_m"}``.
    """

    def summary(sel: list[Mapping[str, Any]]) -> dict[str, Any]:
        return {
            "n": len(sel),
            "median_along_m": float(np.median([abs(r["along_m"]) for r in sel])) if sel else None,
            "median_across_m": float(np.median([abs(r["across_m"]) for r in sel])) if sel else None,
        }

    placed = [r for r in rows if r.get("along_m") is not None]
    classes = sorted({r["class"] for r in placed})
    per_class = {c: summary([r for r in placed if r["class"] == c]) for c in classes}
    return {"overall": summary(placed), "per_class": per_class}


def _track_summary(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Seen, paired and moving-when-paired counts and the median / p90 track error of moving ground-truth rows."""
    errors = [r["track_error_m"] for r in rows if r["track_error_m"] is not None]
    return {
        "seen": len(rows),
        "paired": len(errors),
        "paired_moving": sum(bool(r["object_moving"]) for r in rows),
        "median_track_error_m": float(np.median(errors)) if errors else None,
        "p90_track_error_m": float(np.percentile(errors, 90)) if errors else None,
    }


def evaluate_drive(
    objects: Sequence[TrackedWorldObject],
    gt: dict[str, Any],
    classes: Sequence[str],
    gate_min_m: float = 2.0,
    gate_rel: float = 0.15,
    catalogue: AssetCatalogue | None = None,
    trunk_classes: Collection[str] = (),
) -> dict[str, Any]:
    """Compare a drive's world with its ground truth.

    Args:
        objects: the world's objects (a trunk class's ``position`` at its foot).
        gt: the drive ground-truth document.
        classes: the classes compared (ground truth and world objects of other classes are left out).
        gate_min_m: smallest gate of a moving pair's median track error, metres.
        gate_rel: the gate's share of the moving object's median range.
        catalogue: the ground truth's asset measures; with ``trunk_classes``, a standing
            ground-truth object of those classes is compared at its foot (its ``variant``,
            ``scale`` and ``yaw_rad``, :func:`foot_offset`), else at its origin.
        trunk_classes: the classes compared at their foot.

    Returns:
        JSON-ready: ``moving`` (seen, paired, paired_moving, median and p90 track error,
        the same per class under ``per_class``, per object rows),
        ``standing`` (the :func:`evaluate_bev` result, each box's row with
        ``along_m`` / ``across_m``: its nearest object's signed error along and across its
        :func:`viewing_direction`, None when missed, and ``variant_truth`` / ``variant_world``;
        ``error_split``, :func:`error_split`; ``variants``, :func:`variant_summary`)
        and ``false_moving`` (world objects that move but were paired with no moving object).

    Raises:
        InputError: a trunk class's ground truth without a variant while ``catalogue`` is given.
    """
    from scipy.optimize import linear_sum_assignment  # lazy: only the evaluation needs it

    objects = [w for w in objects if w.class_name in classes]
    times = np.array(gt["times"], dtype=np.float64)
    egos = np.array([np.array(T)[:2, 3] for T in gt["world_from_ego"]])
    seen = [
        o
        for o in gt["objects"]
        if o["class"] in classes and max(o["visible_pixels"]) >= MIN_VISIBLE_PX
    ]
    movers = [o for o in seen if o["moving"]]
    cost = np.full((len(movers), len(objects)), np.inf)
    for i, o in enumerate(movers):
        frames = [k for k, px in enumerate(o["visible_pixels"]) if px >= MIN_VISIBLE_PX]
        track = np.array(o["track"])[:, :2]
        rng = float(np.median([np.linalg.norm(track[k] - egos[k]) for k in frames]))
        gate = max(gate_min_m, gate_rel * rng)
        for j, w in enumerate(objects):
            if w.class_name != o["class"]:
                continue
            d = float(np.median([np.linalg.norm(w.at(float(times[k])) - track[k]) for k in frames]))
            if d <= gate:
                cost[i, j] = d
    used: set[int] = set()
    rows = []
    pairs = dict(
        (int(i), int(j))
        for i, j in zip(*linear_sum_assignment(np.where(np.isfinite(cost), cost, 1e6)))
        if np.isfinite(cost[i, j])
    ) if len(movers) and len(objects) else {}
    for i, o in enumerate(movers):
        j = pairs.get(i)
        if j is not None:
            used.add(j)
        rows.append(
            {
                "name": o["name"],
                "class": o["class"],
                "object": objects[j].name if j is not None else None,
                "object_moving": bool(objects[j].moving) if j is not None else None,
                "track_error_m": float(cost[i, j]) if j is not None else None,
            }
        )
    moving = {
        **_track_summary(rows),
        "per_class": {
            c: _track_summary([r for r in rows if r["class"] == c]) for c in sorted({r["class"] for r in rows})
        },
        "objects": rows,
    }
    boxes = []
    directions = {}
    for k, o in enumerate(seen):
        if o["moving"]:
            continue
        if catalogue is not None and o["class"] in trunk_classes:
            xy = _truth_foot(o, catalogue)
        else:
            xy = np.array(o["track"][0][:2], dtype=np.float64)
        frames = [f for f, px in enumerate(o["visible_pixels"]) if px >= MIN_VISIBLE_PX]
        rng = min(float(np.linalg.norm(xy - egos[f])) for f in frames)
        boxes.append(BevBox(k, o["class"], xy, ("drive",), range_m=rng))
        directions[k] = (xy, viewing_direction(xy, egos[frames]))
    rest = [(w.name, w.class_name, w.position) for j, w in enumerate(objects) if j not in used]
    standing = evaluate_bev(rest, boxes, gate_min_m=gate_min_m, gate_rel=gate_rel)
    where = {name: np.asarray(xy, dtype=np.float64) for name, _, xy in rest}
    variant_of = {w.name: w.variant for w in objects}
    for row in standing["boxes"]:
        row["along_m"] = row["across_m"] = None
        row["variant_truth"] = seen[row["index"]].get("variant")
        row["variant_world"] = (variant_of[row["objects"][0]] or None) if row["objects"] else None
        if row["objects"]:
            xy, u = directions[row["index"]]
            d = where[row["objects"][0]] - xy
            row["along_m"] = float(d @ u)
            row["across_m"] = float(d @ np.array([-u[1], u[0]]))
    standing["error_split"] = error_split(standing["boxes"])
    standing["variants"] = variant_summary(standing["boxes"])
    false_moving = [w.name for j, w in enumerate(objects) if w.moving and j not in used]
    return {"moving": moving, "standing": standing, "false_moving": false_moving}
