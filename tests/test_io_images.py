"""Tests for usdworld.io.images and usdworld.io.hashing."""

from __future__ import annotations

import hashlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import SHARED_DATA

from usdworld.errors import InputError
from usdworld.io.hashing import read_input
from usdworld.io.images import read_image

SHARED = SHARED_DATA  # $USDWORLD_DATA or ../shared/data


def _bgr_pattern(h: int = 6, w: int = 5) -> np.ndarray:
    rng = np.random.default_rng(0)
    return rng.integers(0, 256, size=(h, w, 3), dtype=np.uint8)


def _write(path: Path, array: np.ndarray) -> Path:
    assert cv2.imwrite(str(path), array)
    return path


def test_png_rgb_order_size_and_hash(tmp_path: Path) -> None:
    bgr = _bgr_pattern()
    path = _write(tmp_path / "photo.png", bgr)
    image = read_image(path)
    assert image.rgb.dtype == np.uint8 and image.rgb.shape == (6, 5, 3)
    np.testing.assert_array_equal(image.rgb, bgr[:, :, ::-1])
    assert (image.width, image.height) == (5, 6)
    assert image.file.role == "image" and image.file.name == "photo.png"
    assert image.file.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert not image.rgb.flags.writeable


def test_grey_png_becomes_rgb(tmp_path: Path) -> None:
    grey = np.arange(12, dtype=np.uint8).reshape(3, 4) * 20
    image = read_image(_write(tmp_path / "g.png", grey))
    assert image.rgb.shape == (3, 4, 3)
    for c in range(3):
        np.testing.assert_array_equal(image.rgb[:, :, c], grey)


def test_rgba_png_drops_alpha(tmp_path: Path) -> None:
    bgra = np.zeros((2, 3, 4), dtype=np.uint8)
    bgra[..., 0], bgra[..., 1], bgra[..., 2], bgra[..., 3] = 10, 20, 30, 0
    image = read_image(_write(tmp_path / "a.png", bgra))
    np.testing.assert_array_equal(image.rgb[0, 0], [30, 20, 10])


def test_16bit_png_scaled_to_8bit(tmp_path: Path) -> None:
    bgr16 = np.zeros((2, 2, 3), dtype=np.uint16)
    bgr16[0, 0] = [65535, 32768, 0]
    bgr16[1, 1] = [257, 256 * 100, 128]
    image = read_image(_write(tmp_path / "deep.png", bgr16))
    np.testing.assert_array_equal(image.rgb[0, 0], [0, 128, 255])
    np.testing.assert_array_equal(image.rgb[1, 1], [0, 100, 1])


def test_jpeg_decodes(tmp_path: Path) -> None:
    bgr = np.full((16, 16, 3), (40, 120, 200), dtype=np.uint8)
    path = _write(tmp_path / "p.jpg", bgr)
    image = read_image(path)
    assert image.rgb.shape == (16, 16, 3)
    assert np.abs(image.rgb.astype(int) - [200, 120, 40]).max() <= 3


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"nope\.png: no such file .*check the path"):
        read_image(tmp_path / "nope.png")


def test_folder_instead_of_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="is a folder"):
        read_image(tmp_path)


def test_empty_file(tmp_path: Path) -> None:
    (tmp_path / "e.png").write_bytes(b"")
    with pytest.raises(InputError, match=r"^e\.png: the file is empty"):
        read_image(tmp_path / "e.png")


def test_unsupported_format_named(tmp_path: Path) -> None:
    (tmp_path / "x.png").write_bytes(b"GIF89a" + bytes(20))
    with pytest.raises(InputError, match=r"x\.png: is a GIF file, not a PNG or JPEG image; convert"):
        read_image(tmp_path / "x.png")
    (tmp_path / "t.txt").write_text("hello")
    with pytest.raises(InputError, match="unknown format"):
        read_image(tmp_path / "t.txt")


def test_truncated_png(tmp_path: Path) -> None:
    data = (_write(tmp_path / "full.png", _bgr_pattern(64, 64))).read_bytes()
    (tmp_path / "cut.png").write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match=r"cut\.png: the PNG data is corrupt or truncated"):
        read_image(tmp_path / "cut.png")


def test_truncated_jpeg(tmp_path: Path) -> None:
    data = (_write(tmp_path / "full.jpg", _bgr_pattern(64, 64))).read_bytes()
    (tmp_path / "cut.jpg").write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match=r"cut\.jpg: .*truncated"):
        read_image(tmp_path / "cut.jpg")


def test_corrupt_png_signature_only(tmp_path: Path) -> None:
    (tmp_path / "bad.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"garbage" * 10)
    with pytest.raises(InputError, match=r"bad\.png: .*cannot be decoded"):
        read_image(tmp_path / "bad.png")


def test_read_input_hashes_bytes(tmp_path: Path) -> None:
    (tmp_path / "f.bin").write_bytes(b"abc")
    data, file = read_input(tmp_path / "f.bin", "labels")
    assert data == b"abc"
    assert file.sha256 == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    assert (file.role, file.name) == ("labels", "f.bin")


@pytest.mark.shared_data
@pytest.mark.skipif(not (SHARED / "kitti").is_dir(), reason="real sample data $USDWORLD_DATA/kitti is absent")
def test_real_kitti_and_nuscenes_images() -> None:
    image = read_image(SHARED / "kitti/training/image_2/000000.png")
    assert (image.width, image.height) == (1224, 370)
    front = "nuscenes/demo/n015-2018-07-24-11-22-45+0800__CAM_FRONT__1532402927612460.jpg"
    if (SHARED / front).is_file():
        assert read_image(SHARED / front).rgb.shape == (900, 1600, 3)
