"""Geometry of the street surfaces: road, lane markings, sidewalks and the terrain beyond.

Each function returns ``(points, face_counts, face_indices)`` with ``points`` (N, 3)
float64 world metres and quads as faces. Surfaces at different heights overlap rather
than meet edge to edge, so no sliver of sky shows between them; markings float 2 cm above
the asphalt to stay clear of depth-buffer fighting up to ``MARKINGS_MAX_X_M``.
"""

from __future__ import annotations

import numpy as np

from usdworld.synth.street import KERB_HEIGHT_M, StreetLayout

Polys = tuple[np.ndarray, list[int], list[int]]

MARKING_Z_M = 0.02
MARKING_WIDTH_M = 0.15
#: Markings stop here: beyond it they are sub-pixel and the 24-bit depth buffer can't separate them.
MARKINGS_MAX_X_M = 120.0
TERRAIN_EXTENT_M = 600.0


def _quads(rects: list[tuple[float, float, float, float, float]]) -> Polys:
    """Upward quads from ``(x0, x1, y0, y1, z)`` rectangles."""
    points, indices = [], []
    for i, (x0, x1, y0, y1, z) in enumerate(rects):
        points += [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)]  # counter-clockwise from above
        indices += [4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 3]
    return np.asarray(points, dtype=np.float64).reshape(-1, 3), [4] * len(rects), indices


def road_surface(street: StreetLayout) -> Polys:
    """The asphalt between the kerbs, z = 0 (extends 0.3 m under each sidewalk)."""
    x0, x1 = street.x_range
    return _quads([(x0, x1, street.kerb_right_y - 0.3, street.kerb_left_y + 0.3, 0.0)])


def _dashes(
    y: float, x0: float, x1: float, dash: float, gap: float
) -> list[tuple[float, float, float, float, float]]:
    h = MARKING_WIDTH_M / 2
    out, x = [], x0
    while x < x1:
        out.append((x, min(x + dash, x1), y - h, y + h, MARKING_Z_M))
        x += dash + gap
    return out


def lane_markings(street: StreetLayout) -> Polys:
    """Centre line, lane dividers, parking edge lines and an optional zebra crossing."""
    x0, x1 = street.x_range[0], MARKINGS_MAX_X_M
    rects = _dashes(street.centre_y, x0, x1, 3.0, 6.0)
    right, left = street.lane_centres_y()
    w = street.lane_width_m
    for lanes, sign in ((right, -1.0), (left, 1.0)):
        for y in lanes[:-1]:
            rects += _dashes(y + sign * w / 2, x0, x1, 3.0, 9.0)
        edge = lanes[-1] + sign * w / 2
        rects += _dashes(edge, x0, x1, 1000.0, 0.0)  # solid edge line
    if street.crossing_x is not None:
        y = street.kerb_right_y + 0.4
        while y + 0.5 < street.kerb_left_y - 0.4:
            rects.append((street.crossing_x - 2.0, street.crossing_x + 2.0, y, y + 0.5, MARKING_Z_M))
            y += 1.0
    return _quads(rects)


def _slab(x0: float, x1: float, y_kerb: float, y_outer: float) -> Polys:
    """A sidewalk slab: top, kerb face and outer face (the ends are never seen)."""
    y_lo, y_hi = min(y_kerb, y_outer), max(y_kerb, y_outer)
    z0, z1 = -0.05, KERB_HEIGHT_M
    pts = np.array(
        [
            [x0, y_lo, z1],
            [x1, y_lo, z1],
            [x1, y_hi, z1],
            [x0, y_hi, z1],  # top
            [x0, y_lo, z0],
            [x1, y_lo, z0],
            [x1, y_hi, z0],
            [x0, y_hi, z0],  # bottom corners
        ]
    )
    faces = [[0, 1, 2, 3], [4, 5, 1, 0], [6, 7, 3, 2], [4, 0, 3, 7], [5, 6, 2, 1]]
    return pts, [4] * len(faces), [i for f in faces for i in f]


def sidewalks(street: StreetLayout) -> tuple[Polys, Polys]:
    """(right, left) raised sidewalks, from the kerb to 0.5 m under the building line."""
    x0, x1 = street.x_range
    right = _slab(x0, x1, street.kerb_right_y, street.outer_right_y - 0.5)
    left = _slab(x0, x1, street.kerb_left_y, street.outer_left_y + 0.5)
    return right, left


def terrain(street: StreetLayout) -> Polys:
    """Flat ground behind the building lines and beyond the end of the street, z = 0."""
    e, (x0, x1) = TERRAIN_EXTENT_M, street.x_range
    return _quads(
        [
            (-e, e, street.outer_left_y, e, 0.0),
            (-e, e, -e, street.outer_right_y, 0.0),
            (x1 - 0.5, e, street.outer_right_y - 0.5, street.outer_left_y + 0.5, -0.05),
            (-e, x0 + 0.5, street.outer_right_y - 0.5, street.outer_left_y + 0.5, -0.05),
        ]
    )
