"""Read 2D detections: KITTI ``label_2`` text files and the usdworld detections JSON.

KITTI ``label_2`` (one object per line, fields separated by spaces)::

    type truncated occluded alpha x1 y1 x2 y2 h w l x y z rotation_y [score]

Only ``type``, ``truncated`` (the fraction of the object outside the image, 0..1; KITTI
writes 0..1 floats), the 2D box ``x1 y1 x2 y2`` (pixels) and the optional ``score`` are kept;
``DontCare`` lines are skipped and the 3D fields are ignored. KITTI's 2D boxes are the
image projections of the annotated 3D boxes (clipped to the image): they are *amodal*,
so an occluded object's box bottom is still where it meets the road.

usdworld detections JSON::

    {
      "detections": [
        {
          "class": "car",                      # required, any non-empty string
          "box": [xmin, ymin, xmax, ymax],     # required, pixels, xmax > xmin, ymax > ymin
          "score": 0.9,                        # optional, in [0, 1], default 1.0
          "polygon": [[u, v], [u, v], ...],    # optional, >= 3 vertices in pixels
          "mask": {"size": [H, W],             # optional, COCO RLE of an H x W mask,
                   "counts": ...},             #   H x W = the image size
          "amodal": false                      # optional: true when the box bounds the
        }                                      #   whole object, hidden parts included
      ]
    }

Give at most one of ``polygon`` and ``mask``. ``polygon`` is filled with
``cv2.fillPoly`` (vertices rounded to whole pixels, boundary pixels included).
``mask.counts`` is COCO run-length encoding over the mask in column-major order
(down the first column, then the next), starting with a run of zeros: either a list
of ints (uncompressed RLE, e.g. ``[3, 2, 5]``) or the COCO compressed string
(``pycocotools.mask.encode(...)["counts"].decode()``). ``amodal`` (default false) says the
box was drawn around the whole object, as a projected 3D box is, rather than around its
visible pixels; its bottom edge then locates the ground contact even when something hides
it. Other keys are ignored.

In both formats boxes use the image frame (origin at the top-left corner, u right,
v down; ``xmax`` / ``ymax`` are edges) and are clipped to the image when the image is
given; a box with non-positive size or entirely outside the image is an error, and so
is a box corner or polygon vertex more than :data:`~usdworld.io.limits.MAX_OUTSIDE_IMAGES`
image sizes outside the image (``[0, 0, 1e308, 1e308]`` is a unit or parsing error, not
a box). A file may hold at most :data:`~usdworld.io.limits.MAX_DETECTIONS` detections
(see there for why).
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from usdworld.errors import InputError
from usdworld.io.hashing import (
    PathLike,
    as_array,
    as_float,
    as_floats,
    as_object,
    decode_text,
    json_type,
    parse_json,
    read_input,
    require,
)
from usdworld.io.limits import MAX_DETECTIONS, check_pixel, check_pixels
from usdworld.io.types import Detection, Detections, SourceImage

_KITTI_FIELDS = ("type", "truncated", "occluded", "alpha", "x1", "y1", "x2", "y2")


# --- COCO run-length encoding ---------------------------------------------------------


def rle_encode(mask: np.ndarray) -> list[int]:
    """Uncompressed COCO RLE of a mask.

    Args:
        mask: (H, W) bool or 0/1 array.

    Returns:
        Run lengths over the column-major pixel order, alternating zeros and ones and
        starting with zeros (the first run may be 0); they sum to H * W.
    """
    flat = np.asarray(mask, dtype=bool).ravel(order="F")
    if flat.size == 0:
        return []
    change = np.flatnonzero(flat[1:] != flat[:-1]) + 1
    bounds = np.concatenate([[0], change, [flat.size]])
    runs = np.diff(bounds).tolist()
    return [0, *runs] if flat[0] else runs


def rle_decode(counts: list[int], height: int, width: int) -> np.ndarray:
    """Mask from uncompressed COCO RLE.

    Args:
        counts: run lengths (zeros first, column-major), non-negative, summing to H * W.
        height: H.
        width: W.

    Returns:
        (H, W) bool mask.

    Raises:
        ValueError: negative runs or a total other than H * W.
    """
    runs = np.asarray(counts, dtype=np.int64)
    if runs.size and runs.min() < 0:
        raise ValueError(f"run lengths must be >= 0, got {int(runs.min())}")
    total = int(runs.sum())
    if total != height * width:
        raise ValueError(
            f"run lengths sum to {total}, but the mask has {height}x{width} = {height * width} pixels"
        )
    values = np.arange(runs.size) % 2 == 1
    return np.repeat(values, runs).reshape((height, width), order="F")


def rle_to_string(counts: list[int]) -> str:
    """COCO compressed string of uncompressed RLE (``rleToString`` of the COCO API).

    Each count (from the fourth on, minus the count two places before) is written as
    LEB128-like groups of 5 bits, low bits first, 0x20 flagging "more", plus 48.

    Args:
        counts: run lengths as from :func:`rle_encode`.

    Returns:
        ASCII string of characters ``0``..``o``.
    """
    out: list[str] = []
    for i, count in enumerate(counts):
        x = int(count) - (int(counts[i - 2]) if i > 2 else 0)
        more = True
        while more:
            c = x & 0x1F
            x >>= 5
            more = (x != -1) if (c & 0x10) else (x != 0)
            if more:
                c |= 0x20
            out.append(chr(c + 48))
    return "".join(out)


def rle_from_string(text: str) -> list[int]:
    """Uncompressed RLE from a COCO compressed string (``rleFrString`` of the COCO API).

    Args:
        text: compressed counts.

    Returns:
        Run lengths (column-major, zeros first).

    Raises:
        ValueError: a character outside ``0``..``o``, a cut-off group, or a negative run.
    """
    counts: list[int] = []
    p = 0
    while p < len(text):
        x = 0
        k = 0
        more = True
        while more:
            if p >= len(text):
                raise ValueError("the string ends inside a number")
            c = ord(text[p]) - 48
            if not 0 <= c < 64:
                raise ValueError(f"character {text[p]!r} at position {p} is outside '0'..'o'")
            x |= (c & 0x1F) << (5 * k)
            more = bool(c & 0x20)
            p += 1
            k += 1
            if not more and (c & 0x10):
                x |= -1 << (5 * k)
        if len(counts) > 2:
            x += counts[-2]
        if x < 0:
            raise ValueError(f"run {len(counts)} is negative ({x})")
        counts.append(x)
    return counts


# --- boxes ----------------------------------------------------------------------------


def _check_box(box: list[float], image: SourceImage | None, where: str) -> np.ndarray:
    """Validate and clip ``[xmin, ymin, xmax, ymax]``; ``where`` starts the error message."""
    x1, y1, x2, y2 = box
    w_img, h_img = (None, None) if image is None else (image.width, image.height)
    for value, extent in ((x1, w_img), (y1, h_img), (x2, w_img), (y2, h_img)):
        check_pixel(value, extent, where)
    if not (x2 > x1 and y2 > y1):
        raise InputError(
            f"{where}: box [{x1:g}, {y1:g}, {x2:g}, {y2:g}] has non-positive size; "
            "boxes are [xmin, ymin, xmax, ymax] with xmax > xmin and ymax > ymin"
        )
    if image is None:
        return np.array(box, dtype=np.float64)
    w, h = image.width, image.height
    clipped = np.array(
        [min(max(x1, 0.0), w), min(max(y1, 0.0), h), min(max(x2, 0.0), w), min(max(y2, 0.0), h)]
    )
    if not (clipped[2] > clipped[0] and clipped[3] > clipped[1]):
        raise InputError(
            f"{where}: box [{x1:g}, {y1:g}, {x2:g}, {y2:g}] lies entirely outside the {w}x{h} image "
            f"{image.file.name}; pass the detections of this image"
        )
    return clipped


def _check_count(count: int, where: str) -> None:
    if count > MAX_DETECTIONS:
        raise InputError(
            f"{where}: {count} detections, at most {MAX_DETECTIONS} are accepted (a street photo holds "
            "tens to hundreds of objects); keep the confident ones or run non-maximum suppression first"
        )


def _check_score(score: float, where: str) -> float:
    if not 0.0 <= score <= 1.0:
        raise InputError(f"{where}: score must be in [0, 1], got {score:g}; rescale the detector scores")
    return score


# --- KITTI ----------------------------------------------------------------------------


def read_kitti_labels(path: PathLike, image: SourceImage | None = None) -> Detections:
    """Read a KITTI ``label_2`` file (ground truth, or detector output with a 16th score field).

    Args:
        path: the label text file.
        image: the photo; when given, boxes are clipped to it.

    Returns:
        Detections in file order without ``DontCare`` lines; ``box_px`` (4,) float64,
        score 1.0 when absent, no masks; ``file.role == "detections"``.

    Raises:
        InputError: a line without 15 or 16 fields, a non-number, a score outside [0, 1],
            or a box with non-positive size or entirely outside the image (names the line).
    """
    data, file = read_input(path, "detections")
    text = decode_text(data, file.name)
    _check_count(sum(1 for line in text.splitlines() if line.split()[:1] not in ([], ["DontCare"])), file.name)
    items: list[Detection] = []
    for line_no, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields:
            continue
        where = f"{file.name}: line {line_no}"
        if len(fields) not in (15, 16):
            raise InputError(
                f"{where}: {len(fields)} fields, expected 15 (or 16 with a score): "
                "type truncated occluded alpha x1 y1 x2 y2 h w l x y z rotation_y [score]"
            )
        label = fields[0]
        if label == "DontCare":
            continue
        values = []
        for idx in (1, 4, 5, 6, 7, 15):
            if idx >= len(fields):
                continue
            try:
                v = float(fields[idx])
            except ValueError:
                v = float("nan")
            if not np.isfinite(v):
                field_name = _KITTI_FIELDS[idx] if idx < len(_KITTI_FIELDS) else "score"
                raise InputError(
                    f"{where}: {field_name} = {fields[idx]!r} is not a finite number; fix the line"
                )
            values.append(v)
        truncated, values = values[0], values[1:]
        if truncated > 1.0:
            raise InputError(f"{where}: truncated = {fields[1]!r} must be in [0, 1] (the fraction outside the image)")
        # Detector result files write -1 ("not given") here.
        truncated = max(truncated, 0.0)
        box = _check_box(values[:4], image, where)
        score = _check_score(values[4], where) if len(values) == 5 else 1.0
        items.append(Detection(label=label, box_px=box, score=score, amodal=True, truncated=truncated))
    return Detections(items=tuple(items), file=file)


# --- usdworld JSON --------------------------------------------------------------------


def _mask_from_rle(value: Any, image: SourceImage, where: str) -> np.ndarray:
    obj = as_object(value, where)
    size = as_floats(require(obj, "size", where), f"{where} -> size", 2)
    if [image.height, image.width] != size:
        raise InputError(
            f"{where} -> size: [{size[0]:g}, {size[1]:g}] but the image {image.file.name} is "
            f"[{image.height}, {image.width}] (size is [H, W]); encode the mask at the image size"
        )
    counts_value = require(obj, "counts", where)
    try:
        if isinstance(counts_value, str):
            counts = rle_from_string(counts_value)
        elif isinstance(counts_value, list):
            counts = [int(as_float(c, f"{where} -> counts -> [{i}]")) for i, c in enumerate(counts_value)]
            if any(c != f for c, f in zip(counts, counts_value, strict=True)):
                raise ValueError("run lengths must be whole numbers")
        else:
            raise InputError(
                f"{where} -> counts: must be a list of ints or a COCO compressed string, "
                f"got {json_type(counts_value)}"
            )
        return rle_decode(counts, image.height, image.width)
    except (ValueError, OverflowError) as exc:  # OverflowError: a run beyond int64
        raise InputError(f"{where} -> counts: {exc}; re-encode the mask with pycocotools") from exc


def _mask_from_polygon(value: Any, image: SourceImage, where: str) -> np.ndarray:
    points = as_array(value, where)
    if len(points) < 3:
        raise InputError(f"{where}: needs at least 3 [u, v] vertices, got {len(points)}")
    pts = np.array([as_floats(p, f"{where} -> [{i}]", 2) for i, p in enumerate(points)], dtype=np.float64)
    check_pixels(pts, image.width, image.height, where)
    mask = np.zeros((image.height, image.width), dtype=np.uint8)
    cv2.fillPoly(mask, [np.round(pts).astype(np.int32).reshape(-1, 1, 2)], color=1)
    return mask.astype(bool)


def _read_detection(value: Any, image: SourceImage, where: str) -> Detection:
    obj = as_object(value, where)
    label = require(obj, "class", where)
    if not isinstance(label, str) or not label.strip():
        raise InputError(f"{where} -> class: must be a non-empty string, got {json_type(label)} {label!r}")
    box = _check_box(as_floats(require(obj, "box", where), f"{where} -> box", 4), image, f"{where} -> box")
    score = 1.0
    if "score" in obj:
        score = _check_score(as_float(obj["score"], f"{where} -> score"), f"{where} -> score")
    if "polygon" in obj and "mask" in obj:
        raise InputError(f"{where}: has both polygon and mask; keep one of them")
    mask = None
    if "polygon" in obj:
        mask = _mask_from_polygon(obj["polygon"], image, f"{where} -> polygon")
    elif "mask" in obj:
        mask = _mask_from_rle(obj["mask"], image, f"{where} -> mask")
    if mask is not None and not mask.any():
        key = "polygon" if "polygon" in obj else "mask"
        raise InputError(f"{where} -> {key}: covers no pixel of the image; fix it or drop the {key}")
    amodal = obj.get("amodal", False)
    if not isinstance(amodal, bool):
        raise InputError(f"{where} -> amodal: must be true or false, got {json_type(amodal)} {amodal!r}")
    return Detection(label=label, box_px=box, score=score, mask=mask, amodal=amodal)


def read_detections_json(path: PathLike, image: SourceImage) -> Detections:
    """Read the usdworld detections JSON (format in the module docstring).

    Args:
        path: the JSON file.
        image: the photo; boxes are clipped to it and masks must have its size.

    Returns:
        Detections in file order; ``box_px`` (4,) float64; ``mask`` (H, W) bool or None;
        ``file.role == "detections"``.

    Raises:
        InputError: malformed JSON, a missing or mistyped field (named by its path), a
            score outside [0, 1], a bad box, or a mask of another size or that is empty.
    """
    data, file = read_input(path, "detections")
    doc = parse_json(data, file.name)
    if not isinstance(doc, dict):
        raise InputError(
            f'{file.name}: the top level must be an object {{"detections": [...]}}, got {json_type(doc)}'
        )
    entries = as_array(require(doc, "detections", file.name), f"{file.name} -> detections")
    _check_count(len(entries), f"{file.name} -> detections")
    items = tuple(
        _read_detection(v, image, f"{file.name} -> detections -> [{i}]") for i, v in enumerate(entries)
    )
    return Detections(items=items, file=file)
