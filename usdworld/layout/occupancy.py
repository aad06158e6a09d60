"""A coarse raster that shows, cheaply, how far around a spot the ground holds no free spot.

Collision resolution (:mod:`usdworld.layout.collision`) looks for the nearest spot where a
box overlaps none of the boxes already settled. In a pile of contradictory boxes (a
detector's raw output) most boxes find none, and proving that with the exact candidate
search costs milliseconds per box. :func:`blocked_radius` proves it in a fraction of that:
a spot (the box's centre) is blocked by a settled box when it lies inside that box grown
by the moving box's half extents and shrunk by the overlap tolerance, an open rectangle.
The disk is painted on a raster of square cells; a cell counts as blocked only when the
whole closed cell lies, with a safety margin, inside one such rectangle. Every spot nearer
than the nearest cell that is not blocked is blocked, and the caller need not test it.

The answer is one-sided: the radius is a proof, and a smaller one only means "search
exactly". So the raster's size changes how much is skipped, never a result.
"""

from __future__ import annotations

import functools
import math

import numpy as np

#: Cells along each side of the raster over the disk's square (the cell is 2 r / this).
CELLS = 128
#: Safety margin on every rectangle edge and on the radius, metres: covers the rounding of
#: the exact overlap test (``|x - ox| - w < -tol`` in float64) at coordinates below
#: :data:`MAX_COORD_M`, where an ulp is about 1e-10 m.
MARGIN_M = 1e-6
#: Smallest cell, metres: keeps a cell index's rounding (at most 1e-6 of a cell below
#: :data:`MAX_COORD_M`) far below one cell.
MIN_CELL_M = 1e-4
#: Beyond this magnitude (metres) the shortcut is not taken (the caller searches exactly).
MAX_COORD_M = 1e6


def blocked_radius(
    c0: np.ndarray,
    h: np.ndarray,
    radius: float,
    centers: np.ndarray,
    half: np.ndarray,
    tol: float,
) -> float:
    """A radius within which every spot overlaps one of the boxes (a proof), at most ``radius``.

    A box of half extents ``h`` centred on a spot ``p`` overlaps box ``m`` when
    ``|p - centers[m]| - (h + half[m]) < -tol`` on both axes (as
    :meth:`usdworld.layout.collision._Settled.clear` tests it). Every spot whose distance
    to ``c0``, computed in float64, is at most the returned radius overlaps a box.

    Args:
        c0: (2,) float64 centre of the disk, metres.
        h: (2,) float64 half extents of the moving box, metres.
        radius: the largest radius of interest, metres (>= 0).
        centers: (M, 2) float64 centres of the settled boxes (at least all those that reach
            within ``radius`` of ``c0``).
        half: (M, 2) float64 their half extents.
        tol: allowed overlap, metres.

    Returns:
        ``radius`` when the whole disk is blocked; less (negative when not even ``c0`` is
        shown blocked, or when the coordinates are too large to rasterise safely) otherwise.
    """
    nothing = -math.inf
    if len(centers) == 0 or not (math.isfinite(radius) and radius >= 0.0):
        return nothing
    reach = abs(float(c0[0])) + abs(float(c0[1])) + radius + float(h[0]) + float(h[1])
    if not (math.isfinite(reach) and reach < MAX_COORD_M) or not np.all(np.abs(centers) + half < MAX_COORD_M):
        return nothing
    r = radius + MARGIN_M  # a spot the exact search finds within the radius may lie past it by rounding
    near = np.all(np.abs(centers - c0) < half + h + r, axis=1)  # the others cannot reach the disk
    centers, half = centers[near], half[near]
    cell = max(2.0 * r / CELLS, MIN_CELL_M)
    n = max(1, math.ceil(2.0 * r / cell))
    origin = np.asarray(c0, dtype=np.float64) - r  # the raster covers [c0 - r, c0 - r + n cell] on each axis
    # The open rectangle of blocked spots of each box, shrunk by the margin.
    w = h[None, :] + half - tol - MARGIN_M
    lo, hi = centers - w, centers + w
    # Cells [origin + i cell, origin + (i + 1) cell] with lo < origin + i cell and origin + (i + 1) cell < hi.
    first = np.floor((lo - origin) / cell).astype(np.int64) + 1
    last = np.ceil((hi - origin) / cell).astype(np.int64) - 2
    first, last = np.clip(first, 0, n), np.clip(last, -1, n - 1)
    ok = np.all((w > 0.0) & (first <= last), axis=1)
    if not ok.any():
        return nothing
    first, last = first[ok], last[ok] + 1
    # Each box adds one to a rectangle of a difference array; its two sums count the boxes
    # covering each cell.
    side = n + 1
    up = np.concatenate([first[:, 0] * side + first[:, 1], last[:, 0] * side + last[:, 1]])
    down = np.concatenate([first[:, 0] * side + last[:, 1], last[:, 0] * side + first[:, 1]])
    diff = (np.bincount(up, minlength=side * side) - np.bincount(down, minlength=side * side)).reshape(side, side)
    free = np.cumsum(np.cumsum(diff, axis=0), axis=1)[:n, :n] == 0
    nearest, within = _cell_distances(r, cell, n)
    free &= within
    if not free.any():
        return radius
    return min(float(nearest[free].min()) - MARGIN_M, radius)


@functools.lru_cache(maxsize=64)
def _cell_distances(r: float, cell: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Each raster cell's nearest point to the disk's centre: ((n, n) float64 distances, metres,
    and (n, n) bool which are within ``r``), read-only; a spot within the disk lies in a cell
    no further than it. The searches' radii repeat (rings double up to a bound), so few are made."""
    edges = np.arange(n + 1, dtype=np.float64) * cell  # from the origin, the same on both axes
    gap = np.maximum(np.maximum(edges[:-1] - r, r - edges[1:]), 0.0)
    nearest = np.sqrt(gap[:, None] ** 2 + gap[None, :] ** 2)
    within = nearest <= r
    nearest.setflags(write=False)
    within.setflags(write=False)
    return nearest, within
