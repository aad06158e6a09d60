"""``usdworld vary``: N variations of a world by random permissible edits, reproducible from a seed."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer


def vary(
    world: Path = typer.Argument(..., help="The world's root layer (world.usda) or its folder."),
    n: int = typer.Option(10, "-n", "--count", help="Number of variations."),
    seed: int = typer.Option(0, "--seed", help="Random seed; the same seed writes the same files."),
    output: Path = typer.Option(
        ..., "--output", "-o", help="Folder for variation_NNNN.usda and their edits layers."
    ),
    surface_rules: Optional[Path] = typer.Option(None, "--surface-rules", help="Your surface rule table."),
    replacement_rules: Optional[Path] = typer.Option(
        None, "--replacement-rules", help="Your replacement rule table."
    ),
    library: Optional[Path] = typer.Option(None, "--library", help="User asset library."),
    validate: bool = typer.Option(False, "--validate", help="Validate every variation; exit 1 on any error."),
) -> None:
    """Write N scene variations sharing the world's base, each with its own edits layer."""
    from usdworld.authoring.variations import make_variations
    from usdworld.cli.output import say

    variations = make_variations(
        world,
        n,
        seed,
        output,
        surface_rules=surface_rules,
        replacement_rules=replacement_rules,
        library=library,
    )
    errors = 0
    for v in variations:
        say(f"{v.root}: {len(v.applied)} edit(s)")
        for line in v.applied:
            say(f"  {line}")
        if validate:
            from usdworld.authoring.validate import errors_only, validate_file

            found = errors_only(validate_file(v.root))
            errors += len(found)
            for issue in found:
                typer.echo(f"  error [{issue.validator}:{issue.rule}] {issue.at} {issue.message}")
    say(f"wrote {len(variations)} variation(s) to {output}")
    if errors:
        from usdworld.errors import ValidationFailed

        raise ValidationFailed(f"{errors} validation error(s) in the variations in {output}")


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("vary")(vary)
