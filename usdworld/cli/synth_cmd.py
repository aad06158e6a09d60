"""``usdworld synth``: procedural street scenes rendered to Cityscapes-format files."""

from __future__ import annotations

from pathlib import Path

import typer

#: Scene ``i`` of ``--seed S`` is sampled from ``numpy.random.default_rng(S + i)`` and named
#: ``synth_000000_<S+i, 6 digits>``, so a scene does not depend on ``--count``.
NAME_FORMAT = "synth_000000_{seed:06d}"
#: Drive ``i`` of ``--seed S --sequence N`` is sampled from ``default_rng(S + i)`` and named so;
#: its frames are ``<name>_<frame, 6 digits>``.
DRIVE_NAME_FORMAT = "drive_{seed:06d}"


def synth(
    output: Path = typer.Option(..., "--output", "-o", help="Folder for the files (created if missing)."),
    seed: int = typer.Option(..., "--seed", help="Random seed of the first scene (>= 0)."),
    count: int = typer.Option(1, "--count", help="Number of scenes (seeds SEED, SEED+1, ...)."),
    size: str | None = typer.Option(None, "--size", help="WIDTHxHEIGHT; default 1024x512."),
    sequence: int | None = typer.Option(
        None,
        "--sequence",
        help="Render each scene as a drive of N frames (poses, timestamps, views manifest, drive ground truth).",
    ),
    speed: float = typer.Option(8.0, "--speed", help="With --sequence: the camera's speed, m/s (>= 0)."),
    interval: float = typer.Option(
        0.1, "--interval", help="With --sequence: seconds between frames (> 0); 0.1 is KITTI's 10 Hz."
    ),
    overtaking: float | None = typer.Option(
        None,
        "--overtaking",
        help="With --sequence: add a car overtaking the ego this many m/s faster than it (> 0), "
        "starting out of view beside it (a mover first seen after the first frame).",
    ),
) -> None:
    """Sample street scenes, author them as USD and render Cityscapes-format files + ground truth.

    With --sequence N each scene is a drive: the camera moves along the street, driving cars and
    walking people move at constant velocity, and N frames are written with a views manifest
    (``usdworld build --views``) and the drive's ground truth. --overtaking adds a car that
    enters the view late; the rest of each drive stays what its seed gives.
    """
    import math

    import numpy as np
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from usdworld.cli.output import quiet, say
    from usdworld.cli.render_cmd import parse_size
    from usdworld.errors import InputError
    from usdworld.synth import make_street_scene, write_cityscapes_frame

    if seed < 0:
        raise InputError(f"--seed must be >= 0, got {seed}")
    if count < 1:
        raise InputError(f"--count must be >= 1, got {count}")
    if sequence is not None and sequence < 1:
        raise InputError(f"--sequence must be >= 1, got {sequence}")
    if not speed >= 0:
        raise InputError(f"--speed must be >= 0 m/s, got {speed}")
    if not interval > 0:
        raise InputError(f"--interval must be > 0 s, got {interval}")
    if overtaking is not None and sequence is None:
        raise InputError("--overtaking needs --sequence (a car overtakes during a drive)")
    if overtaking is not None and not (overtaking > 0 and math.isfinite(overtaking)):
        raise InputError(f"--overtaking must be a finite speed > 0 m/s, got {overtaking}")
    width, height = parse_size(size) if size else (1024, 512)
    if sequence is not None:
        _drives(output, seed, count, width, height, sequence, speed, interval, overtaking)
        return
    if output.exists() and not output.is_dir():
        raise InputError(f"-o {output}: exists and is not a folder")
    console = Console(stderr=True)
    names = []
    columns = (
        TextColumn("[bold]synth"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("scenes"),
        TimeElapsedColumn(),
    )
    with Progress(*columns, console=console, disable=quiet()) as progress:
        task = progress.add_task("synth", total=count)
        for i in range(count):
            name = NAME_FORMAT.format(seed=seed + i)
            scene = make_street_scene(np.random.default_rng(seed + i), width, height)
            write_cityscapes_frame(scene, output, name)
            names.append(name)
            progress.update(task, completed=i + 1)
    for name in names:
        say(str(output / f"{name}_leftImg8bit.png"))
    say(
        f"wrote {count} scene(s) of {width}x{height} to {output} (image, labelIds, instanceIds, camera, gt)"
    )


def _drives(
    output: Path,
    seed: int,
    count: int,
    width: int,
    height: int,
    frames: int,
    speed: float,
    interval: float,
    overtaking: float | None,
) -> None:
    import numpy as np

    from usdworld.cli.output import say
    from usdworld.synth.drive import make_drive, write_drive

    for i in range(count):
        name = DRIVE_NAME_FORMAT.format(seed=seed + i)
        rng = np.random.default_rng(seed + i)
        drive = make_drive(rng, width, height, frames, speed, interval, overtake_mps=overtaking)
        paths = write_drive(drive, output, name)
        say(str(paths["views"]))
    say(
        f"wrote {count} drive(s) of {frames} frames of {width}x{height} to {output} "
        f"(per frame: image, labelIds, instanceIds, camera, gt; per drive: views manifest, drive gt)"
    )


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("synth")(synth)
