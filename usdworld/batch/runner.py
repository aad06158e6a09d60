"""Run a batch: stream frames to an executor, record every frame, write batch.json and index.usda.

:func:`run_batch` is the one entry point; the CLI (``usdworld batch``) and the benchmark
call it. It never raises for a frame that fails (the frame's record says why); the caller
decides what a failure means (the CLI exits 1, see :class:`FramesFailed`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable
from pathlib import Path

from usdworld.atomic import ensure_output_dir
from usdworld.authoring.batch_index import IndexEntry, write_index
from usdworld.batch.executors import FrameExecutor, cancelled_record
from usdworld.batch.frames import Frame, Incomplete
from usdworld.batch.progress import BatchProgress
from usdworld.batch.records import (
    DONE,
    BatchSummary,
    FrameRecord,
    Journal,
    merge,
    read_previous,
    write_batch_file,
)
from usdworld.batch.worker import FrameTask
from usdworld.errors import FramesFailed
from usdworld.output_dir import remove_dead_builds
from usdworld.parameters import DEFAULT_PARAMETERS

log = logging.getLogger(__name__)

MAX_RANGE_M = DEFAULT_PARAMETERS.scene.max_range_m  # the default range (scene.max_range_m)


def prepare_output(out_dir: Path) -> Path:
    """Create the batch output folder if needed and return its absolute path.

    Raises:
        OutputError: it exists as a file, or cannot be created or written.
    """
    return ensure_output_dir(Path(out_dir).absolute())


def run_batch(
    items: Iterable[Frame | Incomplete],
    out_dir: Path,
    executor: FrameExecutor,
    *,
    resume: bool = False,
    fail_fast: bool = False,
    progress: BatchProgress | None = None,
    total: int | None = None,
    source: str = "",
    layout: str = "",
) -> BatchSummary:
    """Build every frame of ``items`` into ``out_dir/<frame_id>/``.

    Args:
        items: frames and incomplete entries from :mod:`usdworld.batch.discover`; consumed
            lazily, as workers free up.
        out_dir: the batch output folder (created if missing).
        executor: an entered executor (:class:`~usdworld.batch.executors.InlineExecutor`,
            :class:`~usdworld.batch.executors.LocalPoolExecutor`,
            :class:`~usdworld.batch.dask_executor.DaskExecutor`).
        resume: skip frames whose earlier record (``batch.json`` or the journal of an
            interrupted run) is built or unchanged with the same key and whose world is
            complete; keep the earlier records of frames not seen this time.
        fail_fast: stop at the first failed frame (queued frames are recorded as cancelled).
        progress: where to report progress (None: nowhere).
        total: the number of frames, for the progress's ETA (None: unknown).
        source: the dataset or manifest as given, for ``batch.json``.
        layout: the layout name, for ``batch.json``.

    Returns:
        The summary; ``batch.json`` and (when any world is complete) ``index.usda`` are written.

    Raises:
        OutputError: the output folder cannot be written.
        InputError: ``resume`` and an unreadable ``batch.json``.
    """
    out = prepare_output(out_dir)
    previous = read_previous(out) if resume else {}
    incomplete: list[Incomplete] = []
    records: list[FrameRecord] = []
    ranges: dict[str, float] = {}
    failed = False
    start = time.perf_counter()

    def stop() -> bool:
        return fail_fast and failed

    stream = iter(items)

    def tasks() -> Iterable[FrameTask]:
        for item in stream:
            if isinstance(item, Incomplete):
                incomplete.append(item)
                continue
            ranges[item.frame_id] = item.request.max_range_m
            before = previous.get(item.frame_id)
            previous_key = before.key if before is not None and before.status in DONE else None
            yield FrameTask(item.frame_id, item.source, item.request_in(out), previous_key)
            if stop():
                return

    if previous:  # a crash of this run must not lose what the journal of the last one knew
        write_batch_file(out, _summary(merge(previous, []), (), 0.0, out, None), source, layout)
    if progress is not None:
        progress.start(total, executor.description)
    try:
        with Journal(out) as journal:
            for record in executor.run(tasks(), stop):
                records.append(record)
                journal.append(record)
                failed = failed or record.status == "failed"
                if progress is not None:
                    progress.update(record)
            if stop():  # --fail-fast: list what was never submitted, so batch.json names every frame
                seen = {r.frame_id for r in records}
                for item in stream:
                    if isinstance(item, Incomplete):
                        incomplete.append(item)
                    elif item.frame_id not in seen:
                        record = cancelled_record(FrameTask(item.frame_id, item.source, item.request_in(out)))
                        records.append(record)
                        journal.append(record)
    finally:
        if progress is not None:
            progress.close()
    seconds = time.perf_counter() - start
    # every frame has its record, so no build of this run is still writing: a temporary
    # folder left beside a frame's world is a dead worker's (Dask re-ran its frames elsewhere)
    for record in records:
        for leftover in remove_dead_builds(out / record.frame_id):
            log.warning("%s: removed %s, left by a build whose process died", record.frame_id, leftover.name)
    all_records = merge(previous, records) if resume else merge({}, records)
    entries = [
        IndexEntry(r.frame_id, r.source, ranges.get(r.frame_id, MAX_RANGE_M))
        for r in all_records
        if r.status in DONE and (out / r.frame_id / "world.usda").is_file()
    ]
    index = write_index(out, entries) if entries else None
    if index is None:
        (out / "index.usda").unlink(missing_ok=True)
    summary = _summary(all_records, tuple(incomplete), seconds, out, index)
    write_batch_file(out, summary, source, layout)
    Journal(out).remove()
    return summary


def _summary(
    records: tuple[FrameRecord, ...],
    incomplete: tuple[Incomplete, ...],
    seconds: float,
    out: Path,
    index: Path | None,
) -> BatchSummary:
    return BatchSummary(records, incomplete, seconds, out / "batch.json", index)


def check_failures(summary: BatchSummary) -> None:
    """Raise :class:`FramesFailed` when any frame failed, or a manifest row could not be built.

    Raises:
        FramesFailed: ``N of M frames failed (first: <id>: <error>); see OUT/batch.json``.
    """
    failed = [(r.frame_id, r.error) for r in summary.failed]
    failed += [(i.name, i.reason) for i in summary.failed_inputs]
    if failed:
        name, error = failed[0]
        total = len(summary.records) + len(summary.failed_inputs)
        raise FramesFailed(
            f"{len(failed)} of {total} frames failed (first: {name}: {error}); see {summary.batch_file}"
        )


def make_executor(
    workers: int = 1, scheduler: str | None = None, dask_local: int | None = None, out_dir: Path | None = None
) -> FrameExecutor:
    """The executor for the CLI's ``--workers`` / ``--scheduler`` / ``--dask-local`` (not entered yet).

    Raises:
        InputError: ``workers`` < 1, a Dask option combined with ``--workers`` > 1 or with the
            other Dask option, or Dask not installed.
    """
    from usdworld.batch.dask_executor import DaskExecutor
    from usdworld.batch.executors import InlineExecutor, LocalPoolExecutor
    from usdworld.errors import InputError

    if workers < 1:
        raise InputError(f"--workers must be >= 1, got {workers}")
    if scheduler is not None or dask_local is not None:
        if workers != 1:
            raise InputError(
                "--workers sets a local pool; with --scheduler or --dask-local the cluster's workers run the frames"
            )
        if scheduler is not None and dask_local is not None:
            raise InputError(
                "pass either --scheduler ADDRESS (an existing cluster) or --dask-local N, not both"
            )
        return DaskExecutor(scheduler, dask_local, out_dir)
    return InlineExecutor() if workers == 1 else LocalPoolExecutor(workers)
