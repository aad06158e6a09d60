"""Where frames run: in this process, or in a local pool of worker processes.

An executor is a context manager with one method, ``run(tasks, stop)``: it pulls
:class:`~usdworld.batch.worker.FrameTask` objects from the ``tasks`` iterator only as
workers free up (at most ``2 x workers`` in flight, so discovery streams), and yields one
:class:`~usdworld.batch.records.FrameRecord` per task as frames finish. Once ``stop()``
returns True (``--fail-fast``) it pulls no more tasks, cancels the queued ones (yielding
``cancelled`` records) and yields the frames still running when they finish.

* :class:`InlineExecutor` (``--workers 1``, the default): frames run one after another in
  the calling process. No start-up cost, plain tracebacks with ``--debug``.
* :class:`LocalPoolExecutor` (``--workers N``, N > 1): a
  :class:`concurrent.futures.ProcessPoolExecutor` with the ``spawn`` start method (or
  ``forkserver``), one frame per process at a time. Each worker imports usdworld itself.
  If a worker process dies (killed, out of memory), the frames in flight are recorded as
  failed and a fresh pool carries on. Workers end when the batch process dies
  (:mod:`usdworld.batch.parent_watch`).

The Dask executor, with the same interface, is in :mod:`usdworld.batch.dask_executor`.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, CancelledError, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import replace
from typing import Protocol, Self

from usdworld.batch.parent_watch import exit_with_parent
from usdworld.batch.records import FrameRecord
from usdworld.batch.worker import FrameTask, run_frame
from usdworld.errors import InputError

#: Start methods accepted by :class:`LocalPoolExecutor` (``fork`` is unsafe with USD's threads).
START_METHODS = ("spawn", "forkserver")


class FrameExecutor(Protocol):
    """What the runner needs from an executor (see the module docstring)."""

    #: Human-readable description, e.g. ``local pool (2 workers)``.
    description: str

    def __enter__(self) -> Self: ...

    def __exit__(self, *exc: object) -> None: ...

    def run(self, tasks: Iterable[FrameTask], stop: Callable[[], bool]) -> Iterator[FrameRecord]: ...


def cancelled_record(task: FrameTask) -> FrameRecord:
    """The record of a frame that ``--fail-fast`` kept from running."""
    return FrameRecord(
        task.frame_id,
        "cancelled",
        source=task.source,
        error="not run: the batch stopped at the first failure (--fail-fast)",
    )


def failed_record(task: FrameTask, error: str) -> FrameRecord:
    """The record of a frame whose worker failed outside :func:`run_frame` (e.g. the process died)."""
    return FrameRecord(task.frame_id, "failed", source=task.source, error=error)


class InlineExecutor:
    """Run frames one after another in this process."""

    description = "this process (1 worker)"

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def run(self, tasks: Iterable[FrameTask], stop: Callable[[], bool]) -> Iterator[FrameRecord]:
        """Build each task in turn; stop pulling tasks once ``stop()`` is True."""
        for task in tasks:
            if stop():
                return
            yield run_frame(task)


class LocalPoolExecutor:
    """Run frames in ``workers`` local processes (``spawn`` or ``forkserver``)."""

    def __init__(
        self, workers: int, start_method: str = "spawn", max_tasks_per_child: int | None = None
    ) -> None:
        """
        Args:
            workers: worker processes (>= 1).
            start_method: ``spawn`` (default; every worker starts a fresh interpreter) or
                ``forkserver``.
            max_tasks_per_child: replace a worker after this many frames (None: never).

        Raises:
            InputError: ``workers`` < 1 or an unknown start method.
        """
        if workers < 1:
            raise InputError(f"--workers must be >= 1, got {workers}")
        if start_method not in START_METHODS or start_method not in multiprocessing.get_all_start_methods():
            raise InputError(
                f"start method {start_method!r}: use one of {', '.join(START_METHODS)} available here"
            )
        self.workers = workers
        self.start_method = start_method
        self.max_tasks_per_child = max_tasks_per_child
        self.description = (
            f"local pool ({workers} worker process{'es' if workers > 1 else ''}, {start_method})"
        )
        self._pool: ProcessPoolExecutor | None = None

    def _new_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=multiprocessing.get_context(self.start_method),
            max_tasks_per_child=self.max_tasks_per_child,
            initializer=exit_with_parent,
            initargs=(os.getpid(),),
        )

    def __enter__(self) -> Self:
        self._pool = self._new_pool()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def run(self, tasks: Iterable[FrameTask], stop: Callable[[], bool]) -> Iterator[FrameRecord]:
        """Build the tasks in the pool (see the module docstring)."""
        if self._pool is None:
            raise RuntimeError("LocalPoolExecutor.run outside its with-block")
        it = iter(tasks)
        window = 2 * self.workers
        pending: dict[Future[FrameRecord], FrameTask] = {}
        unsent: FrameTask | None = None  # a task the broken pool refused; sent to the next pool
        exhausted = False
        while True:
            broken = False
            while (unsent or not exhausted) and len(pending) < window and not stop():
                task = unsent or next(it, None)
                if task is None:
                    exhausted = True
                    break
                try:
                    pending[self._pool.submit(run_frame, replace(task, isolated=True))] = task
                    unsent = None
                except BrokenProcessPool:
                    unsent, broken = task, True
                    break
            if not pending and not broken:
                return
            done = wait(pending, return_when=FIRST_COMPLETED)[0] if pending else set()
            for future in sorted(done, key=lambda f: pending[f].frame_id):
                task = pending.pop(future)
                try:
                    yield future.result()
                except CancelledError:
                    yield cancelled_record(task)
                except BrokenProcessPool:
                    broken = True
                    yield failed_record(task, _CRASHED)
                except Exception as exc:  # noqa: BLE001  (e.g. the task or record could not be pickled)
                    yield failed_record(task, f"worker error {type(exc).__name__}: {exc}")
            if broken:
                for task in pending.values():
                    yield failed_record(task, _CRASHED)
                pending.clear()
                self._pool.shutdown(wait=False, cancel_futures=True)
                self._pool = self._new_pool()
            if stop():
                for future in [f for f in pending if f.cancel()]:
                    yield cancelled_record(pending.pop(future))
                if unsent is not None:
                    yield cancelled_record(unsent)
                    unsent = None


_CRASHED = (
    "a worker process died while this frame was in flight (killed or out of memory?); "
    "rerun with --resume to retry, or with --workers 1 to see the error"
)
