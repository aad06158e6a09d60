"""``usdworld segment``: Cityscapes-format labels of one image from a segmentation model."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer


def segment(
    image: Path = typer.Argument(..., help="The photo (PNG or JPEG)."),
    output: Path = typer.Option(..., "--output", "-o", help="Folder for the label files."),
    model: Path = typer.Option(
        ..., "--segment-model", help="Model folder (saved with save_pretrained; never downloaded)."
    ),
    detections: Optional[Path] = typer.Option(
        None, "--detections", help="KITTI label_2 / detections JSON: boxes that split touching objects."
    ),
) -> None:
    """Segment an image with a Hugging Face model (the hf backend) into *_labelIds.png, *_instanceIds.png and a *_color.png preview."""
    from usdworld.cli.output import say
    from usdworld.io.detections import read_detections_json, read_kitti_labels
    from usdworld.io.images import read_image
    from usdworld.segment_stage import segment_photo, write_segment_outputs

    photo = read_image(image)
    dets = None
    if detections is not None:
        read = read_detections_json if detections.suffix.lower() == ".json" else read_kitti_labels
        dets = read(detections, photo)
    seg = segment_photo("hf", model, photo, dets)
    paths = write_segment_outputs(seg, output, image.stem)
    say(f"segmentation: hf model {model.name}")
    for path in paths.values():
        say(f"wrote {path}")


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("segment")(segment)
