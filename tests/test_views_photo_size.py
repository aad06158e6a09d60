"""nuScenes views: a photo's size from its header, as decoding it gives it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import usdworld.views.nuscenes as nuscenes
from usdworld.io.images import read_image


def _photo(path: Path, orientation: int | None = None) -> Path:
    rgb = np.zeros((30, 50, 3), dtype=np.uint8)
    rgb[:, :10] = 255  # not symmetric, so a turn is visible
    image = Image.fromarray(rgb)
    if orientation is None:
        image.save(path)
    else:
        exif = Image.Exif()
        exif[0x0112] = orientation
        image.save(path, exif=exif)
    return path


@pytest.mark.parametrize(
    ("name", "orientation", "size"),
    [
        ("a.png", None, (50, 30)),
        ("b.jpg", None, (50, 30)),
        ("c.jpg", 1, (50, 30)),
        ("d.jpg", 6, (30, 50)),
        ("e.jpg", 8, (30, 50)),
    ],
)
def test_photo_size_is_the_decoded_size_without_decoding(
    tmp_path, monkeypatch, name, orientation, size
) -> None:
    path = _photo(tmp_path / name, orientation)
    decoded = read_image(path)
    assert (decoded.width, decoded.height) == size

    def no_decoding(p):
        raise AssertionError(f"decoded {p}")

    monkeypatch.setattr(nuscenes, "read_image", no_decoding)
    assert nuscenes.photo_size(path) == size

