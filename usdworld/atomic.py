"""Atomic file writes (leaf module): readers see the old content or the new, never a mix.

Data goes to a temporary file in the target's folder, optionally flushed to disk, then
renamed over the target; on any failure the temporary file is removed and the target
is untouched.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from usdworld.errors import OutputError


def write_bytes_atomic(path: str | Path, data: bytes, *, fsync: bool = False) -> None:
    """Replace ``path`` with ``data`` atomically.

    Args:
        path: the file to write.
        data: its new content.
        fsync: flush the data to disk before the rename (survives a power cut).

    Raises:
        OutputError: the folder cannot be written (one line naming the file).
    """
    target = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    except OSError as exc:
        raise OutputError(f"{target}: cannot write in {target.parent} ({exc.strerror or exc}); check the folder") from exc
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            if fsync:
                f.flush()
                os.fsync(f.fileno())
        with contextlib.suppress(OSError):
            os.chmod(tmp, target.stat().st_mode & 0o777 if target.exists() else 0o644)
        os.replace(tmp, target)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise OutputError(f"{target}: cannot write ({exc.strerror or exc}); check the folder is writable") from exc
        raise


def write_text_atomic(path: str | Path, text: str, *, fsync: bool = False) -> None:
    """Replace ``path`` with UTF-8 ``text`` atomically (see :func:`write_bytes_atomic`)."""
    write_bytes_atomic(path, text.encode("utf-8"), fsync=fsync)


def ensure_output_dir(path: str | Path) -> Path:
    """Create an output folder (and parents) if needed; one-line errors otherwise.

    Raises:
        OutputError: it exists as a file, or cannot be created or written.
    """
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise OutputError(f"{out}: exists and is not a folder; choose another -o")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{out}: cannot create the output folder ({exc.strerror or exc}); choose another -o") from exc
    if not os.access(out, os.W_OK | os.X_OK):
        raise OutputError(f"{out}: folder is not writable; choose another -o")
    return out
