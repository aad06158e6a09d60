"""Independent stages of one build, run side by side on a small thread pool.

A build's stages are pure functions of their inputs, and the heavy ones (OpenCV's line
detector and decoders, numpy's reductions) release the GIL, so two stages that do not need
each other's output can run at the same time on two cores. :class:`StageThreads` runs such a
stage on a helper thread while the calling thread goes on with the next ones, and the caller
takes its result (:meth:`concurrent.futures.Future.result`) where the sequential build used it:
data still flows one way, and no result depends on thread timing (each is the object its stage
returns, whichever thread ran it).

With one thread (``threads=1``: batch workers and a rig's view processes, where the processes
are the parallelism) a submitted stage runs at once in the calling thread.

Errors: a stage's exception is raised where its result is taken, as the very same exception
(an :class:`~usdworld.errors.InputError` stays one, with its one-line message). When the calling
thread fails while a stage that comes earlier in the build's order still runs,
:func:`earlier_errors_first` raises that stage's error instead, so the error a bad input gives
is the one the sequential build gives, whatever the threads.

Example::

    with StageThreads(2) as stages:
        lines = stages.submit(detect_segments, image.rgb, params.camera)  # on the helper thread
        seg = read_segmentation(labels, instances, image)                 # meanwhile, here
        segments = lines.result()
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from types import TracebackType
from typing import Any, TypeVar

T = TypeVar("T")

#: Threads a build runs on by default: the calling one and one helper. The build's dependency
#: graph has at most two independent branches at any point, so more threads would only wait.
DEFAULT_THREADS = 2


class StageThreads:
    """A context that runs submitted stages on ``threads - 1`` helper threads (or at once, for one).

    Args:
        threads: threads in all, the calling one included; >= 1.

    Raises:
        ValueError: ``threads`` < 1.
    """

    def __init__(self, threads: int) -> None:
        if threads < 1:
            raise ValueError(f"threads must be >= 1, got {threads}")
        self.threads = threads
        self._pool: ThreadPoolExecutor | None = None

    def __enter__(self) -> StageThreads:
        if self.threads > 1:
            self._pool = ThreadPoolExecutor(max_workers=self.threads - 1, thread_name_prefix="usdworld-stage")
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if self._pool is not None:
            # Wait for the stages still running (their results are dropped): nothing outlives the build.
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def submit(self, fn: Callable[..., T], /, *args: Any, **kwargs: Any) -> Future[T]:
        """Run ``fn(*args, **kwargs)`` on a helper thread (or now, with one thread).

        Returns:
            Its future: ``result()`` gives the return value or raises the stage's own exception.
        """
        if self._pool is not None:
            return self._pool.submit(fn, *args, **kwargs)
        future: Future[T] = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:  # noqa: BLE001  (raised where the result is taken, as in a thread)
            future.set_exception(exc)
        return future


@contextlib.contextmanager
def earlier_errors_first(*earlier: Future[Any]) -> Iterator[None]:
    """Within: work that comes after the stages ``earlier`` in the build's order.

    When the block raises, each of ``earlier`` is waited for, and the first one's exception,
    if any, is raised instead of the block's (a stage that came first fails first, as in a
    sequential build); otherwise the block's own exception goes on.
    """
    try:
        yield
    except Exception:
        for future in earlier:
            error = future.exception()
            if error is not None:
                raise error from None
        raise
