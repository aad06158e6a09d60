"""A drive's world over time: movers shown only where they were seen, ``render --time``, ``--follow-ego``.

Needs headless OpenGL for the render commands (as ``test_render_cmd``; they fail without it).
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pxr import Usd

from usdworld.authoring.rig import visibility_samples
from usdworld.cli.main import main
from usdworld.render import RenderScene

#: A drive (seed 6, five frames 0.5 s apart) with a car overtaking the ego (``synth --overtaking``):
#: out of view at the first frame, it drives into view by the second and is seen to the last.
SEED = 6
OVERTAKE_MPS = 6.0


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("drive_time")
    args = ["synth", "-o", str(folder), "--seed", str(SEED), "--sequence", "5", "--interval", "0.5"]
    assert main([*args, "--size", "320x160", "--overtaking", str(OVERTAKE_MPS)]) == 0
    world = folder / "world"
    views = folder / f"drive_{SEED:06d}_views.json"
    assert main(["build", "--views", str(views), "-o", str(world), "--jobs", "1"]) == 0
    return world


@pytest.fixture(scope="module")
def late(drive: Path) -> str:
    """The world's moving object nearest the overtaking car at the last frame (ground truth), by path."""
    truth = json.loads((drive.parent / f"drive_{SEED:06d}_drive_gt.json").read_text())
    (car,) = [o for o in truth["objects"] if o["role"] == "overtaking"]
    assert car["visible_pixels"][0] == 0 and min(car["visible_pixels"][1:]) > 0  # out of view, then in it
    stage = Usd.Stage.Open(str(drive / "world.usda"))
    last = 2.0 * truth["times"][-1]  # time codes are frames: two per second
    objects = stage.GetPrimAtPath("/World/Objects").GetChildren()
    movers = [p for p in objects if p.GetAttribute("usdworld:moving").Get()]
    where = {str(p.GetPath()): np.array(p.GetAttribute("xformOp:translate").Get(last))[:2] for p in movers}
    path = min(where, key=lambda k: float(np.linalg.norm(where[k] - car["track"][-1][:2])))
    assert np.linalg.norm(where[path] - car["track"][-1][:2]) < 2.0, where
    return path


def test_visibility_samples_known_answers() -> None:
    frames = [0.0, 1.0, 2.0, 3.0, 4.0]
    assert visibility_samples([1.0, 2.0, 3.0, 4.0], frames) == [(0.0, "invisible"), (1.0, "inherited")]
    assert visibility_samples([0.0, 1.0], frames) == [(0.0, "inherited"), (2.0, "invisible")]
    assert visibility_samples([2.0], frames) == [(0.0, "invisible"), (2.0, "inherited"), (3.0, "invisible")]
    assert visibility_samples([0.0, 2.0, 4.0], frames) == []  # a gap inside the track keeps it shown


_FRAMES_AND_TWO_OF_THEM = st.integers(2, 12).flatmap(
    lambda n: st.tuples(st.just(n), st.integers(0, n - 1), st.integers(0, n - 1))
)


@given(_FRAMES_AND_TWO_OF_THEM)
def test_held_visibility_shows_a_mover_exactly_from_its_first_to_its_last_frame(
    case: tuple[int, int, int],
) -> None:
    n, a, b = case
    first, last = min(a, b), max(a, b)
    frames = [0.5 * k for k in range(n)]  # time codes need not be whole
    samples = visibility_samples(frames[first : last + 1], frames)
    for k, f in enumerate(frames):
        # a token is held from its sample on; before the first sample the first holds
        held = [tok for c, tok in samples if c <= f] or [tok for _, tok in samples[:1]] or ["inherited"]
        assert (held[-1] == "inherited") == (first <= k <= last), (samples, k)


def test_a_mover_first_seen_in_the_second_frame_is_invisible_before_it(drive: Path, late: str) -> None:
    stage = Usd.Stage.Open(str(drive / "world.usda"))
    prim = stage.GetPrimAtPath(late)
    assert prim.GetAttribute("usdworld:moving").Get()
    assert list(prim.GetAttribute("usdworld:trackTimes").Get()) == [0.5, 1.0, 1.5, 2.0]
    visibility = prim.GetAttribute("visibility")
    assert visibility.Get() == "inherited"  # the default time shows every object
    assert [visibility.Get(c) for c in (0.0, 0.5, 1.0, 2.5, 4.0)] == ["invisible"] * 2 + ["inherited"] * 3
    objects = stage.GetPrimAtPath("/World/Objects").GetChildren()
    standing = [p for p in objects if not p.GetAttribute("usdworld:moving").Get()]
    assert standing and all(p.GetAttribute("visibility").GetNumTimeSamples() == 0 for p in standing)


def test_the_scene_at_a_time_hides_the_mover_before_it_was_seen_and_moves_it(drive: Path, late: str) -> None:
    stage = Usd.Stage.Open(str(drive / "world.usda"))
    translate = stage.GetPrimAtPath(late).GetAttribute("xformOp:translate")
    centres = {}
    for code in (None, 0.0, 1.0, 4.0):
        scene = RenderScene.from_stage(stage, time=None if code is None else Usd.TimeCode(code))
        obj = scene.object_by_path().get(late)
        assert obj is not None  # a hidden mover keeps its place among the objects
        mine = scene.positions_world[scene.object_ids == obj.index]
        centres[code] = mine.mean(axis=0) if len(mine) else None
    assert centres[0.0] is None
    for code in (1.0, 4.0):  # the mesh moves with its time-sampled translate
        moved = np.array(translate.Get(code)) - np.array(translate.Get(1.0))
        assert centres[code] - centres[1.0] == pytest.approx(moved, abs=1e-3)
    assert centres[None] == pytest.approx(centres[1.0], abs=1e-6)  # the default is its first seen place


def test_a_hidden_mover_keeps_its_id_so_ids_agree_over_time(drive: Path, late: str) -> None:
    stage = Usd.Stage.Open(str(drive / "world.usda"))
    scenes = {code: RenderScene.from_stage(stage, time=Usd.TimeCode(code)) for code in (0.0, 2.0)}
    ids = {code: {o.path: (o.index, o.instance_id) for o in s.objects} for code, s in scenes.items()}
    assert ids[0.0] == ids[2.0] and late in ids[0.0]
    hidden = ids[0.0][late][0]
    assert hidden not in set(scenes[0.0].object_ids.tolist())  # no triangle of it at time 0
    assert hidden in set(scenes[2.0].object_ids.tolist())


def test_a_drive_read_over_time_reads_what_stands_still_once(drive: Path, late: str, monkeypatch) -> None:
    import usdworld.render.scene as scene_module
    from usdworld.render.scene import StaticCache
    from usdworld.render.timing import scene_at

    stage = Usd.Stage.Open(str(drive / "world.usda"))
    codes = [0.0, 1.5, 3.0, 4.0, 2.0]
    fresh = [scene_at(stage, code) for code in codes]
    keys = []
    real = scene_module.prototype_key
    counted = lambda prim, *a: (keys.append(prim.GetPath()), real(prim, *a))[1]  # noqa: E731
    monkeypatch.setattr(scene_module, "prototype_key", counted)
    still, prototypes = StaticCache(), {}
    for k, (code, want) in enumerate(zip(codes, fresh)):
        keys.clear()
        got = scene_at(stage, code, prototypes=prototypes, static=still)
        assert got.objects == want.objects  # (the batches may split alike meshes read at other times)
        assert np.array_equal(got.bounds_world(), want.bounds_world())
        for name in ("positions_world", "normals_world", "colors", "class_ids", "instance_ids", "object_ids"):
            assert np.array_equal(getattr(got, name), getattr(want, name)), (code, name)
        if k:  # after the first read only the movers are read again
            assert set(map(str, keys)) == set(map(str, still.moving))
    assert late in {str(p) for p in still.moving}
    assert len(still.objects) > 3 * len(still.moving)  # the parked cars, buildings, trees


def test_render_time_draws_the_ego_view_then(
    drive: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ids = {}
    for when in ("0", "1s", "2"):  # 1 s is time code 2 at two codes per second
        out = tmp_path / when
        args = ["render", str(drive), "-o", str(out), "--time", when, "--camera", "/World/Ego/Camera"]
        assert main([*args, "--size", "160x80"]) == 0
        assert f"from /World/Ego/Camera at time code {0 if when == '0' else 2}:" in capsys.readouterr().out
        ids[when] = cv2.imread(str(out / "instanceIds.png"), cv2.IMREAD_UNCHANGED)
    assert np.array_equal(ids["1s"], ids["2"])
    assert not np.array_equal(ids["0"], ids["2"])  # the ego moved on and the late car came in


@pytest.mark.parametrize(
    ("when", "expected"),
    [
        ("4.5", "error: --time 4.5: outside the world's time range, time codes 0 to 4 (0 s to 2 s)"),
        ("-1s", "error: --time -1s: outside the world's time range, time codes 0 to 4 (0 s to 2 s)"),
        ("soon", "error: --time 'soon': expected a time code (e.g. 3) or seconds (e.g. 1.5s)"),
        ("nan", "error: --time 'nan': expected a finite time code or seconds"),
    ],
)
def test_render_time_outside_the_drive_is_one_line_exit_2(
    drive: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], when: str, expected: str
) -> None:
    assert main(["render", str(drive), "-o", str(tmp_path / "o"), "--time", when]) == 2
    assert capsys.readouterr().err.strip() == expected
    assert not (tmp_path / "o").exists()


def test_follow_ego_draws_each_frame_as_render_time_does(
    drive: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import usdworld.render.flythrough as flythrough
    from usdworld.render.timing import scene_at

    seen: list[float | None] = []

    def spy(stage: Usd.Stage, code: float | None, **kwargs: object) -> RenderScene:
        seen.append(code)
        return scene_at(stage, code, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(flythrough, "scene_at", spy)
    video = tmp_path / "ego.mp4"
    args = ["flythrough", str(drive), "-o", str(video), "--follow-ego", "--frames", "5", "--size", "64x32"]
    assert main(args) == 0
    assert seen == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert video.stat().st_size > 0
