"""One object list from detected things and segmented stuff, with references that stay unique.

An :class:`~usdworld.perception.objects.ImageObject`'s ``ref`` names it within its image, and
another object's ``occluded_by`` points at that name. Detections number their objects by their
index in the file, a segmentation by the order of its regions: two lists built apart share
numbers, and a pointer of one would name an object of the other. :func:`join_things_and_stuff`
renumbers the stuff past the things and redirects what hides a stuff region's bottom:

* another stuff region: its new number;
* a thing of the segmentation (dropped, since the detections give the things): the detection
  whose box is that thing's (intersection over union at least
  :attr:`~usdworld.parameters.PerceptionParams.same_thing_iou`), or nothing when none is.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams
from usdworld.perception.dedupe import box_iou
from usdworld.perception.objects import ImageObject, sort_objects


def _detection_for(thing: ImageObject, things: list[ImageObject], min_iou: float) -> int:
    """The ref of the detected thing of ``thing``'s class whose box is ``thing``'s, or -1."""
    same = [t for t in things if t.class_name == thing.class_name and t.ref >= 0]
    if not same:
        return -1
    iou = box_iou(thing.box_px, np.array([t.box_px for t in same], dtype=np.float64))
    best = int(np.argmax(iou))
    return same[best].ref if iou[best] >= min_iou else -1


def join_things_and_stuff(
    things: list[ImageObject],
    segmented: list[ImageObject],
    params: PerceptionParams = DEFAULT_PERCEPTION,
) -> list[ImageObject]:
    """The detected ``things`` and the stuff of ``segmented``, sorted, every ``ref`` unique.

    Args:
        things: objects from detections (their refs and ``occluded_by`` among themselves).
        segmented: every object of a segmentation, things included (their refs and
            ``occluded_by`` among themselves); only its stuff is kept.
        params: :attr:`PerceptionParams.same_thing_iou`.

    Returns:
        ``things`` unchanged and the stuff renumbered past them, in canonical order.
    """
    shift = max((o.ref for o in things), default=-1) + 1
    by_ref = {o.ref: o for o in segmented if o.ref >= 0}
    stuff = []
    for o in segmented:
        if o.is_thing:
            continue
        occ = by_ref.get(o.occluded_by) if o.occluded_by >= 0 else None
        if occ is None:
            occluded_by = -1
        elif occ.is_thing:
            occluded_by = _detection_for(occ, things, params.same_thing_iou)
        else:
            occluded_by = occ.ref + shift
        stuff.append(replace(o, ref=o.ref + shift if o.ref >= 0 else -1, occluded_by=occluded_by))
    return sort_objects([*things, *stuff])
