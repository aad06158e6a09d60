"""Objects for the placement tests: a box filled by its mask, and placing them on a straight road (shared by the test modules)."""

from __future__ import annotations

from typing import Any

import numpy as np

from usdworld.authoring.asset_library import library_dirs
from usdworld.authoring.asset_measures import asset_catalogue
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.class_table import load_class_table
from usdworld.layout.draft import DepthMethod
from usdworld.layout.placement import Placement, Skipped, place_objects
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.perception.objects import ImageObject


def box_object(
    class_name: str,
    box: tuple[int, int, int, int],
    ref: int,
    hidden: bool = False,
    by: int = -1,
    source_label: str | None = None,
    instance_id: int | None = None,
) -> ImageObject:
    """An object whose mask fills its box, its contact below the box's middle column.

    Args:
        class_name: its class (a car gets ``ref`` as its instance id, others are stuff).
        box: (x0, y0, x1, y1) pixels, x1/y1 exclusive.
        ref: its identifier in the image.
        hidden: its bottom is hidden.
        by: the ``ref`` of what hides it (-1 none).
        source_label: the label it came from (default: its class).
        instance_id: its instance id (default: ``ref`` for a car, -1 for others).
    """
    x0, y0, x1, y1 = box
    return ImageObject(
        class_name=class_name,
        source_label=class_name if source_label is None else source_label,
        instance_id=(ref if class_name == "car" else -1) if instance_id is None else instance_id,
        box_px=np.array(box, dtype=np.int64),
        mask=np.ones((y1 - y0, x1 - x0), bool),
        contact_px=np.array([(x0 + x1) / 2.0, y1 - 0.5]),
        bottom_truncated=False,
        bottom_occluded=hidden,
        top_truncated=False,
        occluded_by=by,
        ref=ref,
    )


def ground_placement(
    class_name: str,
    xy: tuple[float, float],
    box: tuple[int, int, int, int],
    size_m: tuple[float, float, float],
    method: DepthMethod = DepthMethod.CONTACT,
    cues: tuple[DepthCue, ...] = (),
    ref: int = 1,
) -> Placement:
    """A placement of :func:`box_object` ``(class_name, box, ref)`` standing at ``xy`` on the ground
    (yaw 0, scale 1), its depth the distance from the world's origin.

    Args:
        class_name: its class; it is named ``{class_name}_{ref:04d}``.
        xy: its ground position, metres.
        box: its image box (x0, y0, x1, y1), pixels.
        size_m: its size (length, width, height), metres.
        method: the depth method it was placed by.
        cues: the depth cues it was placed from.
        ref: its identifier in the image.
    """
    x, y = xy
    return Placement(
        name=f"{class_name}_{ref:04d}",
        obj=box_object(class_name, box, ref),
        variant="default",
        position_world=np.array([x, y, 0.0]),
        yaw=0.0,
        yaw_source="road",
        scale=1.0,
        stretch=np.ones(3),
        scale_measured=1.0,
        size_m=np.array(size_m, dtype=np.float64),
        depth_m=float(np.hypot(x, y)),
        method=method,
        cues=cues,
    )


def place_on_a_straight_road(
    objects: list[ImageObject], camera: PinholeCamera, **kwargs: Any
) -> tuple[list[Placement], list[Skipped]]:
    """:func:`place_objects` of ``objects`` with the built-in assets' sizes, the camera's own ground
    homography, a road axis along the camera and the default placement parameters (``kwargs``
    pass on, e.g. ``collision``)."""
    sizes = asset_catalogue((o.class_name for o in objects), library_dirs(None))
    return place_objects(
        objects,
        camera,
        np.linalg.inv(camera.px_from_ground()),
        RoadAxis(0.0, np.zeros(2), "camera_forward"),
        sizes,
        load_class_table(),
        PlacementParams(),
        **kwargs,
    )
