"""The camera's roll: the vertical vanishing point's measurement fused with a level prior.

Rolling a camera about its optical axis turns its image about the principal point ``c``
(square pixels), so the world's vertical, whose vanishing point ``(u, v, w)`` the photo's
poles and building edges give (:func:`usdworld.geometry.vanishing.find_vertical_vanishing_point`),
points from ``c`` at the roll angle: the down direction's ray ``(u - c_x w, v - c_y w, f w)``
has ``roll = atan2(x, y)`` (ISO 8855, :func:`usdworld.geometry.lateral.tilt_from_vanishing_points`),
whatever the focal length. That is the roll against gravity; the world's ground is the
road, which its crossfall tilts against gravity (the car, and its camera, sit on it), so as a
measurement of the roll against the road its spread adds ``params.roll_road_crossfall_deg``
to a bootstrap over the supporting segments and ``params.roll_vertical_sigma_deg`` for poles
and edges that do not stand plumb.

:func:`fuse_roll` combines the measurement with the level prior ``N(0, params.roll_level_std_deg)``
by inverse variance, unless the two disagree by more than ``params.roll_outlier_sigma``
combined sigmas: then the measurement is taken as wrong (leaning facades, a hillside street,
a vanishing point of some other bundle of lines) and the camera stays level, so a wrong
point does not roll the world.

:func:`deroll_points` turns image points by minus the roll about the principal point: the
camera fit of :mod:`usdworld.geometry.estimate` is made for a level camera, and the rolled
photo's points, turned back, are the level camera's.

Frames: image pixels (u right, v down); roll in radians (ISO 8855: positive tilts the left axis up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from usdworld.errors import CalibrationError
from usdworld.geometry.vanishing import VerticalVanishingPoint, segment_lines
from usdworld.parameters.camera import DEFAULT_CAMERA, CameraParams


@dataclass(frozen=True)
class RollMeasurement:
    """The roll a vanishing point measures, with its standard error.

    Attributes:
        roll: radians.
        sigma: standard error, radians (> 0).
        source: what measured it, one phrase.
    """

    roll: float
    sigma: float
    source: str

    def __post_init__(self) -> None:
        if not (math.isfinite(self.roll) and math.isfinite(self.sigma) and self.sigma > 0):
            raise CalibrationError(
                f"roll measurement: roll must be finite and sigma > 0, got {self.roll}, {self.sigma}"
            )


@dataclass(frozen=True)
class RollEstimate:
    """The roll used and how it was obtained.

    Attributes:
        roll: radians, the fused value (0 when the measurement was dropped or absent).
        sigma: its standard error, radians.
        measurement: the vanishing point's roll, or None.
        used: whether the measurement was fused (False when absent or dropped as inconsistent).
    """

    roll: float
    sigma: float
    measurement: RollMeasurement | None
    used: bool

    def describe(self) -> str:
        """One phrase for the build summary."""
        if self.measurement is None:
            return "roll assumed level (0): no vertical vanishing point"
        m = self.measurement
        seen = f"{math.degrees(m.roll):.2f} +- {math.degrees(m.sigma):.2f} deg from {m.source}"
        if not self.used:
            return f"roll assumed level (0): {seen} dropped as inconsistent with a level camera"
        fused = f"roll {math.degrees(self.roll):.2f} +- {math.degrees(self.sigma):.2f} deg"
        return f"{fused} ({seen}, fused with a level prior)"


def roll_of_down_ray(point_h: np.ndarray, center_px: np.ndarray) -> float:
    """The roll (radians) of a camera whose down direction's vanishing point is ``point_h``.

    Args:
        point_h: (3,) float64 homogeneous ``(u, v, w)`` pixels, ``w >= 0``.
        center_px: (2,) float64 principal point, pixels.
    """
    x = float(point_h[0] - center_px[0] * point_h[2])
    y = float(point_h[1] - center_px[1] * point_h[2])
    if y < 0:  # the point above the image: the down ray is its opposite
        x, y = -x, -y
    return math.atan2(x, y)


def _plumb_point(segments: np.ndarray, center: np.ndarray, scale: float) -> np.ndarray:
    """Length-weighted least-squares homogeneous intersection of segments, bit for bit the same
    whatever the BLAS threads: the 3 x 3 normal matrix is summed exactly (``math.fsum``) and
    its smallest eigenvector taken (an SVD of the N x 3 system splits its products over threads).

    Args:
        segments: (N, 4) float64 ``u0, v0, u1, v1`` pixels.
        center: (2,) float64 the normalisation centre, pixels.
        scale: the normalisation scale, pixels.

    Returns:
        (3,) float64 homogeneous point ``(u, v, w)`` pixels, unit norm, ``w >= 0``.
    """
    seg = ((segments.reshape(-1, 2) - center) / scale).reshape(-1, 4)
    lines = segment_lines(seg)
    length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
    normal = np.array([[math.fsum(length * lines[:, i] * lines[:, j]) for j in range(3)] for i in range(3)])
    _, vectors = np.linalg.eigh(normal)
    p = vectors[:, 0]
    p_px = np.array([p[0] * scale + center[0] * p[2], p[1] * scale + center[1] * p[2], p[2]])
    p_px /= math.sqrt(math.fsum(p_px**2))
    return p_px if p_px[2] >= 0 else -p_px


def roll_from_vertical(
    vertical: VerticalVanishingPoint, width: int, height: int, params: CameraParams = DEFAULT_CAMERA
) -> RollMeasurement:
    """The roll the vertical vanishing point measures (module docstring), principal point at the centre:
    the intersection of its supporting segments (refitted exactly, :func:`_plumb_point`) and a
    bootstrap over them.

    Args:
        vertical: the vertical's point and its supporting segments.
        width: image width, pixels.
        height: image height, pixels.
        params: bootstrap resamples and the plumb spread.
    """
    c = np.array([width / 2.0, height / 2.0])
    scale = float(np.hypot(width, height))
    roll = roll_of_down_ray(_plumb_point(vertical.inliers, c, scale), c)
    rng = np.random.default_rng(0)
    n = len(vertical.inliers)
    rolls = []
    for _ in range(params.vertical_bootstrap):
        pick = vertical.inliers[rng.integers(0, n, n)]
        r = roll_of_down_ray(_plumb_point(pick, c, scale), c)
        rolls.append((r - roll + math.pi) % (2 * math.pi) - math.pi)
    mean = math.fsum(rolls) / len(rolls)
    spread = math.sqrt(math.fsum((r - mean) ** 2 for r in rolls) / len(rolls))
    plumb, crossfall = math.radians(params.roll_vertical_sigma_deg), math.radians(params.roll_road_crossfall_deg)
    sigma = math.sqrt(spread**2 + plumb**2 + crossfall**2)
    return RollMeasurement(roll, sigma, f"the vertical of {n} upright segments")


def fuse_roll(measurement: RollMeasurement | None, params: CameraParams = DEFAULT_CAMERA) -> RollEstimate:
    """The measurement fused with the level prior by inverse variance, or level when it is
    absent or further than ``params.roll_outlier_sigma`` combined sigmas from level."""
    prior = math.radians(params.roll_level_std_deg)
    if measurement is None:
        return RollEstimate(0.0, prior, None, False)
    if abs(measurement.roll) > params.roll_outlier_sigma * math.hypot(prior, measurement.sigma):
        return RollEstimate(0.0, prior, measurement, False)
    w_m, w_p = measurement.sigma**-2, prior**-2
    return RollEstimate(measurement.roll * w_m / (w_m + w_p), (w_m + w_p) ** -0.5, measurement, True)


def deroll_points(points_px: np.ndarray, roll: float, center_px: np.ndarray) -> np.ndarray:
    """Image points of a camera rolled by ``roll`` as the level camera would see them.

    Args:
        points_px: (N, 2) float64 ``(u, v)`` pixels.
        roll: radians.
        center_px: (2,) float64 principal point, pixels.

    Returns:
        (N, 2) float64 the points turned by ``-roll`` about the principal point.
    """
    p = np.asarray(points_px, dtype=np.float64).reshape(-1, 2) - center_px
    c, s = math.cos(roll), math.sin(roll)
    # a camera rolled by r (ISO 8855) sees the level image turned by +r in (u, v) (v down; the tests
    # check it against PinholeCamera): turn back by -r
    return np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]]) + center_px
