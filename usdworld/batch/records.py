"""``OUT/batch.json``: one record per frame, written atomically; a journal while the batch runs.

``batch.json``::

    {"format": "usdworld-batch/1", "usdworld_version": "0.1.0",
     "source": "<dataset or manifest as given>", "layout": "cityscapes",
     "summary": {"frames": 40, "built": 39, "unchanged": 0, "failed": 1, "cancelled": 0,
                 "incomplete": 2, "seconds": 31.2, "frames_per_minute": 76.9},
     "frames": [{"frame_id": "...", "status": "built", "seconds": 0.71, "cpu_seconds": 0.69, "objects": 12,
                 "error": null, "key": "<sha256>", "source": "leftImg8bit/...png",
                 "warnings": [...], "worker": "host:pid", "rss_mb": 180.2, "peak_rss_mb": 201.5}, ...],
     "incomplete": [{"name": "...", "reason": "...", "fails": false}, ...]}

Statuses: ``built``; ``unchanged`` (``--resume`` found the same key and a complete world);
``failed`` (``error`` says why; the batch went on unless ``--fail-fast``); ``cancelled``
(not run because ``--fail-fast`` stopped the batch). Frames are sorted by id.

While a batch runs, each record is also appended to ``OUT/.batch-journal.jsonl`` as soon as
it arrives, so ``--resume`` after an interrupted batch knows what was already built.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Self, TextIO

import usdworld
from usdworld.atomic import write_text_atomic
from usdworld.batch.frames import Incomplete
from usdworld.errors import InputError, OutputError

BATCH_FILE = "batch.json"
JOURNAL_FILE = ".batch-journal.jsonl"
FORMAT = "usdworld-batch/1"
STATUSES = ("built", "unchanged", "failed", "cancelled")
#: Statuses whose world folder is complete.
DONE = ("built", "unchanged")


@dataclass(frozen=True)
class FrameRecord:
    """What happened to one frame.

    Attributes:
        frame_id: the frame id (its world is ``OUT/<frame_id>/``).
        status: one of :data:`STATUSES`.
        seconds: wall time of the frame in its worker (0 when cancelled).
        cpu_seconds: CPU time of the worker process during the frame (None when not run).
        objects: objects placed (None unless built or unchanged).
        error: one-line reason of a failure, else None.
        key: resume key of the inputs and options (None when not computed).
        source: the photo as the dataset names it.
        warnings: the build's warnings (also in the world's ``report.json``).
        worker: ``host:pid`` of the process that ran the frame.
        rss_mb: resident memory of that process after the frame, MiB (None when unknown).
        peak_rss_mb: its peak resident memory so far, MiB (None when unknown).
        traceback: for an unexpected error (a bug), the traceback text.
    """

    frame_id: str
    status: str
    seconds: float = 0.0
    cpu_seconds: float | None = None
    objects: int | None = None
    error: str | None = None
    key: str | None = None
    source: str = ""
    warnings: tuple[str, ...] = ()
    worker: str = ""
    rss_mb: float | None = None
    peak_rss_mb: float | None = None
    traceback: str | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError(f"record {self.frame_id}: status must be one of {STATUSES}, got {self.status!r}")

    def to_json(self) -> dict[str, Any]:
        """The record as a JSON object (``traceback`` only when set)."""
        doc = asdict(self)
        doc["warnings"] = list(self.warnings)
        doc["seconds"] = round(self.seconds, 4)
        doc["cpu_seconds"] = None if self.cpu_seconds is None else round(self.cpu_seconds, 4)
        if self.traceback is None:
            del doc["traceback"]
        return doc

    @classmethod
    def from_json(cls, doc: Any, where: str) -> FrameRecord:
        """Read a record written by :meth:`to_json`.

        Raises:
            InputError: ``doc`` is not such a record.
        """
        try:
            values = {k: doc[k] for k in cls.__dataclass_fields__ if k in doc}
            values["warnings"] = tuple(values.get("warnings", ()))
            return cls(**values)
        except (TypeError, KeyError, ValueError) as exc:
            raise InputError(
                f"{where}: not a batch record ({exc}); delete the file to start the batch afresh"
            ) from exc


@dataclass(frozen=True)
class BatchSummary:
    """The outcome of a batch.

    Attributes:
        records: every frame's record, sorted by frame id (with ``--resume``, also the
            frames of earlier runs that this run did not see).
        incomplete: what discovery did not build, and why.
        seconds: wall time of this run.
        batch_file: path of ``batch.json``.
        index_file: path of ``index.usda`` (None when no world was built).
    """

    records: tuple[FrameRecord, ...]
    incomplete: tuple[Incomplete, ...]
    seconds: float
    batch_file: Path
    index_file: Path | None

    def count(self, status: str) -> int:
        """How many records have ``status``."""
        return sum(1 for r in self.records if r.status == status)

    @property
    def failed(self) -> tuple[FrameRecord, ...]:
        """The failed records."""
        return tuple(r for r in self.records if r.status == "failed")

    @property
    def failed_inputs(self) -> tuple[Incomplete, ...]:
        """Frames asked for (manifest rows) that could not be built: they fail the batch too."""
        return tuple(i for i in self.incomplete if i.fails)

    def counts(self) -> dict[str, Any]:
        """The ``summary`` object of ``batch.json``."""
        ran = self.count("built") + self.count("failed")
        doc: dict[str, Any] = {"frames": len(self.records)}
        doc.update({s: self.count(s) for s in STATUSES})
        doc["incomplete"] = len(self.incomplete)
        doc["seconds"] = round(self.seconds, 3)
        doc["frames_per_minute"] = round(60.0 * ran / self.seconds, 2) if self.seconds > 0 and ran else None
        return doc


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (temporary file beside it, then rename).

    Raises:
        OutputError: the folder cannot be written.
    """
    write_text_atomic(path, text)


def batch_document(summary: BatchSummary, source: str, layout: str) -> dict[str, Any]:
    """The ``batch.json`` document of a summary."""
    return {
        "format": FORMAT,
        "usdworld_version": usdworld.__version__,
        "source": source,
        "layout": layout,
        "summary": summary.counts(),
        "frames": [r.to_json() for r in summary.records],
        "incomplete": [{"name": i.name, "reason": i.reason, "fails": i.fails} for i in summary.incomplete],
    }


def write_batch_file(out_dir: Path, summary: BatchSummary, source: str, layout: str) -> Path:
    """Write ``OUT/batch.json`` atomically and return its path."""
    path = out_dir / BATCH_FILE
    atomic_write_text(path, json.dumps(batch_document(summary, source, layout), indent=2) + "\n")
    return path


def read_previous(out_dir: Path) -> dict[str, FrameRecord]:
    """Records of earlier runs: ``batch.json``, then the journal of an interrupted run on top.

    Returns:
        frame id -> latest record; empty when neither file exists.

    Raises:
        InputError: ``batch.json`` exists but is not a batch file (a torn journal line is ignored).
    """
    records: dict[str, FrameRecord] = {}
    path = out_dir / BATCH_FILE
    if path.is_file():
        where = str(path)
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise InputError(f"{where}: unreadable ({exc}); delete it to rebuild every frame") from exc
        if (
            not isinstance(doc, dict)
            or doc.get("format") != FORMAT
            or not isinstance(doc.get("frames"), list)
        ):
            raise InputError(f"{where}: not a {FORMAT} file; delete it to rebuild every frame")
        for i, item in enumerate(doc["frames"]):
            record = FrameRecord.from_json(item, f"{where} -> frames -> [{i}]")
            records[record.frame_id] = record
    journal = out_dir / JOURNAL_FILE
    if journal.is_file():
        for line in journal.read_text(encoding="utf-8", errors="replace").splitlines():
            try:
                record = FrameRecord.from_json(json.loads(line), str(journal))
            except (ValueError, InputError):
                continue  # a line torn by the interruption
            records[record.frame_id] = record
    return records


class Journal:
    """Append-only ``OUT/.batch-journal.jsonl``: one record per line, flushed as it arrives."""

    def __init__(self, out_dir: Path) -> None:
        self.path = out_dir / JOURNAL_FILE
        self._file: TextIO | None = None

    def __enter__(self) -> Self:
        try:
            self._file = open(self.path, "w", encoding="utf-8")
        except OSError as exc:
            raise OutputError(
                f"{self.path}: cannot write ({exc.strerror or exc}); check the output folder is writable"
            ) from exc
        return self

    def append(self, record: FrameRecord) -> None:
        """Write one record line and flush it."""
        if self._file is None:
            raise RuntimeError("Journal.append outside its with-block")
        self._file.write(json.dumps(record.to_json()) + "\n")
        self._file.flush()

    def __exit__(self, *exc: object) -> None:
        if self._file is not None:
            self._file.close()

    def remove(self) -> None:
        """Delete the journal (once ``batch.json`` holds every record)."""
        self.path.unlink(missing_ok=True)


def merge(previous: dict[str, FrameRecord], current: Iterable[FrameRecord]) -> tuple[FrameRecord, ...]:
    """Previous records updated by the current ones, sorted by frame id.

    A frame cancelled now keeps an earlier built/unchanged record: its world is still there.
    """
    merged = dict(previous)
    for r in current:
        before = merged.get(r.frame_id)
        if r.status == "cancelled" and before is not None and before.status in DONE:
            continue
        merged[r.frame_id] = r
    return tuple(merged[k] for k in sorted(merged))
