"""A facade's frontage along its wall, seen between two image columns.

A facade's contact is the foot of its front wall, which faces the road: each image column
sees the ground along one line (its vertical plane's trace), which crosses the wall's
foot at one point. The columns of the facade's ends thus measure its frontage, and a
facade cut by one side of the image runs on out of view by as much as a building of its
size needs.

Frames: world ground (x forward, y left, metres); image pixels (u right, v down).
"""

from __future__ import annotations

import numpy as np

from usdworld.geometry.camera import PinholeCamera
from usdworld.perception.objects import ImageObject


def wall_positions(
    camera: PinholeCamera,
    v: float,
    front_ground: np.ndarray,
    yaw: float,
    columns: tuple[float, ...],
    trace_step_px: float,
) -> list[float] | None:
    """Where image columns meet a facade, metres along it from ``front_ground`` (None when
    a column's trace runs parallel to it).

    Args:
        camera: the source camera.
        v: image row at which each column's ground trace is taken (the facade's base), pixels.
        front_ground: (2,) float64 a point of the wall's foot.
        yaw: the way the wall's front faces, radians.
        columns: image columns, pixels.
        trace_step_px: rows between the two pixels whose ground points give a column's
            trace (``PlacementParams.wall_trace_step_px``).

    Returns:
        One signed position per column, metres along the wall (to its left when facing it).
    """
    along = np.array([-np.sin(yaw), np.cos(yaw)])
    out = []
    for u in columns:
        trace, _ = camera.ground_points(np.array([[u, v], [u, v + trace_step_px]]))
        d = trace[1] - trace[0]
        # front_ground + t * along = trace[0] + r * d
        m = np.column_stack([along, -d])
        if not np.all(np.isfinite(m)) or abs(np.linalg.det(m)) < 1e-9:
            return None
        t, _ = np.linalg.solve(m, trace[0] - front_ground)
        out.append(float(t))
    return out


def facade_frontage(
    camera: PinholeCamera, obj: ImageObject, front_ground: np.ndarray, yaw: float, trace_step_px: float
) -> float:
    """Metres of facade between an object's first and last columns (NaN when not measurable)."""
    ends = wall_positions(
        camera, float(obj.contact_px[1]), front_ground, yaw, (obj.box_px[0], obj.box_px[2]), trace_step_px
    )
    return float("nan") if ends is None else abs(ends[1] - ends[0])


def out_of_view_frontage(seen_m: float, frontage_range_m: tuple[float, float]) -> float:
    """The frontage to expect of a building that runs out of the image at one side, of
    which ``seen_m`` metres are in view.

    A long building is more likely than a short one to cover the column where the image
    ends (in proportion to its frontage), and its seen end lies anywhere along it (with
    density one over its frontage): the two cancel, so of the usual frontages
    (``frontage_range_m``, taken as uniform) every one at least ``seen_m`` long is equally
    likely. The middle of those; ``seen_m`` itself when it is longer than the usual ones.
    NaN stays NaN.

    Example:
        >>> out_of_view_frontage(5.0, (8.0, 25.0)), out_of_view_frontage(15.0, (8.0, 25.0))
        (16.5, 20.0)
        >>> out_of_view_frontage(30.0, (8.0, 25.0))
        30.0
    """
    lo, hi = frontage_range_m
    if not np.isfinite(seen_m) or seen_m >= hi:
        return float(seen_m)
    return 0.5 * (max(seen_m, lo) + hi)


def past_the_side(
    camera: PinholeCamera,
    obj: ImageObject,
    front_ground: np.ndarray,
    yaw: float,
    frontage: float,
    trace_step_px: float,
) -> float:
    """How far along its wall (metres) a facade cut by one side of the image moves so that
    its seen end stays put and the rest of its frontage runs on out of view (0 when
    neither or both sides are cut, or when what is seen is longer than ``frontage``).

    The seen part of such a facade is its far end: the building goes on beyond the edge,
    by as much as a building of its size needs.
    """
    x0, x1 = float(obj.box_px[0]), float(obj.box_px[2])
    cut_left, cut_right = x0 <= 0, x1 >= camera.width
    if cut_left == cut_right:
        return 0.0
    ends = wall_positions(camera, float(obj.contact_px[1]), front_ground, yaw, (x0, x1), trace_step_px)
    if ends is None:
        return 0.0
    seen_end, cut_end = (ends[1], ends[0]) if cut_left else (ends[0], ends[1])
    seen = abs(cut_end - seen_end)
    if seen >= frontage:
        return 0.0
    return float(seen_end + np.sign(cut_end - seen_end) * 0.5 * frontage)
