"""What a command prints as its result, and ``usdworld -q``.

``-q`` means only warnings and errors: commands that write files (build, depth, batch,
render, flythrough, synth, export, vary, report and the edits) print no results, file lists or
progress under it. Commands whose result is what they print (info, edit list / history /
check, assets list, evaluate, validate) print it anyway, and so does ``serve`` its address.
"""

from __future__ import annotations

import logging

import typer

#: The ``usdworld`` command's own ``--quiet`` for the run in progress; None outside a run.
_quiet_option: bool | None = None


def set_quiet(flag: bool | None) -> None:
    """Record the run's ``--quiet`` (the root callback does); None when the run ends."""
    global _quiet_option
    _quiet_option = flag


def quiet() -> bool:
    """True under ``usdworld -q``.

    Read from the ``usdworld`` command's own ``--quiet`` option (:func:`set_quiet`), not from
    the root logger's level, which a library may change while a command runs (Dask's
    LocalCluster does). Outside a command (a caller of
    :func:`usdworld.cli.summary.print_build_summary`, say), quiet when the root logger passes
    only warnings and errors.
    """
    if _quiet_option is not None:
        return _quiet_option
    return logging.getLogger().getEffectiveLevel() > logging.INFO


def say(message: str) -> None:
    """Print one line of a command's results on stdout, unless ``-q`` was given."""
    if not quiet():
        typer.echo(message)
