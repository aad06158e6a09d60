"""Drives in ``build --views``: standing objects placed once, moving cars time-sampled, the ego trajectory."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pxr import Usd, UsdGeom

from usdworld.authoring.validate import errors_only, validate_file
from usdworld.cli.main import main
from usdworld.views.drive import fit_motion

SEED = 3  # a drive whose ego lane has a car ahead, faster than the ego, in every frame


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    folder = tmp_path_factory.mktemp("drive")
    args = ["synth", "-o", str(folder), "--seed", str(SEED), "--sequence", "5", "--interval", "0.5"]
    assert main([*args, "--size", "320x160"]) == 0
    world = folder / "world"
    assert main(["build", "--views", str(folder / f"drive_{SEED:06d}_views.json"), "-o", str(world), "--jobs", "1"]) == 0
    return json.loads((folder / f"drive_{SEED:06d}_drive_gt.json").read_text()), world


def _cars(stage: Usd.Stage) -> list[Usd.Prim]:
    return [p for p in stage.GetPrimAtPath("/World/Objects").GetChildren() if p.GetName().startswith("car_")]


def test_the_world_validates_and_its_time_is_the_drives(drive: tuple[dict, Path]) -> None:
    gt, world = drive
    for layer in ("world.usda", "layers/base.usda"):
        assert errors_only(validate_file(world / layer)) == []
    stage = Usd.Stage.Open(str(world / "world.usda"))
    assert stage.GetTimeCodesPerSecond() == pytest.approx(2.0)
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == pytest.approx((0.0, 4.0))
    ego = UsdGeom.Xformable(stage.GetPrimAtPath("/World/Ego"))
    op = ego.GetOrderedXformOps()[0]
    assert op.GetTimeSamples() == pytest.approx([0.0, 1.0, 2.0, 3.0, 4.0])
    for code, T in zip(op.GetTimeSamples(), gt["world_from_ego"]):
        M = np.array(ego.ComputeLocalToWorldTransform(Usd.TimeCode(code))).T
        assert M[:3, 3] == pytest.approx(np.array(T)[:3, 3], abs=1e-6)
    assert stage.GetPrimAtPath("/World/Ego/Camera").IsA(UsdGeom.Camera)


def test_a_parked_car_seen_in_every_frame_is_placed_once_and_stands(drive: tuple[dict, Path]) -> None:
    """Each world car counts for the ground-truth car nearest to it; a parked car seen in every
    frame has exactly one, near it, standing, though five frames observed it."""
    gt, world = drive
    stage = Usd.Stage.Open(str(world / "world.usda"))
    truth = {o["name"]: np.array(o["track"][0][:2]) for o in gt["objects"] if o["class"] == "car"}
    owners: dict[str, list[Usd.Prim]] = {name: [] for name in truth}
    for prim in _cars(stage):
        xy = np.array(prim.GetAttribute("xformOp:translate").Get())[:2]
        owners[min(truth, key=lambda n: float(np.linalg.norm(truth[n] - xy)))].append(prim)
    parked = [o for o in gt["objects"] if o["role"] == "parked" and min(o["visible_pixels"]) >= 100]
    assert parked
    for o in parked:
        near = owners[o["name"]]
        assert len(near) == 1, (o["name"], [p.GetName() for p in near])
        xy = np.array(near[0].GetAttribute("xformOp:translate").Get())[:2]
        assert np.linalg.norm(xy - truth[o["name"]]) < 0.05 * np.linalg.norm(truth[o["name"]]) + 0.5
        assert not near[0].GetAttribute("usdworld:moving").Get()
        assert near[0].GetAttribute("xformOp:translate").GetNumTimeSamples() == 0
        assert len(near[0].GetAttribute("usdworld:trackTimes").Get()) == 5


def test_a_moving_car_has_time_samples_on_its_truth(drive: tuple[dict, Path]) -> None:
    gt, world = drive
    stage = Usd.Stage.Open(str(world / "world.usda"))
    ahead = [o for o in gt["objects"] if o["role"] == "driving" and min(o["visible_pixels"]) >= 50]
    assert ahead
    for o in ahead:
        track = np.array(o["track"])[:, :2]
        best = None
        for prim in _cars(stage):
            translate = prim.GetAttribute("xformOp:translate")
            codes = translate.GetTimeSamples()
            if len(codes) < 3:
                continue
            errors = [np.linalg.norm(np.array(translate.Get(c))[:2] - track[int(round(c))]) for c in codes]
            if best is None or np.median(errors) < best[0]:
                best = (float(np.median(errors)), prim)
        assert best is not None and best[0] < 0.75, (o["name"], best)
        prim = best[1]
        assert prim.GetAttribute("usdworld:moving").Get()
        v = np.array(prim.GetAttribute("usdworld:velocity").Get())
        assert v == pytest.approx(o["velocity_world"], abs=1.0)
        rotate = prim.GetAttribute("xformOp:rotateZ")
        assert rotate.GetNumTimeSamples() == prim.GetAttribute("xformOp:translate").GetNumTimeSamples()
        assert rotate.Get(rotate.GetTimeSamples()[0]) == pytest.approx(0.0, abs=10.0)  # heading along +X


def test_fit_motion_known_answer() -> None:
    cov = np.tile(np.eye(2) * 1e-6, (3, 1, 1))
    pos = np.array([[1.0, 2.0], [2.0, 2.5], [3.0, 3.0]])
    fit = fit_motion([0.0, 0.5, 1.0], pos, cov, 10.0)
    assert fit.velocity == pytest.approx([2.0, 1.0], abs=1e-4)
    assert fit.predict(1.5)[0] == pytest.approx([4.0, 3.5], abs=1e-4)
    assert fit.speed_chi2() > 1e6
    still = fit_motion([0.0, 0.5, 1.0], pos, cov, 0.0)  # a class that cannot move: the weighted mean
    assert still.velocity.tolist() == [0.0, 0.0]
    assert still.predict(7.0)[0] == pytest.approx([2.0, 2.5])


@settings(max_examples=30, deadline=None)
@given(
    st.lists(st.floats(-50, 50), min_size=2, max_size=2),
    st.lists(st.floats(-15, 15), min_size=2, max_size=2),
    st.lists(st.floats(0.05, 0.5), min_size=2, max_size=6),
)
def test_fit_motion_recovers_exact_constant_velocity(p0: list[float], v: list[float], steps: list[float]) -> None:
    times = np.cumsum([0.0, *steps])
    pos = np.array(p0) + times[:, None] * np.array(v)
    fit = fit_motion(times, pos, np.tile(np.eye(2) * 1e-8, (len(times), 1, 1)), 14.0)
    assert fit.velocity == pytest.approx(v, abs=1e-3)
    assert fit.predict(0.0)[0] == pytest.approx(p0, abs=1e-3)


def test_flythrough_follow_ego_rides_the_ego_camera(drive: tuple[dict, Path], tmp_path: Path) -> None:
    from usdworld.render.flythrough import ego_poses
    from usdworld.views.manifest import read_views_manifest

    gt, world = drive
    stage = Usd.Stage.Open(str(world / "world.usda"))
    poses = ego_poses(stage, 9, 64, 32)  # two video frames per drive frame
    views = read_views_manifest(world.parent / f"drive_{SEED:06d}_views.json").views
    for k, view in enumerate(views):
        assert poses[2 * k] == pytest.approx(view.world_from_cam, abs=1e-6)
    assert poses[1][:3, 3] == pytest.approx(0.5 * (poses[0][:3, 3] + poses[2][:3, 3]), abs=1e-6)
    video = tmp_path / "ego.mp4"
    assert main(["flythrough", str(world), "-o", str(video), "--follow-ego", "--frames", "3", "--size", "64x32"]) == 0
    assert video.stat().st_size > 0


def test_frame_times_group_a_rigs_cameras_into_one_frame() -> None:
    from usdworld.parameters.views import ViewsParams
    from usdworld.views.drive import frame_times

    params = ViewsParams()
    nuscenes_sample = [27.612460, 27.620339, 27.604844, 27.637525, 27.647423, 27.627893]  # one sample's cameras
    assert frame_times(nuscenes_sample, params) is None
    assert frame_times([0.0, 0.1, None], params) is None
    assert frame_times([0.2, 0.0, 0.105, 0.01], params) == [0.2, 0.0, 0.105, 0.0]
