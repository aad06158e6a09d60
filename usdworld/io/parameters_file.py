"""Read a parameters file: ``{section: {field: value}}`` over the defaults (``build --params``).

Only the fields a file names change; every other keeps its default. Each key and value is
checked against the declared sections (:class:`usdworld.parameters.Parameters`): an
unknown section or field, or a value of the wrong type, is a one-line InputError naming
the key and the known ones.

Example file::

    {"scene": {"max_range_m": 60, "fill_reach_m": 5.0}}
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from usdworld.errors import InputError
from usdworld.io.hashing import as_array, as_float, as_object, json_type, parse_json, read_input
from usdworld.parameters import DEFAULT_PARAMETERS, Parameters


def _value(default: Any, raw: Any, where: str) -> Any:
    """``raw`` checked and converted to the type of the field's default."""
    if isinstance(default, bool):
        if not isinstance(raw, bool):
            raise InputError(f"{where}: must be true or false, got {json_type(raw)}")
        return raw
    if isinstance(default, int):
        if isinstance(raw, bool) or not isinstance(raw, int):
            raise InputError(f"{where}: must be a whole number, got {json_type(raw)} {raw!r}")
        return raw
    if isinstance(default, float):
        return as_float(raw, where)
    if isinstance(default, str):
        if not isinstance(raw, str):
            raise InputError(f"{where}: must be a string, got {json_type(raw)}")
        return raw
    if isinstance(default, (tuple, frozenset)):
        items = as_array(raw, where)
        if isinstance(default, tuple):
            if len(items) != len(default):
                raise InputError(f"{where}: must hold {len(default)} values, got {len(items)}")
            return tuple(_value(d, v, f"{where} -> [{i}]") for i, (d, v) in enumerate(zip(default, items)))
        example = next(iter(default), "")
        return frozenset(_value(example, v, f"{where} -> [{i}]") for i, v in enumerate(items))
    raise InputError(f"{where}: cannot be set from a file (a {type(default).__name__})")


def parse_parameters(raw: Any, name: str, base: Parameters = DEFAULT_PARAMETERS) -> Parameters:
    """Parameters from a decoded parameters document.

    Args:
        raw: the decoded JSON.
        name: file name for messages.
        base: the values the document changes.

    Returns:
        ``base`` with the named fields replaced.

    Raises:
        InputError: not an object of objects, an unknown section or field, a wrong type,
            or a value its section rejects.
    """
    if not isinstance(raw, dict):
        raise InputError(f"{name}: must be an object {{section: {{field: value}}}}, got {json_type(raw)}")
    sections = base.sections()
    changes: dict[str, dict[str, Any]] = {}
    for section_name, values in raw.items():
        if section_name not in sections:
            raise InputError(f"{name} -> {section_name}: unknown parameter section; known: {', '.join(sections)}")
        fields = {f.name: f for f in dataclasses.fields(sections[section_name])}  # type: ignore[arg-type]
        where = f"{name} -> {section_name}"
        changes[section_name] = {}
        for key, value in as_object(values, where).items():
            if key not in fields:
                known = ", ".join(sorted(fields)) or "none"
                raise InputError(f"{where} -> {key}: unknown parameter; known: {known}")
            changes[section_name][key] = _value(getattr(sections[section_name], key), value, f"{where} -> {key}")
    try:
        return base.replace(**changes)
    except ValueError as exc:
        raise InputError(f"{name}: {exc}") from None


def read_parameters(path: Path) -> Parameters:
    """Read a parameters file (module docstring) over the defaults.

    Raises:
        InputError: unreadable, not JSON, or not a valid parameters document.
    """
    data, file = read_input(path, "parameters")
    return parse_parameters(parse_json(data, file.name), file.name)
