"""The worker function: build one frame and return its record. Pure and picklable.

:func:`run_frame` takes a :class:`FrameTask` (paths and strings only) and returns a
:class:`~usdworld.batch.records.FrameRecord`; it never raises for a frame that cannot be
built, it records the error. It calls :func:`usdworld.pipeline.build`, the same function as
``usdworld build``, so ``OUT/<frame_id>/`` holds exactly what ``usdworld build -o
OUT/<frame_id>`` writes. Local pool workers and Dask workers import this module (and so
usdworld) themselves: every worker needs the same usdworld version installed and the same
data and output paths (a shared filesystem on a cluster).
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import json
import logging
import os
import socket
import threading
import time
import traceback
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import usdworld
from usdworld.batch.records import FrameRecord
from usdworld.batch.resume import frame_key, world_complete
from usdworld.batch.views import ViewsBuild
from usdworld.errors import UsdWorldError
from usdworld.pipeline import BuildRequest, build

_isolated_ready = False


@dataclass(frozen=True)
class FrameTask:
    """One frame to build.

    Attributes:
        frame_id: the frame id.
        source: the photo as the dataset names it.
        request: the build request (a multi-view world's :class:`~usdworld.batch.views.ViewsBuild`);
            ``request.output`` is ``OUT/<frame_id>`` (absolute).
        previous_key: the key of the frame's earlier complete world (``--resume``), or None
            to build unconditionally.
        isolated: True in a worker process of a pool or cluster: the process then logs
            only errors (warnings are in the record) and runs OpenCV single-threaded (one
            frame per core).
    """

    frame_id: str
    source: str
    request: BuildRequest | ViewsBuild
    previous_key: str | None = None
    isolated: bool = False


def _memory_mb() -> tuple[float | None, float | None]:
    """(current, peak) resident memory of this process in MiB, from /proc or getrusage."""
    try:
        values = {}
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith(("VmRSS:", "VmHWM:")):
                    key, kb = line.split()[:2]
                    values[key] = int(kb) / 1024.0
        return round(values["VmRSS:"], 1), round(values["VmHWM:"], 1)
    except (OSError, KeyError, ValueError):
        pass
    try:
        import resource

        return None, round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)
    except (ImportError, OSError):
        return None, None


def _prepare_isolated_process() -> None:
    """Once per worker process: quiet the per-frame warnings and use one OpenCV thread."""
    global _isolated_ready
    if _isolated_ready:
        return
    logging.getLogger("usdworld").setLevel(logging.ERROR)
    import cv2

    cv2.setNumThreads(1)
    _isolated_ready = True


def _earlier_build(folder: Path) -> tuple[int | None, tuple[str, ...]]:
    """Objects placed and warnings of the world already in ``folder`` (its ``report.json``).

    An unchanged frame keeps what its build said: the warnings are not lost on ``--resume``.
    """
    try:
        report = json.loads((folder / "report.json").read_text())
        return len(report["objects"]), tuple(str(w) for w in report.get("warnings", ()))
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None, ()


_gc_lock = threading.Lock()
_gc_holders = 0


@contextlib.contextmanager
def _collected_here() -> Iterator[None]:
    """Within: no automatic garbage collection in this process; at the end, a collection in
    this thread.

    A worker of a Dask cluster builds while its event loop runs in another thread. The cyclic
    garbage collector runs in whichever thread happens to allocate, so a USD stage left in a
    reference cycle by one frame could be destroyed by another thread while the building
    thread composes the next stage, which USD does not survive ("FATAL ERROR: attempted member
    lookup on NULL TfRefPtr<Pcp_LayerStackRegistry>", signal 6). Collecting only here, in the
    thread that built the frame, keeps USD's objects in the thread that made them. (The crash
    that was seen came from Dask's profiler, not from the collector: :func:`run_frames`.) A
    counter keeps collection off until the last of several concurrent frames
    (threads_per_worker > 1) ends.
    """
    global _gc_holders
    with _gc_lock:
        _gc_holders += 1
        gc.disable()
    try:
        yield
    finally:
        gc.collect()
        with _gc_lock:
            _gc_holders -= 1
            if _gc_holders == 0:
                gc.enable()


def run_frame(task: FrameTask) -> FrameRecord:
    """Build one frame (or find it unchanged) and describe what happened; in a worker process
    (``task.isolated``), with garbage collection kept in this thread (:func:`_collected_here`).

    Args:
        task: the frame.

    Returns:
        Its record: ``built``, ``unchanged`` (same key as ``task.previous_key`` and a
        complete world) or ``failed`` with the error.
    """
    if not task.isolated:
        return _run_frame(task)
    _prepare_isolated_process()
    if isinstance(task.request, BuildRequest):
        # One of several worker processes: the processes are the parallelism, its build uses one thread.
        task = dataclasses.replace(task, request=dataclasses.replace(task.request, threads=1))
    with _collected_here():
        return _run_frame(task)


def _run_frame(task: FrameTask) -> FrameRecord:
    start, cpu_start = time.perf_counter(), time.process_time()
    worker = f"{socket.gethostname()}:{os.getpid()}"
    key = None
    status, objects, error, warnings, trace = "failed", None, None, (), None
    try:
        key = frame_key(task.request)
        if task.previous_key == key and world_complete(task.request.output):
            status = "unchanged"
            objects, warnings = _earlier_build(task.request.output)
        else:
            result = task.request.build() if isinstance(task.request, ViewsBuild) else build(task.request)
            status, objects = "built", len(result.report["objects"])
            warnings = tuple(result.report["warnings"])
    except UsdWorldError as exc:
        error = str(exc)
    except Exception as exc:  # noqa: BLE001  (a bug: record it with the traceback, keep the batch going)
        error = (
            f"unexpected {type(exc).__name__}: {exc} (a bug; see the traceback in batch.json and report it)"
        )
        trace = traceback.format_exc()
    rss, peak = _memory_mb()
    return FrameRecord(
        frame_id=task.frame_id,
        status=status,
        seconds=time.perf_counter() - start,
        cpu_seconds=time.process_time() - cpu_start,
        objects=objects,
        error=error,
        key=key,
        source=task.source,
        warnings=warnings,
        worker=worker,
        rss_mb=rss,
        peak_rss_mb=peak,
        traceback=trace,
    )


_builders = threading.local()


def _builder() -> ThreadPoolExecutor:
    """This thread's own frame-building thread (one per calling thread, made on first use)."""
    pool: ThreadPoolExecutor | None = getattr(_builders, "pool", None)
    if pool is None:
        pool = _builders.pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="usdworld-frames")
    return pool


def _run_frames_here(tasks: tuple[FrameTask, ...]) -> tuple[FrameRecord, ...]:
    return tuple(run_frame(task) for task in tasks)


def run_frames(tasks: tuple[FrameTask, ...]) -> tuple[FrameRecord, ...]:
    """Build several frames one after another: one Dask task (see :mod:`usdworld.batch.dask_executor`).

    The frames are built on a thread of usdworld's own (:func:`_builder`), not on the calling
    Dask thread. A Dask worker's profiler (``distributed.worker.profile``, on by default)
    takes ``sys._current_frames()`` of its task threads every 10 ms in the event-loop thread;
    a Python frame it holds keeps that frame's locals alive after the function returns, and
    when the event loop lets go, a ``Usd.Stage`` among them is destroyed in the event-loop
    thread while the task thread edits a layer that stage still listens to. The task thread
    then recomposes the half-destroyed stage and the worker dies with "FATAL ERROR:
    attempted member lookup on NULL TfRefPtr<Pcp_LayerStackRegistry>" (signal 6; core dump:
    ``frame_dealloc`` -> ``~UsdStage`` in the event loop, ``UsdStage::_HandleLayersDidChange``
    -> ``PcpCache::ComputeLayerStack`` in the task thread). The profiler never samples this
    thread, so every USD object of a frame dies in the thread that made it.

    Args:
        tasks: the frames, in order.

    Returns:
        One record per task, in the same order (:func:`run_frame` never raises for a frame).
    """
    return _builder().submit(_run_frames_here, tasks).result()


def worker_info() -> dict[str, str]:
    """usdworld version and process of a worker (the Dask runner checks every worker with it)."""
    return {"usdworld": usdworld.__version__, "worker": f"{socket.gethostname()}:{os.getpid()}"}
