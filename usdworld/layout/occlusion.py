"""Occlusion order: the object hiding another's bottom bounds its depth from below.

A hidden bottom leaves only bounds from above (the visible bottom's ground point, the cut
height) or the weak top-row estimate; the object in front, when its own depth is known
(not itself only a bound from above) and it is not a facade (``unbounding_occluder``: its
bottom edge hides ground and things far behind it), says the hidden object stands at
least just behind it.

Stuff inferred around detection boxes (:attr:`ImageObject.inferred`) is what remains of
the photo once the boxes are cut out, so a piece bordering a box is seen around that
thing: it does not stand in front of it (:func:`behind_bordered_things`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from usdworld.layout.draft import (
    DepthMethod,
    Draft,
    Forced,
    PlacementContext,
    method_confidence,
    point_at_depth,
)
from usdworld.layout.drafting import draft_object
from usdworld.perception.objects import ImageObject


def drafts_by_ref(drafts: list[Draft]) -> dict[int, Draft]:
    """The drafts by their object's reference (the ``occluded_by`` of others); later ones win."""
    return {d.obj.ref: d for d in drafts if d.obj.ref >= 0}


def occluder(by_ref: dict[int, Draft], obj: ImageObject, ctx: PlacementContext) -> Draft | None:
    """The placed draft of the object hiding ``obj``'s bottom, unless it is an ``unbounding_occluder``."""
    occ = by_ref.get(obj.occluded_by) if obj.occluded_by >= 0 else None
    if occ is None or ctx.classes.has(occ.obj.class_name, "unbounding_occluder"):
        return None
    return occ


def bounding_occluder(by_ref: dict[int, Draft], obj: ImageObject, ctx: PlacementContext) -> Draft | None:
    """:func:`occluder`, when its own depth can bound ``obj``'s from below: not when that
    depth is itself only a bound from above (its bottom hidden or cut, :attr:`DepthMethod.is_partial`)."""
    occ = occluder(by_ref, obj, ctx)
    return None if occ is None or occ.method.is_partial else occ


def behind_depth(occ: Draft, ctx: PlacementContext) -> float:
    """Front depth just behind an occluder: its centre, its back half and ``behind_gap_m``, metres."""
    return occ.depth_m + occ.back_m + ctx.params.behind_gap_m


def sliver(draft: Draft, ctx: PlacementContext) -> bool:
    """True for stuff whose visible part, at its drafted depth, is smaller in both width and
    height than the smallest allowed scale of its class: the whole object there would be
    seen larger, so it does not stand there."""
    obj = draft.obj
    if obj.is_thing:
        return False
    base = draft.size / (draft.scale * draft.stretch)
    metres_per_px = draft.front_depth_m / ctx.camera.fy
    seen = max(obj.width_px * metres_per_px / base[1], obj.height_px * metres_per_px / base[2])
    return seen < ctx.classes[obj.class_name].scale_range[0]


def sliver_behind(draft: Draft, ctx: PlacementContext) -> bool:
    """True for stuff placed just behind its occluder that is a :func:`sliver` there: a
    piece of a far tree or pole seen past a near car, which the occluder does not bound."""
    return draft.method is DepthMethod.BEHIND and sliver(draft, ctx)


def sliver_facade(draft: Draft, ctx: PlacementContext) -> bool:
    """True for a facade piece that is a :func:`sliver` at its drafted depth: too small in
    both width and height for the smallest building of its class there (a column or a few
    of facade at the street's vanishing point), so it is no building of its own. Never for
    a piece cut by the image's border: what is seen of it bounds its size only from below."""
    obj = draft.obj
    cut = obj.top_truncated or obj.bottom_truncated or obj.sides_cut
    return ctx.classes.has(obj.class_name, "facade") and not cut and sliver(draft, ctx)


def move_behind_occluders(drafts: list[Draft], ctx: PlacementContext) -> list[Draft]:
    """Pass: use the object hiding an object's bottom as a lower bound of its depth.

    A contact bound (``contact_partial``) or top-row estimate short of the occluder moves
    the object just behind it; a height-only bound (``height_partial``) is replaced by that
    position. Drafts are taken in order, and an occluder moved earlier bounds by its new
    depth.

    Returns:
        The drafts, in the same order.
    """
    out = list(drafts)
    by_ref = drafts_by_ref(out)
    for k, d in enumerate(out):
        occ = bounding_occluder(by_ref, d.obj, ctx)
        if occ is None or not d.method.is_partial:
            continue
        behind = behind_depth(occ, ctx)
        if d.method in (DepthMethod.CONTACT_PARTIAL, DepthMethod.TOP_ROW) and d.front_depth_m >= behind:
            continue
        depth = behind + d.back_m
        moved = replace(
            d,
            front_depth_m=behind,
            depth_m=depth,
            method=DepthMethod.BEHIND,
            behind=occ.name,
            confidence=method_confidence(DepthMethod.BEHIND, ctx.params) * float(d.obj.score),
            ground=point_at_depth(ctx.camera, *d.obj.contact_px, depth),
        )
        out[k] = moved
        if by_ref.get(d.obj.ref) is d:
            by_ref[d.obj.ref] = moved
    return out


def borders_box(obj: ImageObject, box_px: np.ndarray) -> bool:
    """True when a pixel of ``obj``'s mask lies inside ``box_px`` or next to it (8-neighbours).

    Args:
        obj: the stuff object.
        box_px: (4,) int64 ``xmin, ymin, xmax, ymax`` of a thing (max edges exclusive).
    """
    ox0, oy0 = int(obj.box_px[0]), int(obj.box_px[1])
    x0, y0 = max(int(box_px[0]) - 1, ox0), max(int(box_px[1]) - 1, oy0)
    x1, y1 = min(int(box_px[2]) + 1, int(obj.box_px[2])), min(int(box_px[3]) + 1, int(obj.box_px[3]))
    if x1 <= x0 or y1 <= y0:
        return False
    return bool(obj.mask[y0 - oy0 : y1 - oy0, x0 - ox0 : x1 - ox0].any())


def hides(stuff: Draft, thing: Draft, ctx: PlacementContext) -> bool:
    """True when ``stuff``'s box meets the viewing ray through the centre of ``thing``'s image
    box nearer than ``thing``'s front: placed so, it would hide the thing from the source camera.

    The box: footprint centre ``stuff.ground``, turned by ``stuff.yaw``, ``stuff.size``
    (length along its own x, width, height from the ground up).
    """
    x0, y0, x1, y1 = (float(b) for b in thing.obj.box_px)
    ray = ctx.camera.rays_world(np.array([[0.5 * (x0 + x1), 0.5 * (y0 + y1)]]))[0]
    origin = ctx.camera.center_world
    c, s = np.cos(stuff.yaw), np.sin(stuff.yaw)
    to_local = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    o = to_local @ (origin - np.array([stuff.ground[0], stuff.ground[1], 0.0]))
    r = to_local @ ray
    lo = np.array([-0.5 * stuff.size[0], -0.5 * stuff.size[1], 0.0])
    hi = np.array([0.5 * stuff.size[0], 0.5 * stuff.size[1], stuff.size[2]])
    enter, leave = 0.0, float(thing.front_depth_m)
    for k in range(3):
        if abs(r[k]) < 1e-12:
            if not lo[k] <= o[k] <= hi[k]:
                return False
            continue
        a, b = (lo[k] - o[k]) / r[k], (hi[k] - o[k]) / r[k]
        enter, leave = max(enter, min(a, b)), min(leave, max(a, b))
    return enter < leave


def hides_unbordered_thing(stuff: Draft, things: list[Draft], ctx: PlacementContext) -> bool:
    """True for inferred stuff drafted where it would hide from the source camera (:func:`hides`)
    a thing whose box its mask does not border (:func:`borders_box`).

    The inferred map leaves the boxes unlabelled, so stuff standing in front of a boxed thing
    is seen over the box's edge: its mask borders the box. A piece that does not border it
    is not between the camera and that thing, and a draft putting it there contradicts the
    photo. (A piece that borders the box is seen around the thing and stands behind it:
    :func:`behind_bordered_things`.)

    Args:
        stuff: the draft of a stuff object (False unless :attr:`ImageObject.inferred`).
        things: the drafts of the boxed things.
        ctx: the camera.
    """
    if stuff.obj.is_thing or not stuff.obj.inferred:
        return False
    return any(hides(stuff, t, ctx) and not borders_box(stuff.obj, t.obj.box_px) for t in things)


def behind_bordered_things(
    drafts: list[Draft], ctx: PlacementContext
) -> tuple[list[Draft], list[tuple[ImageObject, str]]]:
    """Pass: inferred stuff in the way of a thing whose box it borders stands behind it.

    The inferred map leaves the boxes unlabelled, so a facade or tree seen around a box is
    hidden by that thing where the box covers it: it cannot stand in front of it. A piece
    that borders a thing's box (:func:`borders_box`), is drafted where it would hide that
    thing from the source camera (:func:`hides`) and whose front is nearer than just
    behind it (:func:`behind_depth`) is redrafted just behind the farthest such thing (its
    size follows the new depth); one that cannot be drafted there is dropped. Pieces that
    border a box but stand beside the thing's line of sight (a facade running along the
    street past a car) keep their own depth.

    Returns:
        (the drafts, in the same order less those dropped; the dropped objects and names).
    """
    things = [d for d in drafts if d.obj.is_thing]
    out: list[Draft] = []
    dropped: list[tuple[ImageObject, str]] = []
    for d in drafts:
        if d.obj.is_thing or not d.obj.inferred:
            out.append(d)
            continue
        bordered = [t for t in things if borders_box(d.obj, t.obj.box_px) and hides(d, t, ctx)]
        if not bordered:
            out.append(d)
            continue
        occ = max(bordered, key=lambda t: behind_depth(t, ctx))
        behind = behind_depth(occ, ctx)
        if d.front_depth_m >= behind:
            out.append(d)
            continue
        forced = draft_object(d.obj, d.name, ctx, Forced(behind, DepthMethod.BEHIND, occ.name))
        if forced is None:
            dropped.append((d.obj, d.name))
        else:
            out.append(forced)
    return out, dropped


def drop_unbounded(
    drafts: list[Draft],
    unplaced: list[tuple[ImageObject, str]],
    ctx: PlacementContext,
    max_partial_depth_m: float,
) -> tuple[list[Draft], list[tuple[ImageObject, str]]]:
    """Pass: unplace the drafts whose depth says nothing useful.

    A depth known only as an upper bound (a cut or hidden bottom) that lies beyond the
    world's range, "just behind" a near occluder for a sliver of stuff too small to be
    the whole object there (:func:`sliver_behind`), or a facade piece too small for any
    building of its class at its depth (:func:`sliver_facade`).

    Returns:
        (the drafts kept, ``unplaced`` followed by the dropped objects and names).
    """
    far = [
        d
        for d in drafts
        if (d.method.is_partial and d.depth_m > max_partial_depth_m) or sliver_behind(d, ctx) or sliver_facade(d, ctx)
    ]
    kept = [d for d in drafts if not any(d is f for f in far)]
    return kept, [*unplaced, *((d.obj, d.name) for d in far)]


def place_behind_occluders(
    drafts: list[Draft], unplaced: list[tuple[ImageObject, str]], ctx: PlacementContext
) -> tuple[list[Draft], list[str]]:
    """Pass: objects with no cue at all but a placed occluder go right behind it.

    Never an ``unbounding_occluder`` (a sliver of facade seen past a tree could be
    anywhere), nor a sliver (:func:`sliver_behind`).

    Returns:
        (the drafts with those placed appended, names of the objects left unplaced).
    """
    by_ref = drafts_by_ref(drafts)
    out = list(drafts)
    skipped: list[str] = []
    for obj, name in unplaced:
        bounding = not ctx.classes.has(obj.class_name, "unbounding_occluder")
        occ = occluder(by_ref, obj, ctx) if bounding else None
        if occ is None:
            skipped.append(name)
            continue
        forced = draft_object(obj, name, ctx, Forced(behind_depth(occ, ctx), DepthMethod.BEHIND, occ.name))
        if forced is None or sliver_behind(forced, ctx):
            skipped.append(name)
        else:
            out.append(forced)
    return out, skipped
