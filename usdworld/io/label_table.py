"""The Cityscapes class table shipped in ``usdworld/data/cityscapes_labels.csv``.

Columns: ``id, name, category, has_instances, r, g, b, placed_as``. ``placed_as`` is
the usdworld asset class an object of this class becomes (empty: not placed).

:func:`label_lookups` derives the arrays perception indexes by label id from it; it is
read once, here at the edge, and passed into perception (which reads no files).

Example:
    >>> by_name("car").id
    26
    >>> by_id(26).placed_as
    'car'
"""

from __future__ import annotations

import csv
import functools
import io
from dataclasses import dataclass

import cv2
import numpy as np

from usdworld.errors import InputError
from usdworld.resources import data_dir

TABLE_NAME = "cityscapes_labels.csv"
_COLUMNS = ("id", "name", "category", "has_instances", "r", "g", "b", "placed_as")
#: Cityscapes names on which an object can stand (a column whose next pixel below
#: is one of these counts as visible ground contact).
GROUND_NAMES = ("road", "sidewalk", "parking", "rail track", "ground", "terrain")


@dataclass(frozen=True)
class LabelClass:
    """One Cityscapes class.

    Attributes:
        id: label id as stored in ``*_labelIds.png`` (0..255).
        name: Cityscapes name (``car``, ``traffic sign`` ...).
        category: Cityscapes category (``flat``, ``vehicle`` ...).
        has_instances: True for thing classes whose objects get ``id*1000+k`` instance ids.
        color: (r, g, b) colour of the class in ``*_color.png``.
        placed_as: usdworld asset class for objects of this class, or None when not placed.
    """

    id: int
    name: str
    category: str
    has_instances: bool
    color: tuple[int, int, int]
    placed_as: str | None

    def __post_init__(self) -> None:
        if not 0 <= self.id <= 255:
            raise InputError(f"{TABLE_NAME}: class '{self.name}' has id {self.id}; ids must be in 0..255")
        if not all(0 <= c <= 255 for c in self.color):
            raise InputError(f"{TABLE_NAME}: class '{self.name}' has colour {self.color}; use 0..255")


def _parse_table(text: str) -> tuple[LabelClass, ...]:
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or tuple(c.strip() for c in rows[0]) != _COLUMNS:
        raise InputError(f"{TABLE_NAME}: header must be {','.join(_COLUMNS)}; reinstall usdworld")
    classes = []
    for line_no, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        if len(row) != len(_COLUMNS):
            raise InputError(f"{TABLE_NAME}: line {line_no} has {len(row)} fields, expected {len(_COLUMNS)}")
        try:
            id_, r, g, b, inst = (int(row[i]) for i in (0, 4, 5, 6, 3))
        except ValueError as exc:
            raise InputError(f"{TABLE_NAME}: line {line_no}: {exc}; fix the class table") from exc
        placed = row[7].strip()
        classes.append(
            LabelClass(
                id=id_,
                name=row[1].strip(),
                category=row[2].strip(),
                has_instances=bool(inst),
                color=(r, g, b),
                placed_as=placed or None,
            )
        )
    ids = [c.id for c in classes]
    if len(set(ids)) != len(ids):
        raise InputError(f"{TABLE_NAME}: duplicate class ids; fix the class table")
    return tuple(classes)


@functools.cache
def label_table() -> tuple[LabelClass, ...]:
    """All classes of the shipped table, in file order (read once per process).

    Raises:
        InputError: the table is missing or malformed (a broken installation).
    """
    path = data_dir() / TABLE_NAME
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{path}: cannot read the class table ({exc}); reinstall usdworld") from exc
    return _parse_table(text)


@functools.cache
def _index() -> tuple[dict[int, LabelClass], dict[str, LabelClass]]:
    table = label_table()
    return {c.id: c for c in table}, {c.name: c for c in table}


def known_ids() -> frozenset[int]:
    """The label ids the table defines."""
    return frozenset(_index()[0])


def by_id(label_id: int) -> LabelClass:
    """The class with label id ``label_id``.

    Raises:
        InputError: no class has that id.
    """
    try:
        return _index()[0][int(label_id)]
    except KeyError:
        raise InputError(
            f"label id {label_id} is not in the Cityscapes class table ({TABLE_NAME}); "
            f"use Cityscapes labelIds ({min(known_ids())}..{max(known_ids())})"
        ) from None


def by_name(name: str) -> LabelClass:
    """The class named ``name`` (exact Cityscapes spelling, e.g. ``traffic sign``).

    Raises:
        InputError: no class has that name.
    """
    try:
        return _index()[1][name]
    except KeyError:
        raise InputError(
            f"class name '{name}' is not in the Cityscapes class table ({TABLE_NAME}); "
            "use a Cityscapes class name such as 'car' or 'traffic sign'"
        ) from None


@dataclass(frozen=True)
class LabelLookups:
    """Arrays indexed by Cityscapes label id (0..255).

    Attributes:
        placed: (256,) object array, placed class name or '' when the id is not placed.
        is_thing: (256,) bool, the id has instances.
        is_ground: (256,) bool, objects can stand on this id (:data:`GROUND_NAMES`).
        names: (256,) object array of Cityscapes names ('' for unknown ids).
    """

    placed: np.ndarray
    is_thing: np.ndarray
    is_ground: np.ndarray
    names: np.ndarray

    def id_of(self, name: str) -> int:
        """Label id of a Cityscapes name.

        Raises:
            KeyError: no class has that name.
        """
        hits = np.nonzero(self.names == name)[0]
        if len(hits) == 0:
            raise KeyError(name)
        return int(hits[0])


def lookups_from_table(table: tuple[LabelClass, ...]) -> LabelLookups:
    """The lookup arrays of a class table (read-only arrays)."""
    placed = np.full(256, "", dtype=object)
    names = np.full(256, "", dtype=object)
    is_thing = np.zeros(256, dtype=bool)
    is_ground = np.zeros(256, dtype=bool)
    for cls in table:
        names[cls.id] = cls.name
        placed[cls.id] = cls.placed_as or ""
        is_thing[cls.id] = bool(cls.has_instances)
        is_ground[cls.id] = cls.name in GROUND_NAMES
    for arr in (placed, names, is_thing, is_ground):
        arr.setflags(write=False)
    return LabelLookups(placed, is_thing, is_ground, names)


@functools.cache
def label_lookups() -> LabelLookups:
    """The lookup arrays of the shipped table (built once per process)."""
    return lookups_from_table(label_table())


def label_values(label_ids: np.ndarray, table: np.ndarray) -> np.ndarray:
    """(H, W) uint8 ``table[label_ids]``: a value per label id, by one OpenCV table lookup.

    Args:
        label_ids: (H, W) uint8 label id per pixel (as read from ``*_labelIds.png``).
        table: (256,) uint8 value of each label id.
    """
    return cv2.LUT(np.ascontiguousarray(label_ids, dtype=np.uint8), np.asarray(table, dtype=np.uint8))


def label_mask(label_ids: np.ndarray, ids) -> np.ndarray:
    """(H, W) bool: the pixels whose label is one of ``ids`` (``np.isin(label_ids, ids)``).

    One 256-entry table lookup over the 8-bit label map (OpenCV's, several times faster
    than ``np.isin``'s comparison per id on a 2048x1024 map); other dtypes use ``np.isin``.

    Args:
        label_ids: (H, W) label id per pixel (uint8 as read from ``*_labelIds.png``).
        ids: the label ids wanted (0..255 for a uint8 map).
    """
    labels = np.asarray(label_ids)
    wanted = [int(i) for i in ids]
    small = all(0 <= i < 256 for i in wanted)
    if labels.dtype != np.uint8 or labels.ndim != 2 or labels.size == 0 or not small:
        return np.isin(labels, wanted)
    table = np.zeros(256, dtype=np.uint8)
    table[wanted] = 1
    return label_values(labels, table).view(bool)
