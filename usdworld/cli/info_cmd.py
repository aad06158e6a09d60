"""``usdworld info``: what a world holds."""

from __future__ import annotations

import json
from pathlib import Path

import typer


def info(
    world: Path = typer.Argument(..., help="A world's world.usda (or its folder)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Summarise a world: objects per class, camera, DLT and edits."""
    from rich.console import Console
    from rich.table import Table

    from usdworld.authoring.inspect import open_world, world_summary

    summary = world_summary(open_world(world))
    if as_json:
        typer.echo(json.dumps(summary, indent=2, sort_keys=True, default=str))
        return
    console = Console()
    console.print(f"[bold]{summary['root']}[/] from {summary['source_image']} (usdworld {summary['usdworld_version']})")
    console.print(f"layers: {' -> '.join(summary['layers'])}")
    table = Table("class", "objects")
    for name, count in summary["classes"].items():
        table.add_row(name, str(count))
    console.print(table)
    console.print(f"{summary['objects_active']} active objects, {summary['objects_inactive']} deleted (inactive)")
    estimated = ", ".join(summary["camera_estimated"]) or "nothing"
    console.print(
        f"camera: height {summary['camera_height_m']:.2f} m, pitch {summary['camera_pitch_deg']:.2f} deg; estimated: {estimated}"
    )
    console.print(f"DLT ({summary['dlt_source']}): RMS {summary['dlt_rms_px']:.3g} px; edits touch {summary['edited_prims']} prims")


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("info")(info)
