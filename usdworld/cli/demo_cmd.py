"""``usdworld demo``: build the bundled synthetic Cityscapes-format sample."""

from __future__ import annotations

from pathlib import Path

import typer


def demo(
    output: Path = typer.Option(Path("demo_world"), "--output", "-o", help="World folder to create."),
) -> None:
    """Build the bundled demo scene (made by usdworld itself, free to share)."""
    from usdworld.cli.output import quiet
    from usdworld.cli.summary import print_build_summary
    from usdworld.demo import demo_request
    from usdworld.pipeline import build as run_build

    result = run_build(demo_request(output))
    if not quiet():
        print_build_summary(result.report, str(result.world))


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("demo")(demo)
