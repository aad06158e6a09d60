"""What a command prints as its result, and ``usdworld -q``.

``-q`` means only warnings and errors: commands that write files (build, depth, batch,
render, flythrough, synth, export, vary and the edits) print no results, file lists or
progress under it. Commands whose result is what they print (info, edit list / history /
check, assets list, evaluate, validate) print it anyway, and so does ``serve`` its address.
"""

from __future__ import annotations

import logging

import typer


def quiet() -> bool:
    """True under ``usdworld -q``: the root logger passes only warnings and errors."""
    return logging.getLogger().getEffectiveLevel() > logging.INFO


def say(message: str) -> None:
    """Print one line of a command's results on stdout, unless ``-q`` was given."""
    if not quiet():
        typer.echo(message)
