"""Opening USD files with one-line errors (every reader of user-supplied stages goes through here),
and the registration of usdworld's schema plugin."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from pxr import Plug, Usd

from usdworld.errors import InputError
from usdworld.resources import schemas_dir


def register_schemas() -> None:
    """Register the codeless schema plugin (``schemas/plugInfo.json``) with OpenUSD.

    Called when :mod:`usdworld.authoring` is imported; must run before the first stage is
    opened in the process. Registering the same folder again does nothing.
    """
    Plug.Registry().RegisterPlugins(str(schemas_dir()))


def open_stage(path: str | Path, what: str = "USD stage", mask: Sequence[str] | None = None) -> Usd.Stage:
    """Open a USD file, or raise an InputError that names it.

    Args:
        path: the file.
        what: how the message names the file (``USD stage``, ``USD asset``, ``USD world`` ...).
        mask: prim paths to compose (with their ancestors and descendants); None composes
            every prim. ``stage.SetPopulationMask`` widens it later.

    Raises:
        InputError: the file does not open (the USD error's last line is quoted).
    """
    try:
        if mask is None:
            stage = Usd.Stage.Open(str(path), Usd.Stage.LoadAll)
        else:
            stage = Usd.Stage.OpenMasked(str(path), Usd.StagePopulationMask(list(mask)), Usd.Stage.LoadAll)
    except Exception as exc:  # pxr raises Tf.ErrorException
        raise InputError(f"{path}: not a readable {what} ({str(exc).strip().splitlines()[-1]})") from exc
    if stage is None:
        raise InputError(f"{path}: not a readable {what}")
    return stage
