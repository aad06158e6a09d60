"""How far a rig's ground departs from the plane under the car, measured from its objects (layout).

Every view of a rig knows its camera exactly (height, pitch and roll above the ground under
the car), so an object's ground contact gives its depth only as far as the object stands on
that plane. Beyond it the road rises and falls and sidewalks stand above it: a surface
``dz`` higher meets the contact's ray at ``d * (1 - dz / h)``, which is what
:attr:`~usdworld.parameters.placement.PlacementParams.ground_height_sigma_m` widens the
contact cue by. That spread is a property of the street, not of the camera, and the
objects measure it: the class-height cue places an object at ``d_h`` with no reference to
the ground, and the contact's ray passes ``dz = h * (1 - d_h / d_c)`` above the plane at
that depth (exact: height along a ray is affine in depth, ``h`` at the camera and 0 at
``d_c``). Each object with both cues is one measurement of the ground's height where it
stands, with the variance its cues' spreads carry; :func:`ground_height_spread` is the
maximum-likelihood standard deviation of the ground's height about the plane given them
(zero when the cues agree as well as their spreads say).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from usdworld.layout.placement import Placement


@dataclass(frozen=True)
class GroundHeights:
    """The ground's height where objects stand, measured from their depth cues.

    Attributes:
        dz_m: (N,) float64 each object's ground height above the camera's ground plane, metres.
        variance_m2: (N,) float64 the variance of each measurement from its cues' spreads, metres squared.
    """

    dz_m: np.ndarray
    variance_m2: np.ndarray


def contact_height_offset(
    contact_depth_m: float,
    contact_sigma_m: float,
    height_depth_m: float,
    height_sigma_m: float,
    camera_height_m: float,
) -> tuple[float, float]:
    """The ground's height under an object implied by its contact and class-height depths.

    Args:
        contact_depth_m: depth where the contact row's ray meets the camera's ground plane, metres (> 0).
        contact_sigma_m: its standard deviation (the row's pixel error), metres.
        height_depth_m: depth from the object's pixel height and its class's height, metres (> 0).
        height_sigma_m: its standard deviation, metres.
        camera_height_m: the camera's height above the ground plane, metres (> 0).

    Returns:
        (dz_m, variance_m2): the height above the plane at which the contact's ray passes
        the object's depth, metres, and its variance propagated from both cues.

    Example:
        >>> [round(v, 6) for v in contact_height_offset(60.0, 0.0, 40.0, 0.0, 1.5)]
        [0.5, 0.0]
    """
    h, dc, dh = camera_height_m, contact_depth_m, height_depth_m
    ratio = dh / dc
    dz = h * (1.0 - ratio)
    # d dz / d dh = -h / dc;  d dz / d dc = h dh / dc^2
    variance = (h / dc) ** 2 * (height_sigma_m**2 + (ratio * contact_sigma_m) ** 2)
    return dz, variance


def ground_heights(views: Iterable[tuple[Sequence[Placement], float]]) -> GroundHeights:
    """One ground-height measurement per placed object that has both a contact and a height cue.

    Args:
        views: each view's placements (its own single-view build) with its camera's height, metres.
    """
    dz: list[float] = []
    var: list[float] = []
    for placements, camera_height_m in views:
        for p in placements:
            cues = {c.name: c for c in p.cues if c.depth_m is not None and c.sigma_m is not None}
            if "contact" not in cues or "height" not in cues:
                continue
            contact, height = cues["contact"], cues["height"]
            d, v = contact_height_offset(
                float(contact.depth_m),  # type: ignore[arg-type]
                float(contact.sigma_m),  # type: ignore[arg-type]
                float(height.depth_m),  # type: ignore[arg-type]
                float(height.sigma_m),  # type: ignore[arg-type]
                camera_height_m,
            )
            dz.append(d)
            var.append(v)
    return GroundHeights(np.array(dz, dtype=np.float64), np.array(var, dtype=np.float64))


def ground_height_spread(heights: GroundHeights) -> float:
    """Maximum-likelihood standard deviation of the ground's height about the plane, metres.

    Each measurement is ``dz_i ~ N(0, s^2 + v_i)``; ``s`` maximises their joint likelihood.
    The likelihood's slope in ``s^2``, ``sum((dz_i^2 - s^2 - v_i) / (s^2 + v_i)^2)``, is
    positive at 0 when the measurements spread more than their variances say, and negative
    at the largest ``dz_i^2`` (every term is); a root between, a maximum, is found by
    bisection. No measurements, or a slope <= 0 at 0 (they agree within their variances): 0.

    Example:
        >>> round(ground_height_spread(GroundHeights(np.array([0.5, -0.5]), np.array([0.09, 0.09]))), 6)
        0.4
    """
    dz2, v = heights.dz_m**2, heights.variance_m2
    if dz2.size == 0:
        return 0.0

    def score(s2: float) -> float:
        w = 1.0 / (s2 + v)
        return float(np.sum((dz2 - s2 - v) * w * w))

    lo, hi = 0.0, float(dz2.max())
    if score(lo) <= 0.0:
        return 0.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if score(mid) > 0.0:
            lo = mid
        else:
            hi = mid
    return math.sqrt(0.5 * (lo + hi))
