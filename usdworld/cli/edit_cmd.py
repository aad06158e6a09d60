"""``usdworld edit WORLD ...``: non-destructive edits into the world's edits layer.

Every sub-command is one call of :class:`usdworld.authoring.edits.WorldEditor`. A refused
edit prints ``error: <op> <name> refused: <rule>: <why>; ...`` and exits 2 having written
nothing; ``--force`` applies it and records that it was forced. The library's refusals
(:class:`~usdworld.errors.EditRefused`) are worded here for command-line users, naming the
options (:func:`cli_message`).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Optional

import typer
from typer.core import TyperGroup

if TYPE_CHECKING:
    import click

    from usdworld.errors import EditRefused


class _EditGroup(TyperGroup):
    """The ``edit`` group, whose WORLD argument comes before the sub-command.

    ``usdworld edit move --help`` would otherwise read ``move`` as the world and show the
    group's help; there the sub-command's own help is shown (the world is not needed for it).
    """

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] in self.commands and any(a in ctx.help_option_names for a in args[1:]):
            args = ["WORLD", *args]  # a stand-in world: the sub-command prints its help and exits
        return super().parse_args(ctx, args)


edit_app = typer.Typer(
    cls=_EditGroup,
    no_args_is_help=True,
    help="Edit a world non-destructively: every edit goes to layers/edits.usda; the base stays untouched.",
)

FORCE = typer.Option(
    False, "--force", help="Apply the edit even when a permissibility rule refuses it (recorded)."
)


def _pair(text: str, option: str) -> tuple[float, float]:
    from usdworld.errors import InputError

    parts = text.split(",")
    try:
        x, y = (float(p) for p in parts)
    except ValueError:
        raise InputError(f"{option}: expected two numbers 'x,y' in metres, got '{text}'") from None
    return x, y


SURFACE_RULES = typer.Option(
    None,
    "--surface-rules",
    help="Your surface rule table (default $USDWORLD_SURFACE_RULES or the shipped one).",
)
REPLACEMENT_RULES = typer.Option(
    None,
    "--replacement-rules",
    help="Your replacement rule table (default $USDWORLD_REPLACEMENT_RULES or the shipped one).",
)
LIBRARY = typer.Option(
    None, "--library", help="User asset library for classes the world has no asset for yet."
)


def _editor(
    ctx: typer.Context,
    surface_rules: Optional[Path] = None,
    replacement_rules: Optional[Path] = None,
    library: Optional[Path] = None,
):  # -> WorldEditor (imported lazily)
    """The editor of the world argument.

    The world's layers are parsed on a thread (:class:`~usdworld.authoring.stages.LayerPrefetch`)
    while the editor's modules (pxr.Usd, numpy, the rules) are imported: the prefetch needs
    only pxr.Sdf, so it starts before pxr.Usd is imported. The editor's stage then finds them
    parsed.
    """
    from usdworld.authoring.stages import prefetch_world_layers

    prefetch = prefetch_world_layers(ctx.obj)
    try:
        from usdworld.authoring.edits import WorldEditor
    finally:
        held = prefetch.wait() if prefetch is not None else ()
    editor = WorldEditor(
        ctx.obj, surface_rules=surface_rules, replacement_rules=replacement_rules, library=library
    )
    del held  # the editor's stage holds them now
    return editor


def _done(result) -> None:  # EditResult
    from usdworld.cli.output import say

    say(f"{result.message} [step {result.step}]")


#: The option that gives each argument an :class:`EditRefused` names in ``field``.
_OPTIONS = {"to": "--to", "by": "--by", "yaw_deg": "--yaw-deg", "variant": "--variant", "color": "--color"}


def cli_message(exc: EditRefused, world: Path, edits_path: Path) -> str:
    """A refusal worded for command-line users: the options to change, how to look things up.

    Args:
        exc: the library's refusal.
        world: the WORLD argument (root layer or folder).
        edits_path: the world's edits layer.
    """
    from usdworld.errors import RefusalReason
    from usdworld.world_files import ROOT_LAYER

    reason, name = exc.reason, exc.subject
    if reason is RefusalReason.NOT_PERMISSIBLE:
        return f"{exc.message} (--force applies it anyway)"
    if reason is RefusalReason.UNKNOWN_OBJECT and not exc.field:  # a well-formed name
        root = world / ROOT_LAYER if world.is_dir() else world
        return f"no object '{name}' in {root}; `usdworld edit {root} list` shows the names"
    if reason is RefusalReason.DELETED_OBJECT:
        return f"{name} is deleted; `reset {name}` or `undo` brings it back"
    if reason is RefusalReason.UNKNOWN_VARIANT:
        return f"--variant: {exc.message}"
    if reason is RefusalReason.SAME_CLASS:
        return (
            f"replace {name}: it is already a {exc.value}; "
            f"pass --variant (one of {', '.join(exc.choices) or 'none'})"
        )
    if reason is RefusalReason.BAD_VALUE:
        if exc.op == "move" and exc.value is None:
            return "move: give exactly one of --to x,y or --by dx,dy"
        if exc.field in ("to", "by"):
            return f"move: --{exc.field} must be finite, got {exc.value}"
        if exc.field == "yaw_deg":
            return f"--yaw-deg: must be finite, got {exc.value}"
        if exc.field == "color":
            return f"--color: expected a hex colour like '#c03030', got '{exc.value}'"
        if exc.field == "steps":
            return f"undo: N must be >= 1, got {exc.value}"
    if reason in (RefusalReason.NOTHING_TO_UNDO, RefusalReason.NOTHING_TO_RESET):
        return f"{exc.message} in {edits_path}"
    return exc.message


@contextlib.contextmanager
def _worded(ctx: typer.Context, editor) -> Iterator[None]:  # editor: WorldEditor
    """Re-raise the library's refusals with their command-line wording."""
    from usdworld.errors import EditRefused

    try:
        yield
    except EditRefused as exc:
        raise EditRefused(
            exc.reason,
            cli_message(exc, Path(ctx.obj), editor.edits_path),
            op=exc.op,
            subject=exc.subject,
            field=exc.field,
            value=exc.value,
            choices=exc.choices,
            violations=exc.violations,
        ) from exc


@edit_app.callback()
def _world(
    ctx: typer.Context,
    world: Path = typer.Argument(..., help="The world's root layer (world.usda) or its folder."),
) -> None:
    ctx.obj = world


@edit_app.command("list")
def list_objects(ctx: typer.Context) -> None:
    """List the objects (by class, then name): class, variant, position, yaw, scale, surface, edit status."""
    import numpy as np

    from usdworld.layout.permissible import surface_at

    editor = _editor(ctx)
    objects = sorted(editor.objects(), key=lambda o: (o.class_name, o.name))
    surfaces, _ = surface_at(
        np.array([o.position_world[:2] for o in objects]).reshape(-1, 2), editor.ground()
    )
    typer.echo(
        f"{'name':<18} {'class':<13} {'variant':<12} {'x m':>8} {'y m':>8} {'yaw deg':>8} "
        f"{'scale':>6}  {'surface':<9} status"
    )
    for o, surface in zip(objects, surfaces):
        status = o.status + (f" {o.color}" if o.color else "")
        typer.echo(
            f"{o.name:<18} {o.class_name:<13} {o.variant or '-':<12} "
            f"{o.position_world[0]:8.2f} {o.position_world[1]:8.2f} "
            f"{o.yaw_deg:8.1f} {o.scale:6.2f}  {surface:<9} {status}"
        )
    typer.echo(f"{len(objects)} object(s), {sum(not o.active for o in objects)} deleted")


@edit_app.command("move")
def move(
    ctx: typer.Context,
    name: str = typer.Argument(..., help="Object name (car_0003) or prim path."),
    to: Optional[str] = typer.Option(None, "--to", help="New ground position 'x,y' in metres."),
    by: Optional[str] = typer.Option(None, "--by", help="Displacement 'dx,dy' in metres."),
    force: bool = FORCE,
    surface_rules: Optional[Path] = SURFACE_RULES,
) -> None:
    """Move an object on the ground (its height follows the surface)."""
    editor = _editor(ctx, surface_rules)
    with _worded(ctx, editor):
        _done(
            editor.move(
                name, to=_pair(to, "--to") if to else None, by=_pair(by, "--by") if by else None, force=force
            )
        )


@edit_app.command("rotate")
def rotate(
    ctx: typer.Context,
    name: str = typer.Argument(..., help="Object name or prim path."),
    yaw_deg: float = typer.Option(..., "--yaw-deg", help="New yaw about Z, degrees (0 = facing +X)."),
    force: bool = FORCE,
) -> None:
    """Set an object's yaw."""
    editor = _editor(ctx)
    with _worded(ctx, editor):
        _done(editor.rotate(name, yaw_deg, force=force))


@edit_app.command("delete")
def delete(ctx: typer.Context, name: str = typer.Argument(..., help="Object name or prim path.")) -> None:
    """Deactivate an object (active = false; undo or reset brings it back)."""
    editor = _editor(ctx)
    with _worded(ctx, editor):
        _done(editor.delete(name))


@edit_app.command("add")
def add(
    ctx: typer.Context,
    class_name: str = typer.Argument(
        ..., metavar="CLASS", help="Class of the new object (car, person, tree ...)."
    ),
    at: str = typer.Option(..., "--at", help="Ground position 'x,y' in metres."),
    variant: Optional[str] = typer.Option(
        None, "--variant", help="Model variant (default: the asset's default)."
    ),
    yaw_deg: Optional[float] = typer.Option(
        None, "--yaw-deg", help="Yaw in degrees (default: like its neighbours)."
    ),
    force: bool = FORCE,
    surface_rules: Optional[Path] = SURFACE_RULES,
    library: Optional[Path] = LIBRARY,
) -> None:
    """Add an object, scaled like its neighbours of the same class."""
    editor = _editor(ctx, surface_rules, library=library)
    with _worded(ctx, editor):
        _done(editor.add(class_name, _pair(at, "--at"), variant=variant, yaw_deg=yaw_deg, force=force))


@edit_app.command("replace")
def replace(
    ctx: typer.Context,
    name: str = typer.Argument(..., help="Object name or prim path."),
    with_class: str = typer.Option(
        ..., "--with", help="Class of the replacement (its own class to switch variant)."
    ),
    variant: Optional[str] = typer.Option(None, "--variant", help="Model variant of the replacement."),
    force: bool = FORCE,
    surface_rules: Optional[Path] = SURFACE_RULES,
    replacement_rules: Optional[Path] = REPLACEMENT_RULES,
    library: Optional[Path] = LIBRARY,
) -> None:
    """Replace an object by another class or another variant."""
    editor = _editor(ctx, surface_rules, replacement_rules, library)
    with _worded(ctx, editor):
        _done(editor.replace(name, with_class, variant=variant, force=force))


@edit_app.command("restyle")
def restyle(
    ctx: typer.Context,
    name: str = typer.Argument(..., help="Object name or prim path."),
    color: str = typer.Option(..., "--color", help="sRGB hex colour, e.g. '#c03030'."),
) -> None:
    """Recolour an object's paint (material diffuseColor and displayColor)."""
    editor = _editor(ctx)
    with _worded(ctx, editor):
        _done(editor.restyle(name, color))


@edit_app.command("undo")
def undo(
    ctx: typer.Context, steps: int = typer.Argument(1, metavar="[N]", help="How many edits to undo.")
) -> None:
    """Undo the last N edits (the edits layer returns to exactly what it was)."""
    editor = _editor(ctx)
    with _worded(ctx, editor):
        undone = editor.undo(steps)
    from usdworld.cli.output import say

    for entry in undone:
        say(f"undid step {entry.step}: {entry.op} {entry.args.get('name', '')}".rstrip())


@edit_app.command("history")
def history(ctx: typer.Context) -> None:
    """List the recorded edits, oldest first."""
    entries = _editor(ctx).history()
    for e in entries:
        args = " ".join(f"{k}={v}" for k, v in sorted(e.args.items()) if k != "name" and v is not None)
        line = f"{e.step:4d}  {e.time or '-':<29} {e.op:<8} {e.args.get('name', ''):<16} {args}".rstrip()
        if e.forced:
            line += f"  FORCED ({'; '.join(e.violations)})"
        typer.echo(line)
    typer.echo(f"{len(entries)} edit(s)")


@edit_app.command("reset")
def reset(
    ctx: typer.Context, name: str = typer.Argument(..., help="Object name or prim path."), force: bool = FORCE
) -> None:
    """Drop every edit of one object (an added object disappears)."""
    editor = _editor(ctx)
    with _worded(ctx, editor):
        _done(editor.reset(name, force=force))


@edit_app.command("check")
def check(ctx: typer.Context) -> None:
    """Report edits whose target no longer exists (e.g. after a rebuild); exit 1 if any."""
    from usdworld.errors import ValidationFailed

    editor = _editor(ctx)
    orphans = editor.check()
    for o in orphans:
        steps = ", ".join(str(s) for s in o.steps) or "none recorded"
        fix = f"`reset {o.object_name}` drops it" if o.object_name else "remove it from the edits layer"
        typer.echo(f"orphaned edit: {o.path} (steps {steps}): no such prim in the world; {fix}")
    if orphans:
        raise ValidationFailed(
            f"{len(orphans)} edit(s) in {editor.edits_path} target prims that no longer exist"
        )
    typer.echo(f"{editor.edits_path}: every edit targets an existing prim")


def register(app: typer.Typer) -> None:
    """Add the command group to the app."""
    app.add_typer(edit_app, name="edit")
