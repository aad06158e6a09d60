"""The road's centre line from the vehicles on it, as a placement pass.

Which way a vehicle faces depends on which side of the line dividing the two directions
it is on (:mod:`usdworld.layout.heading`). That line is the road region's centre when a
road region was seen; from a detector's boxes alone (no road region) the vehicles span
the carriageway instead (:func:`usdworld.layout.heading.vehicle_span_centre`). Their
positions are known only once every object is placed, so this pass comes after the
depth passes and takes each road user's front-versus-back choice again from the centre
line they give. Only the facing can change (by a half turn), never the line the object
lies along, so the footprint, the box the object projects to and every depth stay as
they were.

Frames: ground (x forward, y left, metres; the camera above the origin).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from usdworld.layout.draft import Draft, PlacementContext
from usdworld.layout.heading import vehicle_span_centre
from usdworld.layout.yaw import facing, heading_for

#: The class yaw modes whose facing the road's centre line decides
#: (:func:`usdworld.layout.yaw.heading_for`).
SIDE_RULE_MODES = ("road", "along_road")

#: The prefix a heading's source carries when a box's aspect turned it
#: (:func:`usdworld.layout.boxes.object_heading`).
BOX_ASPECT = "box_aspect_"


def along_the_road(yaw: float, axis_angle: float) -> bool:
    """True when the line ``yaw`` (either way along it) is nearer the road axis than its perpendicular."""
    return abs(float(np.angle(np.exp(2j * (yaw - axis_angle))))) <= 0.5 * np.pi


def face_the_traffic(drafts: list[Draft], ctx: PlacementContext) -> list[Draft]:
    """Pass: with no road region, the vehicles' span gives the road's centre line and the facings.

    The span is taken over the vehicles (class yaw mode ``road``) lying along the road,
    not across it (a crossing vehicle stands on another road). Every road user lying
    along the road (``road`` and ``along_road`` modes) then faces as the side rule says
    with that centre line; the source names it (``..._vehicle_span_traffic_...``).

    Args:
        drafts: the drafts, their positions final.
        ctx: the camera, the road axis (its centre line unmeasured, ``center_source``
            ``camera``, for this pass to act), the class table and the lane width.

    Returns:
        The drafts in the same order; unchanged when the road region gave the centre
        line or no vehicle lies along the road.
    """
    axis = ctx.axis
    if axis.center_source != "camera":
        return drafts
    modes = [ctx.classes[d.obj.class_name].yaw for d in drafts]
    along = [along_the_road(d.yaw, axis.angle) for d in drafts]
    movers = [d.ground[:2] for d, mode, a in zip(drafts, modes, along) if mode == "road" and a]
    if not movers:
        return drafts
    spanned = replace(
        axis, center_ground=vehicle_span_centre(np.array(movers), axis.angle), center_source="vehicles"
    )
    out = []
    for d, mode, a in zip(drafts, modes, along):
        if mode not in SIDE_RULE_MODES or not a:
            out.append(d)
            continue
        side = heading_for(mode, d.ground[:2], spanned, ctx.params)
        source = BOX_ASPECT + side.source if d.yaw_source.startswith(BOX_ASPECT) else side.source
        out.append(replace(d, yaw=facing(d.yaw, side.yaw), yaw_source=source, yaw_confidence=side.confidence))
    return out
