"""A worker process collects a frame's garbage in the frame's own thread (see ``_collected_here``)."""

from __future__ import annotations

import gc
import sys
import threading
from pathlib import Path

import pytest

from usdworld.batch import worker
from usdworld.batch.worker import FrameTask, run_frame
from usdworld.pipeline import BuildRequest


def _task(tmp_path: Path, isolated: bool) -> FrameTask:
    request = BuildRequest(image=tmp_path / "missing.png", output=tmp_path / "out")
    return FrameTask(frame_id="f", source="missing.png", request=request, isolated=isolated)


def test_no_automatic_collection_while_a_worker_builds(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[bool] = []
    real = worker._run_frame
    # not this test process's logging level and OpenCV threads, which a worker process sets once
    monkeypatch.setattr(worker, "_prepare_isolated_process", lambda: None)
    monkeypatch.setattr(worker, "_run_frame", lambda task: (seen.append(gc.isenabled()), real(task))[1])
    assert gc.isenabled()
    record = run_frame(_task(tmp_path, isolated=True))
    assert record.status == "failed"  # the photo is missing: a clean error, not a crash
    assert seen == [False] and gc.isenabled()
    run_frame(_task(tmp_path, isolated=False))  # in the command's own process nothing changes
    assert seen == [False, True]


def test_collection_resumes_only_when_the_last_concurrent_frame_ends(tmp_path: Path) -> None:
    entered, release = threading.Barrier(2), threading.Event()
    states: list[bool] = []

    def frame() -> None:
        with worker._collected_here():
            entered.wait(10)
            release.wait(10)
            states.append(gc.isenabled())

    threads = [threading.Thread(target=frame), threading.Thread(target=frame)]
    for t in threads:
        t.start()
    release.set()
    for t in threads:
        t.join(10)
    assert gc.isenabled()
    assert states == [False, False]  # the first to end did not turn collection back on for the other


def test_frames_are_built_where_the_calling_thread_cannot_show_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A Dask worker's profiler holds sys._current_frames() of its task thread; no frame of a
    # build may be among them, or the build's USD stages can die in the profiler's thread.
    caller = threading.get_ident()
    seen: list[tuple[int, list[str]]] = []

    def recorded(task: FrameTask) -> object:
        names, frame = [], sys._current_frames()[caller]
        while frame is not None:
            names.append(frame.f_code.co_name)
            frame = frame.f_back
        seen.append((threading.get_ident(), names))
        return real(task)

    real = worker._run_frame
    monkeypatch.setattr(worker, "_prepare_isolated_process", lambda: None)
    monkeypatch.setattr(worker, "_run_frame", recorded)
    records = worker.run_frames((_task(tmp_path, True), _task(tmp_path, True)))
    assert [r.status for r in records] == ["failed", "failed"]
    assert len({ident for ident, _ in seen}) == 1 and seen[0][0] != caller  # one builder thread
    assert all("run_frame" not in names and "_run_frame" not in names for _, names in seen)
