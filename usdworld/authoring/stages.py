"""Opening USD files with one-line errors (every reader of user-supplied stages goes through here)."""

from __future__ import annotations

from pathlib import Path

from pxr import Usd

from usdworld.errors import InputError


def open_stage(path: str | Path, what: str = "USD stage") -> Usd.Stage:
    """Open a USD file, or raise an InputError that names it.

    Args:
        path: the file.
        what: how the message names the file (``USD stage``, ``USD asset``, ``USD world`` ...).

    Raises:
        InputError: the file does not open (the USD error's last line is quoted).
    """
    try:
        stage = Usd.Stage.Open(str(path), Usd.Stage.LoadAll)
    except Exception as exc:  # pxr raises Tf.ErrorException
        raise InputError(f"{path}: not a readable {what} ({str(exc).strip().splitlines()[-1]})") from exc
    if stage is None:
        raise InputError(f"{path}: not a readable {what}")
    return stage
