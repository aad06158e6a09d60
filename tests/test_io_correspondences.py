"""Tests for usdworld.io.correspondences."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from usdworld.errors import CalibrationError, InputError
from usdworld.io.correspondences import read_correspondences

PAIRS = [
    ([100, 400], [5, 2]),
    ([500, 400], [5, -2]),
    ([150, 300], [10, 2]),
    ([450, 300], [10, -2]),
    ([300, 350], [7, 0]),
]


def _json(tmp_path: Path, doc: object) -> Path:
    path = tmp_path / "pts.json"
    path.write_text(json.dumps(doc))
    return path


def test_json_pairs(tmp_path: Path) -> None:
    doc = {"pairs": [{"px": px, "ground": g} for px, g in PAIRS]}
    corr = read_correspondences(_json(tmp_path, doc))
    np.testing.assert_array_equal(corr.points_px, [p for p, _ in PAIRS])
    np.testing.assert_array_equal(corr.points_ground, [g for _, g in PAIRS])
    assert corr.points_px.dtype == np.float64 and corr.file.role == "correspondences"


def test_csv_any_column_order_with_bom(tmp_path: Path) -> None:
    path = tmp_path / "pts.csv"
    rows = "\n".join(f"{g[0]}, {px[0]}, {g[1]}, {px[1]}, p{i}" for i, (px, g) in enumerate(PAIRS))
    path.write_text("\ufeffx, u, y, V, name\n" + rows + "\n\n", encoding="utf-8")
    corr = read_correspondences(path)
    np.testing.assert_array_equal(corr.points_px, [p for p, _ in PAIRS])
    np.testing.assert_array_equal(corr.points_ground, [g for _, g in PAIRS])


def test_too_few_pairs(tmp_path: Path) -> None:
    doc = {"pairs": [{"px": px, "ground": g} for px, g in PAIRS[:3]]}
    with pytest.raises(
        CalibrationError, match=r"^pts\.json: 3 pixel/ground pairs, at least 4 are needed .*add 1 more"
    ):
        read_correspondences(_json(tmp_path, doc))


def test_duplicate_pixels(tmp_path: Path) -> None:
    doc = {"pairs": [{"px": [1, 1], "ground": [1, g]} for g in range(3)] + [{"px": [2, 2], "ground": [3, g]} for g in range(2)]}
    with pytest.raises(CalibrationError, match=r"only 2 distinct pixels among 5 pairs"):
        read_correspondences(_json(tmp_path, doc))


def test_repeated_pairs_are_used_once(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    pairs = [{"px": [u, v], "ground": [u + 5.0, v - 1.0]} for u, v in ((0, 0), (9, 0), (0, 9), (9, 9))]
    doc = {"pairs": [pairs[0], pairs[1], pairs[0], pairs[2], pairs[3], pairs[1]]}
    corr = read_correspondences(_json(tmp_path, doc))
    assert corr.points_px.tolist() == [[0, 0], [9, 0], [0, 9], [9, 9]]  # first occurrences, file order
    assert corr.points_ground.tolist() == [[5, -1], [14, -1], [5, 8], [14, 8]]
    assert "2 repeated pixel/ground pairs ignored" in caplog.text


def test_too_many_pairs(tmp_path: Path) -> None:
    doc = {"pairs": [{"px": [i % 97, i // 97], "ground": [float(i), 1.0]} for i in range(1001)]}
    with pytest.raises(CalibrationError, match=r"^pts\.json: 1001 distinct pixel/ground pairs, at most 1000"):
        read_correspondences(_json(tmp_path, doc))


@pytest.mark.parametrize(
    ("pair", "message"),
    [
        ({"px": [1e308, 0], "ground": [1, 1]}, r"^pts\.json: pair -> \[2\]: pixel coordinate 1e\+308 is far outside"),
        ({"px": [5, 5], "ground": [1e308, 1]}, r"^pts\.json -> pairs -> \[2\] -> ground: \[1e\+308, 1\.0\] is beyond 10000 m"),
    ],
)
def test_hostile_numbers(tmp_path: Path, pair: dict[str, list[float]], message: str) -> None:
    doc = {"pairs": [{"px": [0, 0], "ground": [0, 1]}, {"px": [9, 0], "ground": [2, 1]}, pair, {"px": [0, 9], "ground": [0, 5]}]}
    with pytest.raises(InputError, match=message):
        read_correspondences(_json(tmp_path, doc))


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ({"points": []}, r"^pts\.json -> pairs: missing$"),
        ({"pairs": [{"px": [1, 2]}]}, r"^pts\.json -> pairs -> \[0\] -> ground: missing$"),
        ({"pairs": [{"px": [1, 2, 3], "ground": [0, 0]}]}, r"-> \[0\] -> px: must hold 2 numbers, got 3"),
        ({"pairs": [{"px": [1, None], "ground": [0, 0]}]}, r"-> px -> \[1\]: must be a number, got null"),
        ([1, 2], r"the top level must be an object"),
    ],
)
def test_json_errors(tmp_path: Path, doc: object, message: str) -> None:
    with pytest.raises(InputError, match=message):
        read_correspondences(_json(tmp_path, doc))


def test_csv_errors(tmp_path: Path) -> None:
    path = tmp_path / "pts.csv"
    path.write_text("1,2,3,4\n5,6,7,8\n")
    with pytest.raises(
        InputError, match=r"pts\.csv: line 1: header .* lacks column 'u'; the first line must name"
    ):
        read_correspondences(path)
    path.write_text("u,v,x,y\n1,2,3,4\n1,two,3,4\n")
    with pytest.raises(InputError, match=r"pts\.csv: line 3, column v: 'two' is not a finite number"):
        read_correspondences(path)
    path.write_text("u,v,x,y\n1,2,3\n")
    with pytest.raises(InputError, match=r"line 2, column y: '' is not a finite number"):
        read_correspondences(path)
    path.write_bytes(b"u,v,x,y\n\xff\xfe\n")
    with pytest.raises(InputError, match=r"pts\.csv: not UTF-8 text"):
        read_correspondences(path)
