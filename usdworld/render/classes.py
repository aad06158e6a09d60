"""Semantic class label (``LabelsAPI`` taxonomy ``class``) -> Cityscapes label id.

The mapping is derived from the class table (:mod:`usdworld.io.label_table`), not
written out here, by three rules applied in order:

1. **Placed classes.** The ``placed_as`` column read backwards: a world object labelled
   ``car`` came from Cityscapes ``car`` (26), ``tree`` from ``vegetation`` (21),
   ``building`` from ``building`` (11). When several Cityscapes classes are placed as the
   same asset class (``wall`` and ``fence`` -> ``fence``; ``truck``, ``caravan`` and
   ``trailer`` -> ``truck``; ``pole`` and ``polegroup`` -> ``pole``), the Cityscapes class
   of the same name wins (fence 13, truck 27, pole 17), otherwise the lowest id.
2. **Cityscapes names.** Every Cityscapes class name, with spaces written as underscores,
   maps to its own id: ``road`` 7, ``sidewalk`` 8, ``terrain`` 22, ``sky`` 23,
   ``vegetation`` 21, ``traffic_light`` 19 ...
3. Anything else is void (0).

Labels are compared in lower case and with spaces and hyphens read as underscores.
Thing classes (``has_instances`` in the table: person, rider, car, truck, bus, caravan,
trailer, train, motorcycle, bicycle) get per-object instance ids ``id*1000+k``.

Example:
    >>> label_id_for_class("car"), label_id_for_class("tree"), label_id_for_class("road")
    (26, 21, 7)
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from types import MappingProxyType

from usdworld.io.label_table import label_table

#: Label id of pixels and meshes with no (or an unknown) class label.
VOID_ID = 0


def normalise_label(label: str) -> str:
    """``"Traffic Light"`` -> ``"traffic_light"``."""
    return label.strip().lower().replace(" ", "_").replace("-", "_")


@functools.cache
def class_label_ids() -> Mapping[str, int]:
    """The whole mapping, label token -> Cityscapes label id (see the module docstring)."""
    table = label_table()
    mapping: dict[str, int] = {}
    placed: dict[str, list[tuple[int, str]]] = {}
    for row in table:
        if row.placed_as:
            placed.setdefault(normalise_label(row.placed_as), []).append((row.id, normalise_label(row.name)))
    for token, rows in placed.items():
        same_name = [i for i, name in rows if name == token]
        mapping[token] = same_name[0] if same_name else min(i for i, _ in rows)
    for row in table:
        mapping.setdefault(normalise_label(row.name), row.id)
    return MappingProxyType(mapping)


@functools.cache
def thing_label_ids() -> frozenset[int]:
    """Label ids whose objects get their own instance ids (``has_instances`` in the table)."""
    return frozenset(row.id for row in label_table() if row.has_instances)


@functools.lru_cache(maxsize=4096)
def label_id_for_class(label: str | None) -> int:
    """Cityscapes label id of a class label; :data:`VOID_ID` for None or unknown labels.

    Remembered per label: a scene asks once per mesh (54,000 times for 10,000 objects).
    """
    if not label:
        return VOID_ID
    return class_label_ids().get(normalise_label(label), VOID_ID)
