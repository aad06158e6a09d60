"""``usdworld build``: one image to a world folder."""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator
from pathlib import Path
from typing import Optional

import typer

from usdworld.cli.choices import DepthBackendName, SegmentBackendName, Traffic, ViewsLayout


def build(
    image: Optional[Path] = typer.Argument(None, help="The photo (PNG or JPEG); omit it with --views."),
    output: Path = typer.Option(..., "--output", "-o", help="World folder to create (replaced if it holds a world; its edits are kept)."),
    labels: Optional[Path] = typer.Option(None, "--labels", help="Cityscapes *_gtFine_labelIds.png (8-bit)."),
    instances: Optional[Path] = typer.Option(None, "--instances", help="Cityscapes *_gtFine_instanceIds.png (16-bit)."),
    polygons: Optional[Path] = typer.Option(None, "--polygons", help="Cityscapes *_gtFine_polygons.json (instead of --labels)."),
    detections: Optional[Path] = typer.Option(None, "--detections", help="KITTI label_2 .txt or a detections .json."),
    camera: Optional[Path] = typer.Option(None, "--camera", help="Cityscapes camera JSON, KITTI calib .txt, plain camera JSON or INFO.json#CAM_FRONT (mmdetection3d info)."),
    ground_plane: Optional[Path] = typer.Option(None, "--ground-plane", help="KITTI planes file (road plane): roll, and a prior on height and pitch."),
    ground_points: Optional[Path] = typer.Option(None, "--ground-points", help="Manual pixel <-> ground pairs (JSON or CSV, >= 4)."),
    depth: DepthBackendName = typer.Option(DepthBackendName.ground, "--depth", help="Depth backend."),
    depth_weights: Optional[Path] = typer.Option(None, "--depth-weights", help="Weights file/folder of a network backend."),
    depth_map: Optional[Path] = typer.Option(None, "--depth-map", help="Dense metric depth for --depth file: .npy, 16-bit PNG (m*256) or .pfm."),
    segment: SegmentBackendName = typer.Option(
        SegmentBackendName.none, "--segment", help="Segmentation backend: labels from a model instead of --labels."
    ),
    segment_model: Optional[Path] = typer.Option(
        None, "--segment-model", help="Model folder of --segment hf (saved with save_pretrained; never downloaded)."
    ),
    library: Optional[Path] = typer.Option(
        None, "--library", envvar="USDWORLD_LIBRARY", help="User asset library layered over the built-in one."
    ),
    max_range: Optional[float] = typer.Option(
        None, "--max-range", help="Farthest ground distance meshed, metres (default: scene.max_range_m, 80; at most 1000)."
    ),
    traffic: Traffic = typer.Option(
        Traffic.right, "--traffic", help="The side traffic keeps to: which way vehicles face."
    ),
    infer_streets: bool = typer.Option(
        True,
        "--infer-streets/--no-infer-streets",
        help="With --detections and no labels: infer the road, sidewalks, buildings, trees and sky from the photo.",
    ),
    params: Optional[Path] = typer.Option(
        None, "--params", help="Parameters JSON {section: {field: value}} over the defaults (docs/parameters.md)."
    ),
    views: Optional[Path] = typer.Option(
        None,
        "--views",
        help="Several views, one world: a views manifest JSON, "
        "or with --layout nuscenes an mmdetection3d info JSON.",
    ),
    layout: Optional[ViewsLayout] = typer.Option(
        None, "--layout", help="What --views names (default: manifest)."
    ),
    sample: Optional[str] = typer.Option(
        None, "--sample", help="With --layout nuscenes: the sample's token (default: the first)."
    ),
    dataroot: Optional[Path] = typer.Option(
        None,
        "--dataroot",
        help="With --layout nuscenes, instead of --views: the official nuScenes dataset root "
        "(v1.0-*/ tables, samples/), read through nuscenes-devkit (extra: usdworld[nuscenes]).",
    ),
    jobs: Optional[int] = typer.Option(
        None,
        "--jobs",
        help="With --views: worker processes for the views (default: one per view, up to the CPUs).",
    ),
) -> None:
    """Build a layered USD world from one street image, or from several views of one rig (--views)."""
    from usdworld.cli import views_build
    from usdworld.cli.output import quiet
    from usdworld.cli.summary import print_build_summary
    from usdworld.errors import InputError
    from usdworld.io.parameters_file import read_parameters
    from usdworld.parameters import DEFAULT_PARAMETERS
    from usdworld.pipeline import BuildRequest
    from usdworld.pipeline import build as run_build

    per_view = {
        "image": image,
        "labels": labels,
        "instances": instances,
        "polygons": polygons,
        "detections": detections,
        "camera": camera,
        "ground_plane": ground_plane,
        "ground_points": ground_points,
        "depth_map": depth_map,
    }
    if dataroot is not None:
        if views is not None:
            raise InputError("--dataroot and --views: give one (--dataroot is a nuScenes dataset root)")
        if layout is not ViewsLayout.nuscenes:
            raise InputError("--dataroot reads the nuScenes dataset layout; add --layout nuscenes")
        views = dataroot
    views_build.check_options(views, per_view, any(v is not None for v in (layout, sample, jobs)))
    if views is not None:
        if segment is not SegmentBackendName.none or segment_model is not None:
            raise InputError("--segment: a views build takes each view's labels from --views; drop --segment")
        shared = {
            "depth": depth.value,
            "depth_weights": depth_weights,
            "library": library,
            "max_range_m": max_range,
            "traffic": traffic.value,
            "params": read_parameters(params) if params is not None else DEFAULT_PARAMETERS,
        }
        layout_name = (layout or ViewsLayout.manifest).value
        with _log_held_until_success():
            result = views_build.run(views, layout_name, sample, jobs, output, shared)
        if not quiet():
            print_build_summary(result.report, str(result.world))
        return
    request = BuildRequest(
        image=image,
        output=output,
        labels=labels,
        instances=instances,
        polygons=polygons,
        detections=detections,
        camera=camera,
        ground_plane=ground_plane,
        correspondences=ground_points,
        depth_map=depth_map,
        depth=depth.value,
        depth_weights=depth_weights,
        segment=segment.value,
        segment_model=segment_model,
        library=library,
        max_range_m=max_range,
        traffic=traffic.value,
        params=read_parameters(params) if params is not None else DEFAULT_PARAMETERS,
        infer_streets=infer_streets,
    )
    with _log_held_until_success():
        result = run_build(request)
    if quiet():
        return
    print_build_summary(result.report, str(result.world))
    if result.kept_edits:
        typer.echo("kept the existing edits layer (layers/edits.usda)")


class _Held(logging.Handler):
    def __init__(self) -> None:
        super().__init__()
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


@contextlib.contextmanager
def _log_held_until_success() -> Iterator[None]:
    """Hold the build's log lines; print them after success, drop them after an error.

    A reader's warning (an odd principal point, say) would otherwise come before an error
    that a later reader raises, and the error would not be one line. ``--debug`` logs as it goes.
    """
    root = logging.getLogger()
    if root.level <= logging.DEBUG:
        yield
        return
    handlers, held = root.handlers[:], _Held()
    root.handlers = [held]
    try:
        yield
    finally:
        root.handlers = handlers
    for record in held.records:  # reached only after success
        for handler in handlers:
            if record.levelno >= handler.level:
                handler.handle(record)


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("build")(build)
