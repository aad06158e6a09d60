"""``usdworld export``: a world as usdz, usdc, flat usda or glb, validated."""

from __future__ import annotations

from pathlib import Path

import typer

from usdworld.cli.choices import ExportFormat


def export(
    world: Path = typer.Argument(..., help="The world folder or its world.usda."),
    fmt: ExportFormat = typer.Option(..., "--format", "-f", help="The file format."),
    output: Path = typer.Option(..., "--output", "-o", help="File to write (.usdz/.usdc/.usda/.glb)."),
    bake_edits: bool = typer.Option(
        False, "--bake-edits", help="usdz: merge the edits and base layers into one root layer (usdc/usda-flat always do)."
    ),
    flatten: bool = typer.Option(
        False,
        "--flatten",
        help="usdz/usdc: compose everything (references, variants) into one self-contained layer, e.g. for three.js "
        "(usda-flat always is).",
    ),
    drop_inactive: bool = typer.Option(
        False, "--drop-inactive", help="Remove deleted objects instead of keeping them deactivated."
    ),
    no_validate: bool = typer.Option(False, "--no-validate", help="Skip validating the written file."),
    no_omni: bool = typer.Option(False, "--no-omni", help="Validate USD without omni-asset-validator."),
) -> None:
    """Export a world for other tools and validate the result (exit 1 when the validator finds errors)."""
    from usdworld.cli.output import say
    from usdworld.export import export_world
    from usdworld.export.usd_formats import assets_folder

    result = export_world(
        world,
        fmt.value,
        output,
        bake_edits=bake_edits,
        flatten=flatten,
        drop_inactive=drop_inactive,
        validate=not no_validate,
        omni=not no_omni,
    )
    extra = len(result.files) - 1
    say(f"wrote {result.output}" + (f" (+{extra} file(s) in {assets_folder(result.output).name}/)" if extra else ""))
    check = result.check
    if check.skipped:
        say(f"{check.checker}: not run ({check.skipped})")
    else:
        trusted = check.details.get("trusted_assets") if isinstance(check.details, dict) else None
        vouched = f"; {len(trusted)} asset(s) not validated again (their cards record it)" if trusted else ""
        say(f"{check.checker}: 0 errors, {len(check.warnings)} warning(s){vouched}")


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("export")(export)
