"""``--resume``: a frame's key (a hash of its inputs and options) and whether its world is complete.

A frame is skipped on resume when its previous record holds the same key and its world
folder is complete. The key hashes the *content* of every input file (so moving the
dataset does not force a rebuild, while changing one byte does), the options that change
the output (``max_range_m``, the user asset library's files) and the usdworld version.
The output path and the build's thread count (which changes no output) are not part of the key.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import fields
from pathlib import Path
from typing import TYPE_CHECKING

import usdworld
from usdworld.io.camera_infos import split_camera_ref
from usdworld.pipeline import BuildRequest

if TYPE_CHECKING:
    from usdworld.batch.views import ViewsBuild

#: Bumped when the key's recipe changes, so old keys never match.
KEY_FORMAT = "usdworld-batch-key/1"
#: Request fields that change no output, left out of the key: the output path and the threads.
KEY_IGNORED = frozenset({"output", "threads"})
#: Files every complete world folder holds (see usdworld.authoring.world), besides the
#: layers its root names as sublayers (the edits layer and ``layers/base.usda`` or ``.usdc``).
WORLD_FILES = ("world.usda", "report.json")
_CHUNK = 1 << 20


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes, read in 1 MiB chunks; ``missing`` when it cannot be read.

    A file that cannot be read makes the build fail with the reader's own message, so
    the key only has to differ from any real digest.
    """
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            while chunk := f.read(_CHUNK):
                h.update(chunk)
    except OSError:
        return "missing"
    return h.hexdigest()


def folder_digest(folder: Path) -> str:
    """SHA-256 over the relative paths and contents of every file below ``folder``."""
    h = hashlib.sha256()
    if not folder.is_dir():
        return "missing"
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        h.update(path.relative_to(folder).as_posix().encode() + b"\0" + file_digest(path).encode() + b"\0")
    return h.hexdigest()


def frame_key(request: BuildRequest | ViewsBuild) -> str:
    """The resume key of one build: 64 hex characters.

    Args:
        request: the frame's build request (its ``output`` is ignored); a multi-view
            world's is keyed by :func:`usdworld.batch.views.views_key`.

    Returns:
        SHA-256 of the key format, usdworld version, options and input file digests.
    """
    from usdworld.batch.views import ViewsBuild, views_key

    if isinstance(request, ViewsBuild):
        return views_key(request)
    doc: dict[str, object] = {"format": KEY_FORMAT, "usdworld": usdworld.__version__}
    for f in fields(request):
        value = getattr(request, f.name)
        if f.name in KEY_IGNORED or value is None:
            continue
        if f.name == "library":
            doc[f.name] = folder_digest(Path(value))
        elif f.name == "camera":  # info.json#CAM_FRONT: the file's digest and the camera's name
            file, camera = split_camera_ref(value)
            doc[f.name] = file_digest(file) + (f"#{camera}" if camera else "")
        elif isinstance(value, Path):
            doc[f.name] = file_digest(value)
        else:
            doc[f.name] = repr(value)
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


def world_complete(folder: Path) -> bool:
    """True when ``folder`` holds every file of a built world (the root, the layers it names as
    sublayers, a readable ``report.json``)."""
    from usdworld.authoring.stages import world_layer_files  # lazy: pxr
    from usdworld.errors import InputError

    if not all((folder / name).is_file() for name in WORLD_FILES):
        return False
    try:
        layers = world_layer_files(folder)
    except InputError:
        return False
    if not all(layer.is_file() for layer in layers):
        return False
    try:
        report = json.loads((folder / "report.json").read_text())
    except (OSError, ValueError):
        return False
    return isinstance(report, dict) and isinstance(report.get("objects"), list)
