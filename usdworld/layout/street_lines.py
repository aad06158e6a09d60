"""Street lines: objects of one class on one side of a straight street stand in a row.

Facades keep to a building line; trees, lamp posts and signs are set a fixed distance
from the kerb. Where objects of a class on one side of the street have a seen ground
contact, the row they form is a line parallel to the road axis at a lateral offset that
they measure. An object of that class whose own contact is hidden (a tree trunk behind
a parked car, a facade behind a row of cars) or cut by the image border is then placed
where its viewing ray meets that line, instead of at the loose bounds its visible
bottom and its occluder give.

Where no object of the class shows its contact on that side, the sidewalk gives the
row: facades stand at its back edge, and street furniture and trees a customary
distance behind the kerb (:func:`kerb_setback_m`), measured on the sidewalk's ground
points (:func:`sidewalk_lines`). Where parked cars hide that side's sidewalk too, the
cars give the kerb: they park along it (:func:`parked_car_lines`).

Everything here works on the ground plane of the world frame (``_ground``: x forward,
y left, metres) and the road axis of :mod:`usdworld.layout.yaw`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import ClassTable
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.placement import PlacementParams


def kerb_setback_m(class_name: str, classes: ClassTable, params: PlacementParams) -> float | None:
    """Where a row class stands behind the kerb when none of its row is seen, metres: street
    trees (``crown``) :attr:`~PlacementParams.tree_kerb_setback_m`, posts and signs
    :attr:`~PlacementParams.post_kerb_setback_m`; None for facades (they stand at the
    sidewalk's back edge) and classes that form no row."""
    if not classes.has(class_name, "line") or classes.has(class_name, "facade"):
        return None
    return params.tree_kerb_setback_m if classes.has(class_name, "crown") else params.post_kerb_setback_m


def max_spread_m(class_name: str, classes: ClassTable, params: PlacementParams) -> float:
    """Largest spread of a row's members' offsets (median absolute deviation, metres)."""
    return params.facade_row_max_spread_m if classes.has(class_name, "facade") else params.row_max_spread_m


@dataclass(frozen=True)
class StreetLine:
    """A row of objects of one class along one side of the street.

    Attributes:
        class_name: placed class of the row.
        side: +1 left of the road axis, -1 right of it.
        offset_m: signed lateral offset of the row from the axis's centre line (left positive).
        support: number of objects with a seen contact that measured it (0: the sidewalk
            or the parked cars did).
        spread_m: median absolute deviation of their offsets, metres (for a sidewalk row,
            a quarter of the sidewalk's width).
        source: what measured it: ``objects`` (its own class), ``sidewalk`` or ``parked_cars``.
    """

    class_name: str
    side: int
    offset_m: float
    support: int
    spread_m: float
    source: str = "objects"

    def __post_init__(self) -> None:
        if self.side not in (-1, 1):
            raise ValueError(f"StreetLine.side must be +1 or -1, got {self.side}")
        if not np.isfinite(self.offset_m) or self.support < 0 or not self.spread_m >= 0:
            raise ValueError(
                f"StreetLine: bad offset {self.offset_m}, support {self.support} or spread {self.spread_m}"
            )
        if self.source not in ("objects", "sidewalk", "parked_cars"):
            raise ValueError(
                f"StreetLine.source must be objects, sidewalk or parked_cars, got {self.source!r}"
            )


def lateral_offsets(points_ground: np.ndarray, axis: RoadAxis) -> np.ndarray:
    """Signed distances of ground points from the road axis's centre line (left positive).

    Args:
        points_ground: (N, 2) float64 ground points.
        axis: the road axis.

    Returns:
        (N,) float64 metres.

    Example:
        >>> axis = RoadAxis(0.0, np.zeros(2), "camera_forward")
        >>> lateral_offsets(np.array([[10.0, 3.0], [5.0, -2.0]]), axis).tolist()
        [3.0, -2.0]
    """
    p = np.asarray(points_ground, dtype=np.float64).reshape(-1, 2) - axis.center_ground
    return np.cos(axis.angle) * p[:, 1] - np.sin(axis.angle) * p[:, 0]


def fit_street_lines(
    class_names: Sequence[str],
    points_ground: np.ndarray,
    axis: RoadAxis,
    classes: ClassTable,
    params: PlacementParams,
) -> list[StreetLine]:
    """The rows that objects with a seen ground contact form, per class and side.

    Args:
        class_names: (N,) placed class of each object.
        points_ground: (N, 2) float64 ground point of each object's seen contact (a
            facade's front wall, a trunk's foot).
        axis: the road axis.
        classes: the class table (``line`` classes form rows; ``facade`` ones spread more).
        params: :attr:`~PlacementParams.row_min_support` and the row spreads.

    Returns:
        One line per (``line``) class and side with at least ``row_min_support`` objects
        whose offsets agree within :func:`max_spread_m`, in class then side order.
    """
    offsets = lateral_offsets(points_ground, axis)
    names = np.asarray(list(class_names), dtype=object)
    lines = []
    for class_name in sorted(set(class_names) & classes.with_role("line")):
        for side in (-1, 1):
            mine = offsets[(names == class_name) & (np.sign(offsets) == side)]
            if len(mine) < params.row_min_support:
                continue
            centre = float(np.median(mine))
            spread = float(np.median(np.abs(mine - centre)))
            if spread <= max_spread_m(class_name, classes, params):
                lines.append(StreetLine(class_name, side, centre, len(mine), spread))
    return lines


def unmeasured(rows: Sequence[StreetLine], measured: Sequence[StreetLine]) -> list[StreetLine]:
    """The rows whose class and side no row of ``measured`` has, in their order.

    Example:
        >>> walk = [StreetLine("tree", 1, 5.0, 0, 0.5, "sidewalk"), StreetLine("pole", 1, 4.5, 0, 0.5, "sidewalk")]
        >>> [r.class_name for r in unmeasured(walk, [StreetLine("tree", 1, 5.5, 2, 0.1)])]
        ['pole']
    """
    taken = {(line.class_name, line.side) for line in measured}
    return [line for line in rows if (line.class_name, line.side) not in taken]


def sidewalk_lines(
    sidewalk_ground: np.ndarray | None,
    axis: RoadAxis,
    classes: ClassTable,
    params: PlacementParams,
    measured: Sequence[StreetLine] = (),
) -> list[StreetLine]:
    """Rows the sidewalks give, for the classes and sides no object measured.

    Args:
        sidewalk_ground: (N, 2) float64 ground points of sidewalk pixels (within range), or None.
        axis: the road axis.
        classes: the class table (its ``line`` classes get rows).
        params: the sidewalk's edges, point count and setbacks.
        measured: rows already measured by objects (their class and side get none here).

    Returns:
        Per side with at least ``min_sidewalk_points``: a row per ``facade`` class at the
        sidewalk's back edge and one per other row class its :func:`kerb_setback_m` behind
        the kerb (within the sidewalk).
    """
    if sidewalk_ground is None or len(sidewalk_ground) == 0:
        return []
    offsets = lateral_offsets(sidewalk_ground, axis)
    lines = []
    for side in (-1, 1):
        mine = np.abs(offsets[np.sign(offsets) == side])
        if len(mine) < params.min_sidewalk_points:
            continue
        kerb, back = (float(v) for v in np.percentile(mine, params.sidewalk_edge_percentiles))
        spread = params.sidewalk_row_spread_fraction * (back - kerb)
        places = {}
        for class_name in classes.with_role("line"):
            setback = kerb_setback_m(class_name, classes, params)
            places[class_name] = back if setback is None else min(kerb + setback, back)
        for class_name, distance in sorted(places.items()):
            lines.append(StreetLine(class_name, side, side * distance, 0, spread, "sidewalk"))
    return unmeasured(lines, measured)


def lone_rows_agreeing(
    measured: Sequence[StreetLine],
    sidewalk: Sequence[StreetLine],
    classes: ClassTable,
    params: PlacementParams,
) -> list[StreetLine]:
    """The measured rows, less those of a single tree, post or sign that stand more than
    :attr:`~PlacementParams.lone_row_tolerance_m` off the row the sidewalk gives its class
    on that side (a facade's own base line stands: the sidewalk's back edge is the rougher
    measure).

    One tree's or post's "foot" may be ground seen past its crown or arm; the sidewalk,
    measured from many points, then says better where the row is.

    Example:
        >>> lone = StreetLine("tree", -1, -8.0, 1, 0.0)
        >>> walk = StreetLine("tree", -1, -5.0, 0, 0.5, "sidewalk")
        >>> from usdworld.io.class_table import load_class_table
        >>> lone_rows_agreeing([lone], [walk], load_class_table(), PlacementParams())
        []
    """
    by_key = {(line.class_name, line.side): line for line in sidewalk}
    kept = []
    for line in measured:
        walk = by_key.get((line.class_name, line.side))
        lone = line.support == 1 and kerb_setback_m(line.class_name, classes, params) is not None
        if lone and walk is not None and abs(line.offset_m - walk.offset_m) > params.lone_row_tolerance_m:
            continue
        kept.append(line)
    return kept


def parked_car_lines(
    car_ground: np.ndarray,
    car_headings: np.ndarray,
    car_widths: np.ndarray,
    axis: RoadAxis,
    camera_ground: np.ndarray,
    classes: ClassTable,
    params: PlacementParams,
    measured: Sequence[StreetLine] = (),
) -> list[StreetLine]:
    """Rows of street furniture and trees behind the kerb that parked cars line.

    For a side of the street where neither its own objects nor a sidewalk gave a class
    its row, the outermost car parked along the road there (heading within
    ``parked_heading_tol_deg`` of the road's, either way, and at least
    ``parked_min_sideways_m`` to the camera's side, out of its lane) marks the kerb:
    its kerb side is ``parked_kerb_gap_m`` from it. Trees, posts and signs stand their
    :func:`kerb_setback_m` behind that; the building line stays unknown.

    Args:
        car_ground: (N, 2) float64 ground centres of cars placed by their seen contact.
        car_headings: (N,) float64 their yaws, radians.
        car_widths: (N,) float64 their widths, metres.
        axis: the road axis.
        camera_ground: (2,) float64 the camera's ground point.
        classes: the class table (which classes stand behind the kerb, and how far).
        params: the parked cars' thresholds and the setbacks.
        measured: rows already given (their class and side get none here).

    Returns:
        The rows, in side then class order.

    Example:
        >>> axis = RoadAxis(0.0, np.zeros(2), "camera_forward")
        >>> cars = np.array([[12.0, 5.0], [20.0, 4.0]])
        >>> from usdworld.io.class_table import load_class_table
        >>> table, params = load_class_table(), PlacementParams()
        >>> rows = parked_car_lines(cars, np.zeros(2), np.full(2, 1.8), axis, np.zeros(2), table, params)
        >>> [(r.class_name, r.offset_m) for r in rows if r.class_name == "tree"]
        [('tree', 7.2)]
    """
    if len(car_ground) == 0:
        return []
    offsets = lateral_offsets(car_ground, axis)
    turn = np.abs(np.angle(np.exp(1j * (np.asarray(car_headings, dtype=np.float64) - axis.angle))))
    along = np.minimum(turn, np.pi - turn) <= params.parked_heading_tol
    camera_offset = float(lateral_offsets(np.asarray(camera_ground, dtype=np.float64)[None, :2], axis)[0])
    along &= np.abs(offsets - camera_offset) >= params.parked_min_sideways_m
    outer = np.abs(offsets) + 0.5 * np.asarray(car_widths, dtype=np.float64)
    lines = []
    for side in (-1, 1):
        mine = along & (np.sign(offsets) == side)
        if not mine.any():
            continue
        kerb = float(outer[mine].max()) + params.parked_kerb_gap_m
        for class_name in sorted(classes.with_role("line")):
            distance = kerb_setback_m(class_name, classes, params)
            if distance is None:
                continue
            row = StreetLine(
                class_name,
                side,
                round(side * (kerb + distance), 6),
                0,
                params.parked_row_spread_m,
                "parked_cars",
            )
            lines.append(row)
    return unmeasured(lines, measured)


def depth_on_line(
    camera: PinholeCamera, pixel: tuple[float, float], line: StreetLine, axis: RoadAxis
) -> float | None:
    """Optical depth at which a pixel's viewing ray stands above a street line.

    The ray's foot on the ground (the point straight below each of its points) runs
    from below the camera outwards; it crosses the line once, unless it runs parallel
    to the street or away from the line's side.

    Args:
        camera: the source camera.
        pixel: (u, v) pixel of the object (a trunk's column, a facade's base).
        line: the row.
        axis: the road axis the line was fitted along.

    Returns:
        The depth along the optical axis in metres, or None when the ray never stands
        above the line ahead of the camera.
    """
    ray = camera.rays_world(np.array([pixel], dtype=np.float64))[0]
    c = camera.center_world[:2]
    # offset(c + t * ray_xy) = offset(c) + t * (lateral component of ray_xy) = line.offset_m
    start = float(lateral_offsets(c[None, :], axis)[0])
    rate = float(np.cos(axis.angle) * ray[1] - np.sin(axis.angle) * ray[0])
    if abs(rate) < 1e-9:
        return None
    t = (line.offset_m - start) / rate
    return float(t) if t > 0 else None


def line_for(
    lines: Sequence[StreetLine],
    class_name: str,
    camera: PinholeCamera,
    pixel: tuple[float, float],
    axis: RoadAxis,
) -> tuple[StreetLine, float] | None:
    """The row of ``class_name`` that the pixel's ray meets first ahead, with the depth there."""
    best = None
    for line in lines:
        if line.class_name != class_name:
            continue
        depth = depth_on_line(camera, pixel, line, axis)
        if depth is not None and (best is None or depth < best[1]):
            best = (line, depth)
    return best
