"""EXIF focal lengths: known answers from JPEGs written here with Pillow."""

from __future__ import annotations

from PIL.TiffImagePlugin import IFDRational as Fraction

import numpy as np
import pytest
from PIL import Image

from usdworld.io.exif import FILM_DIAGONAL_MM, read_exif_focal


def _jpeg(path, tags: dict[int, object], size=(400, 300)):
    image = Image.fromarray(np.zeros((size[1], size[0], 3), np.uint8))
    exif = Image.Exif()
    ifd = exif.get_ifd(0x8769)
    for k, v in tags.items():
        ifd[k] = v
    image.save(path, exif=exif)
    return path


def test_35mm_equivalent(tmp_path):
    path = _jpeg(tmp_path / "a.jpg", {0xA405: 26})
    got = read_exif_focal(path, 400, 300)
    assert got is not None and got.tag == "FocalLengthIn35mmFilm"
    assert got.f_px == pytest.approx(26 * 500.0 / FILM_DIAGONAL_MM)


def test_focal_length_with_focal_plane_resolution(tmp_path):
    # 4.25 mm lens, 1000 px per cm on the sensor (unit 3 = cm), full width 4000 px, image resized to 400
    tags = {0x920A: Fraction(17, 4), 0xA20E: Fraction(1000, 1), 0xA210: 3, 0xA002: 4000}
    got = read_exif_focal(_jpeg(tmp_path / "b.jpg", tags), 400, 300)
    assert got is not None and got.tag == "FocalLength+FocalPlaneXResolution"
    assert got.f_px == pytest.approx(4.25 * 100.0 * 400 / 4000)


def test_no_exif_and_unreadable(tmp_path):
    assert read_exif_focal(_jpeg(tmp_path / "c.jpg", {}), 400, 300) is None
    assert read_exif_focal(_jpeg(tmp_path / "d.jpg", {0x920A: Fraction(4, 1)}), 400, 300) is None  # no resolution
    (tmp_path / "e.jpg").write_bytes(b"not an image")
    assert read_exif_focal(tmp_path / "e.jpg", 400, 300) is None


def test_build_without_camera_file_takes_the_exif_focal_length(tmp_path):
    """End to end: a JPEG stating 26 mm (35 mm equivalent) and no camera file -> K from EXIF, recorded in report.json."""
    import json

    from usdworld.pipeline import BuildRequest, build

    rng = np.random.default_rng(0)
    path = tmp_path / "photo.jpg"
    image = Image.fromarray(rng.integers(0, 255, (240, 320, 3), dtype=np.uint8))
    exif = Image.Exif()
    exif.get_ifd(0x8769)[0xA405] = 26
    image.save(path, exif=exif)
    labels = tmp_path / "photo_labelIds.png"
    Image.fromarray(np.zeros((240, 320), np.uint8)).save(labels)  # all unlabelled (a photo alone is refused)
    result = build(BuildRequest(image=path, labels=labels, output=tmp_path / "out"))
    expected = 26 * 400.0 / FILM_DIAGONAL_MM
    cam = result.model.camera
    assert cam.focal is not None and "exif" in cam.focal.sources
    assert cam.camera.fx == pytest.approx(expected, rel=0.02)  # the prior (30 %) barely moves a 3 % cue
    focal = json.loads((tmp_path / "out" / "report.json").read_text())["camera"]["focal"]
    assert [c["source"] for c in focal["used"]][:2] == ["prior", "exif"]
    assert "EXIF 35 mm-equivalent focal length 26 mm" in cam.method
