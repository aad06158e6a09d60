"""Cut a region of merged tree crowns into trees, one per crown top or trunk.

Cityscapes labels give vegetation no instances: a row of street trees whose crowns
overlap in the image arrives as one region. Each crown rises to a top of its own (a
conifer's tip, a broad crown's dome), so the region's upper outline has one clear
summit per tree, with a dip where two crowns meet; the region is cut at the deepest dip
between neighbouring summits. A summit counts when it rises above the dips on both its
sides by ``crown_prominence_fraction`` (:class:`~usdworld.parameters.PerceptionParams`)
of the tree's height in its column, the
region's outline from top to bottom there (small bumps of one crown's outline do not;
a small far crown beside a big near one counts by its own height, not the big one's).

A tree further down the row may hide its top behind a nearer crown and still show its
trunk: the region's lower outline then reaches down to the ground once per trunk (a
foot). When there are more feet than summits, the region is cut between neighbouring
feet where the lower outline is highest, where two crowns meet above the ground. A
foot counts when it stands on the ground, or on a thing that hides the trunk below it
(behind a parked car a crown's lowest point is right above its trunk), and reaches down
below its neighbourhood by ``crown_foot_fraction`` of the tree's height there.

Traffic signs are cut the same way (the class table's ``topped`` role): two signs
one behind the other along the kerb run together in the image, each with its plate's
top and its own post down to the ground.

Everything here is in pixels.
"""

from __future__ import annotations

import itertools

import numpy as np

from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams
from usdworld.perception.peaks import local_maxima, prominences


def _summits(profile: np.ndarray, prominence: np.ndarray | float) -> np.ndarray:
    """Columns of the peaks of a profile that rise by ``prominence`` above their dips
    (an edge counts as a dip to zero, so a peak at the crop's side is one)."""
    padded = np.concatenate([[0.0], profile, [0.0]])
    peaks = local_maxima(padded)
    limit = np.broadcast_to(np.asarray(prominence, dtype=np.float64), profile.shape)
    return peaks[prominences(padded, peaks) >= limit[peaks - 1]] - 1


def _cut_at(profile: np.ndarray, peaks: np.ndarray, lowest: bool) -> list[int]:
    """Between each pair of neighbouring peaks, the middle column of the profile's extreme
    (its lowest value when ``lowest``, else its highest)."""
    cuts = []
    for a, b in itertools.pairwise(peaks):
        valley = profile[a : b + 1]
        target = valley.min() if lowest else valley.max()
        at = np.nonzero(valley == target)[0]
        cuts.append(int(a + at[len(at) // 2]))
    return cuts


def crown_ranges(
    mask: np.ndarray, on_ground: np.ndarray | None = None, params: PerceptionParams = DEFAULT_PERCEPTION
) -> list[tuple[int, int]]:
    """Column ranges ``[c0, c1)`` of a vegetation crop, one per crown top or trunk.

    Args:
        mask: (h, w) bool crop of the vegetation region.
        on_ground: (w,) bool, the pixel below each column's lowest pixel is ground or a
            thing standing on it; feet are looked for only there (default: no feet,
            summits alone).
        params: the prominence thresholds (``crown_prominence_fraction``,
            ``crown_prominence_px``, ``crown_foot_fraction``).

    Returns:
        Ranges covering every column of the crop, left to right (one range when the
        outline has a single summit and at most one foot; empty for an empty crop).

    Example:
        >>> m = np.zeros((10, 9), dtype=bool)
        >>> for c, top in enumerate([6, 3, 1, 3, 7, 3, 0, 3, 6]):
        ...     m[top:, c] = True
        >>> crown_ranges(m)
        [(0, 4), (4, 9)]
    """
    mask = np.asarray(mask, dtype=bool)
    cols = np.nonzero(mask.any(axis=0))[0]
    if len(cols) == 0:
        return []
    h, w = mask.shape
    # Upper and lower outlines as heights above the crop's bottom edge; empty columns
    # take their neighbours' (a gap is neither a summit nor a foot).
    top = np.interp(np.arange(w), cols, h - np.argmax(mask[:, cols], axis=0))
    bottom = np.interp(np.arange(w), cols, np.argmax(mask[::-1, cols], axis=0).astype(np.float64))
    summits = _summits(
        top, np.maximum(params.crown_prominence_px, params.crown_prominence_fraction * (top - bottom))
    )
    cuts = _cut_at(top, summits, lowest=True)
    if on_ground is not None:
        # Feet are the lower outline's lowest points: peaks of its depth below the top.
        depth_below = h - bottom
        local = np.maximum(params.crown_prominence_px, params.crown_foot_fraction * (top - bottom))
        feet = _summits(depth_below, local)
        feet = feet[np.asarray(on_ground, dtype=bool)[feet]]
        if len(feet) > max(len(summits), 1):
            cuts = _cut_at(bottom, feet, lowest=False)
    bounds = [0, *cuts, w]
    return [(a, b) for a, b in itertools.pairwise(bounds) if b > a]
