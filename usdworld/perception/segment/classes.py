"""A segmentation model's classes to Cityscapes label ids.

A model names its classes in its config (``id2label``). Each name is looked up, after
:func:`~usdworld.io.segment_labels.normalise_label`, in the segmentation label table
(``usdworld/data/segment_labels.csv``, read at the edge and passed in), then among the
Cityscapes class names themselves; a name found in neither is *unknown*: its pixels are
left ``unlabeled`` and counted (:func:`unknown_pixels`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from usdworld.errors import InputError
from usdworld.io.label_table import LabelLookups
from usdworld.io.segment_labels import normalise_label

#: Cityscapes name of the pixels no class claims.
UNLABELED = "unlabeled"


@dataclass(frozen=True)
class ClassMap:
    """Model class index -> Cityscapes label id.

    Attributes:
        label_ids: (N,) uint8, the Cityscapes label id of each model class index.
        names: the model's class names by index (N).
        unknown: (N,) bool, True where the name is in neither table.
    """

    label_ids: np.ndarray
    names: tuple[str, ...]
    unknown: np.ndarray


def class_map(id2label: Mapping[int | str, str], table: Mapping[str, str], lookups: LabelLookups) -> ClassMap:
    """Map a model's classes to Cityscapes label ids.

    Args:
        id2label: the model config's class names by index (keys int or decimal strings,
            as transformers stores them).
        table: model label -> Cityscapes name ('' = known, unlabelled)
            (:func:`usdworld.io.segment_labels.segment_labels`).
        lookups: the Cityscapes table's arrays.

    Returns:
        The map; indices missing from ``id2label`` count as unknown classes named by their index.

    Raises:
        InputError: ``id2label`` is empty, has a key that is not a non-negative integer, or
            more than 65536 classes.

    Example:
        >>> from usdworld.io.label_table import label_lookups
        >>> class_map({0: "Curb", 1: "bed", 2: "zebra"}, {"curb": "sidewalk", "bed": ""}, label_lookups()).label_ids
        array([8, 0, 0], dtype=uint8)
    """
    if not id2label:
        raise InputError("segmentation model: its config has no id2label (class names); save it with them")
    try:
        by_index = {int(k): str(v) for k, v in id2label.items()}
    except (TypeError, ValueError) as exc:
        raise InputError(f"segmentation model: id2label keys must be integers ({exc})") from None
    if min(by_index) < 0 or max(by_index) >= 65536:
        raise InputError(f"segmentation model: id2label indices must be in 0..65535, got {min(by_index)}..{max(by_index)}")
    n = max(by_index) + 1
    unlabeled = lookups.id_of(UNLABELED)
    ids = np.full(n, unlabeled, dtype=np.uint8)
    unknown = np.zeros(n, dtype=bool)
    names = []
    for i in range(n):
        name = by_index.get(i, str(i))
        names.append(name)
        key = normalise_label(name)
        if key in table:
            ids[i] = lookups.id_of(table[key]) if table[key] else unlabeled
        elif np.any(lookups.names == key):
            ids[i] = lookups.id_of(key)
        else:
            unknown[i] = True
    ids.setflags(write=False)
    unknown.setflags(write=False)
    return ClassMap(ids, tuple(names), unknown)


def unknown_pixels(model_classes: np.ndarray, classes: ClassMap) -> tuple[tuple[str, int], ...]:
    """(name, pixels) of the unknown classes present in a map of model class indices.

    Args:
        model_classes: (H, W) integer model class index per pixel; negative = no class.
        classes: the model's class map.
    """
    values = np.asarray(model_classes).ravel()
    counts = np.bincount(values[(values >= 0) & (values < len(classes.names))], minlength=len(classes.names))
    return tuple((classes.names[i], int(counts[i])) for i in np.flatnonzero(classes.unknown & (counts > 0)))
