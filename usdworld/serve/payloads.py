"""Validation of the JSON bodies of ``usdworld serve``'s edit requests (no web framework here).

Each operation takes one JSON object; unknown keys, wrong types, non-finite numbers and
over-long strings are refused with an :class:`~usdworld.errors.InputError` that names the
field (the app answers 400 with it). Class names must be plain identifiers, so a request
can never make the asset lookup read a path of its choosing.

=========  ==========================================================================
op         body
=========  ==========================================================================
move       ``{"name": "car_0003", "to": [x, y]}`` or ``{"name": ..., "by": [dx, dy]}``
rotate     ``{"name": ..., "yaw_deg": 90}``
delete     ``{"name": ...}``
add        ``{"class": "car", "at": [x, y], "variant": "suv"?, "yaw_deg": 0?}``
replace    ``{"name": ..., "with": "bus", "variant": "city"?}``
restyle    ``{"name": ..., "color": "#c03030"}``
reset      ``{"name": ...}``
undo/redo  ``{"steps": 1?}``
=========  ==========================================================================
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from usdworld.errors import InputError

#: Largest request body accepted, bytes (an edit is a few dozen).
MAX_BODY_BYTES = 16 * 1024
#: Longest string field accepted.
MAX_STRING = 200
#: Most steps one undo or redo request may take.
MAX_STEPS = 1000
#: Largest coordinate accepted, metres (keeps the engine's arithmetic finite and sane).
MAX_COORD_M = 1.0e6

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_FIELDS: dict[str, dict[str, bool]] = {  # op -> field -> required
    "move": {"name": True, "to": False, "by": False},
    "rotate": {"name": True, "yaw_deg": True},
    "delete": {"name": True},
    "add": {"class": True, "at": True, "variant": False, "yaw_deg": False},
    "replace": {"name": True, "with": True, "variant": False},
    "restyle": {"name": True, "color": True},
    "reset": {"name": True},
    "undo": {"steps": False},
    "redo": {"steps": False},
}
#: The operations a request may ask for.
OPERATIONS = tuple(_FIELDS)


@dataclass(frozen=True)
class EditRequest:
    """One validated request.

    Attributes:
        op: an entry of :data:`OPERATIONS`.
        args: the validated fields (numbers as float, points as (x, y) tuples, optional
            fields present only when given and not null).
    """

    op: str
    args: Mapping[str, Any]

    def __post_init__(self) -> None:
        if self.op not in _FIELDS:
            raise InputError(f"unknown operation '{self.op}'; one of {', '.join(OPERATIONS)}")
        object.__setattr__(self, "args", MappingProxyType(dict(self.args)))


def decode_body(raw: bytes) -> dict[str, Any]:
    """A request body as a JSON object.

    Raises:
        InputError: over :data:`MAX_BODY_BYTES`, not UTF-8 JSON, or not an object.
    """
    if len(raw) > MAX_BODY_BYTES:
        raise InputError(f"request body: {len(raw)} bytes, more than the {MAX_BODY_BYTES} allowed")
    if not raw.strip():
        return {}
    try:
        doc = json.loads(raw.decode("utf-8"), parse_constant=_no_constant)
    except (UnicodeDecodeError, json.JSONDecodeError, ValueError) as exc:
        raise InputError(f"request body: not valid JSON ({exc})") from None
    if not isinstance(doc, dict):
        raise InputError(f"request body: must be a JSON object, got {type(doc).__name__}")
    return doc


def _no_constant(name: str) -> None:
    raise ValueError(f"{name} is not allowed")


def _string(op: str, key: str, value: Any) -> str:
    if not isinstance(value, str):
        raise InputError(f"{op} -> {key}: must be a string, got {type(value).__name__}")
    if not value or len(value) > MAX_STRING:
        raise InputError(f"{op} -> {key}: must be 1 to {MAX_STRING} characters long")
    return value


def _identifier(op: str, key: str, value: Any) -> str:
    text = _string(op, key, value)
    if not _IDENT.match(text):
        raise InputError(f"{op} -> {key}: '{text}' is not a class or variant name (letters, digits, _)")
    return text


def _number(op: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{op} -> {key}: must be a number, got {type(value).__name__}")
    try:
        number = float(value)
    except OverflowError:  # an integer beyond a double's range
        number = math.inf
    if not math.isfinite(number) or abs(number) > MAX_COORD_M:
        raise InputError(f"{op} -> {key}: must be finite and within +-{MAX_COORD_M:g}, got {str(value)[:40]}")
    return number


def _point(op: str, key: str, value: Any) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise InputError(f"{op} -> {key}: must be [x, y] in metres, got {json.dumps(value)[:60]}")
    return _number(op, key, value[0]), _number(op, key, value[1])


def parse_edit(op: str, body: Mapping[str, Any]) -> EditRequest:
    """Validate the body of one operation.

    Args:
        op: the operation named by the route.
        body: the decoded JSON object.

    Raises:
        InputError: unknown operation, unknown or missing field, or a bad value.
    """
    fields = _FIELDS.get(op)
    if fields is None:
        raise InputError(f"unknown operation '{op}'; one of {', '.join(OPERATIONS)}")
    unknown = sorted(set(body) - set(fields))
    if unknown:
        raise InputError(f"{op}: unknown field(s) {', '.join(unknown)}; allowed: {', '.join(fields)}")
    missing = [k for k, required in fields.items() if required and body.get(k) is None]
    if missing:
        raise InputError(f"{op}: missing field(s) {', '.join(missing)}")
    args: dict[str, Any] = {}
    for key, value in body.items():
        if value is None:
            continue
        if key == "name":
            args[key] = _string(op, key, value)
        elif key in ("class", "with", "variant"):
            args[key] = _identifier(op, key, value)
        elif key == "color":
            args[key] = _string(op, key, value)
        elif key in ("to", "by", "at"):
            args[key] = _point(op, key, value)
        elif key == "yaw_deg":
            args[key] = _number(op, key, value)
        elif key == "steps":
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_STEPS:
                raise InputError(f"{op} -> steps: must be an integer from 1 to {MAX_STEPS}, got {value!r}")
            args[key] = value
    if op == "move" and ("to" in args) == ("by" in args):
        raise InputError("move: give exactly one of 'to': [x, y] or 'by': [dx, dy]")
    return EditRequest(op, args)
