"""The base layers' object opinions kept in a file, so an edit of a large world reads only its edits layer.

Reading every object's opinions from the layers costs about 30 us per object in Python
(0.3 s of CPU for 10,000 objects, on every command). Below the edits layer nothing
changes between edits, so those layers' opinions (:class:`~.index.Opinions`) are kept in
``objects.index.npz`` beside the base layer, keyed by the SHA-256 of those layers' bytes:
a file whose key does not match the layers on disk (a rebuilt or hand-edited base layer, a
drive layer added) is never used; the opinions are read again and the file rewritten
(atomically). The build writes it for a large world (``AuthoringParams.large_world_min_objects``);
the editor writes it when it had to read the layers of such a world itself. A world folder
that cannot be written is edited without the file.
"""

from __future__ import annotations

import hashlib
import io
import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from pxr import Sdf

from usdworld.atomic import write_bytes_atomic
from usdworld.authoring.editing.index import Opinions, read_opinions
from usdworld.errors import OutputError

log = logging.getLogger(__name__)

#: The file, in the base layer's folder.
INDEX_FILE = "objects.index.npz"
#: Bumped when the file's content changes, so old files never match (2: the objects' heights, yaws,
#: assets and plainness, for the render's view stage).
INDEX_FORMAT = "usdworld-object-index/2"
_CHUNK = 1 << 20


def layers_key(paths: Sequence[Path]) -> str:
    """The key of a group of layer files: SHA-256 over the format, and each file's name and content.

    Args:
        paths: the layer files, strongest first.
    """
    h = hashlib.sha256(INDEX_FORMAT.encode() + b"\0")
    for path in paths:
        file = hashlib.sha256()
        with open(path, "rb") as f:
            while chunk := f.read(_CHUNK):
                file.update(chunk)
        h.update(Path(path).name.encode() + b"\0" + file.digest())
    return h.hexdigest()


def _strings(values: Sequence[str | None]) -> tuple[np.ndarray, np.ndarray]:
    have = np.array([v is not None for v in values], dtype=bool)
    return np.array([v or "" for v in values], dtype=np.str_), have


def save_opinions(path: Path, opinions: Opinions, key: str) -> None:
    """Write the opinions and their key to ``path`` atomically.

    Raises:
        OutputError: the folder cannot be written.
    """
    labels, has_label = _strings(opinions.label)
    variants, has_variant = _strings(opinions.variant)
    active = np.array([-1 if a is None else int(a) for a in opinions.active], dtype=np.int8)
    table = sorted({a for a in opinions.asset if a is not None})
    at = {a: k for k, a in enumerate(table)}
    asset_code = np.array([-1 if a is None else at[a] for a in opinions.asset], dtype=np.int32)
    buf = io.BytesIO()
    np.savez(
        buf,
        key=np.array(key),
        names=np.array(opinions.names, dtype=np.str_),
        defined=opinions.defined,
        translate=opinions.translate,
        scale=opinions.scale,
        labels=labels,
        has_label=has_label,
        variants=variants,
        has_variant=has_variant,
        active=active,
        z_scale_yaw=opinions.z_scale_yaw,
        assets=np.array(table, dtype=np.str_),
        asset_code=asset_code,
        plain=opinions.plain,
    )
    write_bytes_atomic(path, buf.getvalue())


def load_opinions(path: Path, key: str) -> Opinions | None:
    """The opinions kept in ``path``, or None when there is no readable file or its key is not ``key``."""
    try:
        with np.load(path, allow_pickle=False) as data:
            if str(data["key"]) != key:
                return None
            n = len(data["names"])
            labels, variants = data["labels"].tolist(), data["variants"].tolist()
            table = data["assets"].tolist()
            assets = tuple(None if k < 0 else table[k] for k in data["asset_code"].tolist())
            return Opinions(
                tuple(data["names"].tolist()),
                data["defined"].astype(bool),
                data["translate"].astype(np.float64).reshape(n, 2),
                data["scale"].astype(np.float64).reshape(n, 2),
                tuple(v if h else None for v, h in zip(labels, data["has_label"].tolist())),
                tuple(v if h else None for v, h in zip(variants, data["has_variant"].tolist())),
                tuple(None if a < 0 else bool(a) for a in data["active"].tolist()),
                data["z_scale_yaw"].astype(np.float64).reshape(n, 3),
                assets,
                data["plain"].astype(bool).reshape(n),
            )
    except (OSError, ValueError, KeyError, IndexError):
        return None


def lower_opinions(layers: Sequence[Sdf.Layer], min_objects: int) -> Opinions:
    """The opinions of a world's layers below its edits layer (``layers[1:]``).

    From the index file when its key matches those layers' files; else read from the
    layers, and the file (re)written when they define at least ``min_objects`` objects.

    Args:
        layers: the world's sublayers, strongest first (the edits layer first).
        min_objects: the fewest objects worth a file (``AuthoringParams.large_world_min_objects``).
    """
    lower = list(layers[1:])
    if not lower or any(layer.dirty or not layer.realPath for layer in lower):
        return read_opinions(lower)  # what is in memory is not what is on disk
    paths = [Path(layer.realPath) for layer in lower]
    file = paths[-1].parent / INDEX_FILE
    key = None
    if file.is_file():
        try:
            key = layers_key(paths)
        except OSError:
            return read_opinions(lower)
        kept = load_opinions(file, key)
        if kept is not None:
            return kept
    opinions = read_opinions(lower)
    if int(opinions.defined.sum()) >= min_objects:
        try:
            save_opinions(file, opinions, key or layers_key(paths))
        except (OSError, OutputError) as exc:
            log.debug("object index not kept: %s", exc)
    return opinions
