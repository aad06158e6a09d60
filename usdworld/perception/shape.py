"""A scale-free description of the top of a silhouette, to tell asset variants apart.

``top_shape_ratio`` is the number of rows from a silhouette's top down to the first row
at least half as wide as its widest row, divided by that widest width. A cone (a
conifer) widens steadily, so the ratio is large (about 1 for the library's conifer) and
stays so when its lower part is hidden; a round crown or a lamp arm is wide right under
its top (a ratio near 0). The same number is computed for an image mask and for an
asset's side view (:func:`usdworld.authoring.asset_library.top_shape_ratio`).

A mask whose widest row is one or two pixels has no top shape: every row of it is at least
half as wide as that (one pixel), so the ratio would be ``0.5 / widest`` whatever the object,
near a street lamp's (a distant plain pole would vote for the lamp's arm). It has none.

Frames: mask rows run downwards (image v).
"""

from __future__ import annotations

import numpy as np


def top_shape_ratio(mask: np.ndarray) -> float | None:
    """Rows from the top to the first half-widest row, over the widest row's width.

    Args:
        mask: (H, W) bool silhouette (any crop containing it).

    Returns:
        The ratio (>= 0), or None for an empty mask or one whose widest row is at most
        2 pixels (every row is then at least half as wide: no shape to read).

    Example:
        >>> cone = np.array([[abs(c - 10) <= r // 2 for c in range(21)] for r in range(20)])
        >>> round(top_shape_ratio(cone), 2)
        0.55
    """
    m = np.asarray(mask, dtype=bool)
    rows = np.nonzero(m.any(axis=1))[0]
    if not len(rows):
        return None
    m = m[rows[0] : rows[-1] + 1]
    filled = m.any(axis=1)
    first = np.where(filled, np.argmax(m, axis=1), 0)
    last = np.where(filled, m.shape[1] - 1 - np.argmax(m[:, ::-1], axis=1), -1)
    widths = last - first + 1
    widest = int(widths.max())
    if widest <= 2:
        return None
    half = int(np.argmax(widths >= 0.5 * widest))
    return (half + 0.5) / widest
