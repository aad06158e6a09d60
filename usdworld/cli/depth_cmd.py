"""``usdworld depth``: metric depth of one image, as .npy, 16-bit PNG and a preview."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from usdworld.cli.choices import DepthBackendName


def depth(
    image: Path = typer.Argument(..., help="The photo (PNG or JPEG)."),
    output: Path = typer.Option(..., "--output", "-o", help="Folder for the depth files."),
    camera: Optional[Path] = typer.Option(None, "--camera", help="Camera file (Cityscapes JSON, KITTI calib, plain JSON, INFO.json#CAM_FRONT)."),
    labels: Optional[Path] = typer.Option(None, "--labels", help="Cityscapes labelIds PNG (ground pixels for alignment)."),
    instances: Optional[Path] = typer.Option(None, "--instances", help="Cityscapes instanceIds PNG."),
    detections: Optional[Path] = typer.Option(None, "--detections", help="KITTI label_2 / detections JSON (helps estimate the camera)."),
    backend: DepthBackendName = typer.Option(DepthBackendName.ground, "--depth", help="Depth backend."),
    weights: Optional[Path] = typer.Option(None, "--depth-weights", help="Weights file/folder of a network backend."),
    depth_map: Optional[Path] = typer.Option(None, "--depth-map", help="Depth file for --depth file."),
) -> None:
    """Estimate metric depth for an image (network output aligned to the ground)."""
    from usdworld.cli.output import say
    from usdworld.depth_stage import write_depth_outputs
    from usdworld.io.types import DepthMap
    from usdworld.perception.depth import ground_plane_depth
    from usdworld.pipeline import BuildRequest, depth_for_image

    request = BuildRequest(
        image=image, output=output, camera=camera, labels=labels, instances=instances, detections=detections,
        depth=backend.value, depth_weights=weights, depth_map=depth_map,
    )
    outcome, camera_used = depth_for_image(request)
    depth_map_out = outcome.depth_map
    if depth_map_out is None:
        values, valid = ground_plane_depth(camera_used)
        depth_map_out = DepthMap(values, valid, "ground")
    paths = write_depth_outputs(depth_map_out, output, image.stem)
    say(f"depth: {outcome.source} ({outcome.kind}); alignment: {outcome.alignment}")
    for path in paths.values():
        say(f"wrote {path}")


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("depth")(depth)
