"""A road plane (--ground-plane) is a prior on the camera's height and pitch that the objects refine."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from usdworld.pipeline import BuildRequest, build

F, CX, CY, W, H = 300.0, 160.0, 60.0, 320, 120


def _person_boxes(camera_height_m: float) -> list[dict]:
    """Boxes of 1.75 m people standing 6-20 m ahead of a level camera ``camera_height_m`` up."""
    boxes = []
    for depth, lateral in ((6.0, -1.5), (8.0, 2.0), (10.0, -3.0), (13.0, 1.0), (16.0, -2.0), (20.0, 2.5)):
        u = CX + F * lateral / depth
        v_bottom = CY + F * camera_height_m / depth
        v_top = CY + F * (camera_height_m - 1.75) / depth
        half = 0.5 * F * 0.5 / depth
        boxes.append({"class": "person", "box": [u - half, v_top, u + half, v_bottom]})
    return boxes


def test_the_plane_is_a_prior_that_the_objects_refine(tmp_path):
    """People of a camera 1.45 m up pull a plane that says 1.65 m (+-0.14 m) towards 1.45 m; the
    plane's roll stays; the camera record says so."""
    image = tmp_path / "frame.png"
    cv2.imwrite(str(image), np.full((H, W, 3), 110, np.uint8))
    calib = tmp_path / "calib.txt"
    calib.write_text(f"P2: {F} 0 {CX} 0 0 {F} {CY} 0 0 0 1 0\n")
    roll = math.radians(0.5)
    plane = tmp_path / "plane.txt"
    plane.write_text(f"# Matrix\nWIDTH 4\nHEIGHT 1\n{-math.sin(roll)} {-math.cos(roll)} 0 1.65\n")
    detections = tmp_path / "detections.json"
    detections.write_text(json.dumps({"detections": _person_boxes(1.45)}))
    request = BuildRequest(
        image=image, output=tmp_path / "world", detections=detections, camera=calib, ground_plane=plane
    )
    estimate = build(request).model.camera
    assert 1.40 < estimate.camera.height_m < 1.55  # more than half-way from the plane's 1.65 m
    assert estimate.camera.roll == pytest.approx(roll, abs=1e-9)
    assert {"height_m", "pitch"} <= set(estimate.estimated) and "roll" not in estimate.estimated
    assert 0 < estimate.sigma_height_m < 0.14
    assert "road plane's height 1.650 m" in estimate.method
