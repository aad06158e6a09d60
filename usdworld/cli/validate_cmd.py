"""``usdworld validate``: every UsdValidation validator and omni-asset-validator."""

from __future__ import annotations

import json
from pathlib import Path

import typer


def validate(
    world: Path = typer.Argument(..., help="A .usda/.usdc/.usdz file, or a world folder."),
    no_omni: bool = typer.Option(False, "--no-omni", help="Skip omni-asset-validator."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Validate a world (root layer and its assets); exit 1 on any error."""
    from usdworld.authoring.validate import errors_only, omni_validator_available, validate_file
    from usdworld.errors import ValidationFailed

    root = world / "world.usda" if world.is_dir() else world
    files = [root]
    assets = root.parent / "assets"
    if root.name == "world.usda" and assets.is_dir():
        files.extend(sorted(assets.glob("*.usda")))  # asset roots; their geometry sublayers are .usdc
    report = {}
    total_errors = 0
    for path in files:
        issues = validate_file(path, omni=not no_omni)
        errors = errors_only(issues)
        total_errors += len(errors)
        report[str(path)] = [vars(i) for i in issues]
        if not as_json:
            status = "ok" if not errors else f"{len(errors)} error(s)"
            warnings = len(issues) - len(errors)
            typer.echo(f"{path}: {status}" + (f", {warnings} warning(s)" if warnings else ""))
            for issue in issues:
                typer.echo(f"  {issue.severity} [{issue.validator}:{issue.rule}] {issue.at} {issue.message}")
    validators = "UsdValidation" + (" + omni-asset-validator" if (not no_omni and omni_validator_available()) else "")
    if as_json:
        typer.echo(json.dumps({"validators": validators, "errors": total_errors, "files": report}, indent=2))
    else:
        typer.echo(f"{len(files)} file(s) checked with {validators}: {total_errors} error(s)")
    if total_errors:
        raise ValidationFailed(f"{total_errors} validation error(s) in {root}")


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("validate")(validate)
