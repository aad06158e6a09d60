"""Street rows as a placement pass: members whose foot is hidden or cut stand in their row.

Rows along the street (building lines, tree and lamp rows; :mod:`usdworld.layout.street_lines`)
are measured by the members whose ground contact is seen, else by the sidewalk, else by
the cars parked along the kerb. A member whose depth is only a bound (its bottom hidden
or cut), or a tree or pole whose seen "contact" lies more than
:attr:`~usdworld.parameters.placement.PlacementParams.row_outlier_m` beyond its row
(ground seen under its crown or arm), and an object no cue placed, then stand where
their viewing ray meets the row, when that agrees with their own bounds.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from usdworld.io.class_table import ClassTable
from usdworld.layout.draft import DepthMethod, Draft, Forced, PlacementContext, point_at_depth
from usdworld.layout.drafting import draft_object
from usdworld.layout.occlusion import bounding_occluder, drafts_by_ref, hides_unbordered_thing, sliver
from usdworld.layout.street_lines import (
    StreetLine,
    fit_street_lines,
    lateral_offsets,
    line_for,
    lone_rows_agreeing,
    parked_car_lines,
    sidewalk_lines,
    unmeasured,
)
from usdworld.perception.depth.fusion import DepthCue
from usdworld.perception.objects import ImageObject

#: The class whose cars, parked along the road, mark the kerb (:func:`parked_car_lines`).
KERB_LINING_CLASS = "car"


def street_rows(
    drafts: list[Draft], ctx: PlacementContext, sidewalk_ground: np.ndarray | None
) -> list[StreetLine]:
    """The rows: measured by seen contacts (a lone one giving way to a disagreeing sidewalk),
    then the sidewalk's for the rest, then the parked cars' kerb for the rest.

    Args:
        drafts: the drafts so far.
        ctx: camera, axis, class table and thresholds.
        sidewalk_ground: (N, 2) float64 ground points of sidewalk pixels, or None.
    """
    walk = sidewalk_lines(sidewalk_ground, ctx.axis, ctx.classes, ctx.params)
    lines = lone_rows_agreeing(_seen_rows(drafts, ctx), walk, ctx.classes, ctx.params)
    lines += unmeasured(walk, lines)
    lines += _parked_car_rows(drafts, ctx, lines)
    return lines


def onto_street_rows(
    drafts: list[Draft],
    unplaced: list[tuple[ImageObject, str]],
    ctx: PlacementContext,
    sidewalk_ground: np.ndarray | None,
) -> tuple[list[Draft], list[tuple[ImageObject, str]]]:
    """Pass: place on their row the members whose depth is a bound, those off their row, and
    the unplaced ones a row finds.

    Inferred stuff is not stood on its row where it would hide a boxed thing whose box it does
    not border (:func:`~usdworld.layout.occlusion.hides_unbordered_thing`): the photo shows
    that thing uncovered, so the row is wrong for that piece, which keeps its own draft (or
    stays unplaced). One bordering the box is left to
    :func:`~usdworld.layout.occlusion.behind_bordered_things`, which runs next.

    Returns:
        (the drafts, moved ones in place and newly placed ones appended; the objects still unplaced).
    """
    lines = street_rows(drafts, ctx, sidewalk_ground)
    if not lines:
        return drafts, unplaced
    by_ref = drafts_by_ref(drafts)
    things = [d for d in drafts if d.obj.is_thing]
    out = list(drafts)
    for k, d in enumerate(drafts):
        if d.method.is_partial or d.method is DepthMethod.BEHIND:
            moved = onto_street_line(d.obj, d.name, d.upper_m, by_ref, lines, ctx)
        elif off_its_row(d, lines, ctx):
            # Its "contact" is ground seen under its crown or arm, behind its hidden foot:
            # an upper bound, and the row it belongs to is nearer.
            moved = onto_street_line(d.obj, d.name, d.front_depth_m, by_ref, lines, ctx)
        else:
            moved = None
        if moved is not None and not hides_unbordered_thing(moved, things, ctx):
            out[k] = moved
    remaining = []
    for obj, name in unplaced:
        moved = onto_street_line(obj, name, float("inf"), by_ref, lines, ctx)
        if moved is None or hides_unbordered_thing(moved, things, ctx):
            remaining.append((obj, name))
        else:
            out.append(moved)
    return out, remaining


def _seen_rows(drafts: list[Draft], ctx: PlacementContext) -> list[StreetLine]:
    """Rows formed by the objects whose ground contact was seen (front points on the ground)."""
    seen = [
        d
        for d in drafts
        if ctx.classes.has(d.obj.class_name, "line")
        and d.method.is_seen_contact
        and not (d.obj.bottom_truncated or d.obj.bottom_occluded)
    ]
    if not seen:
        return []
    fronts = np.array([point_at_depth(ctx.camera, *d.obj.contact_px, d.front_depth_m) for d in seen])
    return fit_street_lines([d.obj.class_name for d in seen], fronts, ctx.axis, ctx.classes, ctx.params)


def _parked_car_rows(drafts: list[Draft], ctx: PlacementContext, lines: list[StreetLine]) -> list[StreetLine]:
    """Kerb rows from the cars placed by their seen contact (:func:`parked_car_lines`)."""
    cars = [d for d in drafts if d.obj.class_name == KERB_LINING_CLASS and d.method.is_seen_contact]
    return parked_car_lines(
        np.array([d.ground[:2] for d in cars], dtype=np.float64).reshape(-1, 2),
        np.array([d.yaw for d in cars], dtype=np.float64),
        np.array([d.size[1] for d in cars], dtype=np.float64),
        ctx.axis,
        ctx.camera.center_world[:2],
        ctx.classes,
        ctx.params,
        lines,
    )


def off_its_row(d: Draft, lines: list[StreetLine], ctx: PlacementContext) -> bool:
    """True for a ``trunk`` object (tree, pole, sign) placed by a seen contact that lies more
    than ``row_outlier_m`` beyond its class's row on its side of the street (the contact
    is then ground seen past a crown's hem or a lamp's arm, not the foot)."""
    obj = d.obj
    if not ctx.classes.has(obj.class_name, "trunk") or not d.method.is_seen_contact:
        return False
    front = point_at_depth(ctx.camera, *obj.contact_px, d.front_depth_m)[:2]
    offset = float(lateral_offsets(front[None, :], ctx.axis)[0])
    rows = [ln for ln in lines if ln.class_name == obj.class_name and ln.side == np.sign(offset)]
    return any(abs(offset) - abs(ln.offset_m) > ctx.params.row_outlier_m for ln in rows)


def line_pixel(obj: ImageObject, width: int, classes: ClassTable) -> np.ndarray:
    """(2,) float64 pixel whose ray finds an object on its row: a trunk or post stands below
    the middle of its crown or sign when its own foot is hidden (unless the image's side
    cuts it); a ``facade``, and a ``post_contact`` class (a pole: its lowest columns are its
    post, not the lamp's arm beside it), keep their contact pixel."""
    u, v = (float(x) for x in obj.contact_px)
    middle = not classes.has(obj.class_name, "facade") and not classes.has(obj.class_name, "post_contact")
    if middle and obj.box_px[0] > 0 and obj.box_px[2] < width:
        u = 0.5 * float(obj.box_px[0] + obj.box_px[2])
    return np.array([u, v])


def row_over_tree(obj: ImageObject, occ: Draft, ctx: PlacementContext) -> bool:
    """True for a facade whose base a street tree (``crown``) hides: the facades' row,
    measured by many points, is trusted over that one tree's depth (street trees stand in
    front of the facades, so a row that puts the facade in front of the tree means the
    tree is placed too far: its contact was ground seen past its crown)."""
    return ctx.classes.has(obj.class_name, "facade") and ctx.classes.has(occ.obj.class_name, "crown")


def onto_street_line(
    obj: ImageObject,
    name: str,
    upper_m: float,
    by_ref: dict[int, Draft],
    lines: list[StreetLine],
    ctx: PlacementContext,
) -> Draft | None:
    """The draft of an object placed on its class's row, with the row's depth cue.

    The row's depth must agree with what the object's own evidence bounds: no nearer than
    the front of the object hiding its bottom (unless that one's depth is itself only a
    bound from above, or it is a street tree in front of a facade: :func:`row_over_tree`),
    no farther than ``upper_m`` (its visible bottom's ground point) with the slack
    ``line_bound_slack`` and ``line_bound_slack_m``; and what is seen of it must not be
    smaller at the row's depth than the smallest object of its class
    (:func:`~usdworld.layout.occlusion.sliver`: a crown a few pixels wide is no tree 3 m away).

    Returns:
        The draft, or None when there is no such row or they disagree.
    """
    if not ctx.classes.has(obj.class_name, "line"):
        return None
    params, camera = ctx.params, ctx.camera
    pixel = line_pixel(obj, camera.width, ctx.classes)
    hit = line_for(lines, obj.class_name, camera, (float(pixel[0]), float(pixel[1])), ctx.axis)
    if hit is None:
        return None
    line, front = hit
    if front <= 0 or front > upper_m * (1.0 + params.line_bound_slack) + params.line_bound_slack_m:
        return None
    occ = bounding_occluder(by_ref, obj, ctx)
    in_front_of_occluder = occ is not None and front < occ.depth_m - occ.back_m - params.line_bound_slack_m
    if in_front_of_occluder and not row_over_tree(obj, occ, ctx):  # type: ignore[arg-type]
        return None
    moved = draft_object(replace(obj, contact_px=pixel), name, ctx, Forced(front, DepthMethod.STREET_LINE))
    if moved is None or front + moved.back_m <= 0:  # the row meets the ray behind the camera
        return None
    if sliver(moved, ctx):  # seen there, the smallest of its class would look larger
        return None
    return replace(
        moved, cues=(*moved.cues, _row_cue(line, front + moved.back_m, front, obj.class_name, ctx))
    )


def _row_cue(
    line: StreetLine, centre_depth_m: float, front: float, class_name: str, ctx: PlacementContext
) -> DepthCue:
    """The row's depth as a cue. How far off it may be: its spread across the street, seen
    at the ray's angle to the row (a ray nearly along the row magnifies it)."""
    params = ctx.params
    lateral = abs(float(line.offset_m)) + params.row_lateral_floor_m
    sigma = max(line.spread_m, params.row_sigma_floor_m) * max(front / lateral, 1.0)
    side = "left" if line.side > 0 else "right"
    what = {
        "objects": f"row of {line.support} {class_name}s",
        "sidewalk": f"{class_name} row from the sidewalk",
        "parked_cars": f"{class_name} row behind the kerb the parked cars line",
    }[line.source]
    note = f"{what} {abs(line.offset_m):.2f} m {side} of the road axis (spread {line.spread_m:.2f} m)"
    return DepthCue("street_line", centre_depth_m, sigma, note)
