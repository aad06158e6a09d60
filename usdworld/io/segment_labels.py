"""The segmentation label table shipped in ``usdworld/data/segment_labels.csv``.

Columns: ``label, cityscapes, dataset``. ``label`` is a segmentation model's class name
(its config's ``id2label``), lower case; ``cityscapes`` is the Cityscapes class
(:mod:`usdworld.io.label_table`) its pixels become, empty for a class that is known but has
no Cityscapes counterpart (ADE20K's ``bed``, Mapillary's ``water``: those pixels stay
``unlabeled``); ``dataset`` says which label sets use the name (Cityscapes' 19 train classes,
ADE20K's 150, Mapillary Vistas v1.2's 66).

The mapping follows the Cityscapes annotation rules: curbs and curb cuts are ``sidewalk``,
lane markings, manholes and catch basins ``road``, street lights and sign frames ``pole``,
vans ``car`` (Cordts et al. 2016, and the Cityscapes labelling policy).

The table is read once, here at the edge; :mod:`usdworld.perception.segment` looks model
class names up in it.

Example:
    >>> segment_labels()["curb"]
    'sidewalk'
    >>> segment_labels()["bed"]
    ''
"""

from __future__ import annotations

import csv
import functools
import io

from usdworld.errors import InputError
from usdworld.io.label_table import label_table
from usdworld.resources import data_dir

TABLE_NAME = "segment_labels.csv"
_COLUMNS = ("label", "cityscapes", "dataset")


def normalise_label(name: str) -> str:
    """A model class name as the table spells it: lower case, inner whitespace single, ends stripped."""
    return " ".join(str(name).lower().split())


def parse_segment_labels(text: str, source: str = TABLE_NAME) -> dict[str, str]:
    """Model label -> Cityscapes class name ('' = known, left unlabelled) from the CSV text.

    Raises:
        InputError: wrong columns, an empty or not normalised label, a label listed twice,
            or a Cityscapes name the class table does not have (names the row).
    """
    reader = csv.DictReader(io.StringIO(text))
    if tuple(reader.fieldnames or ()) != _COLUMNS:
        raise InputError(f"{source}: the header must be {','.join(_COLUMNS)}, got {reader.fieldnames}")
    names = {c.name for c in label_table()}
    table: dict[str, str] = {}
    for row_no, row in enumerate(reader, start=2):
        label = row["label"] or ""
        target = (row["cityscapes"] or "").strip()
        if not label or label != normalise_label(label):
            raise InputError(f"{source}: row {row_no}: label {label!r} must be non-empty, lower case, single-spaced")
        if label in table:
            raise InputError(f"{source}: row {row_no}: label '{label}' is listed twice; keep one row")
        if target and target not in names:
            raise InputError(f"{source}: row {row_no}: '{target}' is not a Cityscapes class name")
        table[label] = target
    return table


@functools.lru_cache(maxsize=1)
def segment_labels() -> dict[str, str]:
    """The shipped table (read once per process); treat the result as read-only."""
    return parse_segment_labels((data_dir() / TABLE_NAME).read_text(encoding="utf-8"))
