"""The world folder given with ``-o``: checked before a build, swapped in after it.

A build writes its world into a temporary folder next to the output (``.NAME.tmp-XXXX``)
and replaces the output by renames only, so an existing world is untouched when
anything fails. Rules for the output path:

* an existing folder is replaced only when it holds a world (``world.usda``) or is empty;
* a symbolic link is refused, dangling or not: replacing the link would leave its
  target stale, and updating the target would write outside the folder the user named
  (pass the target itself with ``-o``);
* its name, plus the 14 characters of the temporary names, must fit the file system;
* the new folder gets the permissions of a folder made by ``mkdir`` under the process's
  umask (``tempfile.mkdtemp`` makes it 0700).
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import tempfile
from pathlib import Path

from usdworld.atomic import ensure_output_dir
from usdworld.errors import OutputError
from usdworld.world_files import EDITS_LAYER, ROOT_LAYER

#: Characters the temporary siblings add to the output's name (``.`` + ``.tmp-`` + 8).
TEMP_NAME_EXTRA = 14


def temporary_prefix(out: Path) -> str:
    """The name prefix of the temporary folder a build of ``out`` writes its world into."""
    return f".{out.name}.tmp-"


def remove_dead_builds(out: Path) -> list[Path]:
    """Remove the temporary folders that builds of ``out`` left behind when their process died.

    A build removes its temporary folder itself when it fails; only a killed process (a
    Dask worker that crashed, a ``kill -9``) leaves one. Call this only when no build of
    ``out`` can still be running (a batch, once every frame has its record).

    Args:
        out: the world folder whose builds' leftovers to remove.

    Returns:
        The folders removed.
    """
    removed = []
    for leftover in sorted(out.parent.glob(temporary_prefix(out) + "*")):
        if leftover.is_dir() and not leftover.is_symlink():
            shutil.rmtree(leftover, ignore_errors=True)
            removed.append(leftover)
    return removed


def current_umask() -> int:
    """The process's umask, read from /proc where possible (``os.umask`` must set it to read it)."""
    with contextlib.suppress(OSError, ValueError):
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _check_name(out: Path) -> None:
    parent = out.parent if str(out.parent) else Path(".")
    try:
        name_max = os.pathconf(parent, "PC_NAME_MAX") if parent.exists() else 255
    except (OSError, ValueError):
        name_max = 255
    if len(os.fsencode(out.name)) + TEMP_NAME_EXTRA > name_max:
        raise OutputError(
            f"{out.name[:40]}...: the output name is {len(os.fsencode(out.name))} bytes, the file system allows "
            f"{name_max - TEMP_NAME_EXTRA} for a world folder; choose a shorter -o"
        )


def prepare_output(out: Path) -> Path | None:
    """Check the output folder before a build.

    Args:
        out: the ``-o`` folder.

    Returns:
        The existing edits layer to carry over, or None.

    Raises:
        OutputError: ``out`` is a symbolic link, a file, a non-empty folder without a world,
            has a name too long for the file system, or its parent cannot be created.
    """
    _check_name(out)
    try:
        if out.is_symlink():
            target = os.readlink(out)
            if not out.exists():
                raise OutputError(
                    f"{out}: is a dangling symbolic link (to {target}); remove it or choose another -o"
                )
            raise OutputError(
                f"{out}: is a symbolic link (to {target}); a world folder is replaced by renames, "
                f"so pass the folder itself: -o {out.resolve()}"
            )
        if out.exists():
            if not out.is_dir():
                raise OutputError(f"{out}: exists and is not a folder; choose another -o")
            if (out / ROOT_LAYER).is_file():
                edits = out / EDITS_LAYER
                return edits if edits.is_file() else None
            if any(out.iterdir()):
                raise OutputError(f"{out}: folder exists, is not empty and holds no {ROOT_LAYER}; choose another -o")
    except OSError as exc:
        raise OutputError(f"{out}: cannot be used as the output ({exc.strerror or exc}); choose another -o") from exc
    ensure_output_dir(out.parent)
    return None


def swap_in(tmp: Path, out: Path) -> None:
    """Replace ``out`` by the finished folder ``tmp`` with renames only; the old folder goes last.

    ``tmp`` first gets the permissions ``0o777 & ~umask``.

    Raises:
        OutputError: a rename failed (the old world, if any, is back in place).
    """
    with contextlib.suppress(OSError):
        os.chmod(tmp, 0o777 & ~current_umask())
    try:
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
            old.rmdir()
            os.replace(out, old)
            try:
                os.replace(tmp, out)
            except OSError:
                os.replace(old, out)
                raise
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, out)
    except OSError as exc:
        hint = "choose a shorter -o" if exc.errno == errno.ENAMETOOLONG else "check the folder is writable"
        raise OutputError(f"{out}: cannot put the world in place ({exc.strerror or exc}); {hint}") from exc
