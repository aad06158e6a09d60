"""Read Cityscapes-style dense labels into a :class:`Segmentation`.

Two inputs are understood:

* ``*_gtFine_labelIds.png`` (8-bit, one Cityscapes label id per pixel) with an optional
  ``*_gtFine_instanceIds.png`` (16-bit; ``class*1000+k`` on objects of thing classes,
  the label id elsewhere) -- :func:`read_segmentation`;
* ``*_gtFine_polygons.json`` (``imgWidth``, ``imgHeight``, ``objects: [{label, polygon}]``)
  rasterised the way cityscapesScripts' ``json2labelImg`` / ``json2instanceImg`` do --
  :func:`read_polygons`.

Label ids are checked against the shipped class table (:mod:`usdworld.io.label_table`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from usdworld.errors import InputError
from usdworld.io.hashing import (
    PathLike,
    as_array,
    as_float,
    as_object,
    json_type,
    parse_json,
    read_input,
    require,
)
from usdworld.io.images import PNG_COLOR_TYPES, decode_unchanged, png_header, sniff_format
from usdworld.io.label_table import TABLE_NAME, LabelClass, known_ids, label_table
from usdworld.io.limits import MAX_PIXELS, check_pixels
from usdworld.io.types import InputFile, Segmentation, SourceImage

logger = logging.getLogger(__name__)

#: Largest fraction of instance pixels whose class (``id // 1000``) may disagree with
#: the label map before the pair is rejected as belonging to different frames.
MAX_MISMATCH_FRACTION = 0.01

#: Cityscapes classes with a negative id: present in polygon files but never drawn.
SKIPPED_POLYGON_LABELS = frozenset({"license plate"})


def _size_text(shape: tuple[int, ...]) -> str:
    return f"{shape[1]}x{shape[0]}"


def _check_image_size(name: str, shape: tuple[int, ...], image: SourceImage | None, what: str) -> None:
    if image is not None and (shape[0], shape[1]) != (image.height, image.width):
        raise InputError(
            f"{name}: {_size_text(shape)} but the image {image.file.name} is "
            f"{image.width}x{image.height}; pass the {what} of the same frame at the same resolution"
        )


def _decode_png(data: bytes, name: str, what: str) -> np.ndarray:
    fmt = sniff_format(data)
    if fmt == "JPEG":
        raise InputError(f"{name}: is a JPEG, whose lossy compression alters ids; pass {what} as PNG")
    arr = decode_unchanged(data, name, f"{what} as PNG")
    if png_header(data)[3] == 3:
        raise InputError(f"{name}: is a palette PNG, whose colours hide the ids; pass {what} (greyscale PNG)")
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    return arr


def _list_ids(ids: list[int]) -> str:
    shown = ", ".join(str(i) for i in ids[:5])
    return shown if len(ids) <= 5 else f"{shown} (and {len(ids) - 5} more)"


def _read_label_ids(data: bytes, name: str) -> np.ndarray:
    what = "the 8-bit *_gtFine_labelIds.png"
    arr = _decode_png(data, name, what)
    if arr.ndim == 3:
        color = PNG_COLOR_TYPES.get(png_header(data)[3], f"{arr.shape[2]}-channel")
        raise InputError(
            f"{name}: is a {color} colour image; labels must be {what} (one class id per pixel), "
            "not *_color.png"
        )
    if arr.dtype == np.uint16:
        raise InputError(
            f"{name}: 16-bit where 8-bit labelIds are expected (an *_instanceIds.png?); "
            f"pass {what} as labels and the instance map as instances"
        )
    if arr.dtype != np.uint8:
        raise InputError(f"{name}: sample type {arr.dtype}; pass {what}")
    # The ids present, from OpenCV's histogram (a tenth of np.unique's time on a 2048x1024 map):
    # a float32 count of at least one pixel is never zero, however large the image.
    present = np.flatnonzero(cv2.calcHist([np.ascontiguousarray(arr)], [0], None, [256], [0, 256]).ravel())
    unknown = sorted(int(i) for i in present if int(i) not in known_ids())
    if unknown:
        hint = (
            "; this looks like *_labelTrainIds.png: pass *_labelIds.png instead"
            if 255 in unknown or "trainid" in name.lower()
            else ""
        )
        raise InputError(
            f"{name}: ids {_list_ids(unknown)} are not in the Cityscapes class table ({TABLE_NAME}); "
            f"pass Cityscapes labelIds{hint}"
        )
    return arr


def _read_instance_ids(data: bytes, name: str) -> np.ndarray:
    what = "the 16-bit *_gtFine_instanceIds.png"
    arr = _decode_png(data, name, what)
    if arr.ndim == 3:
        raise InputError(f"{name}: is a {arr.shape[2]}-channel colour image; pass {what}")
    if arr.dtype == np.uint8:
        raise InputError(
            f"{name}: 8-bit where 16-bit instanceIds are expected (a labelIds or trainIds file?); pass {what}"
        )
    if arr.dtype != np.uint16:
        raise InputError(f"{name}: sample type {arr.dtype}; pass {what}")
    return arr.astype(np.int32)


@dataclass(frozen=True)
class DecodedSegmentation:
    """A labelIds PNG and its instanceIds PNG decoded, not yet checked against the photo
    (:func:`decode_segmentation`; :meth:`checked` gives the :class:`Segmentation`).

    The photo is not needed to decode them, so a build decodes them while it decodes the photo
    (:mod:`usdworld.stage_threads`). What the instance map gives, its arrays or its error, waits
    here for :meth:`checked`, which raises the errors in :func:`read_segmentation`'s order: the
    labels' size against the photo first.

    Attributes:
        label_ids: (H, W) uint8 label ids, read-only.
        labels_file: the labels' identity (role ``labels``).
        instance_ids: (H, W) int32 instance ids, read-only, or None (none given, or unreadable).
        instances_file: the instances' identity (role ``instances``), or None.
        instances_error: the error reading the instance map gave, or None.
        mismatch: instance pixels whose class (``id // 1000``) differs from the labels, and the
            instance pixels (``id >= 1000``); (0, 0) without an instance map of the labels' size.
    """

    label_ids: np.ndarray
    labels_file: InputFile
    instance_ids: np.ndarray | None = None
    instances_file: InputFile | None = None
    instances_error: InputError | None = None
    mismatch: tuple[int, int] = (0, 0)

    def checked(self, image: SourceImage | None) -> Segmentation:
        """The segmentation, once the maps are checked against the photo and each other.

        Args:
            image: the photo; when given, the maps must have its size.

        Raises:
            InputError: as :func:`read_segmentation`, in its order.
        """
        labels_file, label_ids = self.labels_file, self.label_ids
        _check_image_size(labels_file.name, label_ids.shape, image, "labels")
        if self.instances_error is not None:
            raise self.instances_error
        if self.instance_ids is None or self.instances_file is None:
            return Segmentation(label_ids=label_ids, instance_ids=None, files=(labels_file,))
        instance_ids, inst_file = self.instance_ids, self.instances_file
        if instance_ids.shape != label_ids.shape:
            raise InputError(
                f"{inst_file.name}: {_size_text(instance_ids.shape)} but the labels {labels_file.name} are "
                f"{_size_text(label_ids.shape)}; pass the instance map of the same frame"
            )
        mismatch, n_things = self.mismatch
        if n_things:
            if mismatch > MAX_MISMATCH_FRACTION * n_things:
                raise InputError(
                    f"{inst_file.name}: at {mismatch} of {n_things} instance pixels "
                    f"({100.0 * mismatch / n_things:.1f} %) the class (id // 1000) differs from "
                    f"{labels_file.name}; pass the labels and instances of the same frame"
                )
            if mismatch:
                logger.warning(
                    "%s: at %d of %d instance pixels the class differs from %s (below %.0f %%, accepted)",
                    inst_file.name,
                    mismatch,
                    n_things,
                    labels_file.name,
                    100 * MAX_MISMATCH_FRACTION,
                )
        return Segmentation(label_ids=label_ids, instance_ids=instance_ids, files=(labels_file, inst_file))


def decode_segmentation(labels_path: PathLike, instances_path: PathLike | None = None) -> DecodedSegmentation:
    """Decode a Cityscapes labelIds PNG and, optionally, its instanceIds PNG, without the photo.

    Args:
        labels_path: ``*_gtFine_labelIds.png``, (H, W) 8-bit greyscale label ids.
        instances_path: ``*_gtFine_instanceIds.png``, (H, W) 16-bit greyscale, or None.

    Returns:
        The decoded maps; :meth:`DecodedSegmentation.checked` checks them and raises the
        instance map's errors.

    Raises:
        InputError: the labels file is missing, not a PNG of the right kind or holds ids
            outside the class table (the instance map's errors wait for ``checked``).
    """
    data, labels_file = read_input(labels_path, "labels")
    label_ids = np.ascontiguousarray(_read_label_ids(data, labels_file.name))
    label_ids.setflags(write=False)  # this reader's own arrays: Segmentation keeps them without a copy
    if instances_path is None:
        return DecodedSegmentation(label_ids, labels_file)
    try:
        data, inst_file = read_input(instances_path, "instances")
        instance_ids = _read_instance_ids(data, inst_file.name)
    except InputError as exc:
        return DecodedSegmentation(label_ids, labels_file, instances_error=exc)
    instance_ids.setflags(write=False)
    mismatch = (0, 0)
    if instance_ids.shape == label_ids.shape:
        things = instance_ids >= 1000
        n_things = int(things.sum())
        if n_things:
            mismatch = (int(np.count_nonzero(instance_ids[things] // 1000 != label_ids[things])), n_things)
    return DecodedSegmentation(label_ids, labels_file, instance_ids, inst_file, None, mismatch)


def read_segmentation(
    labels_path: PathLike,
    instances_path: PathLike | None = None,
    image: SourceImage | None = None,
) -> Segmentation:
    """Read a Cityscapes labelIds PNG and, optionally, its instanceIds PNG.

    Args:
        labels_path: ``*_gtFine_labelIds.png``, (H, W) 8-bit greyscale label ids.
        instances_path: ``*_gtFine_instanceIds.png``, (H, W) 16-bit greyscale, or None.
        image: the photo; when given, the maps must have its size.

    Returns:
        Segmentation with ``label_ids`` (H, W) uint8, ``instance_ids`` (H, W) int32 or None,
        and ``files`` = (labels, instances) identities (roles ``labels`` / ``instances``).

    Raises:
        InputError: a file is missing, not a PNG of the right kind (colour, wrong bit
            depth), of another size, holds ids outside the class table, or more than
            :data:`MAX_MISMATCH_FRACTION` of the instance pixels disagree with the labels.
    """
    return decode_segmentation(labels_path, instances_path).checked(image)


def _as_size(value: Any, where: str) -> int:
    f = as_float(value, where)
    if f != int(f) or f <= 0:
        raise InputError(f"{where}: must be a positive integer, got {value}")
    return int(f)


def _polygon_points(value: Any, where: str, width: int, height: int) -> np.ndarray:
    points = as_array(value, where)
    if len(points) < 3:
        raise InputError(f"{where}: needs at least 3 [x, y] points, got {len(points)}")
    out = np.empty((len(points), 2), dtype=np.float64)
    for i, p in enumerate(points):
        pair = as_array(p, f"{where} -> [{i}]")
        if len(pair) != 2:
            raise InputError(f"{where} -> [{i}]: must be [x, y], got {len(pair)} numbers")
        out[i] = [
            as_float(pair[0], f"{where} -> [{i}] -> [0]"),
            as_float(pair[1], f"{where} -> [{i}] -> [1]"),
        ]
    check_pixels(out, width, height, where)  # before the int32 cast: 1e10 would wrap and hang fillPoly
    return np.round(out).astype(np.int32).reshape(-1, 1, 2)


def _polygon_class(label: str, where: str) -> tuple[LabelClass, bool]:
    """The class of a polygon label and whether it is a group (``cargroup`` -> car, True)."""
    classes = {c.name: c for c in label_table()}
    if label in classes:
        return classes[label], False
    if label.endswith("group") and label[: -len("group")] in classes:
        return classes[label[: -len("group")]], True
    raise InputError(f"{where}: '{label}' is not a Cityscapes class; use a name from {TABLE_NAME}")


def read_polygons(path: PathLike, image: SourceImage | None = None) -> Segmentation:
    """Rasterise a Cityscapes ``*_gtFine_polygons.json`` file.

    Objects are drawn in file order (later over earlier) with ``cv2.fillPoly``. A label
    not in the class table but ending in ``group`` (``cargroup``) is drawn as its base
    class without an instance; thing classes get instance ids ``class*1000+k``, k counting
    from 0 per class in file order; other pixels get the label id as instance id, as
    cityscapesScripts does. Objects marked ``"deleted"`` and ``license plate`` are skipped.

    Args:
        path: the polygons JSON file.
        image: the photo; when given, ``imgWidth`` x ``imgHeight`` must be its size.

    Returns:
        Segmentation with ``label_ids`` (H, W) uint8, ``instance_ids`` (H, W) int32 and
        ``files`` = (polygons identity with role ``polygons``,).

    Raises:
        InputError: malformed JSON, missing or wrong fields, unknown labels, a size that
            differs from the image, or more than 1000 objects of one class.
    """
    data, file = read_input(path, "polygons")
    name = file.name
    doc = as_object(parse_json(data, name), name)
    width = _as_size(require(doc, "imgWidth", name), f"{name} -> imgWidth")
    height = _as_size(require(doc, "imgHeight", name), f"{name} -> imgHeight")
    if width * height > MAX_PIXELS:
        raise InputError(f"{name}: {width}x{height} is too large; check imgWidth and imgHeight")
    _check_image_size(name, (height, width), image, "polygons")
    objects = as_array(require(doc, "objects", name), f"{name} -> objects")

    label_ids = np.zeros((height, width), dtype=np.uint8)
    instance_ids = np.zeros((height, width), dtype=np.int32)
    counts: dict[int, int] = {}
    for i, obj_value in enumerate(objects):
        where = f"{name} -> objects -> [{i}]"
        obj = as_object(obj_value, where)
        if obj.get("deleted"):
            continue
        label = require(obj, "label", where)
        if not isinstance(label, str):
            raise InputError(f"{where} -> label: must be a string, got {json_type(label)}")
        points = _polygon_points(require(obj, "polygon", where), f"{where} -> polygon", width, height)
        if label in SKIPPED_POLYGON_LABELS:
            continue
        cls, is_group = _polygon_class(label, f"{where} -> label")
        instance = cls.id
        if cls.has_instances and not is_group:
            k = counts.get(cls.id, 0)
            if k >= 1000:
                raise InputError(f"{where}: more than 1000 '{cls.name}' objects; split the annotation")
            counts[cls.id] = k + 1
            instance = cls.id * 1000 + k
        cv2.fillPoly(label_ids, [points], color=int(cls.id))
        cv2.fillPoly(instance_ids, [points], color=int(instance))
    return Segmentation(label_ids=label_ids, instance_ids=instance_ids, files=(file,))
