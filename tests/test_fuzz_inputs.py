"""Structured fuzzing of every input reader with hostile numbers (8 x 130 = 1,040 cases, about 15 s of CPU).

Each format gets a hypothesis strategy that writes well-formed files filled with
hostile values: huge, tiny, negative, non-finite, non-integer where pixels are meant,
wrong types. Every reader must either return a result that respects its documented
bounds or raise a one-line :class:`UsdWorldError`; any other exception, a warning on
stderr or a hang fails the test.
"""

from __future__ import annotations

import io
import json
import math
import warnings
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from usdworld.errors import UsdWorldError
from usdworld.io.camera_files import read_camera
from usdworld.io.correspondences import read_correspondences
from usdworld.io.depth_files import MAX_FILE_DEPTH_M, read_depth
from usdworld.io.detections import read_detections_json, read_kitti_labels
from usdworld.io.images import read_image
from usdworld.io.labels import read_polygons, read_segmentation
from usdworld.io.limits import MAX_CAMERA_HEIGHT_M, MAX_GROUND_COORD_M, MAX_GROUND_PAIRS, MAX_PIXEL_COORD
from usdworld.io.types import InputFile, SourceImage

H, W = 24, 36
IMAGE = SourceImage(rgb=np.zeros((H, W, 3), np.uint8), file=InputFile("image", "frame.png", "0" * 64))
FUZZ = settings(max_examples=130, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

HOSTILE = [0.0, -0.0, 1.0, -1.0, 0.5, 1e-300, 5e-324, 1e10, -1e10, 2**31, -(2**31) - 1, 1e19, 1e300, 1e308, -1e308]
NUMBER = st.one_of(
    st.sampled_from(HOSTILE),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-2 * W, 2 * W),
    st.integers(-(10**20), 10**20),
)
JSON_VALUE = st.one_of(NUMBER, st.none(), st.booleans(), st.text(max_size=4), st.just([]), st.just({}))


def _write(tmp_path: Path, name: str, data: bytes | str) -> Path:
    path = tmp_path / name
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def _dumps(doc: Any) -> str:
    return json.dumps(doc)  # writes NaN / Infinity literals, which the readers must refuse


def _run(read: Any, *args: Any) -> Any:
    """Call a reader: its result, or None after a one-line UsdWorldError. Warnings fail."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            return read(*args)
        except UsdWorldError as exc:
            assert str(exc) and "\n" not in str(exc)
            return None


# --- images, label maps, instance maps ------------------------------------------------

ARRAYS = st.tuples(
    st.integers(1, 12), st.integers(1, 12), st.sampled_from([None, 1, 2, 3, 4]), st.sampled_from([np.uint8, np.uint16])
).flatmap(
    lambda t: st.builds(
        lambda seed: np.random.default_rng(seed).integers(0, np.iinfo(t[3]).max, (t[0], t[1]) + ((t[2],) if t[2] else ()), endpoint=True).astype(t[3]),
        st.integers(0, 2**32 - 1),
    )
)


def _encode(arr: np.ndarray, ext: str) -> bytes:
    if arr.ndim == 3 and arr.shape[2] == 2 or (ext == ".jpg" and arr.dtype != np.uint8):
        ext = ".png"
    ok, buf = cv2.imencode(ext, arr if not (arr.ndim == 3 and arr.shape[2] == 2) else arr[:, :, 0])
    assert ok
    return buf.tobytes()


@FUZZ
@given(arr=ARRAYS, ext=st.sampled_from([".png", ".jpg"]), cut=st.integers(0, 400))
def test_images(tmp_path: Path, arr: np.ndarray, ext: str, cut: int) -> None:
    data = _encode(arr, ext)
    data = data if cut >= len(data) else data[: max(cut, 1)]
    image = _run(read_image, _write(tmp_path, "img" + ext, data))
    if image is not None:
        assert image.rgb.dtype == np.uint8 and image.rgb.shape[2] == 3


@FUZZ
@given(labels=ARRAYS, instances=st.one_of(st.none(), ARRAYS), ids=st.booleans())
def test_label_and_instance_maps(tmp_path: Path, labels: np.ndarray, instances: np.ndarray | None, ids: bool) -> None:
    if ids:  # known Cityscapes ids at the image size, more often accepted
        labels = (labels.reshape(-1)[: H * W].astype(np.int64) % 34).astype(np.uint8)
        labels = np.resize(labels, (H, W))
    lp = _write(tmp_path, "l.png", _encode(labels, ".png"))
    ip = None if instances is None else _write(tmp_path, "i.png", _encode(instances, ".png"))
    seg = _run(read_segmentation, lp, ip, IMAGE if ids else None)
    if seg is not None:
        assert seg.label_ids.dtype == np.uint8


# --- camera files ---------------------------------------------------------------------


@FUZZ
@given(
    kind=st.sampled_from(["cityscapes", "plain_K", "plain_f", "kitti", "kitti_plane"]),
    values=st.lists(NUMBER, min_size=16, max_size=16),
    wrong=st.one_of(st.none(), st.tuples(st.integers(0, 15), JSON_VALUE)),
)
def test_camera_files(tmp_path: Path, kind: str, values: list[Any], wrong: tuple[int, Any] | None) -> None:
    v: list[Any] = list(values)
    if wrong is not None and kind.startswith(("cityscapes", "plain")):
        v[wrong[0]] = wrong[1]
    plane = None
    if kind == "cityscapes":
        doc: Any = {
            "extrinsic": dict(zip(("baseline", "pitch", "roll", "yaw", "x", "y", "z"), v[:7])),
            "intrinsic": dict(zip(("fx", "fy", "u0", "v0"), v[7:11])),
        }
        path = _write(tmp_path, "cam.json", _dumps(doc))
    elif kind == "plain_K":
        doc = {"K": [[v[0], v[1], v[2]], [0, v[3], v[4]], [0, 0, 1]], "height_m": v[5], "pitch_deg": v[6], "yaw_deg": v[7]}
        path = _write(tmp_path, "cam.json", _dumps(doc))
    elif kind == "plain_f":
        doc = dict(zip(("fx", "fy", "cx", "cy", "height_m", "pitch_deg", "roll_deg", "yaw_deg"), v[:8]))
        path = _write(tmp_path, "cam.json", _dumps(doc))
    else:
        p2 = [v[0], 0, v[1], v[2], 0, v[3], v[4], v[5], 0, 0, 1, v[6]]
        path = _write(tmp_path, "calib.txt", "P2: " + " ".join(repr(float(x)) for x in p2) + "\n")
        if kind == "kitti_plane":
            plane = _write(tmp_path, "plane.txt", "# Matrix\nWIDTH 4\nHEIGHT 1\n" + " ".join(repr(float(x)) for x in v[7:11]) + "\n")
    spec = _run(read_camera, path, IMAGE, plane)
    if spec is not None:
        if spec.K is not None:
            assert np.all(np.isfinite(spec.K)) and spec.K[0, 0] > 0 and spec.K[1, 1] > 0
            assert np.all(np.abs(spec.K) <= MAX_PIXEL_COORD * 10)
        if spec.height_m is not None:
            assert 0 < spec.height_m <= MAX_CAMERA_HEIGHT_M
        for angle in (spec.pitch, spec.roll, spec.yaw):
            assert angle is None or abs(angle) <= 2 * math.pi


# --- detections -----------------------------------------------------------------------

BOX = st.lists(NUMBER, min_size=4, max_size=4)
POLYGON = st.lists(st.lists(NUMBER, min_size=2, max_size=2), min_size=0, max_size=6)
DETECTION = st.fixed_dictionaries(
    {"class": st.sampled_from(["car", "person", "Truck", "", "zeppelin", 3]), "box": BOX},
    optional={
        "score": NUMBER,
        "polygon": POLYGON,
        "mask": st.fixed_dictionaries({"size": st.lists(NUMBER, min_size=2, max_size=2), "counts": st.one_of(st.lists(NUMBER, max_size=4), st.text("0123456789:;<=>?@ABCDEFGHIJKLMNOabcdefghijklmno", max_size=8))}),
        "amodal": JSON_VALUE,
    },
)


def _check_detections(dets: Any) -> None:
    if dets is not None:
        for d in dets.items:
            x1, y1, x2, y2 = d.box_px
            assert 0 <= x1 < x2 <= W and 0 <= y1 < y2 <= H and 0 <= d.score <= 1


@FUZZ
@given(entries=st.lists(DETECTION, max_size=4))
def test_detections_json(tmp_path: Path, entries: list[dict[str, Any]]) -> None:
    _check_detections(_run(read_detections_json, _write(tmp_path, "d.json", _dumps({"detections": entries})), IMAGE))


@FUZZ
@given(lines=st.lists(st.tuples(st.sampled_from(["Car", "Pedestrian", "DontCare", "Zeppelin"]), st.lists(NUMBER, min_size=14, max_size=15)), max_size=4))
def test_kitti_labels(tmp_path: Path, lines: list[tuple[str, list[Any]]]) -> None:
    text = "".join(f"{label} " + " ".join(repr(float(x)) for x in fields) + "\n" for label, fields in lines)
    _check_detections(_run(read_kitti_labels, _write(tmp_path, "000001.txt", text), IMAGE))


# --- polygons, ground points, depth ---------------------------------------------------


@FUZZ
@given(
    size=st.tuples(st.sampled_from([W, 0, -1, 1.5, 1e308, "36"]), st.sampled_from([H, 0, 1e10])),
    objects=st.lists(st.fixed_dictionaries({"label": st.sampled_from(["car", "road", "cargroup", "license plate", "x"]), "polygon": POLYGON}), max_size=4),
)
def test_polygons(tmp_path: Path, size: tuple[Any, Any], objects: list[dict[str, Any]]) -> None:
    doc = {"imgWidth": size[0], "imgHeight": size[1], "objects": objects}
    seg = _run(read_polygons, _write(tmp_path, "p.json", _dumps(doc)), IMAGE)
    if seg is not None:
        assert seg.label_ids.shape == (H, W)


@FUZZ
@given(pairs=st.lists(st.tuples(st.lists(NUMBER, min_size=2, max_size=2), st.lists(NUMBER, min_size=2, max_size=2)), max_size=8), csv=st.booleans())
def test_ground_points(tmp_path: Path, pairs: list[tuple[list[Any], list[Any]]], csv: bool) -> None:
    if csv:
        text = "u,v,x,y\n" + "".join(",".join(repr(float(x)) for x in px + g) + "\n" for px, g in pairs)
    else:
        text = _dumps({"pairs": [{"px": px, "ground": g} for px, g in pairs]})
    corr = _run(read_correspondences, _write(tmp_path, "pts.csv" if csv else "pts.json", text))
    if corr is not None:
        assert 4 <= len(corr.points_px) <= MAX_GROUND_PAIRS
        assert np.all(np.abs(corr.points_px) <= MAX_PIXEL_COORD)
        assert np.all(np.abs(corr.points_ground) <= MAX_GROUND_COORD_M)


@FUZZ
@given(
    fmt=st.sampled_from(["npy", "png", "pfm"]),
    values=st.lists(NUMBER, min_size=1, max_size=4),
    shape=st.sampled_from([(H, W), (W, H), (1, H, W), (0, W), (H,)]),
    dtype=st.sampled_from(["<f4", ">f8", "<f2", "<i4"]),
)
def test_depth_files(tmp_path: Path, fmt: str, values: list[Any], shape: tuple[int, ...], dtype: str) -> None:
    with np.errstate(all="ignore"):
        arr = np.resize(np.array([float(x) for x in values], dtype=np.float64), shape)
    if fmt == "npy":
        buf = io.BytesIO()
        np.save(buf, arr.astype(dtype) if dtype != "<i4" else arr.clip(-1e9, 1e9).astype(np.int32, casting="unsafe"))
        data = buf.getvalue()
    elif fmt == "png" and arr.size == 0:
        data = b"\x89PNG\r\n\x1a\n"  # a signature and nothing else
    elif fmt == "png":
        data = _encode(np.nan_to_num(arr.reshape(arr.shape[-2:]) if arr.ndim >= 2 else arr[None]).clip(0, 65535).astype(np.uint16), ".png")
    else:
        a2 = arr.reshape(arr.shape[-2:]) if arr.ndim >= 2 else arr[None]
        data = f"Pf\n{a2.shape[1]} {a2.shape[0]}\n-1.0\n".encode() + np.flipud(a2).astype("<f4").tobytes()
    depth = _run(read_depth, _write(tmp_path, f"d.{fmt}", data), IMAGE)
    if depth is not None:
        d = depth.depth_m[depth.valid]
        assert d.size and np.all(np.isfinite(d)) and np.all((d > 0) & (d <= MAX_FILE_DEPTH_M))


@pytest.mark.parametrize("n", [0])
def test_strategies_cover_every_format(n: int) -> None:
    """The formats the readers accept, each fuzzed above (a reminder to add one here)."""
    fuzzed = {"images", "label_and_instance_maps", "camera_files", "detections_json", "kitti_labels", "polygons", "ground_points", "depth_files"}
    assert {name[5:] for name in globals() if name.startswith("test_") and name != "test_strategies_cover_every_format"} == fuzzed


def test_a_build_error_after_a_reader_warning_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The camera reader warns about its principal point, then the detections are refused: one line
    (tools/fuzz_build.py case 6); the same warning is printed when the build succeeds."""
    from usdworld.cli.main import main

    image = _write(tmp_path, "img.png", _encode(np.full((64, 96, 3), 90, np.uint8), ".png"))
    calib = _write(tmp_path, "calib.txt", "P2: 80 0 0.5 4 0 80 40 0 0 0 1 0\n")  # cx far from the centre
    bad = _write(tmp_path, "d.json", _dumps({"detections": [{"class": "car", "box": [36, 32, -1, 26]}]}))
    args = ["build", str(image), "--camera", str(calib), "-o", str(tmp_path / "world")]
    assert main([*args, "--detections", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: d.json -> detections -> [0] -> box:"), err
    assert main(args) == 0
    assert "principal point (0.5, 40) is far from the centre" in capsys.readouterr().err
