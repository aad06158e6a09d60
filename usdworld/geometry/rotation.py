"""Turning ground offsets about the vertical axis: one rotation that the build and the editor share.

An asset's footprint or contact is offset from its origin in the asset's frame; turned by the
object's yaw (radians, counter-clockwise about +Z seen from above) it is the offset in the
world. The module imports numpy only, so the editor can use it without the build's layout.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def turned(offset: Sequence[float] | np.ndarray, yaw: float) -> np.ndarray:
    """(2,) float64 an asset-frame ground offset turned by ``yaw`` (radians) into the world.

    Args:
        offset: (2,) float64 (x, y) in the asset's frame, metres.
        yaw: rotation about +Z, radians.

    Example::

        turned((1.0, 0.0), math.pi / 2)  # array([6.1e-17, 1.0])
    """
    c, s = math.cos(yaw), math.sin(yaw)
    ox, oy = (float(x) for x in offset)
    return np.array([c * ox - s * oy, s * ox + c * oy])
