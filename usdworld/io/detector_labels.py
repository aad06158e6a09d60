"""The detector label table shipped in ``usdworld/data/detector_labels.csv``.

Columns: ``label, placed_as, dataset``. ``label`` is a detector's or dataset's class name,
lower case (KITTI ``Van`` is ``van``); ``placed_as`` is the usdworld asset class its objects
become, empty for a label that is known but not placed (nuScenes ``barrier`` and
``traffic_cone``: no asset class of usdworld stands for them, so they are dropped with the
warning every unplaced label gets); ``dataset`` says where the label comes from (KITTI
object labels, nuScenes detection classes, COCO, or a free-form detector name).

The table is read once, here at the edge; :func:`usdworld.perception.classes.placed_class_for_label`
looks labels up in it.

Example:
    >>> detector_labels()["van"]
    'van'
    >>> detector_labels()["traffic_cone"]
    ''
"""

from __future__ import annotations

import csv
import functools
import io

from usdworld.errors import InputError
from usdworld.resources import data_dir

TABLE_NAME = "detector_labels.csv"
_COLUMNS = ("label", "placed_as", "dataset")


def parse_detector_labels(text: str, source: str = TABLE_NAME) -> dict[str, str]:
    """Label -> placed class ('' = known, not placed) from the table's CSV text.

    Raises:
        InputError: wrong columns, an empty or upper-case label, or a label listed twice
            (names the row).
    """
    reader = csv.DictReader(io.StringIO(text))
    if tuple(reader.fieldnames or ()) != _COLUMNS:
        raise InputError(f"{source}: the header must be {','.join(_COLUMNS)}, got {reader.fieldnames}")
    table: dict[str, str] = {}
    for row_no, row in enumerate(reader, start=2):
        label = (row["label"] or "").strip()
        placed = (row["placed_as"] or "").strip()
        if not label or label != label.lower():
            raise InputError(f"{source}: row {row_no}: label {label!r} must be non-empty and lower case")
        if label in table:
            raise InputError(f"{source}: row {row_no}: label '{label}' is listed twice; keep one row")
        table[label] = placed
    return table


@functools.lru_cache(maxsize=1)
def detector_labels() -> dict[str, str]:
    """The shipped table (read once per process); treat the result as read-only."""
    return parse_detector_labels((data_dir() / TABLE_NAME).read_text(encoding="utf-8"))
