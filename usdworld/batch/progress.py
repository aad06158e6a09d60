"""Batch progress: a rich progress bar on a terminal, plain periodic lines otherwise.

Both show frames done of the total, the rate in frames per minute, the time left and
the failures so far. They write to the stream they are given (the CLI passes stderr);
the library itself never prints.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Protocol, TextIO

from usdworld.batch.records import FrameRecord

#: Seconds between two plain progress lines.
PLAIN_INTERVAL_S = 10.0


class BatchProgress(Protocol):
    """What the runner reports to (see :func:`make_progress`)."""

    def start(self, total: int | None, description: str) -> None: ...

    def update(self, record: FrameRecord) -> None: ...

    def close(self) -> None: ...


class _Counts:
    def __init__(self, clock: Callable[[], float]) -> None:
        self.clock = clock
        self.total: int | None = None
        self.done = self.failed = self.unchanged = 0
        self.t0 = clock()

    def add(self, record: FrameRecord) -> None:
        self.done += 1
        self.failed += record.status == "failed"
        self.unchanged += record.status == "unchanged"

    def rate_per_min(self) -> float | None:
        """Frames built (or failed) per minute; unchanged frames of ``--resume`` do not count."""
        elapsed = self.clock() - self.t0
        ran = self.done - self.unchanged
        return 60.0 * ran / elapsed if elapsed > 0 and ran else None

    def rate_text(self) -> str:
        """``12.0 frames/min``; before the first build ``no frame built yet``, never a bare ``?``."""
        rate = self.rate_per_min()
        return f"{rate:.1f} frames/min" if rate else "no frame built yet"

    def eta_s(self) -> float | None:
        elapsed = self.clock() - self.t0
        if self.total is None or not self.done or elapsed <= 0:
            return None
        return (self.total - self.done) * elapsed / self.done


def _duration(seconds: float | None) -> str:
    if seconds is None:
        return "?"
    s = round(seconds)
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


class PlainProgress:
    """One line every ``interval_s`` seconds and a last one at the end::

    batch: 12/40 frames, 1 failed, 0 unchanged, 41.3 frames/min, ETA 0:00:40
    """

    def __init__(
        self,
        stream: TextIO,
        interval_s: float = PLAIN_INTERVAL_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.stream = stream
        self.interval_s = interval_s
        self.clock = clock
        self._counts = _Counts(clock)
        self._last = clock()

    def start(self, total: int | None, description: str) -> None:
        self._counts = _Counts(self.clock)
        self._counts.total = total
        self._last = self.clock()
        self.stream.write(f"batch: {total if total is not None else '?'} frames on {description}\n")
        self.stream.flush()

    def line(self) -> str:
        """The current progress line (without newline)."""
        c = self._counts
        return (
            f"batch: {c.done}/{c.total if c.total is not None else '?'} frames, {c.failed} failed, "
            f"{c.unchanged} unchanged, {c.rate_text()}, ETA {_duration(c.eta_s())}"
        )

    def update(self, record: FrameRecord) -> None:
        self._counts.add(record)
        if self.clock() - self._last >= self.interval_s:
            self._last = self.clock()
            self.stream.write(self.line() + "\n")
            self.stream.flush()

    def close(self) -> None:
        self.stream.write(self.line() + "\n")
        self.stream.flush()


class RichProgress:
    """A rich progress bar: bar, done/total, frames/min, time left, failures."""

    def __init__(self, stream: TextIO) -> None:
        from rich.console import Console

        self.console = Console(file=stream)
        self._counts = _Counts(time.monotonic)
        self._progress: Any = None
        self._task: Any = None

    def start(self, total: int | None, description: str) -> None:
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self._counts = _Counts(time.monotonic)
        self._counts.total = total
        self._progress = Progress(
            TextColumn("[bold]batch[/]"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[rate]}"),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            TextColumn("[red]{task.fields[failed]} failed[/]"),
            console=self.console,
        )
        self.console.print(f"building {total if total is not None else '?'} frames on {description}")
        self._progress.start()
        self._task = self._progress.add_task("batch", total=total, rate=self._counts.rate_text(), failed=0)

    def update(self, record: FrameRecord) -> None:
        self._counts.add(record)
        self._progress.update(self._task, advance=1, rate=self._counts.rate_text(), failed=self._counts.failed)
        if record.status == "failed":
            from rich.markup import escape

            self._progress.console.print(
                f"[red]failed[/] {escape(record.frame_id)}: {escape(record.error or '')}", highlight=False
            )

    def close(self) -> None:
        if self._progress is not None:
            self._progress.stop()


def make_progress(stream: TextIO, interval_s: float = PLAIN_INTERVAL_S) -> BatchProgress:
    """A :class:`RichProgress` when ``stream`` is a terminal, else a :class:`PlainProgress`."""
    isatty = getattr(stream, "isatty", None)
    if isatty is not None and isatty():
        return RichProgress(stream)
    return PlainProgress(stream, interval_s)
