"""tools/focal_report.py: what each focal cue reads per frame (with the shared data); the box shapes' profile."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from usdworld.geometry.focal import BoxShapes, box_shape_cue, box_shape_profile, principal_point
from usdworld.parameters import Parameters
from usdworld.parameters.camera import CameraParams
from usdworld.pipeline import BuildRequest

_TOOL = Path(__file__).parents[1] / "tools" / "focal_report.py"
_spec = importlib.util.spec_from_file_location("focal_report", _TOOL)
focal_report = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(focal_report)


def test_the_box_shape_cue_carries_the_profile_it_is_summarised_from():
    """box_shape_profile is the cue's likelihood: the cue's stored profile is it, and its mode
    is within one grid step of the cue's value on boxes of one car shape seen by a level camera."""
    w, h, f, cam_h = 1242, 375, 721.0, 1.65
    c = principal_point(w, h)
    L, W, H = CameraParams().shape_car_size_m
    boxes = []
    for X, Z in [(-4, 12), (3.5, 15), (-3, 25), (6, 20), (0.5, 30), (-7, 18)]:
        pts = np.array(
            [(X + dx, y, Z + dz) for dx in (-W / 2, W / 2) for dz in (-L / 2, L / 2) for y in (cam_h, cam_h - H)]
        )
        u, v = c[0] + f * pts[:, 0] / pts[:, 2], c[1] + f * pts[:, 1] / pts[:, 2]
        boxes.append([u.min(), v.min(), u.max(), v.max()])
    shapes = BoxShapes(np.array(boxes), np.tile((L, W, H), (6, 1)), np.full(6, 0.12))
    p = CameraParams()
    log_f, log_lik = box_shape_profile(w, h, shapes, None, None, p)
    cue = box_shape_cue(w, h, shapes, None, None, p)
    assert cue is not None and log_lik.max() == 0.0 and np.all(np.diff(log_f) > 0)
    np.testing.assert_array_equal(cue.profile_log_f, log_f)
    np.testing.assert_array_equal(cue.profile_log_lik, log_lik)
    step = log_f[1] - log_f[0]
    assert abs(log_f[np.argmax(log_lik)] - np.log(f)) < 2 * step + cue.sigma_log


@pytest.mark.shared_data
def test_focal_report_on_a_kitti_frame(shared_data, tmp_path):
    """KITTI 000022 (no street vanishing point; two whole cars): the prior reads +11.5 % of P2's
    721.5 px (0.62 of the 1297 px diagonal), the box shapes read both cars, the fused line names them."""
    data = shared_data / "kitti" / "training"
    request = BuildRequest(
        image=data / "image_2" / "000022.png", output=tmp_path / "w", detections=data / "label_2" / "000022.txt"
    )
    line, f_fused = focal_report.frame_report(request, 721.5377, Parameters())
    assert line.startswith("prior  +11.5%")
    assert "vp -" in line and "shapes 2/2 mode" in line and "[box_shapes]" in line
    assert 0.9 < f_fused / 721.5377 < 1.3
