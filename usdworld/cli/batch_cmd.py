"""``usdworld batch``: build every frame of a dataset or manifest, locally or on Dask."""

from __future__ import annotations

import enum
import logging
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from usdworld.parameters import DEFAULT_PARAMETERS

if TYPE_CHECKING:
    from usdworld.batch.frames import Frame, Incomplete

#: Incomplete and failed frames listed on the terminal (the rest are in batch.json).
LIST_LIMIT = 20


class Layout(str, enum.Enum):
    """Dataset layouts of ``--layout``."""

    cityscapes = "cityscapes"
    kitti = "kitti"
    manifest = "manifest"
    views = "views"
    nuscenes = "nuscenes"


def batch(
    source: Path = typer.Argument(
        ...,
        help="Dataset root (with --layout) or a manifest .json/.csv; with --layout views a views manifest "
        "or a folder of them, with --layout nuscenes an mmdetection3d info JSON (one world per sample).",
    ),
    output: Path = typer.Option(
        ..., "--output", "-o", help="Folder for OUT/<frame_id>/ worlds, batch.json and index.usda."
    ),
    layout: Layout | None = typer.Option(
        None,
        "--layout",
        help="cityscapes, kitti, manifest, views or nuscenes (default: manifest for a .json/.csv file).",
    ),
    split: list[str] | None = typer.Option(
        None, "--split", help="Cityscapes split to build (repeatable; default: every split)."
    ),
    ground_plane: bool = typer.Option(
        False, "--ground-plane", help="KITTI: use planes/<id>.txt for roll and a prior on height and pitch."
    ),
    workers: int = typer.Option(
        1, "--workers", "-j", help="Local worker processes; 1 builds in this process."
    ),
    scheduler: str | None = typer.Option(
        None, "--scheduler", help="Run on an existing Dask cluster, e.g. tcp://10.0.0.5:8786."
    ),
    dask_local: int | None = typer.Option(
        None, "--dask-local", help="Run on a Dask LocalCluster of N worker processes."
    ),
    resume: bool = typer.Option(
        False,
        "--resume",
        help="Skip frames whose world is complete and whose inputs and options are unchanged.",
    ),
    fail_fast: bool = typer.Option(False, "--fail-fast", help="Stop at the first failed frame."),
    library: Path | None = typer.Option(
        None, "--library", help="User asset library for every frame (manifest rows may name their own)."
    ),
    max_range: float = typer.Option(
        DEFAULT_PARAMETERS.scene.max_range_m,
        "--max-range",
        help="Farthest ground distance meshed, metres (manifest rows may give their own).",
    ),
) -> None:
    """Build every frame of a dataset into OUT/<frame_id>/, as `usdworld build` would."""
    from usdworld.batch.discover import count_frames, discover, resolve_layout
    from usdworld.batch.progress import make_progress
    from usdworld.batch.runner import check_failures, make_executor, prepare_output, run_batch
    from usdworld.cli.output import say
    from usdworld.errors import InputError

    layout_name = resolve_layout(source, layout.value if layout else None)
    executor = make_executor(workers, scheduler, dask_local, output.absolute())

    def items() -> Iterator[Frame | Incomplete]:
        return discover(
            source,
            layout_name,
            splits=split or (),
            ground_plane=ground_plane,
            library=library,
            max_range_m=max_range,
        )

    total, incomplete = count_frames(items())  # for the progress's ETA
    if total == 0:
        detail = (
            f"; {len(incomplete)} incomplete, e.g. {incomplete[0].name}: {incomplete[0].reason}"
            if incomplete
            else ""
        )
        raise InputError(f"{source}: no complete frames found with --layout {layout_name}{detail}")
    out = prepare_output(output)
    show_progress = logging.getLogger().getEffectiveLevel() <= logging.INFO  # not with --quiet
    quiet = {"usdworld": logging.ERROR, "distributed": logging.WARNING}  # frame warnings are in batch.json
    levels = {name: logging.getLogger(name).level for name in quiet}
    if logging.getLogger().getEffectiveLevel() > logging.DEBUG:
        for name, level in quiet.items():
            logging.getLogger(name).setLevel(level)
    try:
        with executor:
            summary = run_batch(
                items(),
                out,
                executor,
                resume=resume,
                fail_fast=fail_fast,
                progress=make_progress(sys.stderr) if show_progress else None,
                total=total,
                source=str(source),
                layout=layout_name,
            )
    finally:
        for name, level in levels.items():
            logging.getLogger(name).setLevel(level)
    counts = summary.counts()
    rate = f" ({counts['frames_per_minute']:.1f} frames/min)" if counts["frames_per_minute"] else ""
    say(
        f"built {counts['built']}, unchanged {counts['unchanged']}, failed {counts['failed']}, "
        f"cancelled {counts['cancelled']} of {counts['frames']} frames in {summary.seconds:.1f} s{rate}"
    )
    _list("incomplete (not built)", [(i.name, i.reason) for i in summary.incomplete if not i.fails])
    failed = [(i.name, i.reason) for i in summary.failed_inputs]
    _list("failed", failed + [(r.frame_id, r.error or "") for r in summary.failed])
    say(f"wrote {summary.batch_file}" + (f" and {summary.index_file}" if summary.index_file else ""))
    check_failures(summary)


def _list(title: str, rows: list[tuple[str, str]]) -> None:
    if not rows:
        return
    typer.echo(f"{title}: {len(rows)}")
    for name, reason in rows[:LIST_LIMIT]:
        typer.echo(f"  {name}: {reason}")
    if len(rows) > LIST_LIMIT:
        typer.echo(f"  ... and {len(rows) - LIST_LIMIT} more in batch.json")


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("batch")(batch)
