"""Tests for usdworld.io.depth_files."""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from usdworld.errors import InputError, OutputError
from usdworld.io.depth_files import read_depth, write_depth_png16, write_pfm
from usdworld.io.types import InputFile, SourceImage


def _image(h: int, w: int) -> SourceImage:
    return SourceImage(rgb=np.zeros((h, w, 3), np.uint8), file=InputFile("image", "frame.png", "0" * 64))


def _depth() -> np.ndarray:
    d = np.linspace(0.5, 80.0, 12, dtype=np.float32).reshape(3, 4)
    d[0, 0] = np.nan
    d[0, 1] = np.inf
    d[0, 2] = -1.0
    d[0, 3] = 0.0
    return d


def _check(depth_map_depth: np.ndarray, valid: np.ndarray, expected: np.ndarray, atol: float) -> None:
    assert depth_map_depth.dtype == np.float32 and valid.dtype == bool
    np.testing.assert_array_equal(valid[0], [False] * 4)
    assert valid[1:].all()
    np.testing.assert_array_equal(depth_map_depth[0], 0.0)
    np.testing.assert_allclose(depth_map_depth[1:], expected[1:], atol=atol)


def test_npy(tmp_path: Path) -> None:
    np.save(tmp_path / "d.npy", _depth().astype(np.float64))
    dm = read_depth(tmp_path / "d.npy", _image(3, 4))
    _check(dm.depth_m, dm.valid, _depth(), 1e-6)
    assert dm.source == "file:d.npy"


def test_png16_round_trip(tmp_path: Path) -> None:
    write_depth_png16(tmp_path / "d.png", _depth())
    stored = cv2.imread(str(tmp_path / "d.png"), cv2.IMREAD_UNCHANGED)
    assert (
        stored is not None
        and stored.dtype == np.uint16
        and stored[1, 0] == round(float(_depth()[1, 0]) * 256)
    )
    dm = read_depth(tmp_path / "d.png")
    _check(dm.depth_m, dm.valid, _depth(), 0.5 / 256)


def test_png16_known_value(tmp_path: Path) -> None:
    assert cv2.imwrite(str(tmp_path / "k.png"), np.array([[0, 256, 2560]], np.uint16))
    dm = read_depth(tmp_path / "k.png")
    np.testing.assert_array_equal(dm.depth_m, [[0.0, 1.0, 10.0]])
    np.testing.assert_array_equal(dm.valid, [[False, True, True]])


@pytest.mark.parametrize("little_endian", [True, False])
def test_pfm_both_endians_bottom_to_top(tmp_path: Path, little_endian: bool) -> None:
    depth = np.arange(1, 7, dtype=np.float32).reshape(2, 3)
    dtype, scale = ("<f4", -1.0) if little_endian else (">f4", 1.0)
    path = tmp_path / "d.pfm"
    path.write_bytes(f"Pf\n3 2\n{scale}\n".encode() + depth[::-1].astype(dtype).tobytes())
    np.testing.assert_array_equal(read_depth(path).depth_m, depth)


def test_pfm_round_trip(tmp_path: Path) -> None:
    write_pfm(tmp_path / "d.pfm", _depth())
    dm = read_depth(tmp_path / "d.pfm")
    _check(dm.depth_m, dm.valid, _depth(), 0.0)


def test_size_mismatch(tmp_path: Path) -> None:
    np.save(tmp_path / "d.npy", np.ones((3, 4), np.float32))
    with pytest.raises(
        InputError, match=r"^d\.npy: depth is 4x3 but the image frame\.png is 8x6; pass the depth"
    ):
        read_depth(tmp_path / "d.npy", _image(6, 8))


@pytest.mark.parametrize(
    ("name", "make", "message"),
    [
        (
            "d.npy",
            lambda p: np.save(p, np.ones((3, 4), np.uint16)),
            r"dtype uint16; \.npy depth must be float metres",
        ),
        (
            "d.npy",
            lambda p: np.save(p, np.ones((2, 3, 4), np.float32)),
            r"array of shape \(2, 3, 4\); a depth map must be",
        ),
        ("d.npy", lambda p: np.save(p, np.array([[None]], dtype=object)), r"not a plain numeric \.npy array"),
        ("d.npy", lambda p: np.save(p, np.full((2, 2), np.nan)), r"no valid depth"),
        (
            "d.png",
            lambda p: cv2.imwrite(str(p), np.ones((2, 2), np.uint8)),
            r"uint8 samples where 16-bit are expected",
        ),
        ("d.png", lambda p: cv2.imwrite(str(p), np.ones((2, 2, 3), np.uint16)), r"a 3-channel colour image"),
        ("d.pfm", lambda p: p.write_bytes(b"PF\n2 2\n-1.0\n" + bytes(48)), r"a 3-channel PFM"),
        (
            "d.pfm",
            lambda p: p.write_bytes(b"Pf\n2 2\n-1.0\n" + bytes(12)),
            r"12 bytes of samples but the header says 2x2",
        ),
        ("d.pfm", lambda p: p.write_bytes(b"Pf\nxx\n"), r"malformed PFM header"),
        ("d.exr", lambda p: p.write_bytes(b"\x00\x01garbage"), r"is an unknown format; pass depth as \.npy"),
    ],
)
def test_read_errors(tmp_path: Path, name: str, make: Callable[[Path], object], message: str) -> None:
    make(tmp_path / name)
    with pytest.raises(InputError, match=rf"^{re.escape(name)}: " + message):
        read_depth(tmp_path / name)


def test_png16_writer_rejects_far_depth(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match=r"depth up to 300\.0 m does not fit a 16-bit PNG"):
        write_depth_png16(tmp_path / "d.png", np.full((2, 2), 300.0))
    assert not (tmp_path / "d.png").exists()


def test_writers_are_atomic_and_leave_no_temp(tmp_path: Path) -> None:
    write_pfm(tmp_path / "d.pfm", np.ones((2, 2)))
    write_depth_png16(tmp_path / "d.png", np.ones((2, 2)))
    assert sorted(os.listdir(tmp_path)) == ["d.pfm", "d.png"]
    with pytest.raises(OutputError, match="cannot write in"):
        write_pfm(tmp_path / "missing" / "d.pfm", np.ones((2, 2)))
