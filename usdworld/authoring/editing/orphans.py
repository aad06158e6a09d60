"""Edits whose target prim no longer exists in the composed world (e.g. after a rebuild)."""

from __future__ import annotations

from dataclasses import dataclass

from pxr import Sdf, Usd

from usdworld.authoring.editing.journal import entries
from usdworld.world_files import OBJECTS_PATH


@dataclass(frozen=True)
class OrphanEdit:
    """An edit whose target prim no longer exists.

    Attributes:
        path: prim path the edits layer holds opinions on.
        steps: history steps that touched it (its object's steps for a path inside an object).
        object_name: the object the path belongs to ('' when outside ``/World/Objects``);
            ``reset`` of that object drops the orphaned opinions.
    """

    path: str
    steps: tuple[int, ...]
    object_name: str = ""


def orphan_edits(stage: Usd.Stage, edits: Sdf.Layer) -> list[OrphanEdit]:
    """The ``over`` specs of ``edits`` with no defined prim in ``stage``, in layer order."""
    steps: dict[str, list[int]] = {}
    for entry in entries(edits):
        for p in entry.paths:
            steps.setdefault(p, []).append(entry.step)
    out: list[OrphanEdit] = []

    def visit(spec: Sdf.PrimSpec) -> None:
        prim = stage.GetPrimAtPath(spec.path)
        if spec.specifier == Sdf.SpecifierOver and (not prim or not prim.IsDefined()):
            owner = spec.path
            while owner.pathElementCount > 3:
                owner = owner.GetParentPath()
            inside = owner.GetParentPath() == Sdf.Path(OBJECTS_PATH)
            out.append(
                OrphanEdit(str(spec.path), tuple(steps.get(str(owner), ())), owner.name if inside else "")
            )
            return
        if prim and not prim.IsActive():
            return  # an inactive prim's children are not composed
        for child in spec.nameChildren:
            visit(child)

    for root in edits.rootPrims:
        visit(root)
    return out
