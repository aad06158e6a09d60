"""The batched box fit (layout.boxes.fit_view_angle) against the per-turn loop it replaced, bit for bit."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.geometry.camera import PinholeCamera
from usdworld.io.label_table import label_lookups
from usdworld.io.types import Detection, Detections, InputFile
from usdworld.layout.boxes import box_corners, box_corners_turned, fit_view_angle
from usdworld.layout.yaw import view_angle_from_box
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.objects import ImageObject, objects_from_detections


def _loop_fit_view_angle(
    camera: PinholeCamera, ground: np.ndarray, size_lwh: np.ndarray, obj: ImageObject, params: PlacementParams
) -> float:
    """The fit as it was: one ``camera.project`` per turn tried (the reference)."""
    x0, y0, x1, y1 = (float(b) for b in obj.edges_px)
    observed = (x1 - x0) / (y1 - y0)
    bearing = float(np.arctan2(ground[1], ground[0]))
    angles_deg = params.view_angles_deg
    aspects = []
    for angle in np.radians(angles_deg):
        px, depth = camera.project(box_corners(ground, bearing + angle, np.asarray(size_lwh)))
        ok = np.isfinite(px).all() and bool(np.all(depth > 0))
        aspects.append(np.ptp(px[:, 0]) / max(np.ptp(px[:, 1]), 1e-9) if ok else np.nan)
    curve = np.array(aspects)
    if not np.isfinite(curve).all():
        return float(view_angle_from_box(x1 - x0, y1 - y0, tuple(size_lwh)))
    peak = int(np.argmax(curve))
    if observed <= curve[0]:
        return 0.0
    if observed >= curve[-1]:
        return float(np.radians(angles_deg[peak]))
    rising = curve[: peak + 1]
    k = int(np.searchsorted(rising, observed))
    k = min(max(k, 1), peak)
    a0, a1 = angles_deg[k - 1], angles_deg[k]
    t = (observed - rising[k - 1]) / max(rising[k] - rising[k - 1], 1e-12)
    return float(np.radians(a0 + np.clip(t, 0.0, 1.0) * (a1 - a0)))


cameras = st.builds(
    lambda f, cx, cy, h, pitch, roll, yaw: PinholeCamera(
        1242, 375, np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]]), h, pitch, roll, yaw
    ),
    st.floats(200.0, 3000.0),
    st.floats(300.0, 900.0),
    st.floats(100.0, 300.0),
    st.floats(0.5, 3.0),
    st.floats(-0.2, 0.3),
    st.floats(-0.1, 0.1),
    st.floats(-0.3, 0.3),
)
sizes = st.tuples(st.floats(2.5, 12.0), st.floats(1.4, 2.6), st.floats(1.2, 4.0))


def _obj(box: tuple[float, float, float, float]) -> ImageObject:
    dets = Detections(
        (Detection("Car", np.array(box), amodal=True),), InputFile("detections", "d.txt", "0" * 64)
    )
    (obj,) = objects_from_detections(dets, 1242, 375, lookups=label_lookups())
    return obj


@settings(max_examples=300, deadline=None)
@given(
    camera=cameras,
    x=st.floats(-5.0, 120.0),
    y=st.floats(-30.0, 30.0),
    size=sizes,
    u0=st.floats(1.0, 1100.0),
    v0=st.floats(1.0, 300.0),
    w=st.floats(2.0, 600.0),
    h=st.floats(2.0, 300.0),
    step=st.sampled_from([1.0, 2.5, 5.0]),
)
def test_batched_fit_equals_the_per_turn_loop(camera, x, y, size, u0, v0, w, h, step):
    # Random cameras, positions (some behind the camera or under it: the camera-free fallback),
    # box shapes and image boxes: the same angle to the last bit.
    ground, lwh = np.array([x, y]), np.array(size)
    obj = _obj((u0, v0, min(u0 + w, 1240.0), min(v0 + h, 374.0)))
    params = PlacementParams(view_angle_step_deg=step)
    new = fit_view_angle(camera, ground, lwh, obj, params)
    old = _loop_fit_view_angle(camera, ground, lwh, obj, params)
    assert np.array_equal(np.float64(new), np.float64(old)), (new, old)


@settings(max_examples=100, deadline=None)
@given(
    camera=cameras,
    x=st.floats(-5.0, 120.0),
    y=st.floats(-30.0, 30.0),
    size=sizes,
    yaws=st.lists(st.floats(-7.0, 7.0), min_size=1, max_size=100),
)
def test_stacked_corners_and_projection_equal_one_box_at_a_time(camera, x, y, size, yaws):
    ground, lwh = np.array([x, y]), np.array(size)
    corners = box_corners_turned(ground, np.array(yaws), lwh)
    px, depth = camera.project_stacked(corners)
    for k, yaw in enumerate(np.array(yaws)):
        one = box_corners(ground, yaw, lwh)
        one_px, one_depth = camera.project(one)
        assert np.array_equal(corners[k], one)
        assert np.array_equal(px[k], one_px, equal_nan=True)
        assert np.array_equal(depth[k], one_depth)
