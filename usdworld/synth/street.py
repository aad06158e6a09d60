"""The straight street of a synthetic scene: lanes, parking strips, kerbs and sidewalks.

The road runs along world +X (the camera's heading up to a small yaw). Traffic keeps to the
right: lanes right of the centre line (y < ``centre_y``) carry traffic along +X, lanes left of
it along -X. The camera drives in one of the right-hand lanes, so the world origin (below the
camera) lies in that lane. Cross-section, right to left::

    building | sidewalk | parking | lanes -> | centre | lanes <- | parking | sidewalk | building
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Height of the sidewalks above the road, metres.
KERB_HEIGHT_M = 0.15
#: Extent of the street along X, metres (from behind the camera to beyond the horizon haze).
STREET_X_RANGE_M = (-30.0, 260.0)


@dataclass(frozen=True)
class StreetLayout:
    """Cross-section of the street (all y in world metres, Y left).

    Attributes:
        lane_width_m: width of one lane.
        lanes_right: lanes carrying traffic along +X (the camera's direction).
        lanes_left: lanes carrying traffic along -X.
        centre_y: y of the centre line between the two directions.
        parking_right_m: width of the parking strip at the right kerb (0: none).
        parking_left_m: width of the parking strip at the left kerb (0: none).
        sidewalk_right_m: width of the right sidewalk.
        sidewalk_left_m: width of the left sidewalk.
        crossing_x: x of a zebra crossing, or None.
        x_range: (start, end) of the street along X.
    """

    lane_width_m: float
    lanes_right: int
    lanes_left: int
    centre_y: float
    parking_right_m: float
    parking_left_m: float
    sidewalk_right_m: float
    sidewalk_left_m: float
    crossing_x: float | None
    x_range: tuple[float, float] = STREET_X_RANGE_M

    @property
    def kerb_right_y(self) -> float:
        """y of the right kerb (road edge)."""
        return self.centre_y - self.lanes_right * self.lane_width_m - self.parking_right_m

    @property
    def kerb_left_y(self) -> float:
        """y of the left kerb (road edge)."""
        return self.centre_y + self.lanes_left * self.lane_width_m + self.parking_left_m

    @property
    def outer_right_y(self) -> float:
        """y of the right sidewalk's outer edge (the building line)."""
        return self.kerb_right_y - self.sidewalk_right_m

    @property
    def outer_left_y(self) -> float:
        """y of the left sidewalk's outer edge (the building line)."""
        return self.kerb_left_y + self.sidewalk_left_m

    def lane_centres_y(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Centre y of every lane: (right-hand lanes, left-hand lanes), nearest the centre line first."""
        right = tuple(self.centre_y - (i + 0.5) * self.lane_width_m for i in range(self.lanes_right))
        left = tuple(self.centre_y + (i + 0.5) * self.lane_width_m for i in range(self.lanes_left))
        return right, left

    def to_json(self) -> dict[str, object]:
        """JSON-ready description (rounded to millimetres)."""
        r = lambda v: round(float(v), 3)
        return {
            "lane_width_m": r(self.lane_width_m),
            "lanes_right": self.lanes_right,
            "lanes_left": self.lanes_left,
            "centre_y": r(self.centre_y),
            "kerb_right_y": r(self.kerb_right_y),
            "kerb_left_y": r(self.kerb_left_y),
            "outer_right_y": r(self.outer_right_y),
            "outer_left_y": r(self.outer_left_y),
            "kerb_height_m": KERB_HEIGHT_M,
            "crossing_x": None if self.crossing_x is None else r(self.crossing_x),
            "x_range": [r(self.x_range[0]), r(self.x_range[1])],
        }


def sample_street(rng: np.random.Generator) -> StreetLayout:
    """A random street cross-section with the camera's lane around y = 0.

    Args:
        rng: the random generator (consumed in a fixed order).
    """
    lane_w = float(rng.uniform(3.0, 3.5))
    lanes_right = int(rng.choice([1, 1, 2]))
    lanes_left = lanes_right if rng.random() < 0.8 else int(rng.choice([1, 2]))
    ego_lane = int(rng.integers(0, lanes_right))  # 0 = next to the centre line
    centre_y = (ego_lane + 0.5) * lane_w
    parking_right = float(rng.uniform(2.0, 2.4)) if rng.random() < 0.85 else 0.0
    parking_left = float(rng.uniform(2.0, 2.4)) if rng.random() < 0.85 else 0.0
    sidewalk_right = float(rng.uniform(3.0, 5.5))
    sidewalk_left = float(rng.uniform(3.0, 5.5))
    crossing_x = float(rng.uniform(14.0, 32.0)) if rng.random() < 0.5 else None
    return StreetLayout(
        lane_width_m=lane_w,
        lanes_right=lanes_right,
        lanes_left=lanes_left,
        centre_y=centre_y,
        parking_right_m=parking_right,
        parking_left_m=parking_left,
        sidewalk_right_m=sidewalk_right,
        sidewalk_left_m=sidewalk_left,
        crossing_x=crossing_x,
    )
