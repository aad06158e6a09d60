"""Every reader turns any bytes into a result or a one-line UsdWorldError, never a raw exception."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from usdworld.errors import UsdWorldError
from usdworld.io.camera_files import read_camera
from usdworld.io.correspondences import read_correspondences
from usdworld.io.depth_files import read_depth
from usdworld.io.detections import read_detections_json, read_kitti_labels
from usdworld.io.images import read_image
from usdworld.io.labels import read_polygons, read_segmentation
from usdworld.io.types import InputFile, SourceImage

IMAGE = SourceImage(rgb=np.zeros((4, 6, 3), np.uint8), file=InputFile("image", "frame.png", "0" * 64))

READERS: dict[str, Callable[[Path], object]] = {
    "image": read_image,
    "labels": lambda p: read_segmentation(p, image=IMAGE),
    "polygons": lambda p: read_polygons(p, IMAGE),
    "kitti": lambda p: read_kitti_labels(p, IMAGE),
    "detections": lambda p: read_detections_json(p, IMAGE),
    "camera": lambda p: read_camera(p, IMAGE),
    "correspondences": read_correspondences,
    "depth": lambda p: read_depth(p, IMAGE),
}

_ok, _png = cv2.imencode(".png", np.full((4, 6), 7, np.uint8))
SEEDS = [
    bytes(_png),
    json.dumps(
        {"imgWidth": 6, "imgHeight": 4, "objects": [{"label": "car", "polygon": [[0, 0], [3, 0], [3, 3]]}]}
    ).encode(),
    b"Car 0 0 0 1 1 5 3 1 1 1 0 0 0 0\n",
    json.dumps(
        {"detections": [{"class": "car", "box": [0, 0, 2, 2], "mask": {"size": [4, 6], "counts": "23c0"}}]}
    ).encode(),
    json.dumps({"K": [[5, 0, 3], [0, 5, 2], [0, 0, 1]], "height_m": 1.5}).encode(),
    b"P2: 5 0 3 0 0 5 2 0 0 0 1 0\n",
    b"u,v,x,y\n0,0,1,1\n1,0,2,1\n0,1,1,2\n1,1,2,2\n",
    b"Pf\n6 4\n-1.0\n" + np.ones(24, "<f4").tobytes(),
]


def _mutations() -> st.SearchStrategy[bytes]:
    seed = st.sampled_from(SEEDS)
    cut = st.tuples(seed, st.integers(0, 200)).map(lambda t: t[0][: t[1]])
    flip = st.tuples(seed, st.integers(0, 199), st.integers(0, 255)).map(
        lambda t: t[0][: t[1] % max(len(t[0]), 1)] + bytes([t[2]]) + t[0][t[1] % max(len(t[0]), 1) + 1 :]
    )
    return st.one_of(st.binary(max_size=64), cut, flip, seed)


@pytest.mark.parametrize("reader", sorted(READERS))
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=_mutations())
def test_reader_never_leaks_raw_exceptions(tmp_path: Path, reader: str, data: bytes) -> None:
    path = tmp_path / "input.bin"
    path.write_bytes(data)
    try:
        READERS[reader](path)
    except UsdWorldError as exc:
        message = str(exc)
        assert message and "\n" not in message
