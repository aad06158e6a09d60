"""Hostile numbers in every input format give one-line InputErrors, before numpy or OpenCV see them."""

from __future__ import annotations

import io
import json
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from usdworld.errors import CalibrationError, InputError, UsdWorldError
from usdworld.io.camera_files import read_camera
from usdworld.io.depth_files import read_depth
from usdworld.io.detections import read_detections_json, read_kitti_labels
from usdworld.io.images import read_image
from usdworld.io.labels import read_polygons
from usdworld.io.limits import MAX_DETECTIONS, check_pixel
from usdworld.io.types import InputFile, SourceImage

IMAGE = SourceImage(rgb=np.zeros((40, 60, 3), np.uint8), file=InputFile("image", "frame.png", "0" * 64))


def _json(tmp_path: Path, doc: object, name: str = "in.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def test_check_pixel_bounds() -> None:
    assert check_pixel(-600.0, 60, "x") == -600.0  # ten image widths out
    assert check_pixel(660.0, 60, "x") == 660.0
    with pytest.raises(InputError, match=r"^x: pixel coordinate 661 is far outside the image \(allowed -600 \.\. 660\)"):
        check_pixel(661.0, 60, "x")
    with pytest.raises(InputError, match=r"allowed -1e\+06 \.\. 1e\+06"):
        check_pixel(2e6, None, "x")


@pytest.mark.parametrize("box", [[0, 0, 1e308, 1e308], [-1e10, 0, 5, 5], [0, 0, 5, 1e7]])
def test_huge_boxes_refused(tmp_path: Path, box: list[float]) -> None:
    path = _json(tmp_path, {"detections": [{"class": "car", "box": box}]})
    with pytest.raises(InputError, match=r"^in\.json -> detections -> \[0\] -> box: pixel coordinate .* is far outside"):
        read_detections_json(path, IMAGE)


def test_box_slightly_outside_is_clipped(tmp_path: Path) -> None:
    path = _json(tmp_path, {"detections": [{"class": "car", "box": [-20, 10, 80, 50]}]})
    assert read_detections_json(path, IMAGE).items[0].box_px.tolist() == [0, 10, 60, 40]


def test_kitti_huge_box_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / "000001.txt"
    path.write_text("Car 0 0 0 1 1 5 3 1 1 1 0 0 0 0\nCar 0 0 0 0 0 1e308 1e308 1 1 1 0 0 0 0\n")
    with pytest.raises(InputError, match=r"^000001\.txt: line 2: pixel coordinate 1e\+308"):
        read_kitti_labels(path, IMAGE)


def test_too_many_detections(tmp_path: Path) -> None:
    entries = [{"class": "car", "box": [0, 0, 5, 5]}] * (MAX_DETECTIONS + 1)
    with pytest.raises(InputError, match=rf"^in\.json -> detections: {MAX_DETECTIONS + 1} detections, at most {MAX_DETECTIONS}"):
        read_detections_json(_json(tmp_path, {"detections": entries}), IMAGE)
    path = tmp_path / "labels.txt"
    path.write_text("DontCare -1 -1 -10 0 0 5 5 -1 -1 -1 -1000 -1000 -1000 -10\n" * 10 + "Car 0 0 0 0 0 5 5 1 1 1 0 0 0 0\n" * MAX_DETECTIONS)
    assert len(read_kitti_labels(path, IMAGE).items) == MAX_DETECTIONS  # DontCare lines do not count


def test_detection_polygon_beyond_int32_refused_quickly(tmp_path: Path) -> None:
    path = _json(tmp_path, {"detections": [{"class": "car", "box": [0, 0, 5, 5], "polygon": [[0, 0], [1e10, 0], [0, 1e10]]}]})
    with pytest.raises(InputError, match=r"-> polygon -> \[1\]: pixel coordinate 1e\+10 is far outside"):
        read_detections_json(path, IMAGE)


def test_rle_run_beyond_int64(tmp_path: Path) -> None:
    mask = {"size": [40, 60], "counts": [10**30, 5]}
    path = _json(tmp_path, {"detections": [{"class": "car", "box": [0, 0, 5, 5], "mask": mask}]})
    with pytest.raises(InputError, match=r"-> mask -> counts: .*re-encode the mask"):
        read_detections_json(path, IMAGE)


def test_cityscapes_polygon_beyond_int32_refused(tmp_path: Path) -> None:
    doc = {"imgWidth": 60, "imgHeight": 40, "objects": [{"label": "car", "polygon": [[0, 0], [-1e10, 5], [3, 3]]}]}
    with pytest.raises(InputError, match=r"^in\.json -> objects -> \[0\] -> polygon -> \[1\]: pixel coordinate -1e\+10"):
        read_polygons(_json(tmp_path, doc), IMAGE)


@pytest.mark.parametrize(
    ("doc", "error", "message"),
    [
        ({"K": [[1e308, 0, 30], [0, 700, 20], [0, 0, 1]]}, CalibrationError, r"-> K -> \[0\]\[0\]: focal length 1e\+308 px is beyond 6000 px"),
        ({"fx": 70, "fy": 70, "cx": 30, "cy": 1e300}, CalibrationError, r"-> cy: must be finite and within \+-1e\+06 px"),
        ({"height_m": 1e308}, CalibrationError, r"-> height_m: camera height must be <= 100 m, got 1e\+308"),
        ({"yaw_deg": 1e308}, InputError, r"-> yaw_deg: must be within -360 \.\. 360 degrees, got 1e\+308"),
        ({"yaw_deg": -400}, InputError, r"-> yaw_deg: must be within -360 \.\. 360 degrees, got -400"),
    ],
)
def test_camera_numbers_bounded(tmp_path: Path, doc: dict[str, object], error: type[Exception], message: str) -> None:
    with pytest.raises(error, match=r"^cam\.json " + message):
        read_camera(_json(tmp_path, doc, "cam.json"), IMAGE)


def test_cityscapes_yaw_bounded(tmp_path: Path) -> None:
    doc = {
        "extrinsic": {"baseline": 0.2, "pitch": 0.03, "roll": 0.0, "yaw": 1e308, "x": 1.7, "y": 0.1, "z": 1.2},
        "intrinsic": {"fx": 70.0, "fy": 70.0, "u0": 30.0, "v0": 20.0},
    }
    with pytest.raises(InputError, match=r"^cam\.json -> extrinsic -> yaw: must be within -360 \.\. 360 degrees"):
        read_camera(_json(tmp_path, doc, "cam.json"), IMAGE)


def test_kitti_calib_offset_and_focal_bounded(tmp_path: Path) -> None:
    calib = tmp_path / "calib.txt"
    calib.write_text("P2: 70 0 30 1e308 0 70 20 0 0 0 1 0\n")
    with pytest.raises(InputError, match=r"^calib\.txt -> P2 \(line 1\): the camera offset t"):
        read_camera(calib, IMAGE)
    calib.write_text("P2: 1e300 0 30 0 0 70 20 0 0 0 1 0\n")
    with pytest.raises(CalibrationError, match=r"focal length 1e\+300 px is beyond"):
        read_camera(calib, None)


def test_plane_coefficients_bounded(tmp_path: Path) -> None:
    calib = tmp_path / "calib.txt"
    calib.write_text("P2: 70 0 30 0 0 70 20 0 0 0 1 0\n")
    plane = tmp_path / "plane.txt"
    plane.write_text("# Matrix\nWIDTH 4\nHEIGHT 1\n1e308 -1e308 0 1.6\n")
    with pytest.raises(InputError, match=r"^plane\.txt: line 4: plane coefficients must be finite and within \+-1e\+06"):
        read_camera(calib, IMAGE, plane)


def test_depth_beyond_bound_is_invalid(tmp_path: Path) -> None:
    depth = np.full((40, 60), 1e30, np.float32)
    depth[0, 0] = 12.5
    path = tmp_path / "d.npy"
    np.save(path, depth)
    dm = read_depth(path, IMAGE)
    assert dm.valid.sum() == 1 and dm.depth_m[0, 0] == 12.5 and dm.depth_m[1, 1] == 0


def test_npy_header_promising_huge_array(tmp_path: Path) -> None:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (100000, 100000)})
    path = tmp_path / "d.npy"
    path.write_bytes(buf.getvalue() + b"\0" * 64)
    with pytest.raises(InputError, match=r"^d\.npy: array of shape \(100000, 100000\) is more than 268435456 pixels"):
        read_depth(path)
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (400, 600)})
    path.write_bytes(buf.getvalue() + b"\0" * 64)
    with pytest.raises(InputError, match=r"header declares shape \(400, 600\) but the file is shorter"):
        read_depth(path)


def test_pfm_header_too_large(tmp_path: Path) -> None:
    path = tmp_path / "d.pfm"
    path.write_bytes(b"Pf\n100000 100000\n-1.0\n" + b"\0" * 16)
    with pytest.raises(InputError, match=r"^d\.pfm: PFM header gives 100000x100000, more than"):
        read_depth(path)


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def test_png_header_too_large(tmp_path: Path) -> None:
    ihdr = struct.pack(">IIBBBBB", 100000, 100000, 8, 0, 0, 0, 0)
    path = tmp_path / "big.png"
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr) + _png_chunk(b"IEND", b""))
    with pytest.raises(InputError, match=r"^big\.png: the PNG header gives 100000x100000, more than"):
        read_image(path)


def _damaged_png(tmp_path: Path) -> Path:
    ok, buf = cv2.imencode(".png", np.zeros((8, 8), np.uint8))
    data = bytearray(buf.tobytes())
    idat = data.index(b"IDAT")
    data[idat + 6] ^= 0xFF  # break the IDAT data: libpng reports a CRC error on stderr
    path = tmp_path / "bad.png"
    path.write_bytes(bytes(data))
    return path


def test_libpng_messages_do_not_reach_stderr(tmp_path: Path) -> None:
    path = _damaged_png(tmp_path)
    code = (
        "import sys\nfrom usdworld.io.images import read_image\nfrom usdworld.errors import InputError\n"
        f"try:\n    read_image({str(path)!r})\nexcept InputError as e:\n    print('error:', e, file=sys.stderr)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stderr.startswith("error: bad.png: the PNG data is corrupt"), out.stderr
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr


def test_a_decode_on_another_thread_does_not_wait_for_one_in_progress() -> None:
    """The capture is shared, not held: a second block enters while the first is inside."""
    import threading

    from usdworld.io.images import native_stderr_captured

    inside, release = threading.Event(), threading.Event()

    def first() -> None:
        with native_stderr_captured("first"):
            inside.set()
            release.wait(10)

    entered = threading.Event()

    def second() -> None:
        with native_stderr_captured("second"):
            entered.set()

    a = threading.Thread(target=first)
    a.start()
    assert inside.wait(10)
    b = threading.Thread(target=second)
    b.start()
    b.join(2)
    got = entered.is_set()
    release.set()
    a.join(10)
    b.join(10)
    assert got


def test_max_range_capped() -> None:
    from usdworld.pipeline import BuildRequest

    for value in (1e308, float("inf"), float("nan"), 1000.5, 0.0):
        with pytest.raises(UsdWorldError, match=r"^--max-range must be > 0 and <= 1000 m"):
            BuildRequest(image=Path("a.png"), output=Path("w"), max_range_m=value)
    assert BuildRequest(image=Path("a.png"), output=Path("w"), max_range_m=1000.0).max_range_m == 1000.0
