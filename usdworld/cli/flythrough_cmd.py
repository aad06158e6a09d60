"""``usdworld flythrough``: an H.264 fly-through video of a world, with the source vehicle in red."""

from __future__ import annotations

from pathlib import Path

import typer


def flythrough(
    world: Path = typer.Argument(..., help="A world's world.usda (or its folder)."),
    output: Path = typer.Option(..., "--output", "-o", help="The .mp4 file to write."),
    frames: int = typer.Option(120, "--frames", help="Number of frames (>= 2)."),
    size: str | None = typer.Option(
        None, "--size", help="WIDTHxHEIGHT, both even; default 960 wide with the photo's aspect."
    ),
    fps: float = typer.Option(30.0, "--fps", help="Frames per second."),
    camera: str | None = typer.Option(
        None, "--camera", help="Start camera prim; default /World/SourceCamera."
    ),
    follow_ego: bool = typer.Option(
        False,
        "--follow-ego",
        help="Ride a drive's ego camera (/World/Ego/Camera) along its time-sampled trajectory instead.",
    ),
) -> None:
    """Fly from the source camera forward into the scene and up to an aerial view (MP4, H.264)."""
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from usdworld.authoring.inspect import open_world
    from usdworld.cli.output import quiet, say
    from usdworld.cli.render_cmd import parse_size
    from usdworld.errors import InputError
    from usdworld.render.flythrough import EGO_CAMERA_PATH, default_video_size, render_flythrough
    from usdworld.render.outputs import view_camera, world_image_size
    from usdworld.render.video import check_video_size

    if output.suffix.lower() != ".mp4":
        raise InputError(f"-o {output}: the video must be an .mp4 file")
    if frames < 2:
        raise InputError(f"--frames must be >= 2, got {frames}")
    stage = open_world(world)
    width, height = parse_size(size) if size else default_video_size(stage)
    check_video_size(width, height)
    view_camera(stage, *world_image_size(stage), camera_path=camera)  # fail before the progress bar starts
    if follow_ego and not stage.GetPrimAtPath(EGO_CAMERA_PATH):
        raise InputError(
            f"--follow-ego: the world has no {EGO_CAMERA_PATH}; build a drive (build --views with timestamped views)"
        )
    console = Console(stderr=True)
    columns = (
        TextColumn("[bold]fly-through"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("frames"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=console, transient=False, disable=quiet()) as progress:
        task = progress.add_task("render", total=frames)
        result = render_flythrough(
            stage,
            output,
            n_frames=frames,
            width=width,
            height=height,
            fps=fps,
            camera_path=camera,
            follow_ego=follow_ego,
            progress=lambda done, total: progress.update(task, completed=done),
        )
    say(
        f"wrote {result.path}: {result.frames} frames {result.width}x{result.height} at {fps:g} fps, "
        f"H.264 yuv420p +faststart; rendering {result.render_s:.1f} s, total {result.total_s:.1f} s"
    )


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("flythrough")(flythrough)
