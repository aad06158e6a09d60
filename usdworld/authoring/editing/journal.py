"""The history of a world's edits and their undo, kept in the edits layer itself.

``customLayerData["usdworld"]`` holds two arrays of JSON strings, one item per step:
``history`` (operation, arguments, UTC time, forced, the violated rules, the prims
touched) and ``undo`` (the step's inverse: for each prim it touched, the edits layer's
previous spec of it as usda text and its position among its siblings, and the ancestor
specs the step created). :func:`undo_last` puts those specs back (plain Sdf edits of the
same layer), so the layer becomes byte-identical to what it was before the step; the
history travels with the layer through rebuilds.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from pxr import Sdf, Vt

from usdworld.errors import AuthoringError
from usdworld.world_files import OBJECTS_PATH

#: customLayerData key of usdworld's data in an edits layer, and the two arrays below it.
DATA_KEY = "usdworld"
HISTORY_KEY = "history"
UNDO_KEY = "undo"
#: Ancestor prims of every object; a step records which of them it created.
ANCESTORS = ("/World", OBJECTS_PATH)
#: Name a restored spec is written under before it is moved into place.
_RESTORE_NAME = "_usdworld_restore"


def utc_now() -> str:
    """Current UTC time, ISO 8601 with milliseconds (the history's clock)."""
    return datetime.now(UTC).isoformat(timespec="milliseconds")


@dataclass(frozen=True)
class HistoryEntry:
    """One recorded edit.

    Attributes:
        step: 1-based position in the history.
        op: operation name.
        args: the arguments as given (JSON-compatible).
        time: UTC time (ISO 8601), '' when recorded without a clock.
        forced: True when applied despite ``violations``.
        violations: the rules it broke (``rule: why``).
        paths: prims it touched.
    """

    step: int
    op: str
    args: dict[str, Any]
    time: str
    forced: bool
    violations: tuple[str, ...]
    paths: tuple[str, ...]

    @staticmethod
    def from_json(step: int, text: str) -> HistoryEntry:
        """The entry of ``step`` from its JSON text in the history array."""
        raw = json.loads(text)
        return HistoryEntry(
            step=step,
            op=str(raw.get("op", "")),
            args=dict(raw.get("args", {})),
            time=str(raw.get("time", "")),
            forced=bool(raw.get("forced", False)),
            violations=tuple(raw.get("violations", ())),
            paths=tuple(raw.get("paths", ())),
        )


def read_journal(layer: Sdf.Layer) -> tuple[list[str], list[str]]:
    """The history and undo arrays (one JSON string per step, oldest first).

    Raises:
        AuthoringError: the two arrays differ in length (the layer was edited by hand).
    """
    data = layer.customLayerData.get(DATA_KEY, {})
    history, undo = list(data.get(HISTORY_KEY, ())), list(data.get(UNDO_KEY, ()))
    if len(history) != len(undo):
        raise AuthoringError(
            f"{layer.realPath}: customLayerData {DATA_KEY} history and undo differ in length; "
            "the layer was edited by hand"
        )
    return history, undo


def write_journal(layer: Sdf.Layer, history: list[str], undo: list[str]) -> None:
    """Store the two arrays (removing usdworld's data, or all customLayerData, when empty)."""
    cld = dict(layer.customLayerData)
    data = {k: v for k, v in dict(cld.get(DATA_KEY, {})).items() if k not in (HISTORY_KEY, UNDO_KEY)}
    if history:
        data[HISTORY_KEY], data[UNDO_KEY] = Vt.StringArray(history), Vt.StringArray(undo)
    if data:
        cld[DATA_KEY] = data
    else:
        cld.pop(DATA_KEY, None)
    if cld:
        layer.customLayerData = cld
    else:
        layer.ClearCustomLayerData()


def entries(layer: Sdf.Layer) -> list[HistoryEntry]:
    """Every recorded edit, oldest first."""
    return [HistoryEntry.from_json(i + 1, h) for i, h in enumerate(read_journal(layer)[0])]


def capture(layer: Sdf.Layer, path: Sdf.Path) -> tuple[str, int]:
    """The layer's spec of ``path`` as usda text ('' when none) and its sibling index (-1)."""
    spec = layer.GetPrimAtPath(path)
    if not spec:
        return "", -1
    anon = Sdf.Layer.CreateAnonymous(".usda")
    Sdf.CreatePrimInLayer(anon, path.GetParentPath())
    Sdf.CopySpec(layer, path, anon, path)
    return anon.ExportToString(), list(spec.nameParent.nameChildren.keys()).index(path.name)


def restore(layer: Sdf.Layer, path: Sdf.Path, text: str, index: int) -> None:
    """Replace the layer's spec of ``path`` by a captured one (none when ``text`` is '').

    Raises:
        AuthoringError: the spec cannot be moved into place.
    """
    spec = layer.GetPrimAtPath(path)
    if spec:
        del spec.nameParent.nameChildren[path.name]
    if not text:
        return
    anon = Sdf.Layer.CreateAnonymous(".usda")
    anon.ImportFromString(text)
    parent = Sdf.CreatePrimInLayer(layer, path.GetParentPath())
    tmp = parent.path.AppendChild(_RESTORE_NAME)
    Sdf.CopySpec(anon, path, layer, tmp)
    edit = Sdf.BatchNamespaceEdit()
    edit.Add(
        Sdf.NamespaceEdit.ReparentAndRename(
            tmp, parent.path, path.name, min(index, len(parent.nameChildren) - 1)
        )
    )
    if not layer.Apply(edit):
        raise AuthoringError(f"{layer.realPath}: cannot restore {path}")


def _prune(layer: Sdf.Layer, paths: list[str]) -> None:
    """Remove the given ancestor specs when an undo left them empty, deepest first."""
    for p in sorted(paths, key=len, reverse=True):
        spec = layer.GetPrimAtPath(p)
        if (
            spec
            and spec.specifier == Sdf.SpecifierOver
            and not spec.nameChildren
            and not spec.properties
            and set(spec.ListInfoKeys()) <= {"specifier"}
        ):
            if spec.nameParent:
                del spec.nameParent.nameChildren[spec.name]
            else:
                del layer.rootPrims[spec.name]


class StepRecorder:
    """Captures what a step's prims were before it, then appends its history and undo items.

    Create it before authoring (it captures the previous specs), call :meth:`record`
    after.

    Args:
        layer: the edits layer.
        paths: the prims the step touches.
    """

    def __init__(self, layer: Sdf.Layer, paths: list[Sdf.Path]) -> None:
        self.layer, self.paths = layer, paths
        self.created = [p for p in ANCESTORS if not layer.GetPrimAtPath(p)]
        self.captured = [capture(layer, p) for p in paths]

    def record(self, op: str, args: dict, time: str, violations: list[str]) -> int:
        """Append the step to the journal; returns its 1-based step number."""
        history, undo = read_journal(self.layer)
        entry = {
            "op": op,
            "args": args,
            "time": time,
            "forced": bool(violations),
            "violations": violations,
            "paths": [str(p) for p in self.paths],
        }
        inverse = {
            "before": [c[0] for c in self.captured],
            "index": [c[1] for c in self.captured],
            "created": self.created,
        }
        history.append(json.dumps(entry, sort_keys=True))
        undo.append(json.dumps(inverse, sort_keys=True))
        write_journal(self.layer, history, undo)
        return len(history)


def undo_last(layer: Sdf.Layer, steps: int) -> list[HistoryEntry]:
    """Undo the last ``steps`` steps in the layer (the caller checked that they exist).

    Returns:
        The entries undone, newest first.
    """
    history, undo = read_journal(layer)
    undone = []
    for _ in range(steps):
        entry = HistoryEntry.from_json(len(history), history.pop())
        inverse = json.loads(undo.pop())
        undone.append(entry)
        for p, text, index in reversed(list(zip(entry.paths, inverse["before"], inverse["index"]))):
            restore(layer, Sdf.Path(p), text, int(index))
        _prune(layer, list(inverse.get("created", ())))
    write_journal(layer, history, undo)
    return undone
