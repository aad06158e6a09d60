"""The photo's own cues to a focal length no camera file gives (objects, lines, EXIF), fused.

Collects the cues of :mod:`usdworld.geometry.focal` for one photo: the prior, the EXIF
focal length when the file states one, the orthogonal pairs among the street's, the
vertical and the lateral (across the street, :mod:`usdworld.geometry.lateral`) vanishing
points, and the box shapes of whole vehicles of the classes that align with the road.
The pitch and roll the vanishing points imply at the fused focal length are recorded.

Frames: image pixels (u right, v down).
"""

from __future__ import annotations

from collections.abc import Sequence

from dataclasses import replace

import numpy as np

from usdworld.geometry.focal import BoxShapes, FocalCue, FocalEstimate, box_shape_cue, exif_cue, fuse_focal, prior_cue
from usdworld.geometry.lateral import lateral_focal_cue, tilt_from_vanishing_points
from usdworld.geometry.vanishing import (
    VanishingPoint,
    VerticalVanishingPoint,
    horizon_measurement,
    vanishing_focal_cue,
)
from usdworld.io.class_table import ClassTable
from usdworld.io.exif import ExifFocal
from usdworld.parameters.camera import CameraParams
from usdworld.perception.objects import ImageObject


#: The class whose size the box-shape cue takes from ``CameraParams.shape_car_size_m``.
CAR_CLASS = "car"


def box_shapes(
    objects: Sequence[ImageObject], table: ClassTable, width: int, height: int, params: CameraParams
) -> BoxShapes:
    """Vehicles usable by the box-shape cue: classes aligned with the road and of rigid height,
    whose box touches no image border and whose bottom is neither cut nor hidden, with their
    box's edges (:attr:`~usdworld.perception.objects.ImageObject.edges_px`).

    Sizes are the class table's, except a car's: ``params.shape_car_size_m`` (published
    proportions; the table's car is sized for the camera-height fit).

    Args:
        objects: the image objects.
        table: the class table (sizes and height spreads).
        width: image width, pixels.
        height: image height, pixels.
        params: the car's size for this cue.
    """
    rows, sizes, stds = [], [], []
    for o in objects:
        prior = table[o.class_name]
        if prior.yaw != "road" or not prior.rigid_height or prior.kind != "thing":
            continue
        x0, _, x1, y1 = (int(v) for v in o.box_px)
        if o.top_truncated or o.bottom_truncated or o.bottom_occluded or x0 <= 0 or x1 >= width or y1 >= height:
            continue
        # the box's own edges (sub-pixel for a detection), which the cue's projected box
        # predicts; the whole pixels it touches reach up to a pixel further on each side
        rows.append(tuple(float(v) for v in o.edges_px))
        sizes.append(params.shape_car_size_m if o.class_name == CAR_CLASS else prior.size_m)
        stds.append(prior.height_std_m)
    return BoxShapes(
        np.array(rows, dtype=np.float64).reshape(-1, 4),
        np.array(sizes, dtype=np.float64).reshape(-1, 3),
        np.array(stds, dtype=np.float64),
    )


def estimate_focal(
    width: int,
    height: int,
    objects: Sequence[ImageObject],
    table: ClassTable,
    street: VanishingPoint | None,
    segments: np.ndarray,
    vertical: VerticalVanishingPoint | None,
    exif: ExifFocal | None,
    params: CameraParams,
) -> FocalEstimate:
    """Every focal cue of the photo, fused with the prior (:func:`usdworld.geometry.focal.fuse_focal`).

    Args:
        width: image width, pixels.
        height: image height, pixels.
        objects: the image objects.
        table: the class table.
        street: the street's vanishing point, or None.
        segments: (N, 4) the photo's line segments, pixels.
        vertical: the vertical's vanishing point on ``segments``
            (:func:`~usdworld.geometry.vanishing.find_vertical_vanishing_point`), or None.
        exif: the EXIF focal length, or None.
        params: the camera parameters.
    """
    prior = prior_cue(width, height, params)
    cues: list[FocalCue] = [prior]
    if exif is not None:
        cues.append(exif_cue(exif.f_px, exif.detail, params))
    vp = vanishing_focal_cue(street, vertical, width, height, params)
    if vp is not None:
        cues.append(vp)
    lateral = None
    if street is not None:
        lateral_cue, point = lateral_focal_cue(street, segments, width, height, params)
        if lateral_cue is not None:  # a point whose cue is too weak to use does not fix the horizon either
            cues.append(lateral_cue)
            lateral = point
    horizon = horizon_measurement(street, prior.f_px, params) if street is not None else None
    shape = box_shape_cue(
        width, height, box_shapes(objects, table, width, height, params), street.u if street else None, horizon, params
    )
    if shape is not None:
        cues.append(shape)
    fused = fuse_focal(cues, params)
    tilt = tilt_from_vanishing_points(
        fused.f_px,
        width,
        height,
        vertical.point_h if vertical is not None else None,
        street,
        lateral.point_h if lateral is not None else None,
    )
    if vertical is not None:
        source = f"the vertical of {len(vertical.inliers)} upright segments"
    else:
        source = "the street's and the lateral vanishing points"
    return replace(fused, tilt=tilt, tilt_source=source if tilt is not None else "")
