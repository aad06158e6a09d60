"""The street stage of ``build``: with boxes but no labels, the stuff map inferred from the photo.

Wires the detections' boxes, the camera's horizon and the street's vanishing point to
:mod:`usdworld.perception.streets`, and turns the inferred map's stuff (facades, trees) into
objects whose source class is marked ``inferred:`` (provenance says what was not given).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.vanishing import VanishingPoint
from usdworld.io.class_table import ClassTable
from usdworld.io.label_table import label_lookups
from usdworld.io.types import Segmentation, SourceImage
from usdworld.parameters import Parameters
from usdworld.perception.facades import StreetView
from usdworld.perception.objects import INFERRED_PREFIX, ImageObject, objects_from_segmentation
from usdworld.perception.streets import NoStreetError, StreetBox, StreetLabels, infer_street_labels


def infer_streets(
    image: SourceImage,
    objects: list[ImageObject],
    camera: PinholeCamera,
    vanishing: VanishingPoint | None,
    table: ClassTable,
    params: Parameters,
) -> tuple[StreetLabels | None, str]:
    """The stuff map inferred from the photo, the things and the camera's horizon; or None and why not."""
    view = StreetView(
        camera.horizon_v(),
        float(camera.K[0, 0]),
        float(camera.K[0, 2]),
        float(camera.height_m),
        float(vanishing.u) if vanishing is not None else None,
    )
    boxes = [
        StreetBox(np.asarray(o.box_px, dtype=np.float64), table[o.class_name].yaw == "road")
        for o in objects
        if o.is_thing
    ]
    try:
        return infer_street_labels(image.rgb, boxes, view, params.perception), ""
    except NoStreetError as exc:
        return None, f"{image.file.name}: no road, sidewalk or buildings inferred: {exc}"


def inferred_stuff(seg: Segmentation, view: StreetView | None, table: ClassTable, params: Parameters) -> list[ImageObject]:
    """The stuff objects (facades, trees) of an inferred map, their source class marked ``inferred:``."""
    stuff = objects_from_segmentation(seg, view, table, label_lookups(), params.perception)
    return [replace(o, source_label=f"{INFERRED_PREFIX}{o.source_label}") for o in stuff if not o.is_thing]
