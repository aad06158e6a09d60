"""Input class labels (detector or Cityscapes) to the placed asset classes.

The Cityscapes table is data (``usdworld/data/cityscapes_labels.csv``), read with its
lookup arrays by :mod:`usdworld.io.label_table` at the edge and passed in here; this
module maps detector labels (KITTI, nuScenes, COCO, free-form JSON) onto the same placed
classes through the detector label table (``usdworld/data/detector_labels.csv``, read by
:mod:`usdworld.io.detector_labels`).
"""

from __future__ import annotations

import numpy as np

from usdworld.io.detector_labels import detector_labels
from usdworld.io.label_table import LabelLookups


def placed_class_for_label(label: str, lookups: LabelLookups) -> str | None:
    """Placed class for a detector or Cityscapes label, or None when it is not placed.

    Args:
        label: class name as written in the input, any case (``Car``, ``Pedestrian``,
            ``person``, ``traffic light``).
        lookups: the Cityscapes table's arrays (:func:`usdworld.io.label_table.label_lookups`).
    """
    key = label.strip().lower()
    table = detector_labels()
    if key in table:
        return table[key] or None
    hits = np.nonzero(lookups.names == key)[0]
    if len(hits) and lookups.placed[hits[0]]:
        return str(lookups.placed[hits[0]])
    return None
