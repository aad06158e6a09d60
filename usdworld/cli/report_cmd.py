"""``usdworld report``: one self-contained HTML page to check a world (photo, render, objects, camera)."""

from __future__ import annotations

from pathlib import Path

import typer

from usdworld.cli.ground_truth_options import CALIB, GT, NUSCENES_CAMERA


def report(
    world: Path = typer.Argument(..., help="A world's world.usda (or its folder)."),
    output: Path | None = typer.Option(
        None, "--output", "-o", help="HTML file to write (default: report.html in the world's folder)."
    ),
    labels: Path | None = typer.Option(
        None,
        "--labels",
        help="Cityscapes *_gtFine_labelIds.png for the layout IoU (default: the world's labels input, found next to it).",
    ),
    gt: Path | None = GT,
    calib: Path | None = CALIB,
    photo: Path | None = typer.Option(
        None, "--photo", help="The source photo (default: found next to the world)."
    ),
    nuscenes_camera: str = NUSCENES_CAMERA,
) -> None:
    """Write one HTML page with the photo, the render, every object's provenance, the camera and the evaluation."""
    from usdworld.cli.output import say
    from usdworld.report_html import write_report_page

    if output is None:
        output = (world if world.is_dir() else world.parent) / "report.html"
    path = write_report_page(
        world, output, labels=labels, gt=gt, calib=calib, photo=photo, nuscenes_camera=nuscenes_camera
    )
    say(f"wrote {path}")


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("report")(report)
