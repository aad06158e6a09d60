"""``usdworld serve WORLD``: edit a world with the mouse in a local web page.

Prints the page's URL with a per-session token and serves until Ctrl-C. Every edit goes
through the same engine, lock, rules and edits layer as ``usdworld edit``.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import typer

from usdworld.cli.edit_cmd import LIBRARY, REPLACEMENT_RULES, SURFACE_RULES

WORLD = typer.Argument(..., help="The world's root layer (world.usda) or its folder.")
PORT = typer.Option(8765, "--port", help="TCP port; 0 picks a free one.")
HOST = typer.Option(
    "127.0.0.1",
    "--host",
    help="Address to listen on. The default is reachable from this machine only; "
    "0.0.0.0 exposes the editor to the network (anyone with the URL can edit).",
)
PHOTO = typer.Option(
    None, "--photo", help="The source photo (default: its file in the world folder, if there)."
)


def serve(
    world: Path = WORLD,
    port: int = PORT,
    host: str = HOST,
    photo: Path | None = PHOTO,
    surface_rules: Path | None = SURFACE_RULES,
    replacement_rules: Path | None = REPLACEMENT_RULES,
    library: Path | None = LIBRARY,
) -> None:
    """Open a world in the browser: 3D view from the source camera, object list, mouse edits."""
    try:
        import starlette  # noqa: F401
        import uvicorn  # noqa: F401
    except ImportError as exc:
        from usdworld.errors import InputError

        raise InputError(
            f"usdworld serve needs starlette and uvicorn ({exc.name} is missing): pip install 'usdworld[serve]'"
        ) from None
    from usdworld.serve.app import LOOPBACK_HOSTS, create_app, new_token
    from usdworld.serve.server import bind, serve_forever
    from usdworld.serve.session import WorldSession

    session = WorldSession(
        world, photo=photo, surface_rules=surface_rules, replacement_rules=replacement_rules, library=library
    )
    try:
        listener = bind(host, port)
    except BaseException:
        session.close()
        raise
    token = new_token()
    app = create_app(
        session, token, allowed_hosts=LOOPBACK_HOSTS if listener.loopback else None, on_shutdown=session.close
    )
    count = len(session.snapshot()["objects"])
    typer.echo(f"usdworld serve: {session.root} ({count} objects)")
    if session.photo is None:
        typer.echo("no source photo found: pass --photo to show it")
    if not listener.loopback:
        typer.echo(
            f"warning: listening on {listener.host}, reachable from other machines; anyone with the URL can edit",
            err=True,
        )
    typer.echo(f"open {listener.url(token)}")
    typer.echo("press Ctrl-C to stop")
    sys.stdout.flush()
    serve_forever(app, listener, access_log=logging.getLogger().isEnabledFor(logging.DEBUG))
    typer.echo("usdworld serve: stopped")


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("serve")(serve)
