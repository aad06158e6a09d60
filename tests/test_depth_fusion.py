"""Tests for usdworld.perception.depth.fusion: per-object depth cues and their fusion."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.errors import InputError, LayoutError
from usdworld.io.types import DepthMap
from usdworld.perception.depth import DepthCue, fuse, object_depth_cues
from usdworld.perception.depth.fusion import contact_sigma_m, erode, interquartile_mean

FY = 1000.0
CAM_H = 1.5
CAR_H = 1.5


def _scene(object_depth: float, background: float = 60.0) -> tuple[np.ndarray, DepthMap]:
    mask = np.zeros((100, 120), bool)
    mask[30:70, 40:90] = True
    depth = np.full(mask.shape, background, np.float32)
    depth[mask] = object_depth
    return mask, DepthMap(depth_m=depth, valid=np.ones(mask.shape, bool), source="test")


def test_fully_visible_near_object_is_dominated_by_contact() -> None:
    mask, dm = _scene(8.6)
    cues = object_depth_cues(
        mask, np.zeros_like(mask), 8.0, dm, CAR_H, FY * CAR_H / 8.3, FY, camera_height_m=CAM_H
    )
    assert [c.name for c in cues] == ["contact", "cnn", "height"] and all(c.available for c in cues)
    fused = fuse(cues)
    assert fused.method == "contact"
    assert fused.depth_m == pytest.approx(8.0, abs=0.05)
    assert fused.sigma_m < min(c.sigma_m for c in cues)  # type: ignore[type-var]
    assert fused.cues == tuple(cues)


def test_truncated_object_uses_cnn_and_height() -> None:
    mask, dm = _scene(21.0)
    # Bottom occluded: no contact; the top and bottom of the mask are still its extent here.
    cues = object_depth_cues(
        mask, np.zeros_like(mask), None, dm, CAR_H, FY * CAR_H / 19.0, FY, camera_height_m=CAM_H
    )
    fused = fuse(cues)
    assert cues[0].available is False and cues[0].note == "bottom truncated or occluded"
    assert fused.method == "fused" and 19.0 < fused.depth_m < 21.0
    assert len(fused.cues) == 3  # the unavailable contact cue is kept for provenance
    # Cut at the image bottom: neither contact nor height, the CNN alone.
    only_cnn = fuse(
        object_depth_cues(mask, np.zeros_like(mask), None, dm, CAR_H, None, FY, camera_height_m=CAM_H)
    )
    assert only_cnn.method == "cnn" and only_cnn.depth_m == pytest.approx(21.0)
    assert [c.note for c in only_cnn.cues if not c.available] == [
        "bottom truncated or occluded",
        "top or bottom cut",
    ]


def test_cnn_cue_excludes_occluders_and_mask_edges() -> None:
    mask, dm = _scene(15.0)
    depth = dm.depth_m.copy()
    occluders = np.zeros_like(mask)
    occluders[30:70, 40:60] = True  # a pole in front, 5 m away, covering part of the object
    depth[occluders] = 5.0
    # A 1-px ring of background depth inside the mask edge (segmentation bleeding).
    ring = mask & ~erode(mask, 1)
    depth[ring] = 60.0
    cues = object_depth_cues(
        mask,
        occluders,
        None,
        DepthMap(depth, np.ones_like(mask), "t"),
        CAR_H,
        None,
        FY,
        camera_height_m=CAM_H,
    )
    assert cues[1].depth_m == pytest.approx(15.0)
    assert cues[1].sigma_m == pytest.approx(1.5)
    assert "eroded 2 px" in cues[1].note


def test_cnn_cue_unavailable_without_pixels() -> None:
    mask, dm = _scene(15.0)
    cues = object_depth_cues(mask, mask.copy(), 10.0, dm, CAR_H, None, FY, camera_height_m=CAM_H)
    assert cues[1].depth_m is None and cues[1].note == "0 unoccluded pixels with depth (need 10)"
    assert (
        object_depth_cues(mask, mask, 10.0, None, CAR_H, None, FY, camera_height_m=CAM_H)[1].note
        == "no depth map"
    )


def test_documented_sigmas() -> None:
    # Contact: a uniform error over one pixel of row (1/sqrt(12) px) -> d^2 / (f h sqrt(12)),
    # with a 1 % floor, in quadrature.
    assert contact_sigma_m(30.0, FY, CAM_H) == pytest.approx(np.hypot(900 / 1500 / np.sqrt(12.0), 0.3))
    mask, dm = _scene(12.0)
    cues = object_depth_cues(
        mask, np.zeros_like(mask), None, dm, 1.75, 50.0, FY, camera_height_m=CAM_H, class_height_std_m=0.1
    )
    d = FY * 1.75 / 50.0
    assert cues[2].depth_m == pytest.approx(d)
    assert cues[2].sigma_m == pytest.approx(d * np.hypot(0.1 / 1.75, 1 / 50.0))


@settings(max_examples=30, deadline=None)
@given(st.floats(1.0, 100.0), st.floats(1.0, 100.0))
def test_sigmas_grow_with_distance(d1: float, d2: float) -> None:
    near, far = sorted((d1, d2))
    assert contact_sigma_m(near, FY, CAM_H) <= contact_sigma_m(far, FY, CAM_H)


def test_inverse_variance_known_answer_and_errors() -> None:
    fused = fuse([DepthCue("contact", 10.0, 1.0), DepthCue("cnn", 20.0, 2.0)])
    assert fused.depth_m == pytest.approx(12.0) and fused.sigma_m == pytest.approx(1 / np.sqrt(1.25))
    assert fused.method == "contact"  # 80 % of the weight
    assert fused.chi2 == pytest.approx(1.0 * 4.0 + 0.25 * 64.0)
    with pytest.raises(
        LayoutError, match=r"no depth cue is available: contact \(bottom truncated\), cnn \(unavailable\)"
    ):
        fuse([DepthCue("contact", None, None, "bottom truncated"), DepthCue("cnn", None, None)])
    with pytest.raises(InputError, match="depth_m and sigma_m must both be set or both None"):
        DepthCue("cnn", 3.0, None)
    with pytest.raises(InputError, match="sigma_m must be finite and > 0"):
        DepthCue("cnn", 3.0, 0.0)
    with pytest.raises(InputError, match="fy must be > 0"):
        object_depth_cues(
            np.ones((2, 2), bool), np.zeros((2, 2), bool), 1.0, None, 1.0, None, 0.0, camera_height_m=1.0
        )


def test_helpers() -> None:
    m = np.zeros((7, 7), bool)
    m[1:6, 1:6] = True
    np.testing.assert_array_equal(np.argwhere(erode(m, 2)), [[3, 3]])
    assert not erode(np.ones((3, 3), bool), 1)[0, 0]  # outside the image is background
    assert interquartile_mean(np.array([1.0, 2.0, 3.0, 4.0, 100.0])) == pytest.approx(3.0)


def test_class_mean_uncertainty_widens_only_the_height_cue() -> None:
    mask, _ = _scene(20.0)
    h_px = FY * CAR_H / 20.0
    plain = object_depth_cues(mask, np.zeros_like(mask), 20.0, None, CAR_H, h_px, FY, camera_height_m=CAM_H)
    widened = object_depth_cues(
        mask, np.zeros_like(mask), 20.0, None, CAR_H, h_px, FY, camera_height_m=CAM_H, class_mean_rel_sigma=0.1
    )
    assert widened[0] == plain[0]  # contact untouched
    std_rel = 0.1  # HEIGHT_REL_STD default
    assert plain[2].sigma_m == pytest.approx(20.0 * np.sqrt(std_rel**2 + (1 / h_px) ** 2))
    assert widened[2].sigma_m == pytest.approx(20.0 * np.sqrt(std_rel**2 + 0.1**2 + (1 / h_px) ** 2))
    assert widened[2].depth_m == plain[2].depth_m
