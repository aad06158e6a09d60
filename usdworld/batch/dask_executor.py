"""Run frames on a Dask cluster: an existing one (``--scheduler``) or a local one (``--dask-local N``).

Needs ``dask[distributed]`` (``pip install "dask[distributed]>=2026.8"``). Dask ships a
task (one or more :class:`~usdworld.batch.worker.FrameTask` of paths) to a worker, which
imports :mod:`usdworld.batch.worker` and runs :func:`~usdworld.batch.worker.run_frames`
there; only the small records come back. So every worker needs:

* the same usdworld version installed (checked when the batch starts), and
* the same paths: the dataset and the output folder at the same location on every
  machine (a shared or network filesystem). Workers that cannot see the output folder are
  named in the error.

An existing cluster, by hand::

    dask scheduler                                   # on one machine; prints tcp://HOST:8786
    dask worker tcp://HOST:8786 --nworkers 8 --nthreads 1   # on each worker machine
    usdworld batch frames.json -o /shared/worlds --scheduler tcp://HOST:8786

One thread per worker process suits usdworld (the build is mostly single-threaded Python
and numpy). ``dask worker`` sets ``MALLOC_TRIM_THRESHOLD_=65536`` in its worker processes,
which makes each frame about 40 % slower (every large array becomes a fresh mmap);
``--dask-local`` leaves it unset. usdworld never changes the configuration of an existing
cluster; for ``dask worker`` put this in a Dask config file on the worker machines (e.g.
``~/.config/dask/usdworld.yaml``), the first part always, the rest when frames are short
(well under a second) and the workers fill every core::

    distributed:
      nanny:
        pre-spawn-environ:
          MALLOC_TRIM_THRESHOLD_: null
      worker:
        profile:
          enabled: false
        memory:
          monitor-interval: 500ms
      admin:
        tick:
          interval: 1s
        system-monitor:
          interval: 5s

On Kubernetes use dask-kubernetes, on HPC schedulers (SLURM, PBS, SGE, LSF) use
dask-jobqueue; both give a scheduler address to pass as ``--scheduler``.

``--dask-local N`` starts ``LocalCluster(n_workers=N, threads_per_worker=1,
processes=True)`` for the run, with :data:`LOCAL_CLUSTER_CONFIG` (the settings above): no
profiler sampling the running frame 100 times a second, and the event-loop, host and
memory monitors polled less often. Its dashboard therefore shows no profile. The scheduler
and the nannies live in this process, so with one worker per core every CPU cycle Dask
spends there or in a worker's event loop is taken from the frames: with Dask's defaults,
2 workers on 2 cores built about 13 % fewer frames per minute than the local pool
(BENCHMARKS.md, batch section). This process's own Dask configuration and environment are
left as they were.

Frames go to the cluster in tasks of one or more frames (:func:`frames_per_task`), on any
cluster: Dask spends a few milliseconds of CPU per task on its scheduler, client and
worker, a few per cent of a 0.15 s frame. The first tasks hold one frame each; then each
task holds as many frames as take about :data:`TASK_SECONDS` (at most
:data:`MAX_FRAMES_PER_TASK`), judged from the frames finished so far. Frames of half a
second or more go one per task.
"""

from __future__ import annotations

import logging
import math
import os
import statistics
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import replace
from itertools import islice
from pathlib import Path
from typing import Any, Self

from usdworld.batch.executors import cancelled_record, failed_record
from usdworld.batch.records import FrameRecord
from usdworld.batch.worker import FrameTask, run_frames, worker_info
from usdworld.errors import ClusterError, InputError

INSTALL_HINT = 'pip install "dask[distributed]>=2026.8"'
#: glibc variable Dask's nanny sets to 65536 in every worker process by default. It turns off
#: glibc's adaptive mmap threshold, so each large numpy array is a fresh mmap and a frame
#: takes about 40 % longer; the LocalCluster leaves it unset.
MALLOC_TRIM = "MALLOC_TRIM_THRESHOLD_"
#: Dask settings of the LocalCluster that ``--dask-local`` starts; they reach its scheduler,
#: nannies and (through the nannies) its worker processes, never an existing cluster. Measured
#: idle on 2 cores, a 2-worker LocalCluster used about 10 % of a core with Dask's defaults
#: and under 1 % with these; while a 0.15 s frame was built, a worker's event loop used
#: about 4 ms of CPU with the defaults and about 1 ms with these.
LOCAL_CLUSTER_CONFIG: dict[str, object] = {
    # See MALLOC_TRIM: unset, glibc's adaptive threshold keeps large arrays off fresh mmaps.
    f"distributed.nanny.pre-spawn-environ.{MALLOC_TRIM}": None,
    # The worker samples the stack of the running task every 10 ms (default) for the
    # dashboard's profile page; each sample takes the GIL from the frame being built.
    "distributed.worker.profile.enabled": False,
    # Event-loop health check of every scheduler, nanny and worker (default every 20 ms);
    # it only warns about loops blocked longer than distributed.admin.tick.limit (3 s).
    "distributed.admin.tick.interval": "1s",
    # Host CPU, memory and network sampling for the dashboard (default every 500 ms).
    "distributed.admin.system-monitor.interval": "5s",
    # Spill, pause and terminate checks of each worker's memory (default every 100 ms).
    "distributed.worker.memory.monitor-interval": "500ms",
}
#: Seconds to wait for a scheduler to answer.
CONNECT_TIMEOUT_S = 20
#: Aim for Dask tasks of about this many seconds of frames (:func:`frames_per_task`).
TASK_SECONDS = 0.5
#: At most this many frames in one Dask task.
MAX_FRAMES_PER_TASK = 8
#: Frames whose seconds :func:`frames_per_task` judges from (the most recent ones).
RECENT_FRAMES = 16


def import_distributed() -> Any:
    """The ``distributed`` module, or an InputError with the install hint."""
    try:
        import distributed
    except ImportError as exc:
        raise InputError(f"Dask is not installed ({exc}); {INSTALL_HINT}") from exc
    return distributed


def _sees_folder(path: str) -> bool:
    return Path(path).is_dir()


def frames_per_task(recent_seconds: Sequence[float], task_seconds: float = TASK_SECONDS) -> int:
    """How many frames the next Dask task should build.

    Args:
        recent_seconds: wall seconds of recently finished frames (any order; may be empty).
        task_seconds: the aim for one task's seconds; 0 gives one frame per task.

    Returns:
        ``floor(task_seconds / median(recent_seconds))`` clamped to 1..MAX_FRAMES_PER_TASK;
        1 while no frame has finished.

    Example:
        >>> frames_per_task([0.12, 0.13, 0.11], 0.5)
        4
        >>> frames_per_task([], 0.5), frames_per_task([2.0], 0.5)
        (1, 1)
    """
    if not recent_seconds or task_seconds <= 0:
        return 1
    median = statistics.median(recent_seconds)
    if median <= 0:
        return MAX_FRAMES_PER_TASK
    return max(1, min(MAX_FRAMES_PER_TASK, math.floor(task_seconds / median)))


@contextmanager
def _environ_kept(names: Iterable[str]) -> Iterator[None]:
    """Put the environment variables ``names`` back as they were on leaving.

    A Dask nanny writes its ``pre-spawn-environ`` (``OMP_NUM_THREADS=1`` ...) into this
    process's ``os.environ`` before it spawns a worker, and leaves it there; without this,
    a local pool started later by the same process would run single-threaded libraries too.
    """
    saved = {name: os.environ.get(name) for name in names}
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def start_local_cluster(workers: int) -> Any:
    """A ``LocalCluster`` of ``workers`` single-threaded processes with :data:`LOCAL_CLUSTER_CONFIG`.

    This process's Dask configuration and environment are the same afterwards.
    """
    import dask

    distributed = import_distributed()
    # the second context manager reads the configuration the first one set
    with (
        dask.config.set(LOCAL_CLUSTER_CONFIG),
        _environ_kept(dask.config.get("distributed.nanny.pre-spawn-environ")),
    ):
        return distributed.LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        )


def _chunk_records(future: Any, chunk: tuple[FrameTask, ...]) -> tuple[FrameRecord, ...]:
    """The records of a finished, cancelled or failed Dask task of :func:`run_frames`."""
    if future.status == "finished":
        records: tuple[FrameRecord, ...] = future.result()
        return records
    if future.status == "cancelled":
        return tuple(cancelled_record(task) for task in chunk)
    exc = future.exception()
    return tuple(failed_record(task, f"Dask {type(exc).__name__}: {exc}") for task in chunk)


class DaskExecutor:
    """Run frames on a Dask cluster (see the module docstring)."""

    def __init__(
        self,
        address: str | None = None,
        local_workers: int | None = None,
        out_dir: Path | None = None,
        timeout_s: float = CONNECT_TIMEOUT_S,
        task_seconds: float = TASK_SECONDS,
    ) -> None:
        """
        Args:
            address: scheduler address, e.g. ``tcp://10.0.0.5:8786``.
            local_workers: start a LocalCluster of this many single-threaded worker processes
                instead (with :data:`LOCAL_CLUSTER_CONFIG`).
            out_dir: the batch output folder; every worker must see it (checked on start).
            timeout_s: seconds to wait for the scheduler.
            task_seconds: aim for Dask tasks of about this many seconds of frames
                (:func:`frames_per_task`); 0 sends one frame per task.

        Raises:
            InputError: neither or both of ``address`` and ``local_workers``, ``local_workers`` < 1,
                or Dask is not installed.
        """
        if (address is None) == (local_workers is None):
            raise InputError("pass exactly one of --scheduler ADDRESS and --dask-local N")
        if local_workers is not None and local_workers < 1:
            raise InputError(f"--dask-local must be >= 1, got {local_workers}")
        import_distributed()
        self.address = address
        self.local_workers = local_workers
        self.out_dir = out_dir
        self.timeout_s = timeout_s
        self.task_seconds = task_seconds
        self.description = (
            f"Dask scheduler {address}"
            if address
            else f"Dask LocalCluster ({local_workers} worker process{'es' if local_workers != 1 else ''})"
        )
        self.client: Any = None
        self._cluster: Any = None

    def __enter__(self) -> Self:
        distributed = import_distributed()
        try:
            if self.address is not None:
                self.client = distributed.Client(self.address, timeout=self.timeout_s)
            else:
                self._cluster = start_local_cluster(self.local_workers or 1)
                self.client = distributed.Client(self._cluster)
        except (OSError, TimeoutError) as exc:
            self.__exit__()
            raise ClusterError(
                f"{self.address}: cannot reach the Dask scheduler ({exc}); start one with `dask scheduler` "
                "and workers with `dask worker tcp://HOST:8786`, or use --workers N for a local pool"
            ) from exc
        except RuntimeError as exc:  # LocalCluster: "Nanny failed to start."
            self.__exit__()
            raise ClusterError(
                f"{self.description}: could not start ({exc}); a script that starts it must guard its "
                'entry point with `if __name__ == "__main__":` (worker processes re-import it)'
            ) from exc
        try:
            self._check_workers()
        except BaseException:
            self.__exit__()
            raise
        return self

    def _check_workers(self) -> None:
        info = self.client.run(worker_info)
        if not info:
            raise ClusterError(
                f"{self.description}: no workers connected; start some with `dask worker {self.address}`"
            )
        import usdworld

        wrong = sorted(
            f"{w} has {i['usdworld']}" for w, i in info.items() if i["usdworld"] != usdworld.__version__
        )
        if wrong:
            raise ClusterError(
                f"Dask workers run another usdworld than this {usdworld.__version__}: {'; '.join(wrong)}; install the same version everywhere"
            )
        if self.out_dir is not None:
            blind = sorted(w for w, ok in self.client.run(_sees_folder, str(self.out_dir)).items() if not ok)
            if blind:
                raise ClusterError(
                    f"Dask workers {', '.join(blind)} cannot see the output folder {self.out_dir}; "
                    "workers need the same data and output paths (a shared filesystem)"
                )

    def __exit__(self, *exc: object) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

    def _slots(self) -> int:
        return max(2, 2 * sum(self.client.nthreads().values()))

    def run(self, tasks: Iterable[FrameTask], stop: Callable[[], bool]) -> Iterator[FrameRecord]:
        """Build the tasks on the cluster (see :mod:`usdworld.batch.executors` for the contract).

        Frames go in Dask tasks of :func:`frames_per_task` frames, at most ``2 x threads``
        tasks in flight. With ``stop()``, every unfinished task is cancelled; a task already
        running on a worker still finishes there (its worlds are written atomically) but its
        frames are recorded as cancelled.
        """
        if self.client is None:
            raise RuntimeError("DaskExecutor.run outside its with-block")
        distributed = import_distributed()
        it = iter(tasks)
        pending: dict[str, tuple[FrameTask, ...]] = {}
        recent: deque[float] = deque(maxlen=RECENT_FRAMES)
        futures = distributed.as_completed(loop=self.client.loop)

        def submit_next() -> bool:
            chunk = tuple(islice(it, frames_per_task(recent, self.task_seconds)))
            if not chunk:
                return False
            isolated = tuple(replace(task, isolated=True) for task in chunk)
            future = self.client.submit(run_frames, isolated, pure=False, retries=0)
            pending[future.key] = chunk
            futures.add(future)
            return True

        for _ in range(self._slots()):
            if stop() or not submit_next():
                break
        stopping = False
        for future in futures:
            records = _chunk_records(future, pending.pop(future.key))
            future.release()
            recent.extend(r.seconds for r in records if r.status != "cancelled")
            yield from records
            if not stopping and stop():
                stopping = True
                with futures.lock:
                    unfinished = list(futures.futures)
                self.client.cancel(unfinished)
            if not stopping:
                submit_next()
