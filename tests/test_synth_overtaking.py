"""``synth --sequence --overtaking``: a car that starts out of view beside the ego and drives into view."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.cli.main import main
from usdworld.geometry.camera import PinholeCamera, intrinsics_from_fov
from usdworld.synth.drive import make_drive
from usdworld.synth.overtaking import ENTRY_MARGIN_M, entry_centre_x, overtaking_lane_y
from usdworld.synth.street import StreetLayout

CAR = np.array([4.0, 1.8, 1.5])


def _street(lanes_right: int, ego_lane: int, lanes_left: int = 1) -> StreetLayout:
    return StreetLayout(3.2, lanes_right, lanes_left, (ego_lane + 0.5) * 3.2, 2.2, 2.2, 4.0, 4.0, None)


def _corners(size: np.ndarray, centre_x: float, lane_y: float) -> np.ndarray:
    xs, ys, zs = np.meshgrid(
        centre_x + np.array([-0.5, 0.5]) * size[0], lane_y + np.array([-0.5, 0.5]) * size[1], [0.0, size[2]]
    )
    return np.stack([xs.ravel(), ys.ravel(), zs.ravel()], axis=1)


def _in_image(camera: PinholeCamera, points: np.ndarray) -> np.ndarray:
    px, depth = camera.project(points)
    with np.errstate(invalid="ignore"):
        inside = (px[:, 0] >= 0) & (px[:, 0] <= camera.width) & (px[:, 1] >= 0) & (px[:, 1] <= camera.height)
    return (depth > 0) & inside


def test_the_lane_is_the_one_beside_the_ego_else_the_first_oncoming_one() -> None:
    # the ego's lane is centred on y = 0; lanes are 3.2 m wide
    assert overtaking_lane_y(_street(2, 0)) == pytest.approx(-3.2)  # ego beside the centre line: the outer lane
    assert overtaking_lane_y(_street(2, 1)) == pytest.approx(3.2)  # ego in the outer lane: the inner one
    assert overtaking_lane_y(_street(1, 0)) == pytest.approx(3.2)  # one lane each way: the oncoming one
    assert overtaking_lane_y(_street(3, 1)) == pytest.approx(3.2)  # one either side: the one nearer the centre


def test_entry_bound_known_answer() -> None:
    # 90 degrees wide, level, principal point centred: the left edge is the plane y = x (camera at x = 0).
    camera = PinholeCamera(640, 320, intrinsics_from_fov(640, 320, 90.0), 1.5, 0.0, 0.0, 0.0)
    # the first corner to reach the edge is the front one nearest the axis, at y = 3.4 - 0.9 = 2.5
    assert entry_centre_x(camera, CAR, 3.4) == pytest.approx(2.5 - 2.0)
    assert entry_centre_x(camera, CAR, -3.4) == pytest.approx(2.5 - 2.0)  # and mirrored on the right


@settings(max_examples=60, deadline=None)
@given(
    hfov=st.floats(50.0, 90.0),
    height=st.floats(1.2, 1.7),
    pitch=st.floats(-2.0, 5.0),
    roll=st.floats(-1.0, 1.0),
    yaw=st.floats(-2.0, 2.0),
    lane_y=st.sampled_from([-3.3, 3.1, 6.5]),
)
def test_the_car_is_out_of_view_up_to_the_bound_and_comes_into_view_past_it(
    hfov: float, height: float, pitch: float, roll: float, yaw: float, lane_y: float
) -> None:
    K = intrinsics_from_fov(480, 240, hfov)
    camera = PinholeCamera(480, 240, K, height, math.radians(pitch), math.radians(roll), math.radians(yaw))
    bound = entry_centre_x(camera, CAR, lane_y)
    # the box is convex and every corner is beyond one edge's plane: no pixel of it is in view
    assert not _in_image(camera, _corners(CAR, bound - 1e-6, lane_y)).any()
    # 5 cm past the bound a vertical edge of the box (sampled every 5 cm) reaches into the image
    edges = np.repeat(_corners(CAR, bound + 0.05, lane_y)[::2], 31, axis=0)
    edges[:, 2] = np.tile(np.linspace(0.0, CAR[2], 31), 4)
    assert _in_image(camera, edges).any()


def test_the_drive_is_the_seeds_own_plus_the_car_entering_after_the_first_frame() -> None:
    plain = make_drive(np.random.default_rng(2), 320, 160, 5, 8.0, 0.5)
    drive = make_drive(np.random.default_rng(2), 320, 160, 5, 8.0, 0.5, overtake_mps=6.0)
    (car,) = [o for o in drive.scene.objects if o.role == "overtaking"]
    others = [o for o in drive.scene.objects if o.role != "overtaking"]
    assert np.array_equal(drive.scene.camera.world_from_cam(), plain.scene.camera.world_from_cam())
    assert np.array_equal(drive.scene.camera.K, plain.scene.camera.K)
    assert drive.scene.street == plain.scene.street
    assert [o.name for o in others] == [o.name for o in plain.scene.objects]  # nothing was in its way
    assert all(np.array_equal(a.centre_world, b.centre_world) for a, b in zip(others, plain.scene.objects))
    assert car.name == f"car_{sum(o.class_name == 'car' for o in others):04d}"
    assert drive.velocities[car.name] == pytest.approx([14.0, 0.0])
    lane = overtaking_lane_y(drive.scene.street)
    bound = entry_centre_x(drive.scene.camera, car.size_m, lane)
    assert car.centre_world == pytest.approx([bound - ENTRY_MARGIN_M, lane, 0.0])
    camera = drive.scene.camera
    seen = []
    for t in drive.times:  # each frame's camera sees the world shifted by the ego's x
        x = drive.position(car, float(t))[0] - drive.ego_x(float(t))
        seen.append(bool(_in_image(camera, _corners(car.size_m, x, lane)).any()))
    assert seen == [False, True, True, True, True]


def test_whatever_it_would_run_into_is_left_out() -> None:
    from usdworld.synth.assets import class_asset, default_assets
    from usdworld.synth.overtaking import add_overtaking_car
    from usdworld.synth.placement import SynthObject

    street = _street(1, 0)
    camera = PinholeCamera(640, 320, intrinsics_from_fov(640, 320, 90.0), 1.5, 0.0, 0.0, 0.0)
    one = lambda name, x, y, role: SynthObject(  # noqa: E731
        name, "car", "sedan", np.array([x, y, 0.0]), math.pi, np.ones(3), CAR, role
    )
    oncoming = one("car_0000", 40.0, 3.2, "driving")  # meets it: closing at 8 + 6 + 10 m/s from 40 m in 2 s
    far = one("car_0001", 80.0, 3.2, "driving")  # 80 m away: 48 m closed in 2 s, not met
    parked = one("car_0002", 6.0, 7.5, "parked")  # in the parking strip, beside its lane
    velocities = {"car_0000": np.array([-10.0, 0.0]), "car_0001": np.array([-10.0, 0.0])}
    car = class_asset(default_assets(), "car")
    objects, moving = add_overtaking_car(
        (oncoming, far, parked), velocities, street, camera, car, 8.0, 6.0, 2.0
    )
    assert [o.name for o in objects] == ["car_0001", "car_0002", "car_0003"]
    assert set(moving) == {"car_0001", "car_0003"}


def test_overtaking_options_are_one_line_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = str(tmp_path / "o")
    assert main(["synth", "-o", out, "--seed", "1", "--overtaking", "5"]) == 2
    expected = "error: --overtaking needs --sequence (a car overtakes during a drive)"
    assert capsys.readouterr().err.strip() == expected
    assert main(["synth", "-o", out, "--seed", "1", "--sequence", "2", "--overtaking", "0"]) == 2
    assert capsys.readouterr().err.strip() == "error: --overtaking must be a finite speed > 0 m/s, got 0.0"
    assert not (tmp_path / "o").exists()
