"""Lookups from input class labels to the placed asset classes.

The Cityscapes table is data (``usdworld/data/cityscapes_labels.csv``, read by
:mod:`usdworld.io.label_table`); this module only derives lookup arrays from it and
maps detector labels (KITTI, free-form JSON) onto the same placed classes.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from usdworld.io.label_table import label_table

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

#: Cityscapes names of the ground surfaces usdworld meshes.
GROUND_SURFACES = ("road", "sidewalk")
#: Cityscapes names on which an object can stand (a column whose next pixel below
#: is one of these counts as visible ground contact).
GROUND_NAMES = ("road", "sidewalk", "parking", "rail track", "ground", "terrain")


@dataclass(frozen=True)
class LabelLookups:
    """Arrays indexed by Cityscapes label id (0..255).

    Attributes:
        placed: (256,) object array, placed class name or '' when the id is not placed.
        is_thing: (256,) bool, the id has instances.
        is_ground: (256,) bool, objects can stand on this id.
        names: (256,) object array of Cityscapes names ('' for unknown ids).
    """

    placed: np.ndarray
    is_thing: np.ndarray
    is_ground: np.ndarray
    names: np.ndarray

    def id_of(self, name: str) -> int:
        """Label id of a Cityscapes name."""
        hits = np.nonzero(self.names == name)[0]
        if len(hits) == 0:
            raise KeyError(name)
        return int(hits[0])


@lru_cache(maxsize=1)
def label_lookups() -> LabelLookups:
    """The lookup arrays derived from the Cityscapes class table."""
    placed = np.full(256, "", dtype=object)
    names = np.full(256, "", dtype=object)
    is_thing = np.zeros(256, dtype=bool)
    is_ground = np.zeros(256, dtype=bool)
    for cls in label_table():
        if not 0 <= cls.id < 256:
            continue
        names[cls.id] = cls.name
        placed[cls.id] = cls.placed_as or ""
        is_thing[cls.id] = bool(cls.has_instances)
        is_ground[cls.id] = cls.name in GROUND_NAMES
    for arr in (placed, names, is_thing, is_ground):
        arr.setflags(write=False)
    return LabelLookups(placed, is_thing, is_ground, names)


def placed_class_for_label(label: str) -> str | None:
    """Placed class for a detector or Cityscapes label, or None when it is not placed.

    Args:
        label: class name as written in the input, any case (``Car``, ``Pedestrian``,
            ``person``, ``traffic light``).
    """
    key = label.strip().lower()
    if key in DETECTOR_LABELS:
        return DETECTOR_LABELS[key]
    lookups = label_lookups()
    hits = np.nonzero(lookups.names == key)[0]
    if len(hits) and lookups.placed[hits[0]]:
        return str(lookups.placed[hits[0]])
    return None
