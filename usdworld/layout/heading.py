"""Which way a road user faces: the side of the road it is on and the traffic direction.

A photo from a car is taken from a lane of its own direction of travel: in right-hand
traffic the lanes carrying the camera's direction lie in the camera's lane and to its
right, the oncoming ones to its left beyond the line that divides the two directions.
That line is never inside the camera's lane: it lies at least half a lane to the
camera's left (right-hand traffic), and further when the road region's centre line is
further (a wide road with several lanes each way). A vehicle on the camera's side of it
moves with the camera's traffic and shows its back; a vehicle beyond it is oncoming and
shows its front. Cars parked along a kerb face the way the traffic on their side moves
(parking against the traffic is not allowed, e.g. German StVO section 12 (4); UK Highway
Code rule 248 at night), so the same rule holds for them.

What the side cannot tell (a one-way street, a crossing, a car turning) is not known from
the road alone; each heading carries a confidence in [0.5, 1]: 0.5 at the dividing line
(a coin flip), rising to 1 one lane away from it.

Where no road region was seen (a detector's boxes alone), the road's extent is read from
the vehicles on it: the carriageway spans at least from the outermost vehicle on one side
to the outermost on the other, the camera's own car included, and a two-way road's
dividing line lies at the middle of its carriageway (equal lanes each way; the roads'
design guidelines, e.g. RAA 2008 and the AASHTO Green Book, build two-way cross-sections
symmetric about the centre line): :func:`vehicle_span_centre`.

A vehicle whose box shows it turned across the road is crossing it (streets meet at
about right angles; :func:`usdworld.layout.yaw.line_from_view_angles`). Which way it
crosses follows the same side rule on the crossing road, whose centre line is not seen:
the camera sees the crossing road's near side first, whose traffic moves from the
camera's left to its right in right-hand traffic (right to left in left-hand traffic):
:func:`crossing_heading`, a tie-break with confidence 0.5.

People walk along the sidewalk or the road, either way (pedestrian flows on a sidewalk
run both ways): the axis gives their heading modulo 180 degrees, and the same side rule
only breaks the tie (confidence 0.5).

Frames: ground (x forward, y left, metres; the camera above the origin); yaw in radians
about +Z, 0 along +x.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usdworld.errors import InputError

#: Traffic directions: the side of the road traffic keeps to.
TRAFFIC_SIDES = ("right", "left")


@dataclass(frozen=True)
class Heading:
    """One object's yaw and what chose it.

    Attributes:
        yaw: radians about +Z, wrapped to (-pi, pi].
        source: how it was chosen, e.g. ``traffic_right_camera_lane``,
            ``traffic_right_same_side``, ``traffic_right_opposite_side``,
            ``along_road_traffic_right_same_side``, ``facing_camera``.
        confidence: how sure the facing direction (front versus back) is, in [0, 1].
    """

    yaw: float
    source: str
    confidence: float

    def __post_init__(self) -> None:
        if not np.isfinite(self.yaw):
            raise ValueError(f"heading yaw must be finite, got {self.yaw}")
        if not 0.0 <= self.confidence <= 1.0:
            raise ValueError(f"heading confidence must be in [0, 1], got {self.confidence}")


def check_traffic(traffic: str) -> str:
    """``traffic`` unchanged when it is ``right`` or ``left``; InputError otherwise."""
    if traffic not in TRAFFIC_SIDES:
        raise InputError(f"--traffic: must be one of {', '.join(TRAFFIC_SIDES)}, got {traffic!r}")
    return traffic


def lateral_offset(point_ground: np.ndarray, axis_angle: float) -> float:
    """Signed distance of a ground point from the line through the camera along the road, metres.

    Args:
        point_ground: (2,) float64 ground point.
        axis_angle: the road axis's yaw, radians.

    Returns:
        Positive left of the line (seen looking along ``axis_angle``), negative right.

    Example:
        >>> lateral_offset(np.array([10.0, 2.0]), 0.0)
        2.0
    """
    p = np.asarray(point_ground, dtype=np.float64)
    return float(np.cos(axis_angle) * p[1] - np.sin(axis_angle) * p[0])


def traffic_heading(
    point_ground: np.ndarray,
    axis_angle: float,
    centre_ground: np.ndarray,
    traffic: str,
    lane_width_m: float,
) -> Heading:
    """The heading of a vehicle moving with the traffic of its side of the road.

    Let ``t`` be the object's lateral offset towards the oncoming side (left in
    right-hand traffic). The line dividing the two directions lies at
    ``t_div = max(t_centre, lane_width_m / 2)``: the road region's centre line
    (``centre_ground``; the camera's own position when no road region was seen) but
    never inside the camera's lane. ``t <= t_div`` moves with the camera (yaw = the
    axis); beyond it, oncoming (yaw = the axis + pi).

    Args:
        point_ground: (2,) float64 object ground point.
        axis_angle: the road axis's yaw, radians.
        centre_ground: (2,) float64 a point on the road region's centre line.
        traffic: ``right`` or ``left``: the side traffic keeps to.
        lane_width_m: one lane's width, metres.

    Returns:
        The heading; source ``traffic_<side>_camera_lane`` (within half a lane of the
        camera's line), ``traffic_<side>_same_side`` or ``traffic_<side>_opposite_side``;
        confidence 0.5 at the dividing line rising linearly to 1 one lane away.

    Example:
        >>> h = traffic_heading(np.array([20.0, 0.5]), 0.0, np.zeros(2), "right", 3.5)
        >>> (h.yaw, h.source)
        (0.0, 'traffic_right_camera_lane')
    """
    check_traffic(traffic)
    towards_oncoming = 1.0 if traffic == "right" else -1.0
    t = towards_oncoming * lateral_offset(point_ground, axis_angle)
    t_div = max(towards_oncoming * lateral_offset(centre_ground, axis_angle), 0.5 * lane_width_m)
    confidence = float(0.5 + 0.5 * min(1.0, abs(t - t_div) / lane_width_m))
    if t > t_div:
        return Heading(_wrap(axis_angle + np.pi), f"traffic_{traffic}_opposite_side", confidence)
    where = "camera_lane" if abs(t) <= 0.5 * lane_width_m else "same_side"
    return Heading(_wrap(axis_angle), f"traffic_{traffic}_{where}", confidence)


def along_road_heading(
    point_ground: np.ndarray,
    axis_angle: float,
    centre_ground: np.ndarray,
    traffic: str,
    lane_width_m: float,
) -> Heading:
    """A person's heading: along the road, the way the traffic on their side moves.

    Either way along the street is as likely for a walker; the side rule of
    :func:`traffic_heading` breaks the tie, and the confidence says it is a tie (0.5).

    Args:
        point_ground: (2,) float64 ground point.
        axis_angle: the road axis's yaw, radians.
        centre_ground: (2,) float64 a point on the road region's centre line.
        traffic: ``right`` or ``left``.
        lane_width_m: one lane's width, metres.

    Returns:
        The heading; source ``along_road_`` followed by :func:`traffic_heading`'s.
    """
    h = traffic_heading(point_ground, axis_angle, centre_ground, traffic, lane_width_m)
    return Heading(h.yaw, f"along_road_{h.source}", 0.5)


def crossing_heading(axis_angle: float, traffic: str) -> Heading:
    """The heading of a vehicle crossing the road: on the crossing road's near side.

    Args:
        axis_angle: the (camera's) road axis's yaw, radians.
        traffic: ``right`` or ``left``.

    Returns:
        yaw ``axis - pi/2`` (moving to the camera's right) in right-hand traffic,
        ``axis + pi/2`` in left-hand traffic; source ``crossing_traffic_<side>_near_side``;
        confidence 0.5 (which side of the crossing road it is on is not known).

    Example:
        >>> h = crossing_heading(0.0, "right")
        >>> (round(float(np.degrees(h.yaw)), 1), h.source, h.confidence)
        (-90.0, 'crossing_traffic_right_near_side', 0.5)
    """
    check_traffic(traffic)
    turn = -0.5 * np.pi if traffic == "right" else 0.5 * np.pi
    return Heading(_wrap(axis_angle + turn), f"crossing_traffic_{traffic}_near_side", 0.5)


def vehicle_span_centre(points_ground: np.ndarray, axis_angle: float) -> np.ndarray:
    """A point on the road's centre line read from the vehicles on it.

    The carriageway spans at least from the outermost vehicle on one side of the camera
    to the outermost on the other, the camera itself (at the origin, on the road)
    included; its centre line is taken half-way between the two.

    Args:
        points_ground: (N, 2) float64 ground points of the vehicles moving along the road
            (N may be 0).
        axis_angle: the road axis's yaw, radians.

    Returns:
        (2,) float64 the point of that centre line abreast of the camera (on the line
        through the origin across the road).

    Example:
        >>> vehicle_span_centre(np.array([[30.0, 2.5], [40.0, 11.0], [20.0, -3.0]]), 0.0)
        array([0., 4.])
    """
    pts = np.asarray(points_ground, dtype=np.float64).reshape(-1, 2)
    offsets = np.array([lateral_offset(p, axis_angle) for p in pts] + [0.0])
    middle = 0.5 * (float(offsets.min()) + float(offsets.max()))
    return middle * np.array([-np.sin(axis_angle), np.cos(axis_angle)]) + 0.0


def _wrap(angle: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    a = (angle + np.pi) % (2 * np.pi) - np.pi
    return float(np.pi if a == -np.pi else a)
