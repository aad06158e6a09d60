"""``usdworld report``: one self-contained HTML page to check a world (photo, render, objects, camera)."""

from __future__ import annotations

from pathlib import Path

import typer


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
    gt: Path | None = typer.Option(
        None, "--gt", help="3D ground truth: synth *_gt.json, KITTI label_2 .txt or nuScenes info JSON."
    ),
    calib: Path | None = typer.Option(
        None, "--calib", help="KITTI calib file for --gt label_2 (default: ../calib/<same name>)."
    ),
    photo: Path | None = typer.Option(
        None, "--photo", help="The source photo (default: found next to the world)."
    ),
    nuscenes_camera: str = typer.Option(
        "CAM_FRONT", "--nuscenes-camera", help="Camera of a nuScenes info file."
    ),
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
