"""Tests for the ``file`` depth backend (formats are read by usdworld.io.depth_files)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from usdworld.errors import InputError
from usdworld.io.depth_files import write_depth_png16, write_pfm
from usdworld.perception.depth import make_backend

RGB = np.zeros((6, 8, 3), np.uint8)


def _depth() -> np.ndarray:
    d = np.linspace(1.0, 60.0, 48, dtype=np.float32).reshape(6, 8)
    d[0, 0], d[0, 1], d[0, 2], d[1, 0] = np.nan, np.inf, 0.0, -3.0
    return d


def _check(pred, atol: float) -> None:
    ref = _depth()
    ok = np.isfinite(ref) & (ref > 0)
    np.testing.assert_array_equal(pred.valid, ok)
    np.testing.assert_allclose(pred.depth[ok], ref[ok], atol=atol)
    assert (pred.depth[~ok] == 0).all() and np.isfinite(pred.depth).all()
    assert pred.kind == "metric"


def test_npy_round_trip_masks_bad_values(tmp_path: Path) -> None:
    np.save(tmp_path / "d.npy", _depth())
    backend = make_backend("file", tmp_path / "d.npy")
    assert backend.name == "file:d.npy"
    _check(backend.predict(RGB), atol=0)


def test_png16_round_trip(tmp_path: Path) -> None:
    write_depth_png16(tmp_path / "d.png", _depth())
    _check(make_backend("file", tmp_path / "d.png").predict(RGB), atol=0.5 / 256)


def test_pfm_round_trip(tmp_path: Path) -> None:
    write_pfm(tmp_path / "d.pfm", _depth())
    _check(make_backend("file", tmp_path / "d.pfm").predict(RGB), atol=0)


def test_wrong_size_and_missing_file(tmp_path: Path) -> None:
    np.save(tmp_path / "d.npy", _depth())
    backend = make_backend("file", tmp_path / "d.npy")
    with pytest.raises(
        InputError, match=r"^depth map d.npy: is 8x6 pixels, the image is 9x6; give a depth map"
    ):
        backend.predict(np.zeros((6, 9, 3), np.uint8))
    with pytest.raises(InputError, match=r"depth map .*nope.npy: no such file; give a .npy"):
        make_backend("file", tmp_path / "nope.npy")
