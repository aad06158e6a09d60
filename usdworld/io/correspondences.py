"""Read manual pixel <-> ground correspondences (the paper's "5-6 selected points").

Two formats, recognised from the content:

* JSON: ``{"pairs": [{"px": [u, v], "ground": [x, y]}, ...]}``
* CSV with a header naming the columns ``u, v, x, y`` (any order; other columns are
  ignored), one pair per row.

``(u, v)`` are pixels (origin at the top-left corner, u right, v down); ``(x, y)`` are
metres on the ground (x forward, y left, origin below the camera). At least
:data:`MIN_PAIRS` pairs with distinct pixels are needed for a homography. Pixels must lie
within :data:`~usdworld.io.limits.MAX_PIXEL_COORD` and ground points within
:data:`~usdworld.io.limits.MAX_GROUND_COORD_M`; a pair repeated exactly is kept once
(with a warning), and at most :data:`~usdworld.io.limits.MAX_GROUND_PAIRS` distinct pairs
are accepted.
"""

from __future__ import annotations

import csv
import io
import logging

import numpy as np

from usdworld.errors import CalibrationError, InputError
from usdworld.io.hashing import (
    PathLike,
    as_array,
    as_floats,
    as_object,
    decode_text,
    json_type,
    parse_json,
    read_input,
    require,
)
from usdworld.io.limits import MAX_GROUND_COORD_M, MAX_GROUND_PAIRS, check_pixels
from usdworld.io.types import GroundCorrespondences

logger = logging.getLogger(__name__)

#: A homography has 8 degrees of freedom; each pair gives 2 equations.
MIN_PAIRS = 4

_CSV_COLUMNS = ("u", "v", "x", "y")


def _from_json(data: bytes, name: str) -> tuple[list[list[float]], list[list[float]]]:
    doc = parse_json(data, name)
    if not isinstance(doc, dict):
        raise InputError(f'{name}: the top level must be an object {{"pairs": [...]}}, got {json_type(doc)}')
    pairs = as_array(require(doc, "pairs", name), f"{name} -> pairs")
    px, ground = [], []
    for i, value in enumerate(pairs):
        where = f"{name} -> pairs -> [{i}]"
        pair = as_object(value, where)
        px.append(as_floats(require(pair, "px", where), f"{where} -> px", 2))
        ground.append(as_floats(require(pair, "ground", where), f"{where} -> ground", 2))
    return px, ground


def _from_csv(text: str, name: str) -> tuple[list[list[float]], list[list[float]]]:
    reader = csv.reader(io.StringIO(text, newline=""))
    rows: list[tuple[int, list[str]]] = []
    try:
        for row in reader:
            if any(c.strip() for c in row):
                rows.append((reader.line_num, row))
    except csv.Error as exc:
        raise InputError(
            f"{name}: not valid CSV ({exc}); write a header u,v,x,y and one pair per line"
        ) from exc
    if not rows:
        raise InputError(f"{name}: no rows; write a header u,v,x,y and one pair per line")
    header = [c.strip().lower() for c in rows[0][1]]
    missing = [c for c in _CSV_COLUMNS if c not in header]
    if missing:
        raise InputError(
            f"{name}: line {rows[0][0]}: header {','.join(header)!r} lacks column {missing[0]!r}; "
            "the first line must name the columns u,v,x,y"
        )
    cols = [header.index(c) for c in _CSV_COLUMNS]
    px, ground = [], []
    for line_no, row in rows[1:]:
        values = []
        for col, col_name in zip(cols, _CSV_COLUMNS, strict=True):
            cell = row[col].strip() if col < len(row) else ""
            try:
                v = float(cell)
            except ValueError:
                v = float("nan")
            if not np.isfinite(v):
                raise InputError(
                    f"{name}: line {line_no}, column {col_name}: {cell!r} is not a finite number"
                )
            values.append(v)
        px.append(values[:2])
        ground.append(values[2:])
    return px, ground


def read_correspondences(path: PathLike) -> GroundCorrespondences:
    """Read pixel <-> ground pairs from JSON or CSV.

    Args:
        path: the correspondences file.

    Returns:
        GroundCorrespondences with ``points_px`` (N, 2) and ``points_ground`` (N, 2)
        float64, 4 <= N <= MAX_GROUND_PAIRS, in file order without exact repeats;
        ``file.role == "correspondences"``.

    Raises:
        InputError: malformed file, missing fields, non-numbers (named by path or line), or
            a pixel or ground coordinate beyond its bound.
        CalibrationError: fewer than 4 or more than MAX_GROUND_PAIRS distinct pairs, or
            fewer than 4 distinct pixels.
    """
    data, file = read_input(path, "correspondences")
    text = decode_text(data, file.name)
    if text.lstrip().startswith(("{", "[")):
        px, ground = _from_json(data, file.name)
    else:
        px, ground = _from_csv(text, file.name)
    points_px = np.array(px, dtype=np.float64).reshape(-1, 2)
    points_ground = np.array(ground, dtype=np.float64).reshape(-1, 2)
    check_pixels(points_px, None, None, f"{file.name}: pair")
    far = np.flatnonzero(~(np.abs(points_ground) <= MAX_GROUND_COORD_M).all(axis=1))
    if far.size:
        raise InputError(
            f"{file.name} -> pairs -> [{int(far[0])}] -> ground: {points_ground[far[0]].tolist()} is beyond "
            f"{MAX_GROUND_COORD_M:g} m; ground points are metres from the camera (x forward, y left)"
        )
    _, first = np.unique(np.hstack([points_px, points_ground]), axis=0, return_index=True)
    repeated = len(points_px) - len(first)
    if repeated:
        keep = np.sort(first)
        points_px, points_ground = points_px[keep], points_ground[keep]
    if len(points_px) > MAX_GROUND_PAIRS:
        raise CalibrationError(
            f"{file.name}: {len(points_px)} distinct pixel/ground pairs, at most {MAX_GROUND_PAIRS} are "
            "accepted (5-20 spread over the road determine the homography); keep a spread-out subset"
        )
    if len(points_px) < MIN_PAIRS:
        raise CalibrationError(
            f"{file.name}: {len(points_px)} pixel/ground pairs, at least {MIN_PAIRS} are needed for the "
            f"ground homography; add {MIN_PAIRS - len(points_px)} more (5-6 spread over the road is best)"
        )
    distinct = len(np.unique(points_px, axis=0))
    if distinct < MIN_PAIRS:
        raise CalibrationError(
            f"{file.name}: only {distinct} distinct pixels among {len(points_px)} pairs; at least "
            f"{MIN_PAIRS} different points are needed, remove the duplicates and add others"
        )
    if repeated:  # after every check that can fail, so that an error stays one line
        logger.warning("%s: %d repeated pixel/ground pairs ignored (each pair is used once)", file.name, repeated)
    return GroundCorrespondences(points_px=points_px, points_ground=points_ground, file=file)
