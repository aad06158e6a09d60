"""What a batch builds: :class:`Frame` (one complete frame) and :class:`Incomplete` (one that is not).

Discovery (:mod:`usdworld.batch.discover`) yields these; the runner turns each frame into
one ``usdworld build`` of ``OUT/<frame_id>/``. Both are small frozen dataclasses of paths
and strings, so streams of them pickle cheaply to worker processes.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from pathlib import Path

from typing import TYPE_CHECKING

from usdworld.errors import InputError
from usdworld.pipeline import BuildRequest

if TYPE_CHECKING:
    from usdworld.batch.views import ViewsBuild

#: A frame id: letters, digits, ``.``, ``_``, ``-``; starts with a letter or digit.
FRAME_ID_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,199}$")
#: Files the batch writes into OUT itself; no frame may be named like them.
RESERVED_NAMES = frozenset({"batch.json", "index.usda"})


def check_frame_id(frame_id: str) -> str:
    """``frame_id`` if it can name a folder of OUT, else an InputError saying why.

    Raises:
        InputError: empty, too long, other characters than letters, digits, ``._-``,
            a leading ``.``/``_``/``-``, or one of :data:`RESERVED_NAMES`.
    """
    if not FRAME_ID_PATTERN.match(frame_id):
        raise InputError(
            f"frame id {frame_id!r}: use 1-200 letters, digits, '.', '_' or '-', starting with a letter or digit"
        )
    if frame_id in RESERVED_NAMES:
        raise InputError(f"frame id {frame_id!r}: reserved for the batch's own files; rename the frame")
    return frame_id


@dataclass(frozen=True)
class Frame:
    """One frame with every input ``usdworld build`` needs.

    Attributes:
        frame_id: names the world folder ``OUT/<frame_id>/`` (see :func:`check_frame_id`).
        source: the photo as the dataset names it (path relative to the dataset root, or
            as written in the manifest); recorded in ``batch.json`` and ``index.usda``.
        request: the build inputs and options (a :class:`~usdworld.batch.views.ViewsBuild`
            for a multi-view world); ``request.output`` is ``Path(frame_id)``, the world
            folder relative to the batch output (see :meth:`request_in`).
    """

    frame_id: str
    source: str
    request: BuildRequest | ViewsBuild

    def __post_init__(self) -> None:
        check_frame_id(self.frame_id)
        if self.request.output != Path(self.frame_id):
            raise InputError(
                f"frame {self.frame_id}: request.output must be {self.frame_id!r}, got {self.request.output}"
            )

    def request_in(self, out_dir: Path) -> BuildRequest | ViewsBuild:
        """The build request writing this frame's world to ``out_dir/<frame_id>``."""
        return replace(self.request, output=Path(out_dir) / self.frame_id)


@dataclass(frozen=True)
class Incomplete:
    """A file or frame discovery found but will not build, and why.

    Attributes:
        name: the frame id, or the file's path relative to the dataset root.
        reason: what is missing or wrong, e.g. ``no gtFine/val/x/x_gtFine_instanceIds.png``.
        fails: the frame was asked for (a manifest row), so not building it fails the batch
            (exit 1); a dataset's stray or partial files are only listed.
    """

    name: str
    reason: str
    fails: bool = False


def make_frame(frame_id: str, source: str, image: Path, **options: object) -> Frame | Incomplete:
    """A :class:`Frame`, or an :class:`Incomplete` when the id or the option set is invalid.

    Args:
        frame_id: the frame id.
        source: the photo as the dataset names it.
        image: the photo's path.
        **options: further :class:`~usdworld.pipeline.BuildRequest` fields (not ``output``).
    """
    try:
        check_frame_id(frame_id)
        return Frame(frame_id, source, BuildRequest(image=image, output=Path(frame_id), **options))  # type: ignore[arg-type]
    except InputError as exc:
        return Incomplete(frame_id, str(exc))
