"""``usdworld assets``: list the asset libraries, add a user's model as a class asset."""

from __future__ import annotations

import json
from pathlib import Path

import typer

assets_app = typer.Typer(no_args_is_help=True, help="List the asset libraries; add your own models.")

LIBRARY_HELP = "User asset library folder (default: $USDWORLD_LIBRARY)."


@assets_app.command("add")
def add(
    class_name: str = typer.Argument(..., metavar="CLASS", help="The class the model is for (see: usdworld assets list)."),
    file: Path = typer.Argument(..., help="OBJ, glTF/GLB, PLY or USD file."),
    variant: str | None = typer.Option(None, "--variant", help="Variant name (default: the file name)."),
    up: str | None = typer.Option(None, "--up", help="The file's up axis: y or z (default: y; USD: its upAxis)."),
    unit_scale: float | None = typer.Option(
        None, "--unit-scale", help="Metres per file unit, e.g. 0.01 for cm (default: 1; USD: its metersPerUnit)."
    ),
    front: str = typer.Option("+x", "--front", help="The file axis the model faces: +x -x +y -y +z -z."),
    library: Path | None = typer.Option(None, "--library", envvar="USDWORLD_LIBRARY", help=LIBRARY_HELP),
    replace: bool = typer.Option(
        False, "--replace", help="Hide the built-in variants of CLASS: only your variants are used."
    ),
    overwrite: bool = typer.Option(False, "--overwrite", help="Overwrite an existing variant of the same name."),
    default: bool = typer.Option(False, "--default", help="Make this variant the class's default."),
) -> None:
    """Import a model as a variant of CLASS in your asset library (validated before it is added).

    The variant is added beside the built-in variants of CLASS (a build chooses among them
    all); --replace hides the built-in ones.
    """
    from usdworld.authoring.user_assets import LIBRARY_ENV, add_asset
    from usdworld.errors import InputError

    if library is None:
        raise InputError(f"no user asset library: pass --library DIR or set {LIBRARY_ENV}")
    added = add_asset(
        library,
        class_name,
        file,
        variant=variant,
        up=up,
        unit_scale=unit_scale,
        front=front,
        replace=replace,
        overwrite=overwrite,
        make_default=default,
    )
    l, w, h = added.size
    typer.echo(f"added {class_name}/{added.variant} ({l:.2f} x {w:.2f} x {h:.2f} m) to {added.path}")
    for note in added.notes:
        typer.echo(f"  note: {note}")
    typer.echo(f"{class_name} variants: {', '.join(added.variants)} (default {added.default_variant})")


@assets_app.command("list")
def list_(
    library: Path | None = typer.Option(None, "--library", envvar="USDWORLD_LIBRARY", help=LIBRARY_HELP),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON array."),
) -> None:
    """List the class assets of your library and of the built-in one."""
    from usdworld.authoring.user_assets import list_assets

    entries = list_assets(library)
    if as_json:
        rows = [
            {
                "class": e.class_name,
                "library": e.library,
                "path": str(e.path),
                "variants": list(e.variants),
                "default": e.default_variant,
                "active": e.active,
                "builtin_variants": list(e.builtin_variants),
            }
            for e in entries
        ]
        typer.echo(json.dumps(rows, indent=2))
        return
    width = max([len("class")] + [len(e.class_name) for e in entries])
    typer.echo(f"{'class'.ljust(width)}  {'library':8}  {'default':14}  variants")
    kept_beside = {e.class_name for e in entries if e.library == "user" and e.builtin_variants}
    for e in entries:
        if e.library == "user":
            own = [v for v in e.variants if v not in e.builtin_variants]
            shown = ", ".join(own) + (f"; built-in: {', '.join(e.builtin_variants)}" if e.builtin_variants else "")
            status = ""
        else:
            shown = ", ".join(e.variants)
            if e.active:
                status = ""
            elif e.class_name in kept_beside:
                status = "  (in the user asset, beside your variants)"
            else:
                status = "  (hidden by the user library: added with --replace)"
        typer.echo(f"{e.class_name.ljust(width)}  {e.library:8}  {e.default_variant:14}  {shown}{status}")
    where = f"user library: {library}" if library is not None else "no user library (--library or $USDWORLD_LIBRARY)"
    typer.echo(where)


def register(app: typer.Typer) -> None:
    """Add the command group to the app."""
    app.add_typer(assets_app, name="assets")
