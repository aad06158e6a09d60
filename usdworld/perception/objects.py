"""Objects found in the image: things from instance ids or boxes, stuff from class masks.

Everything here is in pixel space. An object knows its class, its box, its mask (as a
crop aligned to the box), the pixel where it meets the ground and whether that
contact is cut by the image border or hidden by another object.

What a class does comes from the class table's roles (:mod:`usdworld.io.class_table`):
``facade`` regions are cut by perspective (:mod:`usdworld.perception.facades`), ``crown``
and ``topped`` ones by their tops and feet (:mod:`usdworld.perception.crowns`), ``post``
pieces are joined down through what stands in front, and ``trunk`` classes stand on
their lowest columns. The thresholds are :class:`~usdworld.parameters.PerceptionParams`.
"""

from __future__ import annotations

import logging
from collections import Counter
from dataclasses import dataclass

import cv2
import numpy as np

from usdworld.io.class_table import ClassTable
from usdworld.io.label_table import LabelLookups
from usdworld.io.types import Detections, Segmentation
from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams
from usdworld.perception.crowns import crown_ranges
from usdworld.perception.facades import StreetView, facade_ranges, fill_through_occluders

logger = logging.getLogger(__name__)


#: Source-label prefix of the stuff inferred from the photo when only boxes are given.
INFERRED_PREFIX = "inferred:"


@dataclass(frozen=True)
class ImageObject:
    """One object seen in the image.

    Attributes:
        class_name: placed class (asset name, e.g. ``car``, ``tree``).
        source_label: class as given by the input (Cityscapes name or detector label).
        instance_id: Cityscapes instance id, detection index, or -1 for stuff regions.
        box_px: (4,) int64 ``xmin, ymin, xmax, ymax``; xmax/ymax exclusive.
        mask: (ymax-ymin, xmax-xmin) bool crop of the object's pixels inside the box.
        contact_px: (2,) float64 pixel (u, v) where the object meets the ground. A mask's
            lowest pixel row ``r`` is covered when the true edge lies in ``[r, r + 1)``
            (OpenCV pixel centres at integers), so ``v = r + 0.5``; boxes keep their edge. A
            trunk's or a region's column ``u`` is the median of its pixels' columns, each at its
            centre, the integer (as the renderer projects, :mod:`usdworld.render.camera`).
        bottom_truncated: the bottom touches the image border.
        bottom_occluded: the bottom is mostly hidden by other objects.
        top_truncated: the top touches the image border.
        standing_on: Cityscapes name of the surface below the contact ('' unknown).
        score: detection confidence in [0, 1].
        occluded_by: ``ref`` of the object hiding most of this one's bottom (-1 none).
        ref: identifier of the object within its image (unique, stable for the same input).
        box_only: the object comes from a 2D box without a mask (its box bottom follows
            the projected 3D box, not the visible ground contact).
        left_truncated: the left side touches the image border (or the input marks the
            object cut there): the box bounds the object only from the right.
        right_truncated: the right side touches the image border (or is marked cut).
        left_hidden: the left side of the mask borders, in most of its rows, an object whose
            bottom is lower in the image (nearer on the ground): the mask bounds the object
            from the right only, like a cut side (:func:`hidden_sides`).
        right_hidden: the same on the right side.
        box_edges_px: (4,) float64 ``xmin, ymin, xmax, ymax`` of a box-only object as its
            detection gave them, sub-pixel (a projected 3D box's edges are not whole pixels),
            in the intrinsics' pixel frame; None: ``box_px`` (a mask's pixels). See :attr:`edges_px`.
    """

    class_name: str
    source_label: str
    instance_id: int
    box_px: np.ndarray
    mask: np.ndarray
    contact_px: np.ndarray
    bottom_truncated: bool
    bottom_occluded: bool
    top_truncated: bool
    standing_on: str = ""
    score: float = 1.0
    occluded_by: int = -1
    ref: int = -1
    box_only: bool = False
    left_truncated: bool = False
    right_truncated: bool = False
    box_edges_px: np.ndarray | None = None
    left_hidden: bool = False
    right_hidden: bool = False

    def __post_init__(self) -> None:
        for name in (
            "bottom_truncated",
            "bottom_occluded",
            "top_truncated",
            "left_truncated",
            "right_truncated",
            "left_hidden",
            "right_hidden",
        ):
            object.__setattr__(self, name, bool(getattr(self, name)))
        object.__setattr__(self, "instance_id", int(self.instance_id))
        object.__setattr__(self, "score", float(self.score))
        box = np.asarray(self.box_px, dtype=np.int64)
        mask = np.asarray(self.mask, dtype=bool)
        if box.shape != (4,) or mask.shape != (box[3] - box[1], box[2] - box[0]):
            raise ValueError(f"mask shape {mask.shape} does not match box {box.tolist()}")
        box.setflags(write=False)
        object.__setattr__(self, "box_px", box)
        if self.box_edges_px is not None:
            edges = np.array(self.box_edges_px, dtype=np.float64)
            if edges.shape != (4,) or not (edges[2] > edges[0] and edges[3] > edges[1]):
                raise ValueError(f"box edges {edges.tolist()} are not a box")
            edges.setflags(write=False)
            object.__setattr__(self, "box_edges_px", edges)

    @property
    def mask_area(self) -> int:
        return int(np.count_nonzero(self.mask))

    @property
    def edges_px(self) -> np.ndarray:
        """(4,) float64 the object's extent in the image, ``xmin, ymin, xmax, ymax``: a box-only
        object's own sub-pixel edges (:attr:`box_edges_px`), else its whole-pixel ``box_px``.

        ``box_px`` holds the pixels a box touches (its edges rounded outwards, for the mask
        crop); measuring a box's height on it adds between 0 and 2 pixels, one on average,
        which is 3 % of a person 35 px tall: its class-height depth 3 % short.
        """
        if self.box_edges_px is not None:
            return self.box_edges_px
        return self.box_px.astype(np.float64)

    @property
    def height_px(self) -> float:
        """The image height of the object, pixels (:attr:`edges_px`)."""
        e = self.edges_px
        return float(e[3] - e[1])

    @property
    def width_px(self) -> float:
        """The image width of the object, pixels (:attr:`edges_px`)."""
        e = self.edges_px
        return float(e[2] - e[0])

    @property
    def is_thing(self) -> bool:
        return self.instance_id >= 0

    @property
    def inferred(self) -> bool:
        """Stuff inferred from the photo around the detection boxes (source label ``inferred:...``)."""
        return self.source_label.startswith(INFERRED_PREFIX)

    @property
    def cut_sides(self) -> tuple[str, ...]:
        """The sides cut by the image border, of ``left``, ``right``, ``top``, ``bottom`` in that order."""
        flags = (self.left_truncated, self.right_truncated, self.top_truncated, self.bottom_truncated)
        return tuple(side for side, cut in zip(("left", "right", "top", "bottom"), flags) if cut)

    @property
    def sides_cut(self) -> bool:
        """True when the left or the right side is cut: the box's width bounds the object from one side only."""
        return self.left_truncated or self.right_truncated

    @property
    def left_bounded(self) -> bool:
        """The box's left edge is the object's own: cut by neither the border nor a nearer object."""
        return not (self.left_truncated or self.left_hidden)

    @property
    def right_bounded(self) -> bool:
        """The box's right edge is the object's own: cut by neither the border nor a nearer object."""
        return not (self.right_truncated or self.right_hidden)


def _column_bottoms(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns of a crop that hold pixels and the row of their lowest pixel.

    Args:
        mask: (h, w) bool crop.

    Returns:
        cols: (k,) int64 column indices with at least one pixel.
        bottoms: (k,) int64 row of the lowest pixel in each of those columns.
    """
    has = mask.any(axis=0)
    cols = np.nonzero(has)[0]
    h = mask.shape[0]
    bottoms = h - 1 - np.argmax(mask[::-1, cols], axis=0)
    return cols, bottoms


@dataclass(frozen=True)
class _Contact:
    contact_px: np.ndarray
    bottom_truncated: bool
    bottom_occluded: bool
    standing_on: str
    occluder: int = 0


def _contact_from_mask(
    mask: np.ndarray,
    x0: int,
    y0: int,
    label_ids: np.ndarray | None,
    owner: np.ndarray | None,
    own_value: int,
    thing: bool,
    trunk: bool,
    lookups: LabelLookups,
    params: PerceptionParams,
) -> _Contact:
    """Ground contact of a mask crop placed at (x0, y0) in an image.

    A column touches the ground when the pixel just below its lowest pixel is a
    ground class; it is hidden when that pixel belongs to another placed object
    (``owner`` differs and is not 0); it is cut when the column reaches the border.
    Things and stuff on a ``trunk`` (trees, poles) are judged by their lowest columns
    only (``params.bottom_band_fraction``); a trunk's contact is where those columns stand.
    """
    H = label_ids.shape[0] if label_ids is not None else (owner.shape[0] if owner is not None else 0)
    cols, bottoms = _column_bottoms(mask)
    rows_abs = bottoms + y0
    cols_abs = cols + x0
    lowest = int(rows_abs.max())
    truncated = H > 0 and lowest >= H - 1
    below = np.minimum(rows_abs + 1, max(H - 1, 0))
    at_border = rows_abs >= H - 1
    if label_ids is not None:
        below_labels = label_ids[below, cols_abs]
        on_ground = lookups.is_ground[below_labels] & ~at_border
    else:
        below_labels = None
        on_ground = ~at_border
    if owner is not None:
        below_owner = owner[below, cols_abs]
        hidden = (below_owner != 0) & (below_owner != own_value) & ~at_border
        on_ground &= ~hidden
    else:
        hidden = np.zeros_like(on_ground)
    if thing or trunk:
        # Judge a thing by its lowest columns (feet, tyres), not by arms or bumpers, and a
        # tree by its trunk, not by its crown: the pixels below those may be ground far
        # behind the object.
        band = rows_abs >= lowest - max(params.bottom_band_min_px, params.bottom_band_fraction * mask.shape[0])
        occluded = (not truncated) and on_ground[band].mean() < params.contact_fraction
        support = on_ground & band
    else:
        occluded = (not truncated) and not on_ground.any()
        support = on_ground
    use = on_ground if on_ground.any() else ~hidden if (~hidden).any() else np.ones_like(on_ground)
    if thing:
        v = float(rows_abs[use].max()) + 0.5
        u = float(x0 + mask.shape[1] / 2.0)
    elif trunk:
        # Where the trunk's or post's own foot is hidden, it is still the foot: not a
        # lamp's arm or a crown's hem beside it, whose lower edge has nothing below.
        foot = use & band if (use & band).any() else band
        u = float(np.median(cols_abs[foot]))
        v = float(rows_abs[foot].max()) + 0.5
    else:
        order = np.argsort(cols_abs[use])
        mid = order[len(order) // 2]
        u = float(cols_abs[use][mid])
        v = float(np.median(rows_abs[use])) + 0.5
    standing_on = ""
    if below_labels is not None and support.any():
        values, counts = np.unique(below_labels[support], return_counts=True)
        standing_on = str(lookups.names[values[np.argmax(counts)]])
    occluder = 0
    if occluded and owner is not None and hidden.any():
        values, counts = np.unique(below_owner[hidden], return_counts=True)
        occluder = int(values[np.argmax(counts)])
    return _Contact(np.array([u, v]), bool(truncated), bool(occluded), standing_on, occluder)


def hidden_sides(
    mask: np.ndarray, x0: int, y0: int, owner: np.ndarray, own_value: int, bottoms: np.ndarray, fraction: float
) -> tuple[bool, bool]:
    """Which sides of a mask a nearer object hides: (left, right).

    In each row of the mask, the pixel just beyond its outermost pixel on a side belongs
    either to the background or to another object. The side is hidden when, in at least
    ``fraction`` of the rows, it belongs to an object whose lowest row is below this mask's:
    on the ground, the object whose bottom is lower in the image stands nearer, so it hides
    what lies beyond the mask's edge there (a car behind another in a parked row shows only
    its side's sliver). A side at the image border is cut, not hidden.

    Args:
        mask: (h, w) bool crop.
        x0: column of the crop's left pixel in the image.
        y0: row of the crop's top pixel in the image.
        owner: (H, W) int32 index (1-based) of the object owning each pixel, 0 for none.
        own_value: this mask's index in ``owner``.
        bottoms: (K + 1,) int64 lowest row of each object index (entry 0 unused).
        fraction: share of the mask's rows that must be hidden.

    Returns:
        (left hidden, right hidden).
    """
    H, W = owner.shape
    rows = np.nonzero(mask.any(axis=1))[0]
    if len(rows) == 0:
        return False, False
    sub = mask[rows]
    first = np.argmax(sub, axis=1)
    last = sub.shape[1] - 1 - np.argmax(sub[:, ::-1], axis=1)
    rows_abs = rows + y0
    own_bottom = int(rows_abs.max())
    out = []
    for cols in (first + x0 - 1, last + x0 + 1):
        inside = (cols >= 0) & (cols < W)
        if not inside.any():
            out.append(False)
            continue
        other = owner[rows_abs[inside], cols[inside]]
        nearer = (other != 0) & (other != own_value) & (bottoms[other] > own_bottom)
        out.append(bool(nearer.sum() >= fraction * len(rows)))
    return out[0], out[1]


def _split_columns(mask: np.ndarray, aspect: float, min_width_px: int) -> list[tuple[int, int]]:
    """Split a wide stuff crop into column ranges of about ``aspect`` x their height (at
    least ``min_width_px`` wide; no cut leaves less than half a piece to its right)."""
    cols, bottoms = _column_bottoms(mask)
    if len(cols) == 0:
        return []
    tops = np.argmax(mask[:, cols], axis=0)
    heights = np.zeros(mask.shape[1])
    heights[cols] = bottoms - tops + 1
    ranges = []
    start = 0
    w = mask.shape[1]
    while start < w:
        end = start + 1
        tallest = heights[start]
        while end < w:
            tallest = max(tallest, heights[end])
            if end - start >= max(aspect * tallest, min_width_px) and (w - end) >= 0.5 * aspect * tallest:
                break
            end += 1
        ranges.append((start, end))
        start = end
    return ranges


def _ground_below(
    crop: np.ndarray, x0: int, y0: int, labels: np.ndarray, lookups: LabelLookups, or_things: bool = False
) -> np.ndarray:
    """(w,) bool: the pixel below each column's lowest pixel of the crop is a ground class
    (or, with ``or_things``, a thing that may hide the ground there)."""
    cols, bottoms = _column_bottoms(crop)
    rows = y0 + bottoms + 1
    inside = rows < labels.shape[0]
    below = labels[rows[inside], x0 + cols[inside]]
    out = np.zeros(crop.shape[1], dtype=bool)
    out[cols[inside]] = lookups.is_ground[below] | (or_things & lookups.is_thing[below])
    return out


#: Largest instance id counted with ``np.bincount`` (a table of this many entries); larger ids are sorted.
_MAX_COUNTED_ID = 1 << 20


def _instance_groups(instance_ids: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """Instance ids >= 1000 and their boxes ``(xmin, ymin, xmax, ymax)``, sorted by id.

    One pass over the image finds the instance pixels; each pixel then updates its
    instance's box in place (``ufunc.at``), so no pixel is sorted.

    Args:
        instance_ids: (H, W) integer instance map.

    Returns:
        ``(id, box)`` pairs, ``box`` (4,) int64 with xmax/ymax exclusive.
    """
    h, w = instance_ids.shape
    things = np.ascontiguousarray(instance_ids) >= 1000
    where = np.flatnonzero(things)
    if len(where) == 0:
        return []
    vals = instance_ids.ravel()[where]
    if int(vals.max()) < _MAX_COUNTED_ID:
        ids = np.flatnonzero(np.bincount(vals))
        index = np.zeros(int(ids[-1]) + 1, dtype=np.intp)
        index[ids] = np.arange(len(ids))
        group = index[vals]
    else:
        ids, group = np.unique(vals, return_inverse=True)
    ys = np.repeat(np.arange(h), np.count_nonzero(things, axis=1))  # flat indices are in row order
    xs = where - ys * w
    boxes = np.empty((len(ids), 4), dtype=np.int64)
    boxes[:, :2] = (w, h)
    boxes[:, 2:] = 0
    np.minimum.at(boxes[:, 0], group, xs)
    np.minimum.at(boxes[:, 1], group, ys)
    np.maximum.at(boxes[:, 2], group, xs + 1)
    np.maximum.at(boxes[:, 3], group, ys + 1)
    return [(int(v), b) for v, b in zip(ids, boxes)]


def _lookup(table: np.ndarray, label_ids: np.ndarray) -> np.ndarray:
    """``table[label_ids]`` for a (256,) bool table and uint8 labels, as one OpenCV table lookup.

    Args:
        table: (256,) bool, a value per label id.
        label_ids: (h, w) uint8 label ids.

    Returns:
        (h, w) bool.
    """
    return cv2.LUT(np.ascontiguousarray(label_ids), table.astype(np.uint8)).view(bool)


def _components(mask: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """8-connected components of a mask, labelled 16-bit when they fit (faster in OpenCV).

    Args:
        mask: (h, w) bool.

    Returns:
        The count (background included), the (h, w) label image and the (n, 5) int32 stats
        ``x, y, w, h, area`` of :func:`cv2.connectedComponentsWithStats`.
    """
    image = mask.view(np.uint8) if mask.flags.c_contiguous else np.ascontiguousarray(mask, dtype=np.uint8)
    # Every component holds the start of a row run, so the runs bound the label count.
    runs = np.count_nonzero(image[:, 0]) + np.count_nonzero(image[:, 1:] > image[:, :-1])
    ltype = cv2.CV_16U if runs < np.iinfo(np.uint16).max else cv2.CV_32S
    n, comp, stats, _ = cv2.connectedComponentsWithStats(image, connectivity=8, ltype=ltype)
    return n, comp, stats


def _facade_sides(
    crop: np.ndarray,
    region: np.ndarray,
    x: int,
    y: int,
    labels: np.ndarray,
    view: StreetView,
    piece_area: float,
    width: int,
    aspect: float,
    lookups: LabelLookups,
    params: PerceptionParams,
) -> list[tuple[int, int]] | None:
    """:func:`facade_ranges` of a facade crop, cut first at the street's vanishing point:
    where the two sides' far ends meet there the labels make one region of them, but a
    building never stands on both sides. A side whose base is not measurable is cut by
    ``aspect`` (the class's ``split_aspect``); None when neither side's is."""
    split = round(view.vanishing_u) - x if view.vanishing_u is not None else 0
    sides = [(0, split), (split, crop.shape[1])] if 0 < split < crop.shape[1] else [(0, crop.shape[1])]
    parts = [
        facade_ranges(
            crop[:, a:b],
            x + a,
            y,
            _ground_below(crop[:, a:b], x + a, y, labels, lookups),
            view,
            piece_area,
            roof_mask=region[:, a:b],
            image_width=width,
            params=params,
        )
        for a, b in sides
    ]
    if all(part is None for part in parts):
        return None
    ranges: list[tuple[int, int]] = []
    for (a, b), part in zip(sides, parts):
        if part is None:
            part = _split_columns(crop[:, a:b], aspect, params.split_min_width_px)
        ranges.extend((a + c0, a + c1) for c0, c1 in part)
    return ranges


@dataclass(frozen=True)
class SegmentRegions:
    """The regions of a label map before the photo's perspective cuts them
    (:func:`segment_regions`; :func:`objects_from_regions` makes the objects).

    Attributes:
        things: (class, source label, instance id, box (4,) int64, (h, w) bool crop) of each
            instance large enough to place, in instance order.
        stuff: (class, source label, (h, w) bool crop, (h, w) bool region its component spans,
            x, y of the crop's top-left pixel, the class's minimum area in pixels) of each stuff
            component large enough, by class name, then component label.
    """

    things: tuple[tuple[str, str, int, np.ndarray, np.ndarray], ...]
    stuff: tuple[tuple[str, str, np.ndarray, np.ndarray, int, int, int], ...]


def segment_regions(
    seg: Segmentation,
    classes: ClassTable,
    lookups: LabelLookups,
    params: PerceptionParams = DEFAULT_PERCEPTION,
) -> SegmentRegions:
    """The things of the instance map and the stuff components of the class masks: the part of
    :func:`objects_from_segmentation` that needs no perspective (a build finds them while it
    looks for the street's vanishing point, :mod:`usdworld.stage_threads`).

    Args:
        seg: label ids (and instance ids) of one image.
        classes: the class table; its roles say how each class's regions are joined.
        lookups: the Cityscapes table's arrays (:func:`usdworld.io.label_table.label_lookups`).
        params: the perception thresholds.
    """
    labels = np.asarray(seg.label_ids)
    H, W = labels.shape
    things: list[tuple[str, str, int, np.ndarray, np.ndarray]] = []
    stuff: list[tuple[str, str, np.ndarray, np.ndarray, int, int, int]] = []

    inst = np.asarray(seg.instance_ids) if seg.instance_ids is not None else None
    if inst is not None:
        for iid, box in _instance_groups(inst):
            label_id = iid // 1000
            if label_id > 255 or not lookups.placed[label_id]:
                continue
            x0, y0, x1, y1 = (int(b) for b in box)
            crop = inst[y0:y1, x0:x1] == iid
            if crop.sum() < params.min_thing_area_px:
                continue
            things.append((str(lookups.placed[label_id]), str(lookups.names[label_id]), iid, box, crop))

    by_class: dict[str, list[int]] = {}
    for i in range(256):
        if lookups.placed[i] and not (inst is not None and lookups.is_thing[i]):
            by_class.setdefault(str(lookups.placed[i]), []).append(i)
    if inst is not None:
        # With instances, the things are the instances: a class that things are placed as
        # makes no stuff regions from other labels' pixels either.
        for i in range(256):
            if lookups.is_thing[i] and lookups.placed[i]:
                by_class.pop(str(lookups.placed[i]), None)
    # One pass over the image: each pixel's stuff class as a small integer (0 = none); each
    # class's mask is then cut to the rows and columns it occupies.
    class_names = sorted(by_class)
    class_of_id = np.zeros(256, dtype=np.uint8)
    for k, class_name in enumerate(class_names, start=1):
        class_of_id[by_class[class_name]] = k
    class_map = cv2.LUT(np.ascontiguousarray(labels, dtype=np.uint8), class_of_id)
    for k, class_name in enumerate(class_names, start=1):
        min_area = max(params.min_stuff_area_px, int(params.min_area_fraction(class_name) * H * W))
        class_mask = class_map == k
        if np.count_nonzero(class_mask) < min_area:
            continue
        ox, oy, ow, oh = cv2.boundingRect(class_mask.view(np.uint8))
        own = class_mask[oy : oy + oh, ox : ox + ow]
        window = own
        if classes.has(class_name, "facade") or classes.has(class_name, "crown"):
            # A facade or a crown split by a pole or a tree in front of it is one object:
            # its pieces are joined through what stands in front before components are
            # labelled (and cut again by roofline, frontage or crown tops below).
            window_labels = labels[oy : oy + oh, ox : ox + ow]
            stands_in_front = lookups.placed != ""
            if classes.has(class_name, "crown"):
                # Facades stand behind street trees: two crowns with a wall between them are two.
                stands_in_front &= ~np.isin(lookups.placed, sorted(classes.with_role("facade")))
            window = fill_through_occluders(own, _lookup(stands_in_front, window_labels))
        elif classes.has(class_name, "post"):
            # A post split by a sign, a crown or a car in front of it is one post: its
            # pieces are joined down each column through what stands in front.
            window_labels = labels[oy : oy + oh, ox : ox + ow]
            in_front = _lookup(lookups.placed != "", window_labels)
            window = fill_through_occluders(own.T, in_front.T).T
        n, comp, stats = _components(window)
        for k_comp in range(1, n):
            x, y, w, h, _ = (int(v) for v in stats[k_comp])
            region = comp[y : y + h, x : x + w] == k_comp
            crop = region & own[y : y + h, x : x + w]
            x, y = x + ox, y + oy
            if crop.sum() < min_area:
                continue
            source = str(lookups.names[int(np.bincount(labels[y : y + h, x : x + w][crop]).argmax())])
            stuff.append((class_name, source, crop, region, x, y, min_area))
    return SegmentRegions(tuple(things), tuple(stuff))


def objects_from_regions(
    regions: SegmentRegions,
    seg: Segmentation,
    view: StreetView | None,
    classes: ClassTable,
    lookups: LabelLookups,
    params: PerceptionParams = DEFAULT_PERCEPTION,
) -> list[ImageObject]:
    """The objects of a label map's regions: stuff cut into pieces (facades by the photo's
    perspective), then each object's ground contact.

    Args:
        regions: :func:`segment_regions` of ``seg`` with the same tables and parameters.
        seg: label ids (and instance ids) of one image.
        view: the photo's perspective; with it, runs of facades are cut into buildings
            (:mod:`usdworld.perception.facades`), else (or when a facade's base is not in
            view) into chunks of a fixed pixel aspect.
        classes: the class table.
        lookups: the Cityscapes table's arrays.
        params: the perception thresholds.

    Returns:
        Objects sorted by (class, instance id, contact u).
    """
    labels = np.asarray(seg.label_ids)
    H, W = labels.shape
    split_aspect = params.split_aspect_by_class
    pending: list[tuple[str, str, int, np.ndarray, np.ndarray, bool]] = [
        (class_name, source, iid, box, crop, True) for class_name, source, iid, box, crop in regions.things
    ]
    for class_name, source, crop, region, x, y, min_area in regions.stuff:
        w = crop.shape[1]
        ranges = None
        piece_area = min_area
        if view is not None and classes.has(class_name, "facade"):
            piece_area = max(params.min_stuff_area_px, int(min_area * params.facade_piece_area))
            ranges = _facade_sides(
                crop, region, x, y, labels, view, piece_area, W, split_aspect[class_name], lookups, params
            )
        if ranges is None and classes.has(class_name, "topped"):
            ranges = crown_ranges(crop, _ground_below(crop, x, y, labels, lookups, or_things=True), params)
        if ranges is None:
            if class_name in split_aspect:
                ranges = _split_columns(crop, split_aspect[class_name], params.split_min_width_px)
            else:
                ranges = [(0, w)]
        for c0, c1 in ranges:
            sub = crop[:, c0:c1]
            rows = np.nonzero(sub.any(axis=1))[0]
            if len(rows) == 0 or sub.sum() < piece_area / 2:
                continue
            sub = sub[rows[0] : rows[-1] + 1]
            box = np.array([x + c0, y + rows[0], x + c1, y + rows[-1] + 1])
            pending.append((class_name, source, -1, box, sub, False))

    owner = np.zeros((H, W), dtype=np.int32)
    objects: list[ImageObject] = []
    bottoms = np.full(len(pending) + 1, -1, dtype=np.int64)
    for idx, (_, _, _, box, crop, _) in enumerate(pending, start=1):
        x0, y0, x1, y1 = (int(b) for b in box)
        np.copyto(owner[y0:y1, x0:x1], idx, where=crop)
        bottoms[idx] = y1 - 1
    for idx, (class_name, source, iid, box, crop, thing) in enumerate(pending, start=1):
        x0, y0, x1, y1 = (int(b) for b in box)
        contact = _contact_from_mask(
            crop, x0, y0, labels, owner, idx, thing, classes.has(class_name, "trunk"), lookups, params
        )
        left_hidden, right_hidden = (
            hidden_sides(crop, x0, y0, owner, idx, bottoms, params.hidden_side_fraction) if thing else (False, False)
        )
        objects.append(
            ImageObject(
                class_name=class_name,
                source_label=source,
                instance_id=iid,
                box_px=np.asarray(box, dtype=np.int64),
                mask=crop,
                contact_px=contact.contact_px,
                bottom_truncated=contact.bottom_truncated,
                bottom_occluded=contact.bottom_occluded,
                top_truncated=y0 <= 0,
                standing_on=contact.standing_on,
                occluded_by=contact.occluder if contact.occluder else -1,
                ref=idx,
                left_truncated=x0 <= 0,
                right_truncated=x1 >= W,
                left_hidden=left_hidden,
                right_hidden=right_hidden,
            )
        )
    return sort_objects(objects)


def objects_from_segmentation(
    seg: Segmentation,
    view: StreetView | None,
    classes: ClassTable,
    lookups: LabelLookups,
    params: PerceptionParams = DEFAULT_PERCEPTION,
) -> list[ImageObject]:
    """Things from the instance map (or class components) and stuff from class masks:
    :func:`objects_from_regions` of :func:`segment_regions`.

    Args:
        seg: label ids (and instance ids) of one image.
        view: the photo's perspective; with it, runs of facades are cut into buildings
            (:mod:`usdworld.perception.facades`), else (or when a facade's base is not in
            view) into chunks of a fixed pixel aspect.
        classes: the class table; its roles say how each class's regions are cut and joined.
        lookups: the Cityscapes table's arrays (:func:`usdworld.io.label_table.label_lookups`).
        params: the perception thresholds.

    Returns:
        Objects sorted by (class, instance id, contact u).
    """
    return objects_from_regions(segment_regions(seg, classes, lookups, params), seg, view, classes, lookups, params)


def sort_objects(objects: list[ImageObject]) -> list[ImageObject]:
    """Canonical order: class, then instance id (stuff last), then contact u and v."""
    return sorted(
        objects,
        key=lambda o: (
            o.class_name,
            o.instance_id if o.instance_id >= 0 else 1 << 30,
            float(o.contact_px[0]),
            float(o.contact_px[1]),
        ),
    )


def border_sides(
    box_px: np.ndarray, width: int, height: int, truncated: float = 0.0
) -> tuple[bool, bool, bool, bool]:
    """Which sides of a detection box are cut by the image border.

    A side within one pixel of the border is cut (KITTI clips its boxes to
    ``[0, W - 1] x [0, H - 1]``). An object the input marks truncated (``truncated > 0``,
    KITTI's fraction outside the image) whose box touches no border still leaves the image:
    the side nearest the border is taken as cut.

    Args:
        box_px: (4,) float64 ``xmin, ymin, xmax, ymax`` in pixels.
        width: image width, pixels.
        height: image height, pixels.
        truncated: fraction of the object outside the image, [0, 1].

    Returns:
        (left, right, top, bottom) cut flags.
    """
    x0, y0, x1, y1 = (float(b) for b in box_px)
    gaps = np.array([x0, width - x1, y0, height - y1])
    cut = gaps <= 1.0
    if truncated > 0 and not cut.any():
        cut[int(np.argmin(gaps))] = True
    return bool(cut[0]), bool(cut[1]), bool(cut[2]), bool(cut[3])


def _bottom_occluders(
    boxes_px: np.ndarray, amodal: np.ndarray, block: int = 256
) -> tuple[np.ndarray, np.ndarray]:
    """What hides each box's bottom edge: the box lower in the image that covers most of it.

    Box ``j`` can hide box ``i``'s bottom row ``b`` when its bottom is more than a pixel
    lower (``ymax_j > b + 1``) and its top is above that row (``ymin_j < b``); it covers
    ``(min(xmax) - max(xmin)) / max(width_i, 1e-9)`` of the edge. The largest positive
    cover wins, the first box in input order among equals. Amodal boxes are hidden by
    nothing. Boxes are sorted by bottom so that each block of rows compares only with the
    boxes whose bottom is low enough, in numpy: O(n^2 / block) Python steps at worst,
    exactly the values of a pairwise loop in input order (the same IEEE operations).

    Args:
        boxes_px: (N, 4) float64 ``xmin, ymin, xmax, ymax``.
        amodal: (N,) bool, the box bounds the whole object.
        block: rows compared at once (memory ``block x N`` float64 per temporary).

    Returns:
        covered: (N,) float64 the largest cover (0 when nothing covers the edge).
        occluder: (N,) int64 row of ``boxes_px`` of the box giving it (-1 none).
    """
    n = len(boxes_px)
    covered = np.zeros(n)
    occluder = np.full(n, -1, dtype=np.int64)
    if n < 2:
        return covered, occluder
    x0, y0, x1, y1 = (np.ascontiguousarray(boxes_px[:, k]) for k in range(4))
    by_bottom = np.argsort(y1, kind="stable")
    sorted_bottoms = y1[by_bottom]
    rows = np.nonzero(~amodal)[0]
    rows = rows[np.argsort(y1[rows], kind="stable")]
    for start in range(0, len(rows), block):
        r = rows[start : start + block]
        b = y1[r]
        # Boxes whose bottom is below the block's highest bottom + 1: a superset of each row's candidates.
        cols = by_bottom[np.searchsorted(sorted_bottoms, b.min() + 1.0, side="right") :]
        if len(cols) == 0:
            continue
        # The loop's tests as written (``not (ymax_j <= b + 1)``, ``not (ymin_j >= b)``): the same with NaN.
        candidate = ~(y1[cols][None, :] <= (b + 1.0)[:, None]) & ~(y0[cols][None, :] >= b[:, None])
        candidate &= cols[None, :] != r[:, None]
        width = np.maximum(x1[r] - x0[r], 1e-9)
        with np.errstate(invalid="ignore"):
            cover = (
                np.minimum(x1[r][:, None], x1[cols][None, :]) - np.maximum(x0[r][:, None], x0[cols][None, :])
            ) / width[:, None]
        cover = np.where(candidate & (cover > 0.0), cover, -np.inf)
        best = cover.max(axis=1)
        first = np.where(cover == best[:, None], cols[None, :], n).min(axis=1)
        hit = best > 0.0
        covered[r[hit]] = best[hit]
        occluder[r[hit]] = first[hit]
    return covered, occluder


def objects_from_detections(
    detections: Detections,
    width: int,
    height: int,
    segmentation: Segmentation | None = None,
    *,
    lookups: LabelLookups,
    params: PerceptionParams = DEFAULT_PERCEPTION,
) -> list[ImageObject]:
    """Things from 2D detections (boxes, optionally masks).

    A box's contact is its bottom centre. Its bottom counts as occluded when another
    box whose bottom is lower (closer) covers at least ``params.occluded_fraction`` of its
    bottom edge, unless
    the box is amodal (drawn around the whole object, hidden parts included): then its
    bottom edge is the contact row whatever hides it.

    Args:
        detections: the detections; labels without a placed class are skipped.
        width: image width in pixels.
        height: image height in pixels.
        segmentation: optional labels, used to tell what each object stands on.
        lookups: the Cityscapes table's arrays (:func:`usdworld.io.label_table.label_lookups`).
        params: the perception thresholds.

    Returns:
        Objects sorted canonically; ``instance_id`` is the detection's index in the file.
    """
    from usdworld.perception.classes import placed_class_for_label  # detector label tables: boxes only

    items = []
    dropped: Counter[str] = Counter()
    for index, det in enumerate(detections.items):
        class_name = placed_class_for_label(det.label, lookups)
        if class_name is None:
            dropped[det.label] += 1
            continue
        x0, y0, x1, y1 = det.box_px
        box = np.array(
            [np.floor(x0), np.floor(y0), np.ceil(x1), np.ceil(y1)], dtype=np.float64
        ).clip([0, 0, 0, 0], [width, height, width, height]).astype(np.int64)
        if box[2] <= box[0] or box[3] <= box[1]:
            continue
        if det.mask is not None:
            crop = np.asarray(det.mask)[box[1] : box[3], box[0] : box[2]]
        else:
            crop = np.ones((box[3] - box[1], box[2] - box[0]), dtype=bool)
        items.append((index, det, class_name, np.asarray(det.box_px, dtype=np.float64), box, crop))
    if dropped:
        logger.warning(
            "%s: %d detections of classes usdworld does not place were dropped: %s",
            detections.file.name,
            sum(dropped.values()),
            ", ".join(f"{label} ({n})" for label, n in sorted(dropped.items())),
        )

    objects = []
    labels = np.asarray(segmentation.label_ids) if segmentation is not None else None
    covered, occluder_pos = _bottom_occluders(
        np.array([item[3] for item in items], dtype=np.float64).reshape(-1, 4),
        np.array([item[1].amodal for item in items], dtype=bool),
    )
    for k, (index, det, class_name, fbox, box, crop) in enumerate(items):
        bottom = float(fbox[3])
        occluders = float(covered[k])
        occluder = items[occluder_pos[k]][0] if occluder_pos[k] >= 0 else -1
        standing_on = ""
        if labels is not None:
            v = int(min(max(bottom, 0), height - 1))
            u = int(min(max((fbox[0] + fbox[2]) / 2, 0), width - 1))
            standing_on = str(lookups.names[labels[v, u]])
        cut = border_sides(fbox, width, height, det.truncated)
        objects.append(
            ImageObject(
                class_name=class_name,
                source_label=det.label,
                instance_id=index,
                box_px=box,
                mask=crop,
                contact_px=np.array([(fbox[0] + fbox[2]) / 2.0, bottom]),
                bottom_truncated=cut[3],
                bottom_occluded=occluders >= params.occluded_fraction,
                top_truncated=cut[2],
                left_truncated=cut[0],
                right_truncated=cut[1],
                standing_on=standing_on,
                score=float(det.score),
                occluded_by=occluder if occluders >= params.occluded_fraction else -1,
                ref=index,
                box_only=det.mask is None,
                # Clipped to the image as box_px is, so a cut side's edge is the border's.
                box_edges_px=np.clip(fbox, 0.0, [width, height, width, height]) if det.mask is None else None,
            )
        )
    return sort_objects(objects)
