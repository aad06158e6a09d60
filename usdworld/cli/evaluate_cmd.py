"""``usdworld evaluate``: layout IoU, photo SSIM, colour error and 3D errors of a world against its inputs."""

from __future__ import annotations

from pathlib import Path

import typer

from usdworld.cli.ground_truth_options import CALIB, GT, NUSCENES_CAMERA


def _fmt(value: object, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def evaluate(
    world: Path = typer.Argument(..., help="A world's world.usda (or its folder)."),
    labels: Path | None = typer.Option(
        None,
        "--labels",
        help="Cityscapes *_gtFine_labelIds.png (default: the world's labels input, found next to it).",
    ),
    gt: Path | None = GT,
    photo: Path | None = typer.Option(
        None, "--photo", help="The source photo for SSIM (default: found next to the world)."
    ),
    calib: Path | None = CALIB,
    nuscenes_camera: str = NUSCENES_CAMERA,
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object (last)."),
) -> None:
    """Render the world from its source camera and compare it with its labels, photo and 3D ground truth."""
    import json
    import logging

    from usdworld.authoring.inspect import open_world
    from usdworld.demo import demo_dir
    from usdworld.evaluation import (
        evaluate_world,
        find_beside_world,
        read_ground_truth,
        read_label_ids,
        world_input_names,
    )
    from usdworld.render.outputs import read_photo, world_source_image

    log = logging.getLogger("usdworld.evaluate")
    stage = open_world(world)
    root = Path(stage.GetRootLayer().realPath)
    if labels is None:
        name = world_input_names(stage).get("labels", "")
        labels = find_beside_world(root, name, [demo_dir()])
        if labels is None:
            log.info(
                "no labels: %s; pass --labels for the layout IoU",
                f"{name} not found next to the world" if name else "the world was built without labels",
            )
    if photo is None:
        photo = find_beside_world(root, world_source_image(stage), [demo_dir()])
    truth = read_ground_truth(gt, calib, nuscenes_camera) if gt is not None else None
    label_ids = read_label_ids(labels) if labels is not None else None
    photo_rgb = read_photo(photo) if photo is not None else None
    result = evaluate_world(stage, labels=label_ids, photo=photo_rgb, gt=truth)
    for note in result.scene_warnings:
        log.warning("%s looks like the ground truth of another scene: %s", gt.name if gt else "", note)
    doc = result.to_json()
    doc["world"] = str(root)
    doc["labels"] = str(labels) if labels is not None else None
    doc["photo"] = str(photo) if photo is not None else None
    if as_json:
        typer.echo(json.dumps(doc, sort_keys=True))
        return
    from rich.console import Console
    from rich.table import Table

    console = Console()
    console.print(f"[bold]{root}[/] rendered at {result.size[0]}x{result.size[1]}")
    if label_ids is not None and labels is not None:
        table = Table(
            "class",
            "IoU",
            "rendered & labelled px",
            "rendered | labelled px",
            title=f"layout vs {labels.name}",
        )
        for name, iou in sorted(result.per_class_iou.items()):  # by class name, as every table
            table.add_row(name, _fmt(iou), str(result.intersections[name]), str(result.unions[name]))
        console.print(table)
        console.print(f"mIoU {_fmt(result.miou)} over {len(result.classes)} classes the world places")
    if result.ssim is not None:
        console.print(f"SSIM photo vs render: {result.ssim:.3f}")
    if result.colour is not None:
        c = result.colour
        console.print(
            f"colour error per object, photo vs render (median over {c['objects']}): "
            f"CIE76 {_fmt(c['median_delta_e76'], 1)}, CIEDE2000 {_fmt(c['median_delta_e2000'], 1)}"
        )
    if result.objects is not None and result.ground_truth is not None:
        o = result.objects
        table = Table(
            "class",
            "placed/total",
            "median pos. m",
            "median depth m",
            "median yaw deg",
            "median size m",
            title=f"3D errors vs {result.ground_truth['file']} ({result.ground_truth['kind']})",
        )
        for name, s in list(o["per_class"].items()) + [("things", o["things"]), ("all", o)]:
            table.add_row(
                name,
                f"{s['placed']}/{s['total']}",
                _fmt(s["median_position_error_m"], 2),
                _fmt(s["median_depth_error_m"], 2),
                _fmt(s["median_yaw_error_deg"], 1),
                _fmt(s["median_size_error_m"], 2),
            )
        console.print(table)
        how = "instance ids, then distance" if o["matched_by_instance_id"] else "distance"
        console.print(f"matched by {how}; {o['unmatched_placed']} placed object(s) match no ground truth")


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("evaluate")(evaluate)
