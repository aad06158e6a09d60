"""Read an input file's bytes once and identify it for provenance; shared text/JSON parsing.

Every reader in :mod:`usdworld.io` calls :func:`read_input` first and decodes the
returned bytes, so the digest recorded in the USD layers is the digest of exactly
what was parsed. The JSON helpers here turn malformed documents into one-line
:class:`~usdworld.errors.InputError` messages that name the field path, e.g.
``cam.json -> intrinsic -> fy: missing``.

Example:
    >>> data, file = read_input("photo.png", "image")  # doctest: +SKIP
    >>> file.name, len(file.sha256)  # doctest: +SKIP
    ('photo.png', 64)
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from pathlib import Path
from typing import Any

from usdworld.errors import InputError
from usdworld.io.types import InputFile

#: Accepted for every ``path`` argument of the readers.
PathLike = str | os.PathLike[str]


def sha256_hex(data: bytes) -> str:
    """Hex SHA-256 digest of ``data`` (64 lowercase hex characters)."""
    return hashlib.sha256(data).hexdigest()


def read_input(path: PathLike, role: str) -> tuple[bytes, InputFile]:
    """Read a whole input file and describe it.

    Args:
        path: file to read.
        role: what the file is for (``image``, ``labels``, ``camera`` ...), recorded in
            the returned :class:`InputFile`.

    Returns:
        data: the file's bytes.
        file: ``InputFile(role, name=<basename>, sha256=<digest of data>)``.

    Raises:
        InputError: the file is missing, is a folder, cannot be read, or is empty.
    """
    p = Path(path)
    try:
        data = p.read_bytes()
    except FileNotFoundError as exc:
        raise InputError(f"{p}: no such file (the {role} file); check the path") from exc
    except IsADirectoryError as exc:
        raise InputError(f"{p}: is a folder, not a file; pass the {role} file itself") from exc
    except PermissionError as exc:
        raise InputError(f"{p}: permission denied; make the {role} file readable") from exc
    except OSError as exc:
        raise InputError(f"{p}: cannot be read ({exc.strerror or exc}); check the {role} file") from exc
    if not data:
        raise InputError(f"{p.name}: the file is empty (0 bytes); pass a complete {role} file")
    return data, InputFile(role=role, name=p.name, sha256=sha256_hex(data))


def decode_text(data: bytes, name: str) -> str:
    """Decode a text input file as UTF-8 (a leading byte-order mark is dropped).

    Args:
        data: the file's bytes.
        name: file name for the error message.

    Raises:
        InputError: the bytes are not UTF-8 text.
    """
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(
            f"{name}: not UTF-8 text (byte {exc.start} is 0x{data[exc.start]:02x}); "
            "save the file as UTF-8 text"
        ) from exc


def parse_json(data: bytes, name: str) -> Any:
    """Parse a JSON input file.

    Args:
        data: the file's bytes.
        name: file name for the error message.

    Returns:
        The decoded document (``NaN`` / ``Infinity`` literals are rejected).

    Raises:
        InputError: the bytes are not UTF-8 or not valid JSON.
    """
    text = decode_text(data, name)

    def _reject_constant(token: str) -> Any:
        raise ValueError(f"{token} is not a JSON number")

    try:
        return json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise InputError(
            f"{name}: not valid JSON (line {exc.lineno} column {exc.colno}: {exc.msg}); fix the syntax"
        ) from exc
    except (ValueError, RecursionError) as exc:
        raise InputError(f"{name}: not valid JSON ({exc}); fix the file") from exc


def json_type(value: Any) -> str:
    """JSON name of a decoded value's type (``object``, ``array``, ``string`` ...)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, (int, float)):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list):
        return "array"
    if isinstance(value, dict):
        return "object"
    return type(value).__name__


def as_object(value: Any, where: str) -> dict[str, Any]:
    """``value`` if it is a JSON object, else an InputError naming ``where``."""
    if not isinstance(value, dict):
        raise InputError(f"{where}: must be an object, got {json_type(value)}")
    return value


def as_array(value: Any, where: str) -> list[Any]:
    """``value`` if it is a JSON array, else an InputError naming ``where``."""
    if not isinstance(value, list):
        raise InputError(f"{where}: must be an array, got {json_type(value)}")
    return value


def require(obj: dict[str, Any], key: str, where: str) -> Any:
    """``obj[key]``, or an InputError ``<where> -> <key>: missing``."""
    if key not in obj:
        raise InputError(f"{where} -> {key}: missing")
    return obj[key]


def as_float(value: Any, where: str) -> float:
    """A finite JSON number as float, else an InputError naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{where}: must be a number, got {json_type(value)}")
    try:
        f = float(value)
    except OverflowError:
        f = math.inf
    if not math.isfinite(f):
        raise InputError(f"{where}: must be finite, got {f}")
    return f


def as_floats(value: Any, where: str, n: int) -> list[float]:
    """A JSON array of exactly ``n`` finite numbers, else an InputError naming ``where``."""
    items = as_array(value, where)
    if len(items) != n:
        raise InputError(f"{where}: must hold {n} numbers, got {len(items)}")
    return [as_float(v, f"{where} -> [{i}]") for i, v in enumerate(items)]


def folder_identity(path: PathLike, role: str) -> InputFile:
    """Describe a folder input (a model saved with ``save_pretrained``) by its files' content.

    The digest covers every regular file below the folder (hidden ones left out), in sorted
    relative-path order, each as its path and bytes, streamed in 4 MiB blocks.

    Args:
        path: the folder.
        role: what the folder is for (``segment_model``).

    Returns:
        ``InputFile(role, name=<folder name>, sha256=<digest>)``.

    Raises:
        InputError: the path is not a readable folder.
    """
    folder = Path(path)
    if not folder.is_dir():
        raise InputError(f"{folder}: no such folder (the {role}); check the path")
    digest = hashlib.sha256()
    try:
        files = sorted(
            p for p in folder.rglob("*") if p.is_file() and not any(part.startswith(".") for part in p.relative_to(folder).parts)
        )
        for file in files:
            digest.update(file.relative_to(folder).as_posix().encode("utf-8") + b"\0")
            with file.open("rb") as stream:
                for block in iter(lambda: stream.read(4 * 1024 * 1024), b""):
                    digest.update(block)
    except OSError as exc:
        raise InputError(f"{folder}: cannot be read ({exc.strerror or exc}); check the {role}") from exc
    return InputFile(role=role, name=folder.name, sha256=digest.hexdigest())
