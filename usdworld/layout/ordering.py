"""The paper's depth post-processing along ground lines (step 1, "post-processing").

Points on the ground on the same image row ``v`` share one depth, and an object whose
ground contact is lower in the image (larger ``v``) is closer. When per-object depth
comes from a dense map (a CNN), two rules repair what the map gets wrong:

1. Two objects whose contact rows are similar (within ``similar_rows_px``) and whose
   depths differ by at least ``delta_m`` both get the depth of the closer one.
2. When an object lower in the image is farther than an object higher in the image
   whose box overlaps it horizontally (so one hides the other), the higher object is
   moved behind the lower one: its depth becomes the lower one's depth + ``delta_m``.
   (The paper's wording of this rule is ambiguous; this is the reading that enforces
   its own ground-line assumption, restricted to objects that overlap in the image.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class OrderingResult:
    """Depths after the rules and what each rule changed.

    Attributes:
        depth_m: (N,) float64 corrected depths.
        rule: (N,) object array, '' or the rule(s) that changed each depth (``rule1``, ``rule2``).
    """

    depth_m: np.ndarray
    rule: np.ndarray


def apply_ordering_rules(
    contact_v: np.ndarray,
    depth_m: np.ndarray,
    boxes_px: np.ndarray,
    *,
    delta_m: float,
    similar_rows_px: float,
) -> OrderingResult:
    """Apply rules 1 and 2 of the paper's post-processing.

    Args:
        contact_v: (N,) float64 contact rows, pixels.
        depth_m: (N,) float64 per-object depths, metres.
        boxes_px: (N, 4) float64 boxes ``xmin, ymin, xmax, ymax``.
        delta_m: the paper's threshold delta, metres (``PlacementParams.ordering_delta_m``).
        similar_rows_px: rows closer than this count as "similar Y"
            (``PlacementParams.ordering_similar_rows_px``).

    Returns:
        The corrected depths; input order is kept. The result does not depend on
        the input order.
    """
    v = np.asarray(contact_v, dtype=np.float64)
    d = np.asarray(depth_m, dtype=np.float64).copy()
    boxes = np.asarray(boxes_px, dtype=np.float64).reshape(-1, 4)
    n = len(v)
    rule = np.array([""] * n, dtype=object)
    # Process in a canonical order (closest contact first, then by column) so that the
    # result is independent of the input order.
    order = np.lexsort((boxes[:, 0], d, -v))

    # Rule 1: similar rows, depths differ by >= delta -> both take the closer depth.
    for ii, a in enumerate(order):
        for b in order[ii + 1 :]:
            if abs(v[a] - v[b]) <= similar_rows_px and abs(d[a] - d[b]) >= delta_m:
                closer = min(d[a], d[b])
                for k in (a, b):
                    if d[k] != closer:
                        d[k] = closer
                        rule[k] = "rule1"

    # Rule 2: an overlapping object higher in the image must lie behind a lower one.
    for ii, a in enumerate(order):  # a: lower in the image (closer) first
        for b in order[ii + 1 :]:
            if v[b] >= v[a] - similar_rows_px:
                continue
            overlap = min(boxes[a, 2], boxes[b, 2]) - max(boxes[a, 0], boxes[b, 0])
            if overlap <= 0:
                continue
            if d[b] < d[a]:
                d[b] = d[a] + delta_m
                rule[b] = (rule[b] + "+rule2").lstrip("+")
    return OrderingResult(d, rule)
