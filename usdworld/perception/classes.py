"""Input class labels (detector or Cityscapes) to the placed asset classes.

The Cityscapes table is data (``usdworld/data/cityscapes_labels.csv``), read with its
lookup arrays by :mod:`usdworld.io.label_table` at the edge and passed in here; this
module maps detector labels (KITTI, free-form JSON) onto the same placed classes.
"""

from __future__ import annotations

import numpy as np

from usdworld.io.label_table import LabelLookups

#: Detector / KITTI label (lower case) -> placed class. Cityscapes names are
#: accepted too (see :func:`placed_class_for_label`).
DETECTOR_LABELS: dict[str, str] = {
    "car": "car",
    "van": "car",
    "truck": "truck",
    "bus": "bus",
    "tram": "train",
    "train": "train",
    "pedestrian": "person",
    "person": "person",
    "person_sitting": "person",
    "cyclist": "rider",
    "rider": "rider",
    "bicycle": "bicycle",
    "motorcycle": "motorcycle",
    "motorbike": "motorcycle",
    "misc": "misc",
    "tree": "tree",
    "building": "building",
    "pole": "pole",
    "traffic_light": "traffic_light",
    "traffic light": "traffic_light",
    "traffic_sign": "traffic_sign",
    "traffic sign": "traffic_sign",
    "fence": "fence",
    "wall": "fence",
}


def placed_class_for_label(label: str, lookups: LabelLookups) -> str | None:
    """Placed class for a detector or Cityscapes label, or None when it is not placed.

    Args:
        label: class name as written in the input, any case (``Car``, ``Pedestrian``,
            ``person``, ``traffic light``).
        lookups: the Cityscapes table's arrays (:func:`usdworld.io.label_table.label_lookups`).
    """
    key = label.strip().lower()
    if key in DETECTOR_LABELS:
        return DETECTOR_LABELS[key]
    hits = np.nonzero(lookups.names == key)[0]
    if len(hits) and lookups.placed[hits[0]]:
        return str(lookups.placed[hits[0]])
    return None
