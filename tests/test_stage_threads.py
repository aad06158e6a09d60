"""A build's independent stages on a helper thread (:mod:`usdworld.stage_threads`): the same world
as one after the other, whatever the timing; a stage's error reaches the caller as itself, in the
sequential build's order, with nothing written; the request stays picklable."""

from __future__ import annotations

import multiprocessing
import pickle
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import usdworld.pipeline
from usdworld.batch.resume import frame_key
from usdworld.batch.worker import FrameTask, run_frame
from usdworld.cli.main import main
from usdworld.errors import CalibrationError, InputError, LayoutError
from usdworld.pipeline import BuildRequest, build
from usdworld.stage_threads import StageThreads, earlier_errors_first
from usdworld.synth import make_street_scene, write_cityscapes_frame


@pytest.fixture(scope="module")
def street(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A synthetic street frame (shadows, sky, 40-odd objects), 512x256."""
    scene = make_street_scene(np.random.default_rng(3), 512, 256)
    files = write_cityscapes_frame(scene, tmp_path_factory.mktemp("street"), "street_000000_000001")
    return {k: files[k] for k in ("image", "labels", "instances", "camera")}


def _files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _slowed(monkeypatch: pytest.MonkeyPatch, name: str, seconds: float) -> None:
    """Make ``usdworld.pipeline.<name>`` start ``seconds`` late (the other branch ends first)."""
    original = getattr(usdworld.pipeline, name)

    def late(*args, **kwargs):
        time.sleep(seconds)
        return original(*args, **kwargs)

    monkeypatch.setattr(usdworld.pipeline, name, late)


@pytest.fixture(scope="module")
def sequential(street: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    out = tmp_path_factory.mktemp("seq") / "world"
    build(BuildRequest(output=out, threads=1, **street))
    return _files(out)


@pytest.mark.parametrize(
    "late", [None, "read_image", "_street_lines", "_read_segmentation", "estimate_scene_light", "_surfaces"]
)
def test_threaded_build_writes_the_sequential_world_byte_for_byte(
    street: dict[str, Path],
    sequential: dict[str, bytes],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    late: str | None,
) -> None:
    """Every file of the world folder is identical, whichever side of each pair of stages ends first."""
    if late is not None:
        _slowed(monkeypatch, late, 0.05)
    build(BuildRequest(output=tmp_path / "world", threads=2, **street))
    threaded = _files(tmp_path / "world")
    assert set(threaded) == set(sequential)
    assert {k for k in threaded if threaded[k] != sequential[k]} == set()


def test_two_threads_run_the_light_beside_the_colours(
    street: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The stages really run on two threads with ``threads=2`` and on one with ``threads=1``."""
    seen: dict[str, str] = {}
    for name in ("_street_lines", "_read_segmentation", "estimate_scene_light", "_surfaces", "_colours"):
        original = getattr(usdworld.pipeline, name)

        def where(*args, __original=original, __name=name, **kwargs):
            seen[__name] = threading.current_thread().name
            return __original(*args, **kwargs)

        monkeypatch.setattr(usdworld.pipeline, name, where)
    build(BuildRequest(output=tmp_path / "two", threads=2, **street))
    main_thread = threading.current_thread().name
    assert seen["_read_segmentation"] == seen["estimate_scene_light"] == main_thread
    assert main_thread not in (seen["_street_lines"], seen["_surfaces"], seen["_colours"])
    seen.clear()
    build(BuildRequest(output=tmp_path / "one", threads=1, **street))
    assert set(seen.values()) == {main_thread}


def test_two_threads_decode_the_label_maps_while_the_photo_is_decoded(
    street: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The photo on the helper thread, the label maps meanwhile on the calling one."""
    events: dict[str, tuple[str, float]] = {}
    read_image, decode = usdworld.pipeline.read_image, usdworld.pipeline.decode_segmentation

    def slow_photo(*args, **kwargs):
        time.sleep(0.3)
        out = read_image(*args, **kwargs)
        events["photo decoded"] = (threading.current_thread().name, time.perf_counter())
        return out

    def labels(*args, **kwargs):
        events["labels started"] = (threading.current_thread().name, time.perf_counter())
        return decode(*args, **kwargs)

    monkeypatch.setattr(usdworld.pipeline, "read_image", slow_photo)
    monkeypatch.setattr(usdworld.pipeline, "decode_segmentation", labels)
    build(BuildRequest(output=tmp_path / "world", threads=2, **street))
    (photo_thread, photo_done), (labels_thread, labels_start) = events["photo decoded"], events["labels started"]
    assert labels_thread == threading.current_thread().name != photo_thread
    assert labels_start < photo_done


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("stage", ["_street_lines", "_surfaces", "_colours"])
def test_a_helper_stage_error_reaches_the_caller_as_itself_and_nothing_is_written(
    street: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, threads: int, stage: str
) -> None:
    error = InputError(f"{stage}: refused")

    def refuse(*args, **kwargs):
        raise error

    monkeypatch.setattr(usdworld.pipeline, stage, refuse)
    with pytest.raises(InputError) as raised:
        build(BuildRequest(output=tmp_path / "world", threads=threads, **street))
    assert raised.value is error
    assert list(tmp_path.iterdir()) == []  # no world, no temporary folder


def test_a_helper_stage_error_is_a_one_line_cli_error(
    street: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def refuse(*args, **kwargs):
        raise CalibrationError("street.png: the street's lines cross nowhere; give --camera")

    monkeypatch.setattr(usdworld.pipeline, "_street_lines", refuse)
    args = ["build", str(street["image"]), "--labels", str(street["labels"]), "--instances", str(street["instances"])]
    assert main([*args, "--camera", str(street["camera"]), "-o", str(tmp_path / "world")]) == 2
    err = capsys.readouterr().err
    assert err == "error: street.png: the street's lines cross nowhere; give --camera\n"
    assert not (tmp_path / "world").exists()


@pytest.mark.parametrize("threads", [1, 2])
def test_when_two_stages_fail_the_earlier_ones_error_wins(
    street: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, threads: int
) -> None:
    """The ground surfaces come before the light in the build: their error is the one raised,
    even though the light (on the calling thread) fails first."""

    def surfaces_fail(*args, **kwargs):
        time.sleep(0.05)
        raise LayoutError("surfaces: refused")

    def light_fails(*args, **kwargs):
        raise InputError("light: refused")

    monkeypatch.setattr(usdworld.pipeline, "_surfaces", surfaces_fail)
    monkeypatch.setattr(usdworld.pipeline, "estimate_scene_light", light_fails)
    with pytest.raises(LayoutError, match="surfaces: refused"):
        build(BuildRequest(output=tmp_path / "world", threads=threads, **street))


def test_request_and_build_stay_picklable_and_build_in_a_worker_process(
    street: dict[str, Path], tmp_path: Path, sequential: dict[str, bytes]
) -> None:
    request = BuildRequest(output=tmp_path / "world", threads=2, **street)
    assert pickle.loads(pickle.dumps(request)) == request
    assert pickle.loads(pickle.dumps(build)) is build
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        result = pool.submit(build, request).result()
    assert pickle.loads(pickle.dumps(result.report)) == result.report
    assert _files(tmp_path / "world") == sequential


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "2"])
def test_threads_must_be_a_positive_integer(street: dict[str, Path], tmp_path: Path, bad: object) -> None:
    with pytest.raises(InputError, match="threads must be an integer >= 1"):
        BuildRequest(output=tmp_path / "w", threads=bad, **street)  # type: ignore[arg-type]


def test_the_thread_count_leaves_the_resume_key_alone(street: dict[str, Path], tmp_path: Path) -> None:
    one = BuildRequest(output=tmp_path / "a", threads=1, **street)
    two = BuildRequest(output=tmp_path / "a", threads=2, **street)
    assert frame_key(one) == frame_key(two)


def test_a_batch_worker_process_builds_on_one_thread(
    street: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A pool's worker (``isolated``) is one of several processes: its build gets ``threads=1``;
    a frame built in the batch's own process keeps the request's threads."""
    import usdworld.batch.worker as worker

    asked: list[int] = []

    def record(request: BuildRequest):
        asked.append(request.threads)
        raise InputError("not built")

    monkeypatch.setattr(worker, "build", record)
    request = BuildRequest(output=tmp_path / "f", threads=2, **street)
    monkeypatch.setattr(worker, "_isolated_ready", True)  # keep this process's OpenCV threads and logging
    run_frame(FrameTask("f", "street.png", request, isolated=True))
    run_frame(FrameTask("f", "street.png", request))
    assert asked == [1, 2]


# --- StageThreads ------------------------------------------------------------------------


def test_one_thread_runs_a_stage_at_once_and_keeps_its_error_for_the_result() -> None:
    order: list[str] = []
    with StageThreads(1) as stages:
        done = stages.submit(order.append, "stage")
        order.append("after")
        failed = stages.submit(int, "x")
    assert order == ["stage", "after"] and done.result() is None
    with pytest.raises(ValueError, match="invalid literal"):
        failed.result()


def test_two_threads_run_a_stage_beside_the_caller() -> None:
    started, release = threading.Event(), threading.Event()

    def stage() -> str:
        started.set()
        assert release.wait(5)
        return threading.current_thread().name

    with StageThreads(2) as stages:
        future = stages.submit(stage)
        assert started.wait(5)  # it runs while this thread is here
        release.set()
        assert future.result() != threading.current_thread().name


def test_earlier_errors_first_prefers_the_earlier_stage_and_passes_its_own_otherwise() -> None:
    first = InputError("first")
    with StageThreads(2) as stages:
        earlier = stages.submit(_raise_late, first)
        with pytest.raises(InputError) as raised, earlier_errors_first(earlier):
            raise LayoutError("second")
        assert raised.value is first
        fine = stages.submit(lambda: 1)
        with pytest.raises(LayoutError, match="own"), earlier_errors_first(fine):
            raise LayoutError("own")


def _raise_late(error: Exception) -> None:
    time.sleep(0.05)
    raise error


def test_stage_threads_need_at_least_one() -> None:
    with pytest.raises(ValueError, match="threads must be >= 1"):
        StageThreads(0)
