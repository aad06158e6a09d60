"""Object orientation on the ground: road direction, side of the road, facing the camera."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usdworld.layout.heading import Heading, along_road_heading, check_traffic, traffic_heading
from usdworld.parameters.placement import PlacementParams


#: What can give a road axis's centre line (:attr:`RoadAxis.center_source`).
CENTER_SOURCES = ("road_region", "vehicles", "camera")


@dataclass(frozen=True)
class RoadAxis:
    """The road's principal direction on the ground.

    Attributes:
        angle: direction of the road axis in radians (world yaw, in (-pi/2, pi/2]).
        center_ground: (2,) float64 a point on the road's centre line.
        source: how it was found (``vanishing_point``, ``road_pca`` or ``camera_forward``).
        traffic: the side traffic keeps to, ``right`` or ``left`` (``--traffic``).
        center_source: what gave ``center_ground``: ``road_region`` (the road pixels'
            median), ``vehicles`` (:func:`usdworld.layout.heading.vehicle_span_centre`)
            or ``camera`` (nothing: the camera's position).
    """

    angle: float
    center_ground: np.ndarray
    source: str
    traffic: str = "right"
    center_source: str = "camera"

    def __post_init__(self) -> None:
        check_traffic(self.traffic)
        if self.center_source not in CENTER_SOURCES:
            raise ValueError(
                f"RoadAxis.center_source must be one of {', '.join(CENTER_SOURCES)}, got {self.center_source!r}"
            )


def road_axis(
    road_points_ground: np.ndarray | None,
    vanishing_angle: float | None = None,
    params: PlacementParams = PlacementParams(),  # noqa: B008 (frozen)
    traffic: str = "right",
) -> RoadAxis:
    """The road's direction and a point on its centre line.

    The direction is the street's vanishing direction when one is given (the lines along
    the street meet there; exact for a straight street whatever part of it is in view),
    else the principal axis of the road region projected onto the ground (which a
    visible area lopsided about the road, e.g. more lanes on one side, tilts by a few
    degrees). The centre is the road points' median.

    Args:
        road_points_ground: (N, 2) float64 ground points of road pixels (within range), or None.
        vanishing_angle: world yaw of the street's vanishing direction, radians, or None.
        params: ``road_axis_min_points`` (fewer fall back to the camera's forward axis) and
            ``max_road_axis_angle_deg`` (an axis further from the camera's heading is a
            crossing, or a wrong estimate, not the street).
        traffic: the side traffic keeps to, ``right`` or ``left``.

    Returns:
        The axis; with nothing to go on, the camera forward axis through the origin.
    """
    enough = road_points_ground is not None and len(road_points_ground) >= params.road_axis_min_points
    max_angle = params.max_road_axis_angle
    center = np.median(np.asarray(road_points_ground, dtype=np.float64), axis=0) if enough else np.zeros(2)
    center_source = "road_region" if enough else "camera"
    if vanishing_angle is not None and abs(_wrap(vanishing_angle)) <= max_angle:
        return RoadAxis(_wrap(vanishing_angle), center, "vanishing_point", traffic, center_source)
    if not enough:
        return RoadAxis(0.0, np.zeros(2), "camera_forward", traffic)
    pts = np.asarray(road_points_ground, dtype=np.float64)
    centred = pts - pts.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    direction = vt[0]
    if direction[0] < 0:
        direction = -direction
    angle = float(np.arctan2(direction[1], direction[0]))
    # A street seen from a car runs away from the camera; an axis across the view
    # means the road region is a crossing, so keep the camera's heading instead.
    if abs(angle) > max_angle:
        return RoadAxis(0.0, center, "camera_forward", traffic, center_source)
    return RoadAxis(angle, center, "road_pca", traffic, center_source)


def choose_yaw(
    mode: str,
    position_ground: np.ndarray,
    axis: RoadAxis,
    params: PlacementParams = PlacementParams(),  # noqa: B008 (frozen)
) -> tuple[float, str]:
    """Yaw of one object and a word on how it was chosen (:func:`heading_for` without its confidence)."""
    h = heading_for(mode, position_ground, axis, params)
    return h.yaw, h.source


def heading_for(
    mode: str,
    position_ground: np.ndarray,
    axis: RoadAxis,
    params: PlacementParams = PlacementParams(),  # noqa: B008 (frozen)
) -> Heading:
    """Heading of one object by its class's yaw mode.

    Args:
        mode: the class prior's yaw mode: ``road`` (a vehicle: along the road, moving
            with the traffic of its side, :func:`usdworld.layout.heading.traffic_heading`),
            ``along_road`` (a person: along the road, either way,
            :func:`usdworld.layout.heading.along_road_heading`), ``face_road`` (the
            asset's forward axis across the road, towards its centre line: a building's
            front), ``camera`` (face the camera) or ``none`` (keep the asset axes).
        position_ground: (2,) float64 object position on the ground.
        axis: the road axis and the traffic side.
        params: ``lane_width_m`` (the camera's lane).

    Returns:
        The heading; its source is prefixed by the axis's source for the road modes
        (``vanishing_point_traffic_right_same_side``), and by ``vehicle_span_`` after it
        when the vehicles gave the road's centre line
        (``vanishing_point_vehicle_span_traffic_right_same_side``).
    """
    if mode == "camera":
        bearing = float(np.arctan2(position_ground[1], position_ground[0]))
        return Heading(_wrap(bearing + np.pi), "facing_camera", 1.0)
    if mode in ("road", "along_road"):
        rule = traffic_heading if mode == "road" else along_road_heading
        h = rule(position_ground, axis.angle, axis.center_ground, axis.traffic, params.lane_width_m)
        span = "vehicle_span_" if axis.center_source == "vehicles" else ""
        return Heading(h.yaw, f"{axis.source}_{span}{h.source}", h.confidence)
    if mode == "face_road":
        d = np.array([np.cos(axis.angle), np.sin(axis.angle)])
        rel = np.asarray(position_ground, dtype=np.float64) - axis.center_ground
        left = d[0] * rel[1] - d[1] * rel[0] > 0
        return Heading(_wrap(axis.angle + (-np.pi / 2 if left else np.pi / 2)), f"{axis.source}_facing_road", 1.0)
    return Heading(0.0, "none", 1.0)


def view_angle_from_box(box_w_px: float, box_h_px: float, size_lwh: tuple[float, float, float]) -> float:
    """How far a box-shaped object is turned from the viewing ray, from its image box's aspect.

    An upright box of length ``L``, width ``W`` and height ``H`` turned by ``a`` from the
    line of sight shows ``W cos a + L sin a`` metres across for ``H`` metres up, so the
    image box's aspect gives ``a`` (perspective ignored). That width rises from ``W``
    (seen end on) to ``sqrt(W^2 + L^2)`` at ``atan(L / W)`` and falls back to ``L`` (side
    on): an aspect wider than ``L / H`` has two answers, and the angle between them,
    ``atan(L / W)``, is returned.

    Args:
        box_w_px: image box width, pixels (> 0).
        box_h_px: image box height, pixels (> 0).
        size_lwh: the class's typical length, width and height, metres.

    Returns:
        The angle in [0, pi/2] radians (0: seen end on, pi/2: side on).

    Example:
        >>> round(float(np.degrees(view_angle_from_box(100.0, 100.0, (4.0, 1.5, 1.5)))), 1)
        0.0
        >>> round(float(np.degrees(view_angle_from_box(200.0, 100.0, (4.0, 1.5, 1.5)))), 1)
        24.1
    """
    length, width, height = (float(x) for x in size_lwh)
    across = box_w_px / box_h_px * height
    peak = float(np.arctan2(length, width))
    if across >= length:
        return peak
    radius = float(np.hypot(length, width))
    return float(np.clip(peak - np.arccos(np.clip(across / radius, -1.0, 1.0)), 0.0, np.pi / 2))


def line_from_view_angles(
    view_angles: tuple[float, ...], bearing: float, axis_angle: float
) -> tuple[float, bool]:
    """The line (yaw modulo pi) a box's turns allow that lies nearest the road or across it.

    A box's aspect gives the turn from the line of sight, to either side (``bearing +-
    angle``), and near the aspect's peak two turns (:func:`usdworld.layout.boxes.fit_view_angles`).
    Vehicles move along the road or, at a crossing, across it, and streets meet at about
    right angles: of the candidate lines the one nearest the road axis or its
    perpendicular is kept; on a tie, along the road.

    Args:
        view_angles: one or more turns in [0, pi/2] radians.
        bearing: world yaw of the line of sight to the object, radians.
        axis_angle: the road axis's yaw, radians.

    Returns:
        (the line's yaw in radians, wrapped to (-pi, pi], which way along it not decided;
        whether it is across the road: nearer the axis's perpendicular than the axis).

    Example:
        >>> line, across = line_from_view_angles((np.radians(68.0),), np.radians(-25.0), 0.0)
        >>> round(float(np.degrees(line)), 1), across
        (-93.0, True)
    """
    best: tuple[float, bool, float] | None = None
    for angle in view_angles:
        for candidate in (bearing + angle, bearing - angle):
            off = abs(_wrap(2.0 * (candidate - axis_angle))) / 2.0  # from the axis, modulo pi: [0, pi/2]
            across = off > 0.25 * np.pi
            gap = 0.5 * np.pi - off if across else off
            if best is None or (gap, across) < (best[0], best[1]):
                best = (gap, across, candidate)
    assert best is not None
    return _wrap(best[2]), best[1]


def facing(line: float, towards: float) -> float:
    """``line`` or ``line + pi``, whichever is nearer the yaw ``towards`` (radians, wrapped)."""
    return _wrap(line) if abs(_wrap(line - towards)) <= 0.5 * np.pi else _wrap(line + np.pi)


def _wrap(angle: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    a = (angle + np.pi) % (2 * np.pi) - np.pi
    return float(np.pi if a == -np.pi else a)
