"""What an image box says about a box-shaped object: its turn and its sideways position.

A detector's box (or a KITTI label, the projection of a 3D box) of a car whose whole
outline is in view carries more than its bottom row: its aspect says how far the car is
turned from the line of sight, and its centre column where the car's centre is once
that turn is known. Both are found by projecting the class's 3D box with the camera.

Frames: world (Z up, metres, ground z = 0, camera above the origin); image pixels.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import ClassPrior
from usdworld.layout.heading import Heading, crossing_heading
from usdworld.layout.yaw import RoadAxis, facing, heading_for, line_from_view_angles, view_angle_from_box
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.objects import ImageObject


def box_corners(centre_xy: np.ndarray, yaw: float, size_lwh: np.ndarray) -> np.ndarray:
    """(8, 3) float64 world corners of an upright box standing on the ground (bottom four first)."""
    offsets, h = _foot_offsets(yaw, size_lwh)
    return _corners_at(np.asarray(centre_xy, dtype=np.float64), offsets, h)


def _foot_offsets(yaw: float, size_lwh: np.ndarray) -> tuple[np.ndarray, float]:
    """((4, 2) float64 footprint corners relative to the centre, turned by ``yaw``; the height)."""
    l, w, h = (float(v) for v in size_lwh)
    c, s = np.cos(yaw), np.sin(yaw)
    return _local_corners(l, w) @ np.array([[c, s], [-s, c]]), h


def _corners_at(centre_xy: np.ndarray, offsets: np.ndarray, h: float) -> np.ndarray:
    """(8, 3) float64 corners of the box whose footprint corners are ``centre_xy + offsets``."""
    foot = centre_xy + offsets
    corners = np.empty((8, 3))
    corners[:4, :2] = foot
    corners[4:, :2] = foot
    corners[:4, 2] = 0.0
    corners[4:, 2] = h
    return corners


def _local_corners(l: float, w: float) -> np.ndarray:
    """(4, 2) float64 footprint corners in the box's own frame, (+-l/2, +-w/2), x major."""
    return np.array([[-l / 2, -w / 2], [-l / 2, w / 2], [l / 2, -w / 2], [l / 2, w / 2]])


def box_corners_turned(centre_xy: np.ndarray, yaws: np.ndarray, size_lwh: np.ndarray) -> np.ndarray:
    """(K, 8, 3) float64 world corners of one box at K yaws, each stack bit for bit :func:`box_corners`.

    Args:
        centre_xy: (2,) float64 footprint centre, metres.
        yaws: (K,) float64 yaws, radians.
        size_lwh: (3,) float64 length, width and height, metres.
    """
    l, w, h = (float(v) for v in size_lwh)
    yaws = np.asarray(yaws, dtype=np.float64).reshape(-1)
    c, s = np.cos(yaws), np.sin(yaws)
    local = _local_corners(l, w)
    rot = np.empty((len(yaws), 2, 2))
    rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1] = c, s, -s, c
    foot = np.asarray(centre_xy, dtype=np.float64) + local @ rot  # (K, 4, 2): one 4x2 by 2x2 product per yaw
    corners = np.empty((len(yaws), 8, 3))
    corners[:, :4, :2] = foot
    corners[:, 4:, :2] = foot
    corners[:, :4, 2] = 0.0
    corners[:, 4:, 2] = h
    return corners


def box_aspect_usable(obj: ImageObject, prior: ClassPrior, image_width: int) -> bool:
    """True for a box-only road object (a vehicle) whose whole box is in view and unhidden."""
    if (
        not obj.box_only
        or prior.yaw != "road"
        or obj.bottom_occluded
        or obj.bottom_truncated
        or obj.top_truncated
    ):
        return False
    x0, y0, x1, y1 = (float(b) for b in obj.edges_px)
    return x0 > 0.5 and x1 < image_width - 0.5 and x1 > x0 and y1 > y0


def box_view_angle(obj: ImageObject, prior: ClassPrior, image_width: int) -> float | None:
    """Camera-free turn from the box's aspect (:func:`usdworld.layout.yaw.view_angle_from_box`),
    for when the camera is not known yet; None when the box is not usable."""
    if not box_aspect_usable(obj, prior, image_width):
        return None
    x0, y0, x1, y1 = (float(b) for b in obj.edges_px)
    return view_angle_from_box(x1 - x0, y1 - y0, prior.size_m)


def fit_view_angle(
    camera: PinholeCamera, ground: np.ndarray, size_lwh: np.ndarray, obj: ImageObject, params: PlacementParams
) -> float:
    """The turn from the line of sight whose projected box has the image box's aspect.

    Unlike the camera-free :func:`box_view_angle`, perspective is included: a near car's
    box is taller than ``f H / d`` (its near bottom edge is lower), which the flat
    formula reads as a narrower, less turned car. The aspect rises from end on to a peak
    near ``atan(L / W)`` and falls to side on; an aspect beyond the side-on one is
    ambiguous and gives the peak (:func:`fit_view_angles` gives both turns).

    Args:
        camera: the source camera.
        ground: (2,) footprint centre, metres.
        size_lwh: (3,) the class's length, width and height, metres.
        obj: the image evidence (a usable box: :func:`box_aspect_usable`).
        params: the turns tried (:attr:`~PlacementParams.view_angles_deg`).

    Returns:
        The angle in [0, pi/2] radians.
    """
    turns, peak = _fit_turns(camera, ground, size_lwh, obj, params)
    return turns[0] if len(turns) == 1 else peak


def fit_view_angles(
    camera: PinholeCamera, ground: np.ndarray, size_lwh: np.ndarray, obj: ImageObject, params: PlacementParams
) -> tuple[float, ...]:
    """Every turn from the line of sight whose projected box has the image box's aspect.

    The aspect rises from end on to a peak near ``atan(L / W)`` and falls to side on:
    an aspect between the side-on one and the peak is met twice, once on each slope
    (a car seen turned 50 degrees or 80 degrees can show the same box), and both turns
    are returned; one above the peak gives the peak, one below end on gives 0.

    Args:
        camera: the source camera.
        ground: (2,) footprint centre, metres.
        size_lwh: (3,) the class's length, width and height, metres.
        obj: the image evidence (a usable box: :func:`box_aspect_usable`).
        params: the turns tried (:attr:`~PlacementParams.view_angles_deg`).

    Returns:
        One or two angles in [0, pi/2] radians, the rising slope's first.
    """
    return _fit_turns(camera, ground, size_lwh, obj, params)[0]


def _fit_turns(
    camera: PinholeCamera, ground: np.ndarray, size_lwh: np.ndarray, obj: ImageObject, params: PlacementParams
) -> tuple[tuple[float, ...], float]:
    """(:func:`fit_view_angles`'s turns, the turn of the aspect's peak in radians)."""
    x0, y0, x1, y1 = (float(b) for b in obj.edges_px)
    observed = (x1 - x0) / (y1 - y0)
    angles_deg, curve = _aspect_curve(camera, ground, size_lwh, params.view_angle_step_deg)
    if curve is None:
        flat = float(view_angle_from_box(x1 - x0, y1 - y0, tuple(size_lwh)))
        return (flat,), flat
    peak = int(np.argmax(curve))
    peak_turn = float(np.radians(angles_deg[peak]))
    if observed <= curve[0]:
        return (0.0,), peak_turn
    if observed >= curve[peak]:
        return (peak_turn,), peak_turn
    rising = _reaches(angles_deg[: peak + 1], curve[: peak + 1], observed)
    if observed < curve[-1]:
        return (rising,), peak_turn
    return (rising, _reaches(angles_deg[peak:][::-1], curve[peak:][::-1], observed)), peak_turn


def _aspect_curve(
    camera: PinholeCamera, ground: np.ndarray, size_lwh: np.ndarray, step_deg: float
) -> tuple[np.ndarray, np.ndarray | None]:
    """((K,) turns tried in degrees, (K,) the projected box's aspect at each, or None when a
    turn projects off the image plane)."""
    bearing = float(np.arctan2(ground[1], ground[0]))
    angles_deg, angles = _turns(step_deg)
    return angles_deg, _aspect_at_yaws(camera, ground, bearing + angles, size_lwh)


def _reaches(angles_deg: np.ndarray, curve: np.ndarray, observed: float) -> float:
    """The turn, radians, where a rising ``curve`` (K,) over ``angles_deg`` (K,) reaches
    ``observed`` (linear between the turns tried; ``observed`` within the curve's range)."""
    k = int(np.searchsorted(curve, observed))
    k = min(max(k, 1), len(curve) - 1)
    a0, a1 = angles_deg[k - 1], angles_deg[k]
    t = (observed - curve[k - 1]) / max(curve[k] - curve[k - 1], 1e-12)
    return float(np.radians(a0 + min(max(t, 0.0), 1.0) * (a1 - a0)))


def _aspect_at_yaws(
    camera: PinholeCamera, ground: np.ndarray, yaws: np.ndarray, size_lwh: np.ndarray
) -> np.ndarray | None:
    """(K,) float64 width over height of the projected box at each yaw, or None when a turn
    projects a corner behind the camera or to a non-finite pixel, or a ratio is not finite.

    The values are bit for bit those of :meth:`PinholeCamera.project_stacked` on
    :func:`box_corners_turned` followed by ``np.ptp`` over the 8 corners (the same products
    in the same shapes, the same elementwise operations), with fewer numpy calls: the
    pixel is only divided out where every depth is in front of the camera (where
    :meth:`~PinholeCamera.project_stacked` would write NaN, the fit gives up either way).

    Args:
        camera: the source camera.
        ground: (2,) float64 footprint centre, metres.
        yaws: (K,) float64 yaws, radians.
        size_lwh: (3,) float64 length, width and height, metres.
    """
    corners = box_corners_turned(ground, yaws, np.asarray(size_lwh))
    p_cam = (corners - camera.center_world) @ camera.rotation_world_from_cam
    depth = p_cam[..., 2]
    if not (depth > 1e-9).all():
        return None
    uvw = p_cam @ camera.K.T
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        px = uvw[..., :2] / uvw[..., 2:3]
        if not np.isfinite(px).all():
            return None
        # The spans as np.ptp takes them, max - min over the 8 corners of each turn; corner-major
        # (8, K, 2) so that each reduction is 7 elementwise passes (max and min select, in any order).
        by_corner = np.ascontiguousarray(px.transpose(1, 0, 2))
        span = by_corner.max(axis=0) - by_corner.min(axis=0)
        curve = span[:, 0] / np.maximum(span[:, 1], 1e-9)
    return curve if np.isfinite(curve).all() else None


@functools.lru_cache(maxsize=8)
def _turns(step_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The turns tried by :func:`fit_view_angle` (:attr:`PlacementParams.view_angles_deg`),
    in degrees and in radians, made once per step (read-only (K,) float64 each)."""
    degrees = PlacementParams(view_angle_step_deg=step_deg).view_angles_deg
    radians = np.radians(degrees)
    degrees.setflags(write=False)
    radians.setflags(write=False)
    return degrees, radians


def align_box_columns(
    camera: PinholeCamera,
    ground: np.ndarray,
    yaw: float,
    size: np.ndarray,
    obj: ImageObject,
    params: PlacementParams,
    heading_known: bool = True,
) -> np.ndarray:
    """Shift an object sideways so that its projected 3D box spans the same columns as the image box.

    The box centre column is not the projection of the object's centre when the object
    is seen at an angle (its near side widens the box). A few fixed-point steps move the
    centre perpendicular to the viewing ray until the projected and observed box centres
    agree, by at most ``box_align_max_shift`` of the object's width.

    A box whose one side is hidden by a nearer object shows the object's own edge on the
    other side only: the object extends behind the nearer one, by what its size says. The
    projected box's edge on the seen side is aligned with the image box's edge there
    instead, moving the centre by at most half the footprint's diagonal (the seen part's ray
    passes through the footprint). Which corner makes that edge depends on the heading:
    without one (``heading_known`` False: a person turned to the camera for want of theirs)
    a hidden side is not taken as cut. Boxes hidden on both sides, and boxes cut by the
    left or right image border, are left alone (a border-cut box's contact row is not its
    nearest contact either, so its seen edge alone would move it across the ray while its
    depth stays off: :func:`place_border_cut` places such a box from its seen edge and its
    contact row together).

    Args:
        camera: the source camera.
        ground: (2,) float64 footprint centre.
        yaw: object yaw, radians.
        size: (3,) float64 length, width, height.
        obj: the image evidence.
        params: the alignment's steps and largest shift.
        heading_known: ``yaw`` is the object's heading, not a stand-in for it.

    Returns:
        (2,) float64 corrected footprint centre.
    """
    x0, _, x1, _ = (float(b) for b in obj.edges_px)
    if x0 <= 0.5 or x1 >= camera.width - 0.5:
        return ground
    left = obj.left_bounded or not heading_known
    right = obj.right_bounded or not heading_known
    if not (left or right):
        return ground
    start = np.asarray(ground, dtype=np.float64)
    cx, cy = float(start[0]), float(start[1])
    offsets, h = _foot_offsets(yaw, size)  # the turn is fixed: only the centre moves
    for _ in range(params.box_align_iterations):
        px, depth = camera.project(_corners_at(np.array([cx, cy]), offsets, h))
        if not np.isfinite(px).all():
            return ground
        u = px[:, 0]
        bearing = np.arctan2(cy, cx)
        lx, ly = -float(np.sin(bearing)), float(np.cos(bearing))
        if left and right:
            error_px = 0.5 * (x0 + x1) - 0.5 * (float(u.min()) + float(u.max()))
            # The step along ``left = (-sin, cos)``, each coordinate in plain floats with numpy's
            # elementwise order: centre - left * error * mean depth / fx.
            scale = float(np.mean(depth))
            cx, cy = cx - lx * error_px * scale / camera.fx, cy - ly * error_px * scale / camera.fx
            continue
        # One edge: the corner that makes it moves with the centre; a Newton step on its
        # column, whose rate per metre along ``left`` is its projection's.
        edge = int(np.argmin(u)) if left else int(np.argmax(u))
        error_px = (x0 if left else x1) - float(u[edge])
        corner = _corners_at(np.array([cx, cy]), offsets, h)[edge : edge + 1]
        moved, _ = camera.project(corner + np.array([[lx, ly, 0.0]]) * 1e-3)
        rate = (float(moved[0, 0]) - float(u[edge])) / 1e-3
        if not (np.isfinite(rate) and abs(rate) > 1e-9):
            return ground
        cx, cy = cx + lx * error_px / rate, cy + ly * error_px / rate
    centre = np.array([cx, cy])
    shift = centre - start
    if left and right:
        limit = params.box_align_max_shift * float(size[1])
    else:
        limit = 0.5 * float(np.hypot(size[0], size[1]))
    norm = float(np.linalg.norm(shift))
    return start + shift * (limit / norm) if norm > limit else centre


def place_border_cut(
    camera: PinholeCamera,
    ground: np.ndarray,
    yaw: float,
    size: np.ndarray,
    reach_lw: np.ndarray,
    obj: ImageObject,
    params: PlacementParams,
) -> np.ndarray:
    """The footprint centre of an object cut by the left or the right image border, from what is seen.

    Such an object's contact row is not its nearest contact (that lies beyond the border):
    it is the lowest row its footprint reaches over the columns inside the image, and its
    seen side's edge is its own. With its heading and size known, the two fix the centre:
    the projected 3D box's inner edge falls on the image box's edge there, and its contact
    footprint (``reach_lw``: a car's tyres), clipped to the image's columns, reaches down to
    the contact row. That row's lowest point lies on the footprint, somewhere between the
    seen columns: the centre lies within half the box's diagonal of the ground under that
    stretch of the row, which two nested
    bisections over that range (across the ray every corner's column moves one way; along it
    the footprint's rows rise as it recedes, scanned first for the nearest change of sign)
    solve for it. Without one (the seen edge or row is out of reach of a box of that size and
    heading), ``ground`` is kept.

    Args:
        camera: the source camera.
        ground: (2,) float64 footprint centre as drafted (on the contact's ray).
        yaw: the object's heading, radians (its real one, not a stand-in).
        size: (3,) float64 length, width and height, metres.
        reach_lw: (2,) float64 length and width of its contact footprint, metres.
        obj: the image evidence: cut on one side only, its other side and its bottom seen.
        params: the scan's and the bisections' steps.

    Returns:
        (2,) float64 footprint centre; ``ground`` when the object is not cut on one side
        only, or the seen edge and row cannot both be met.
    """
    x0, _, x1, _ = (float(b) for b in obj.edges_px)
    # Cut where the box reaches the border (KITTI clips its boxes to [0, W - 1]), not where the
    # input only marks the object truncated (its box's side is then its own).
    left_cut = obj.left_truncated and x0 <= 1.0
    right_cut = obj.right_truncated and x1 >= camera.width - 1.0
    if left_cut == right_cut or (left_cut and not obj.right_bounded) or (right_cut and not obj.left_bounded):
        return ground
    seen_u = x1 if left_cut else x0
    seen_v = float(obj.contact_px[1])
    offsets, h = _foot_offsets(yaw, size)
    rim = _foot_offsets(yaw, np.array([reach_lw[0], reach_lw[1], 0.0]))[0][[0, 1, 3, 2]]  # round the rim
    ends, _ = camera.ground_points(np.array([[x0, seen_v], [x1, seen_v]]))
    if not np.isfinite(ends).all():
        return ground
    origin = 0.5 * (ends[0] + ends[1])
    ray = origin - np.asarray(camera.center_world[:2], dtype=np.float64)
    along = ray / max(float(np.linalg.norm(ray)), 1e-9)
    left = np.array([-along[1], along[0]])
    reach = 0.5 * float(np.hypot(size[0], size[1]))
    span = reach + 0.5 * float(np.linalg.norm(ends[1] - ends[0]))

    def inner_minus_seen(c: np.ndarray) -> float:
        """The projected box's inner edge column minus the seen one (NaN: behind the camera)."""
        px, depth = camera.project(_corners_at(c, offsets, h))
        if not ((depth > 0).all() and np.isfinite(px).all()):
            return float("nan")
        return (float(px[:, 0].max()) if left_cut else float(px[:, 0].min())) - seen_u

    def across(s: float) -> np.ndarray | None:
        """The centre ``s`` metres along the ray whose inner edge meets the seen one (None: none)."""
        # Moving left lowers every column: the residual falls with ``q``.
        q = _bisect(lambda q: inner_minus_seen(origin + s * along + q * left), -span, span, params)
        return None if q is None else origin + s * along + q * left

    def row_minus_seen(s: float) -> float:
        c = across(s)
        if c is None:
            return float("nan")
        px, depth = camera.project(np.column_stack([c + rim, np.zeros(4)]))
        if not ((depth > 0).all() and np.isfinite(px).all()):
            return float("nan")
        return lowest_row_inside(px, float(camera.width)) - seen_v

    # Where the seen edge is out of reach (or no footprint is left inside the image) the row is
    # undefined: scan the range for the nearest pair of defined rows on either side of the seen one.
    steps = np.linspace(-span, span, params.border_cut_scan_steps + 1)
    rows = [row_minus_seen(float(t)) for t in steps]
    s = None
    for k in range(len(steps) - 1):
        if np.isfinite(rows[k]) and np.isfinite(rows[k + 1]) and rows[k] * rows[k + 1] <= 0:
            s = _bisect(row_minus_seen, float(steps[k]), float(steps[k + 1]), params)
            break
    centre = None if s is None else across(s)
    if centre is None or _to_segment(centre, ends[0], ends[1]) > reach:
        return ground
    return centre


def _to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from the point ``p`` to the segment from ``a`` to ``b`` ((2,) each), metres."""
    ab = b - a
    t = float(np.clip(np.dot(p - a, ab) / max(float(np.dot(ab, ab)), 1e-18), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab)))


def _bisect(f: Callable[[float], float], lo: float, hi: float, params: PlacementParams) -> float | None:
    """A root of ``f`` (a float function, NaN where undefined) between ``lo`` and ``hi``, by
    :attr:`~PlacementParams.border_cut_bisections` halvings; None without a change of sign."""
    f_lo, f_hi = f(lo), f(hi)
    if not (np.isfinite(f_lo) and np.isfinite(f_hi)) or f_lo * f_hi > 0:
        return None
    for _ in range(params.border_cut_bisections):
        mid = 0.5 * (lo + hi)
        f_mid = f(mid)
        if not np.isfinite(f_mid):
            return None
        if (f_mid > 0) == (f_lo > 0):
            lo, f_lo = mid, f_mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def lowest_row_inside(rim_px: np.ndarray, width: float) -> float:
    """The largest row of a convex polygon's image (``rim_px`` (N, 2), in order round it) over
    the columns ``0 <= u <= width``; NaN when none of it is inside.

    A ground polygon's image is a polygon (straight lines stay straight), so its lowest point
    inside the image is one of its corners there or where an edge crosses a border column.
    """
    rows = [float(p[1]) for p in rim_px if 0.0 <= p[0] <= width]
    n = len(rim_px)
    for i in range(n):
        a, b = rim_px[i], rim_px[(i + 1) % n]
        for x in (0.0, width):
            if (a[0] - x) * (b[0] - x) < 0:
                t = (x - a[0]) / (b[0] - a[0])
                rows.append(float(a[1] + t * (b[1] - a[1])))
    return max(rows) if rows else float("nan")


def object_yaw(
    prior: ClassPrior,
    point: np.ndarray,
    axis: RoadAxis,
    obj: ImageObject,
    camera: PinholeCamera,
    params: PlacementParams,
) -> tuple[float, str]:
    """(yaw in radians, source label) of :func:`object_heading`."""
    h = object_heading(prior, point, axis, obj, camera, params)
    return h.yaw, h.source


def object_heading(
    prior: ClassPrior,
    point: np.ndarray,
    axis: RoadAxis,
    obj: ImageObject,
    camera: PinholeCamera,
    params: PlacementParams,
) -> Heading:
    """The class's heading rule at ``point`` (:func:`usdworld.layout.yaw.heading_for`: the
    side of the road and the traffic direction), turned to match a whole box's aspect when
    there is one (:func:`fit_view_angles`).

    The aspect gives the turn from the line of sight, to either side and modulo 180
    degrees (front and back look alike in a box); of those lines the one nearest the road
    or across it is kept (:func:`usdworld.layout.yaw.line_from_view_angles`), and the
    side rule picks which way round: the road's side rule along it, the crossing road's
    (:func:`usdworld.layout.heading.crossing_heading`) across it.

    Args:
        prior: the object's class prior (its yaw mode and size).
        point: (2,) float64 ground point of the object.
        axis: the road axis and the traffic side.
        obj: the image evidence.
        camera: the source camera.
        params: the turns tried by the box fit and the lane width.

    Returns:
        The heading (source ``box_aspect_`` prefixed when the box turned it,
        ``box_aspect_<axis source>_crossing_traffic_<side>_near_side`` across the road; the
        side rule's confidence, which is about front versus back).
    """
    h = heading_for(prior.yaw, point, axis, params)
    if not box_aspect_usable(obj, prior, camera.width):
        return h
    turns = fit_view_angles(camera, point, prior.size_m, obj, params)
    bearing = float(np.arctan2(point[1], point[0]))
    line, across = line_from_view_angles(turns, bearing, axis.angle)
    if across:
        h = crossing_heading(axis.angle, axis.traffic)
        return Heading(facing(line, h.yaw), f"box_aspect_{axis.source}_{h.source}", h.confidence)
    return Heading(facing(line, h.yaw), f"box_aspect_{h.source}", h.confidence)
