"""Cut a run of touching facades into building-sized pieces, allowing for perspective.

Cityscapes labels give buildings no instances: a street's facades arrive as one region.
It is cut where the roofline steps (neighbouring buildings rarely share a height) and
then into pieces of about ``roofline_frontage_m`` of frontage each where the roofline
is seen, ``frontage_m`` where the image's top cuts it off (near the camera, where
nothing tells one building from the next).

Frontage is foreshortened: a facade running along the street towards its vanishing point
is squeezed more the nearer it gets to that point, so a fixed pixel width would hold one
building near the camera and ten far down the street. The facade's base line tells how
much ground each column spans: a ground point seen at row ``v`` below the horizon row
``v_h`` lies ``Z = f * h_cam / (v - v_h)`` ahead and ``X = (u - c_x) * Z / f`` aside (a
level camera of height ``h_cam``; a pitch of a few degrees changes this little), and the
frontage is the length of the base line on the ground. Where parked cars or people hide
the base, it is taken from the columns that stand on the ground: a wall's base is a
straight line in the image and, for a wall along the street, one through the street's
vanishing point, so one column on the ground measures the whole wall down to the
horizon. A facade's height does not enter, so a facade cut by the top of the image is
measured as well as one seen whole.

Everything here is in pixels plus the camera height; :class:`StreetView` carries what the
photo's perspective needs (no camera pose). The thresholds are fields of
:class:`~usdworld.parameters.PerceptionParams`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams


@dataclass(frozen=True)
class StreetView:
    """What perspective a street photo has, in pixels, and the camera height.

    Attributes:
        horizon_v: row of the horizon (the street's vanishing point's row, or where a given
            camera pitch puts it; roll taken as level).
        focal_px: focal length, pixels.
        principal_u: column of the principal point.
        camera_height_m: the camera's height above the ground the facades stand on (given,
            or a typical one).
        vanishing_u: column of the street's vanishing point (on the horizon), when the
            photo's lines give one: walls along the street have their base lines through
            it. None: each base line is fitted freely.
    """

    horizon_v: float
    focal_px: float
    principal_u: float
    camera_height_m: float
    vanishing_u: float | None = None


def fill_through_occluders(mask: np.ndarray, occluders: np.ndarray) -> np.ndarray:
    """A facade region with what stands in front of it filled in, row by row.

    A tree, a pole or a car in front of a facade splits its label region into pieces that
    are one wall: each row's run of occluder pixels with facade pixels right on both its
    sides is taken to hide facade. Runs that reach the sky, the road or the image border
    on either side stay open, so facades on the two sides of a street never join.

    Args:
        mask: (H, W) bool facade pixels.
        occluders: (H, W) bool pixels of objects that may stand in front of a facade.

    Returns:
        (H, W) bool: ``mask`` plus the occluder runs it encloses.

    Example:
        >>> m = np.array([[1, 0, 0, 1, 0, 0]], dtype=bool)
        >>> o = np.array([[0, 1, 1, 0, 1, 1]], dtype=bool)
        >>> fill_through_occluders(m, o).astype(int).tolist()
        [[1, 1, 1, 1, 0, 0]]
    """
    mask = np.asarray(mask, dtype=bool)
    h, w = mask.shape
    # Rows laid end to end, each padded by a pixel that is neither facade nor occluder,
    # so that a run of occluders never continues into the next row.
    occ = np.zeros((h, w + 2), dtype=bool)
    np.logical_and(occluders, ~mask, out=occ[:, 1:-1])
    wall = np.zeros((h, w + 2), dtype=bool)
    wall[:, 1:-1] = mask
    occ_flat, wall_flat = occ.ravel(), wall.ravel()
    edges = np.flatnonzero(occ_flat[1:] != occ_flat[:-1]) + 1
    rising = occ_flat[edges]
    starts = edges[rising]  # first pixel of each run of occluders
    ends = edges[~rising]  # first pixel after it
    enclosed = wall_flat[starts - 1] & wall_flat[ends]
    starts, ends = starts[enclosed], ends[enclosed]
    if len(starts):
        # The enclosed runs' pixels, run after run: each run's start plus 0, 1, ... its length - 1.
        lengths = ends - starts
        offsets = np.repeat(starts - (np.cumsum(lengths) - lengths), lengths)
        wall_flat[offsets + np.arange(len(offsets))] = True
    return np.ascontiguousarray(wall[:, 1:-1])


def _roofline_cuts(tops: np.ndarray, heights: np.ndarray, params: PerceptionParams) -> list[int]:
    """Indices ``i`` (into the occupied columns) where a new building starts: the roofline
    steps by more than ``roof_step_fraction`` of the lower column (and ``roof_step_min_px``)."""
    step = np.abs(np.diff(tops))
    lower = np.minimum(heights[:-1], heights[1:])
    limit = np.maximum(params.roof_step_min_px, params.roof_step_fraction * lower)
    return [int(i) + 1 for i in np.nonzero(step > limit)[0]]


def _base_line(u: np.ndarray, v: np.ndarray, view: StreetView) -> tuple[float, float] | None:
    """Least-squares line ``v = slope * u + intercept`` through base points.

    With the street's vanishing point known, the line passes through it (a wall along the
    street) and one base point fixes it; otherwise the points must span >= 3 columns.
    """
    if view.vanishing_u is not None:
        du, dv = u - view.vanishing_u, v - view.horizon_v
        norm = float(du @ du)
        if len(u) == 0 or norm == 0.0:
            return None
        slope = float(du @ dv) / norm
        return slope, view.horizon_v - slope * view.vanishing_u
    if len(u) < 2 or np.ptp(u) < 3:
        return None
    slope, intercept = np.polyfit(u, v, 1)
    return float(slope), float(intercept)


def base_frontage_m(
    u: np.ndarray, v_base: np.ndarray, view: StreetView, params: PerceptionParams = DEFAULT_PERCEPTION
) -> np.ndarray:
    """Ground length of the base line between neighbouring columns, metres.

    Args:
        u: (k,) float64 column centres, increasing.
        v_base: (k,) float64 row of the base (ground contact edge) in each column.
        view: the photo's perspective.
        params: base points closer to the horizon than ``params.min_below_horizon_px`` are
            too far to measure.

    Returns:
        (k,) float64: the length from each column to the next (the last column repeats
        its neighbour's); inf where a base point is at or above the horizon.
    """
    below = v_base - view.horizon_v
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(below >= params.min_below_horizon_px, view.focal_px * view.camera_height_m / below, np.inf)
        x = (u - view.principal_u) * z / view.focal_px
        step = np.hypot(np.diff(x), np.diff(z))
    step = np.where(np.isfinite(step), step, np.inf)
    return np.concatenate([step, step[-1:]]) if len(step) else np.zeros(len(u))


def _cut_lengths(
    total: float, max_pieces: int, cut_left: bool, cut_right: bool, frontage: float, min_piece_m: float
) -> np.ndarray:
    """Where to cut one building's run of facade: metres of frontage from its left end.

    A run seen whole is cut into equal pieces of about ``frontage``. A run that goes on
    out of the image at one side is seen from its far end, which is a building's end: it
    is cut every ``frontage`` from that end, and what is left at the image's edge
    is the seen part of one more building (no piece shorter than ``min_piece_m``).
    At most ``max_pieces`` pieces; equal pieces when that is fewer.

    Example:
        >>> _cut_lengths(30.0, 10, False, False, 12.0, 3.0).round(1).tolist()
        [15.0]
        >>> _cut_lengths(30.0, 10, True, False, 12.0, 3.0).round(1).tolist()
        [6.0, 18.0]
    """
    n = max(1, min(round(total / frontage), max_pieces))
    if cut_left != cut_right:
        from_end = frontage * np.arange(1, int(np.ceil(total / frontage)))
        from_end = from_end[total - from_end >= min_piece_m]
        if 0 < len(from_end) < max_pieces:
            return np.sort(total - from_end) if cut_left else from_end
    return total * np.arange(1, n) / n


def facade_ranges(
    mask: np.ndarray,
    x0: int,
    y0: int,
    on_ground: np.ndarray,
    view: StreetView,
    min_area_px: float,
    roof_mask: np.ndarray | None = None,
    image_width: int | None = None,
    params: PerceptionParams = DEFAULT_PERCEPTION,
) -> list[tuple[int, int]] | None:
    """Column ranges ``[c0, c1)`` of a facade crop, one per building-sized piece.

    Args:
        mask: (h, w) bool crop of the facade region.
        x0, y0: the crop's top-left pixel in the image.
        on_ground: (w,) bool, the pixel below the column's lowest facade pixel is ground.
        view: the photo's perspective.
        min_area_px: pieces are no smaller than this many pixels on average.
        roof_mask: (h, w) bool crop of the region with what stands in front of it filled
            in (:func:`fill_through_occluders`), whose top is the roofline; default ``mask``.
        image_width: the image's width; with it, a building running out of the image at
            one side is cut from its seen end (:func:`_cut_lengths`).
        params: the facade thresholds (frontages, roofline step, shortest piece).

    Returns:
        Ranges covering every column of the crop, left to right; None when the base is
        not measurable (no column on the ground below the horizon, or fewer than two
        without the vanishing point).
    """
    cols = np.nonzero(mask.any(axis=0))[0]
    if len(cols) == 0:
        return []
    h = mask.shape[0]
    roof = mask if roof_mask is None else np.asarray(roof_mask, dtype=bool) | mask
    tops = np.argmax(roof[:, cols], axis=0)
    bottoms = h - 1 - np.argmax(mask[::-1, cols], axis=0)
    heights = (bottoms - tops + 1).astype(np.float64)
    u = x0 + cols + 0.5
    v_edge = y0 + bottoms + 1.0
    ground = np.asarray(on_ground, dtype=bool)[cols] & (v_edge - view.horizon_v >= params.min_below_horizon_px)
    if ground.sum() < (1 if view.vanishing_u is not None else 2):
        return None
    # Each building's base is a straight line in the image (through the street's
    # vanishing point when it is known): fitted to its columns on the ground (pixel rows
    # are too coarse to measure depth column by column), or to the whole run's when too
    # few of its own are on the ground (parked cars hide them).
    starts = [0, *_roofline_cuts(tops, heights, params), len(cols)]
    run_line = _base_line(u[ground], v_edge[ground], view)
    v_base = np.empty_like(u)
    for a, b in itertools.pairwise(starts):
        line = _base_line(u[a:b][ground[a:b]], v_edge[a:b][ground[a:b]], view) or run_line
        if line is None:
            v_base[a:b] = np.interp(u[a:b], u[ground], v_edge[ground])
        else:
            v_base[a:b] = line[0] * u[a:b] + line[1]
    length = base_frontage_m(u, v_base, view, params)
    # Beyond the measurable range the pieces' lengths are not known: one piece there.
    length = np.where(np.isfinite(length), length, 0.0)

    buildings: list[tuple[int, int]] = []
    for a, b in itertools.pairwise(starts):
        if buildings and (
            length[a:b].sum() < params.min_piece_m or length[buildings[-1][0] : a].sum() < params.min_piece_m
        ):
            buildings[-1] = (buildings[-1][0], b)
        else:
            buildings.append((a, b))

    ranges: list[tuple[int, int]] = []
    for k, (a, b) in enumerate(buildings):
        cut_left = k == 0 and x0 + int(cols[a]) <= 0
        cut_right = (
            k == len(buildings) - 1 and image_width is not None and x0 + int(cols[b - 1]) + 1 >= image_width
        )
        w = length[a:b]
        max_pieces = max(1, int(heights[a:b].sum() // max(min_area_px, 1.0)))
        roof_seen = np.mean(y0 + tops[a:b] > 0) > 0.5
        frontage = params.roofline_frontage_m if roof_seen else params.frontage_m
        edges = _cut_lengths(float(w.sum()), max_pieces, cut_left, cut_right, frontage, params.min_piece_m)
        cuts = np.searchsorted(np.cumsum(w), edges)
        bounds = sorted({a, *(a + int(e) + 1 for e in cuts), b})
        ranges.extend((int(cols[s]), int(cols[e - 1]) + 1) for s, e in itertools.pairwise(bounds) if e > s)
    # Cover the crop's columns without gaps (empty columns go to the piece on their left).
    return [
        (0 if k == 0 else ranges[k][0], mask.shape[1] if k == len(ranges) - 1 else ranges[k + 1][0])
        for k in range(len(ranges))
    ]
