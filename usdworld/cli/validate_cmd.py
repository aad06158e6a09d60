"""``usdworld validate``: every UsdValidation validator and omni-asset-validator.

The output is short: first the files the world needs that are missing or do not open (the
usual cause of everything after), then one line per rule with its count and a first
example, then the total. ``--verbose`` lists every finding under its file; ``--json`` gives
them all as one object.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

import typer

if TYPE_CHECKING:
    from usdworld.authoring.validate import ValidationIssue

#: Characters of a rule's example message shown in the short output.
EXAMPLE_CHARS = 100


def _shown(path: Path | str, base: Path) -> str:
    """A path relative to the world's folder when it lies inside it."""
    try:
        return str(Path(path).resolve().relative_to(base.resolve()))
    except ValueError:
        return str(path)


def _short(text: str) -> str:
    text = " ".join(text.split())
    return text if len(text) <= EXAMPLE_CHARS else text[: EXAMPLE_CHARS - 3] + "..."


def _rule_lines(found: list[tuple[Path, ValidationIssue]], base: Path) -> list[str]:
    """One line per (severity, rule): count, files it fired in, and the first finding."""
    counts = Counter((i.severity, f"{i.validator}:{i.rule}") for _, i in found)
    first: dict[tuple[str, str], tuple[Path, ValidationIssue]] = {}
    files: dict[tuple[str, str], set[str]] = {}
    for path, issue in found:
        key = (issue.severity, f"{issue.validator}:{issue.rule}")
        first.setdefault(key, (path, issue))
        files.setdefault(key, set()).add(_shown(path, base))
    order = sorted(counts, key=lambda k: (k[0] != "error", -counts[k], k[1]))
    width = max((len(k[1]) for k in order), default=0)
    lines = []
    for key in order:
        path, issue = first[key]
        where = ", ".join(sorted(files[key])) if len(files[key]) <= 2 else f"{len(files[key])} files"
        at = f" {issue.at}" if issue.at else ""
        lines.append(
            f"  {key[0]:7} {counts[key]:5d}  {key[1].ljust(width)}  {_short(issue.message)}  [{where}{at}]"
        )
    return lines


def validate(
    world: Path = typer.Argument(..., help="A .usda/.usdc/.usdz file, or a world folder."),
    no_omni: bool = typer.Option(False, "--no-omni", help="Skip omni-asset-validator."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="List every finding, not one line per rule."),
) -> None:
    """Validate a world (root layer and its assets); exit 1 on any error."""
    from usdworld.authoring.validate import (
        errors_only,
        file_problems,
        omni_validator_available,
        validate_file,
    )
    from usdworld.errors import ValidationFailed

    root = world / "world.usda" if world.is_dir() else world
    base = root.parent
    files = [root]
    assets = root.parent / "assets"
    if root.name == "world.usda" and assets.is_dir():
        files.extend(sorted(assets.glob("*.usda")))  # asset roots; their geometry sublayers are .usdc
    problems = file_problems(root) if root.is_file() else []
    found: list[tuple[Path, ValidationIssue]] = []
    for path in files:
        found.extend((path, issue) for issue in validate_file(path, omni=not no_omni))
    total_errors = len(errors_only([i for _, i in found])) + len(problems)
    validators = "UsdValidation" + (
        " + omni-asset-validator" if (not no_omni and omni_validator_available()) else ""
    )
    if as_json:
        report: dict[str, list[dict[str, str]]] = {str(p): [] for p in files}
        for path, issue in found:
            report[str(path)].append(vars(issue))
        typer.echo(
            json.dumps(
                {
                    "validators": validators,
                    "errors": total_errors,
                    "file_problems": [vars(p) for p in problems],
                    "files": report,
                },
                indent=2,
            )
        )
    else:
        for p in problems:
            by = f" (needed by {_shown(p.needed_by, base)})" if p.needed_by else ""
            reason = f": {p.reason}" if p.reason else ""
            typer.echo(f"{p.kind} file: {_shown(p.path, base)}{by}{reason}")
        if verbose:
            for path in files:
                issues = [i for f, i in found if f == path]
                errors = len(errors_only(issues))
                typer.echo(f"{path}: {errors} error(s), {len(issues) - errors} warning(s)")
                for issue in issues:
                    typer.echo(
                        f"  {issue.severity} [{issue.validator}:{issue.rule}] {issue.at} {_one_line(issue.message)}"
                    )
        elif found:
            typer.echo("findings by rule (severity, count, rule, first message [files, where]):")
            for line in _rule_lines(found, base):
                typer.echo(line)
        warnings = len(found) - len(errors_only([i for _, i in found]))
        more = "" if verbose or not found else "; --verbose lists every finding"
        typer.echo(
            f"{len(files)} file(s) checked with {validators}: {total_errors} error(s)"
            + (f", {warnings} warning(s)" if warnings else "")
            + more
        )
    if total_errors:
        raise ValidationFailed(f"{total_errors} validation error(s) in {root}")


def _one_line(text: str) -> str:
    return " ".join(text.split())


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("validate")(validate)
