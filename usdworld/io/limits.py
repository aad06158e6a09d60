"""Caps on the numbers usdworld accepts from outside, each with the reason for its value.

Every reader checks its numbers against these bounds before any of them reaches numpy,
OpenCV or manifold3d, so a hostile or mistyped value (``1e308``, ``1e10``, a negative
size) gives a one-line :class:`~usdworld.errors.InputError` instead of an overflow, a
native crash or a hang. The bounds are far outside anything a street photo and its
calibration produce, so real inputs never meet them.
"""

from __future__ import annotations

import math

import numpy as np

from usdworld.errors import InputError

#: Largest ``--max-range``, metres. The ground is meshed out to this distance; at 1 km a
#: road pixel of a 2048-pixel-wide photo already spans tens of metres, and past a few km
#: the mesh's float32 coordinates lose centimetres (and manifold3d fails on huge values).
MAX_RANGE_CAP_M = 1000.0

#: How far outside the image a pixel coordinate (box corner, polygon vertex, ground
#: point) may lie, in image sizes: a box or polygon of a truncated object extends a
#: little past the border, never this far. Beyond it, a coordinate is a unit or parsing
#: error (and past int32 it would make ``cv2.fillPoly`` run for minutes).
MAX_OUTSIDE_IMAGES = 10.0

#: Absolute bound on a pixel coordinate when no image size is known (a 100-megapixel
#: photo is 12k pixels wide); also keeps every rounded vertex far inside int32.
MAX_PIXEL_COORD = 1.0e6

#: Most detections read from one file. A street photo holds tens of objects (KITTI's
#: densest frame about 30, a crowded car park a few hundred) and detectors cap their
#: output at 100-300 per image; beyond this the file is raw, un-suppressed output whose
#: placement would take minutes and gigabytes. Run non-maximum suppression first.
MAX_DETECTIONS = 5000

#: Most pixel <-> ground pairs (after removing exact duplicates). A homography needs 4;
#: a hand-picked set has 5-20 and a surveyed one a few hundred.
MAX_GROUND_PAIRS = 1000

#: Largest |x| or |y| of a ground point, metres: a photo cannot show a marked point 10 km
#: away; beyond this the value is in the wrong unit (mm, or geographic coordinates).
MAX_GROUND_COORD_M = 10_000.0

#: Largest camera height above the road, metres (a mast or a roof top stays below 100 m).
MAX_CAMERA_HEIGHT_M = 100.0

#: Largest focal length in pixels, as a multiple of the image width when the image is
#: known (a 1000 mm lens on a full-frame sensor is about 28 widths), else absolutely.
MAX_FOCAL_WIDTHS = 100.0
MAX_FOCAL_PX = 1.0e7

#: Largest |yaw| of a camera file, degrees (one turn either way).
MAX_YAW_DEG = 360.0

#: Largest |coefficient| of a KITTI ground plane ``a x + b y + c z + d = 0`` (KITTI
#: writes a unit normal and d of about 1.65 m); keeps the norm from overflowing.
MAX_PLANE_COEFF = 1.0e6

#: Most pixels of an image, label map, instance map or depth map (2^28 = a 16384 x 16384
#: photo): the size of OpenCV's own default decoding cap's order, and about 1 GB as RGB.
MAX_PIXELS = 1 << 28


def check_pixel(value: float, extent: int | None, where: str) -> float:
    """Refuse a pixel coordinate far outside an image axis of ``extent`` pixels.

    Args:
        value: a finite coordinate in pixels (u or v).
        extent: image width (for u) or height (for v), or None when unknown.
        where: start of the error message (file and field).

    Returns:
        ``value`` unchanged.

    Raises:
        InputError: ``|value|`` beyond :data:`MAX_OUTSIDE_IMAGES` image sizes (or
            :data:`MAX_PIXEL_COORD` without an image).
    """
    bound = MAX_PIXEL_COORD if extent is None else min(MAX_PIXEL_COORD, MAX_OUTSIDE_IMAGES * extent)
    lo, hi = (-bound, bound) if extent is None else (-bound, extent + bound)
    if not (math.isfinite(value) and lo <= value <= hi):
        raise InputError(
            f"{where}: pixel coordinate {value:g} is far outside the image (allowed {lo:g} .. {hi:g}); "
            "coordinates are pixels of this image"
        )
    return value


def check_pixels(points_px: np.ndarray, width: int | None, height: int | None, where: str) -> None:
    """Refuse (N, 2) pixel points with a coordinate far outside a ``width`` x ``height`` image.

    Args:
        points_px: (N, 2) float64 (u, v) pixels, finite.
        width: image width in pixels or None.
        height: image height in pixels or None.
        where: start of the error message.

    Raises:
        InputError: the first point beyond the bounds of :func:`check_pixel`, by index.
    """
    for axis, extent in ((0, width), (1, height)):
        bound = MAX_PIXEL_COORD if extent is None else min(MAX_PIXEL_COORD, MAX_OUTSIDE_IMAGES * extent)
        lo, hi = (-bound, bound) if extent is None else (-bound, extent + bound)
        col = points_px[:, axis]
        bad = np.flatnonzero(~((col >= lo) & (col <= hi)))
        if bad.size:
            check_pixel(float(col[bad[0]]), extent, f"{where} -> [{int(bad[0])}]")


def check_range(value: float, lo: float, hi: float, where: str, unit: str, hint: str) -> float:
    """``value`` if it is finite and in ``[lo, hi]``, else a one-line InputError.

    Args:
        value: the number.
        lo: smallest accepted value.
        hi: largest accepted value.
        where: start of the error message.
        unit: unit for the message (``m``, ``degrees`` ...).
        hint: how to fix it, ending the message.
    """
    if not (math.isfinite(value) and lo <= value <= hi):
        raise InputError(f"{where}: must be within {lo:g} .. {hi:g} {unit}, got {value:g}; {hint}")
    return value
