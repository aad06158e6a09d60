"""Cut a region of merged tree crowns into trees, one per crown top.

Cityscapes labels give vegetation no instances: a row of street trees whose crowns
overlap in the image arrives as one region. Each crown rises to a top of its own (a
conifer's tip, a broad crown's dome), so the region's upper outline has one clear
summit per tree, with a dip where two crowns meet. The region is cut at the deepest
dip between neighbouring summits; a summit counts when it rises above the dips on both
its sides by :data:`MIN_PROMINENCE_FRACTION` of the region's height (small bumps of one
crown's outline do not).

Everything here is in pixels.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import find_peaks

#: A crown top must rise above its neighbouring dips by this fraction of the region's height.
MIN_PROMINENCE_FRACTION = 0.1
#: ... and by at least this many pixels.
MIN_PROMINENCE_PX = 4.0


def crown_ranges(mask: np.ndarray) -> list[tuple[int, int]]:
    """Column ranges ``[c0, c1)`` of a vegetation crop, one per crown top.

    Args:
        mask: (h, w) bool crop of the vegetation region.

    Returns:
        Ranges covering every column of the crop, left to right (one range when the
        outline has a single summit; empty for an empty crop).

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
    w = mask.shape[1]
    rows = np.nonzero(mask.any(axis=1))[0]
    height = float(rows[-1] - rows[0] + 1)
    # Upper outline, as a height above the crop's bottom; empty columns take their
    # neighbours' (a gap is not a summit).
    top = np.full(w, np.nan)
    top[cols] = mask.shape[0] - np.argmax(mask[:, cols], axis=0)
    top = np.interp(np.arange(w), cols, top[cols])
    prominence = max(MIN_PROMINENCE_PX, MIN_PROMINENCE_FRACTION * height)
    # Pad with zero height so that a summit at the crop's edge is seen as one.
    peaks, _ = find_peaks(np.concatenate([[0.0], top, [0.0]]), prominence=prominence)
    peaks = peaks - 1
    if len(peaks) < 2:
        return [(0, w)]
    cuts = []
    for a, b in zip(peaks[:-1], peaks[1:]):
        valley = top[a : b + 1]
        low = np.nonzero(valley == valley.min())[0]
        cuts.append(int(a + low[len(low) // 2]))
    bounds = [0, *cuts, w]
    return [(bounds[i], bounds[i + 1]) for i in range(len(bounds) - 1) if bounds[i + 1] > bounds[i]]
