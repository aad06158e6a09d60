"""Tuned numbers of the collision stage (see :mod:`usdworld.parameters.base` for the field conventions)."""

from __future__ import annotations

from dataclasses import dataclass

from usdworld.parameters.base import param


@dataclass(frozen=True)
class CollisionParams:
    """Thresholds of the collision stage; each field documents its unit, meaning and origin."""

    tolerance_m: float = param(
        0.01,
        "m",
        "Footprint boxes may overlap by at most this much on both axes before they count as colliding "
        "(also the editor's fit check).",
        "convention: below a centimetre, invisible at street scale",
    )
    clearance_m: float = param(
        0.005,
        "m",
        "Gap left between two boxes that had to be separated; below tolerance_m so that a separated "
        "pair never counts as overlapping again.",
        "convention: half of tolerance_m",
    )
    neighbourhood_m: float = param(
        50.0,
        "m",
        "A box that overlaps is first tried flush against the edges of the settled boxes within this "
        "distance (beyond their half extents); only when none of those spots is free are every "
        "settled box's edges tried.",
        "convention: well beyond the size of any placed class, so the fallback is rare",
    )
    max_displacement_m: float = param(
        25.0,
        "m",
        "An object that would have to move further than this on the ground to clear the objects "
        "already settled is not placed: it is dropped from the placements and named in the build's "
        "warnings. Only a pile of contradictory boxes (a detector's raw output, a label file dumped on "
        "one spot) pushes an object that far; the search for a free spot stops at this radius. Below "
        "neighbourhood_m, so the fallback over every settled box is never needed.",
        "convention: about five car lengths (4.5 m); no real photo's object is misplaced by that much. "
        "Largest displacement measured: 1.7 m on 25 KITTI frames (x3 camera modes), nuScenes and "
        "Cityscapes, 8.7 m on the demo, 14.0 m on the 50 synthetic scenes",
    )
    max_candidates: int = param(
        65536,
        "count",
        "The search for a free spot considers the candidates (the original coordinates and the "
        "positions flush against nearby boxes' edges, combined x by y) in rings of growing radius; "
        "an object whose ring would hold more than this many spots is dropped like one beyond "
        "max_displacement_m. Bounds the work per object in a pile of boxes with distinct edges, "
        "where the candidates grow as the square of the boxes settled nearby.",
        "convention: 256 x 256; a ring holds at most (2 M + 1)^2 spots for M boxes nearby, so a scene "
        "needs over 127 objects packed within max_displacement_m of one another to reach it",
    )
    depth_sigmas: float = param(
        3.0,
        "count",
        "Collision resolution moves an object no nearer the camera than this many standard deviations "
        "of its fused depth cues before its drafted depth (one with no cue that has a sigma comes no "
        "nearer at all), nor farther than a hidden bottom's bound: nearer, it would stand in front of what "
        "the photo shows. An object whose nearest free spot is not allowed takes the nearest allowed one "
        "(or slides along its viewing ray), or is not placed.",
        "published: the three-sigma rule (99.7 % of a normally distributed error lies within 3 sigma)",
    )
    duplicate_iou: float = param(
        0.95,
        "fraction",
        "Two thing detections of one class whose boxes have at least this intersection over union "
        "are one object seen twice (a detector's raw output without suppression, a label file listed "
        "twice) and are merged whatever their number: two real objects cannot both fill 95 % of one "
        "box, since the farther one projects smaller and higher.",
        "geometry: two cars one car length (4.5 m) apart at 60 m differ in box size by 7 %, IoU < 0.9",
    )
    dense_detections: int = param(
        200,
        "count",
        "Above this many thing detections in one image the input is treated as a detector's raw "
        "output, and same-class boxes with IoU of at least dense_iou are merged as well.",
        "convention: KITTI's densest frames have about 40 labelled objects, Cityscapes' about 100 "
        "persons; 200 leaves room for a crowded car park",
    )
    dense_iou: float = param(
        0.7,
        "fraction",
        "IoU at or above which two same-class detections are merged in a dense input (see dense_detections).",
        "published: the usual non-maximum suppression threshold of detector proposals (Ren et al., "
        "Faster R-CNN, NeurIPS 2015, 0.7)",
    )
