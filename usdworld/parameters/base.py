"""How a tuned number is declared: value, unit, meaning and origin in one place (leaf module).

Every algorithm threshold of usdworld is a field of one of the frozen section dataclasses
in this package, declared with :func:`param`. A field's metadata carries its unit, its
meaning and where the value comes from:

* ``geometry``: follows from the camera model or the scene's geometry (the docstring says how);
* ``published: <source>``: a published statistic (cited);
* ``tuned: synthetic set``: measured on the synthetic round trip (``tools/eval_synth.py``);
* ``tuned: KITTI dev frames`` and so on for other measured data;
* ``convention``: a choice with no measured effect (a unit, a display default).

Values derived from others are properties of their section, never a second field.
"""

from __future__ import annotations

import dataclasses
from typing import Any

#: Origins a field may give (a ``published:`` or ``tuned:`` origin adds its source after the colon).
ORIGIN_KINDS = ("geometry", "published", "tuned", "convention")


def param(default: Any, unit: str, doc: str, origin: str) -> Any:
    """A documented section field.

    Args:
        default: the value used unless a caller overrides it.
        unit: ``m``, ``px``, ``rad``, ``fraction``, ``count``, ``1`` (dimensionless) ...
        doc: what the number means, one or two sentences.
        origin: ``geometry``, ``convention``, ``published: <citation>`` or ``tuned: <data>``.

    Returns:
        A :func:`dataclasses.field` carrying the documentation as metadata.
    """
    kind = origin.split(":", 1)[0].strip()
    if kind not in ORIGIN_KINDS:
        raise ValueError(f"origin must start with one of {ORIGIN_KINDS}, got {origin!r}")
    meta = {"unit": unit, "doc": doc, "origin": origin}
    if isinstance(default, (list, dict, set)):
        raise TypeError("parameters are immutable: use a tuple or frozenset default")
    return dataclasses.field(default=default, metadata=meta)


def section_rows(section: object) -> list[dict[str, Any]]:
    """One row per field of a section: name, value, unit, origin, doc."""
    rows = []
    for f in dataclasses.fields(section):  # type: ignore[arg-type]
        rows.append(
            {
                "name": f.name,
                "value": getattr(section, f.name),
                "unit": f.metadata.get("unit", ""),
                "origin": f.metadata.get("origin", ""),
                "doc": f.metadata.get("doc", ""),
            }
        )
    return rows


def plain(value: Any) -> Any:
    """A JSON-ready copy of a parameter value (tuples become lists, frozensets sorted lists)."""
    if isinstance(value, (tuple, list)):
        return [plain(v) for v in value]
    if isinstance(value, frozenset):
        return sorted(plain(v) for v in value)
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in sorted(value.items())}
    return value
