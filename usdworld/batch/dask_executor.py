"""Run frames on a Dask cluster: an existing one (``--scheduler``) or a local one (``--dask-local N``).

Needs ``dask[distributed]`` (``pip install "dask[distributed]>=2026.8"``). Dask ships the
task (a :class:`~usdworld.batch.worker.FrameTask` of paths) to a worker, which imports
:mod:`usdworld.batch.worker` and runs :func:`~usdworld.batch.worker.run_frame` there; only
the small record comes back. So every worker needs:

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
``--dask-local`` leaves it unset, and for ``dask worker`` put this in a Dask config file on
the worker machines (e.g. ``~/.config/dask/usdworld.yaml``)::

    distributed:
      nanny:
        pre-spawn-environ:
          MALLOC_TRIM_THRESHOLD_: null

On Kubernetes use dask-kubernetes, on HPC schedulers (SLURM, PBS, SGE, LSF) use
dask-jobqueue; both give a scheduler address to pass as ``--scheduler``.
``--dask-local N`` starts ``LocalCluster(n_workers=N, threads_per_worker=1,
processes=True)`` for the run, which is mainly useful to try the cluster path on one machine.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any, Self

from usdworld.batch.executors import cancelled_record, failed_record
from usdworld.batch.records import FrameRecord
from usdworld.batch.worker import FrameTask, run_frame, worker_info
from usdworld.errors import ClusterError, InputError

INSTALL_HINT = 'pip install "dask[distributed]>=2026.8"'
#: glibc variable Dask's nanny sets to 65536 in every worker process by default. It turns off
#: glibc's adaptive mmap threshold, so each large numpy array is a fresh mmap and a frame
#: takes about 40 % longer; the LocalCluster leaves it unset.
MALLOC_TRIM = "MALLOC_TRIM_THRESHOLD_"
#: Seconds to wait for a scheduler to answer.
CONNECT_TIMEOUT_S = 20


def import_distributed() -> Any:
    """The ``distributed`` module, or an InputError with the install hint."""
    try:
        import distributed
    except ImportError as exc:
        raise InputError(f"Dask is not installed ({exc}); {INSTALL_HINT}") from exc
    return distributed


def _sees_folder(path: str) -> bool:
    return Path(path).is_dir()


class DaskExecutor:
    """Run frames on a Dask cluster (see the module docstring)."""

    def __init__(
        self,
        address: str | None = None,
        local_workers: int | None = None,
        out_dir: Path | None = None,
        timeout_s: float = CONNECT_TIMEOUT_S,
    ) -> None:
        """
        Args:
            address: scheduler address, e.g. ``tcp://10.0.0.5:8786``.
            local_workers: start a LocalCluster of this many single-threaded worker processes instead.
            out_dir: the batch output folder; every worker must see it (checked on start).
            timeout_s: seconds to wait for the scheduler.

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
                import dask

                with dask.config.set({f"distributed.nanny.pre-spawn-environ.{MALLOC_TRIM}": None}):
                    self._cluster = distributed.LocalCluster(
                        n_workers=self.local_workers,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=":0",
                        silence_logs=logging.ERROR,
                    )
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

        With ``stop()``, every unfinished frame is cancelled; a frame already running on a
        worker still finishes there (its world is written atomically) but is recorded as cancelled.
        """
        if self.client is None:
            raise RuntimeError("DaskExecutor.run outside its with-block")
        distributed = import_distributed()
        it = iter(tasks)
        pending: dict[str, FrameTask] = {}
        futures = distributed.as_completed(loop=self.client.loop)

        def submit_next() -> bool:
            task = next(it, None)
            if task is None:
                return False
            future = self.client.submit(run_frame, replace(task, isolated=True), pure=False, retries=0)
            pending[future.key] = task
            futures.add(future)
            return True

        for _ in range(self._slots()):
            if stop() or not submit_next():
                break
        stopping = False
        for future in futures:
            task = pending.pop(future.key)
            if future.status == "finished":
                yield future.result()
            elif future.status == "cancelled":
                yield cancelled_record(task)
            else:
                exc = future.exception()
                yield failed_record(task, f"Dask {type(exc).__name__}: {exc}")
            future.release()
            if not stopping and stop():
                stopping = True
                with futures.lock:
                    unfinished = list(futures.futures)
                self.client.cancel(unfinished)
            if not stopping:
                submit_next()
