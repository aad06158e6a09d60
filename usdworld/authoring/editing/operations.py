"""The edit operations, each one transaction over the state reader and the edits layer.

What each authors in the edits layer:

=========  =======================================================================
move       ``double3 xformOp:translate`` (z follows the ground under the new point)
rotate     ``float xformOp:rotateZ`` (degrees)
delete     ``active = false`` (the prim stays, inactive)
add        ``def Xform "<class>_<NNNN>"`` with an explicit ``references`` list to
           ``../assets/<class>.usda`` (copied into the world when missing), the
           ``model`` variant, translate / rotateZ / scale ops, the ``class`` label and
           UsdWorldProvenanceAPI values marking it user-added
replace    another class: ``references = [@../assets/<new>.usda@]`` (an explicit list
           op), its label and scale; the same class: only the ``model`` variant selection
restyle    see :mod:`usdworld.authoring.editing.restyle`
reset      removes every opinion the edits layer holds on the object
=========  =======================================================================

An edit the rules of :mod:`usdworld.layout.permissible` refuse raises
:class:`~usdworld.errors.EditRefused` (``not_permissible``) and writes nothing;
``force=True`` applies it and records the rules overridden.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd

from usdworld.authoring import asset_library
from usdworld.authoring.editing import restyle as paint
from usdworld.authoring.editing.journal import StepRecorder, capture, restore
from usdworld.authoring.editing.state import ObjectState, WorldState, footprints, object_path
from usdworld.authoring.editing.transaction import EditsTransaction
from usdworld.errors import AuthoringError, EditRefused, InputError, RefusalReason
from usdworld.geometry.rotation import turned
from usdworld.io.class_table import ClassPrior, ClassTable
from usdworld.layout import permissible as rules
from usdworld.world_files import OBJECTS_PATH


@dataclass(frozen=True)
class EditResult:
    """What an edit did.

    Attributes:
        op: operation name.
        name: the object edited (for ``add``, the new name).
        step: its history step.
        forced: True when applied despite ``violations``.
        violations: the rules overridden (empty unless forced).
        message: one line for the user, e.g. ``moved car_0003 to (12.50, -3.00) on road``.
    """

    op: str
    name: str
    step: int
    forced: bool
    violations: tuple[str, ...]
    message: str


@dataclass(frozen=True)
class Editing:
    """What the operations work on (built once per editor).

    Attributes:
        stage: the composed world.
        tx: the edits layer's transactions.
        state: the state reader.
        classes: the class table.
        surface_rules: the surface rule table.
        replacement_rules: the replacement rule table.
        libraries: asset folders, the world's own first.
        assets_dir: the world's asset folder (``add``/``replace`` copy assets into it).
        clock: the time recorded in the history.
    """

    stage: Usd.Stage
    tx: EditsTransaction
    state: WorldState
    classes: ClassTable
    surface_rules: rules.SurfaceRules
    replacement_rules: rules.ReplacementRules
    libraries: tuple[Path, ...]
    assets_dir: Path
    clock: Callable[[], str]


def wrap_deg(d: float) -> float:
    """Degrees wrapped to (-180, 180], rounded to 1e-6."""
    r = math.fmod(d, 360.0)
    if r > 180.0:
        r -= 360.0
    elif r <= -180.0:
        r += 360.0
    return round(r, 6)


def _commit(
    ed: Editing,
    op: str,
    args: dict,
    paths: list[Sdf.Path],
    violations: list[rules.Violation],
    author: Callable[[], None],
) -> int:
    """Author one edit into the edits layer with its history entry and save it."""
    recorder = StepRecorder(ed.tx.layer, paths)
    with Usd.EditContext(ed.stage, Usd.EditTarget(ed.tx.layer)):
        author()
    step = recorder.record(op, args, ed.clock(), [str(v) for v in violations])
    ed.tx.save()
    return step


def _gate(op: str, name: str, violations: list[rules.Violation], force: bool) -> list[rules.Violation]:
    """The violations an edit overrides; raises when there are some and it is not forced."""
    if violations and not force:
        why = "; ".join(str(v) for v in violations)
        raise EditRefused(
            RefusalReason.NOT_PERMISSIBLE,
            f"{op} {name} refused: {why}; nothing was written",
            op=op,
            subject=name,
            violations=tuple(violations),
        )
    return violations


def _result(op: str, name: str, step: int, violations: list[rules.Violation], message: str) -> EditResult:
    if violations:
        message += f" (forced: {'; '.join(str(v) for v in violations)})"
    return EditResult(op, name, step, bool(violations), tuple(str(v) for v in violations), message)


def _xform_op(prim: Usd.Prim, op: str) -> Usd.Attribute:
    attr = prim.GetAttribute(f"xformOp:{op}")
    if not attr:
        raise AuthoringError(
            f"{prim.GetPath()}: no xformOp:{op}; usdworld edits need the translate/rotateZ/scale ops build writes"
        )
    return attr


def _prior(ed: Editing, op: str, class_name: str) -> ClassPrior:
    try:
        return ed.classes[class_name]
    except InputError as exc:
        raise EditRefused(
            RefusalReason.UNKNOWN_CLASS,
            str(exc),
            op=op,
            subject=class_name,
            choices=tuple(sorted(ed.classes)),
        ) from None


def _variant(ed: Editing, op: str, class_name: str, variant: str | None) -> str:
    info = asset_library.asset_info(class_name, ed.libraries)
    if variant is None:
        return info.default_variant
    if variant not in info.variants:
        raise EditRefused(
            RefusalReason.UNKNOWN_VARIANT,
            f"{class_name} has no variant '{variant}'; available: {', '.join(info.variants) or 'none'}",
            op=op,
            subject=class_name,
            field="variant",
            value=variant,
            choices=info.variants,
        )
    return variant


def _asset_ref(ed: Editing, class_name: str) -> str:
    """Relative reference from the edits layer to the world's asset (copied in when missing)."""
    target = ed.assets_dir / f"{class_name}.usda"
    if not target.is_file():
        from usdworld.authoring.world import copy_asset  # the world writer's pxr modules: only here

        copy_asset(asset_library.asset_path(class_name, ed.libraries), ed.assets_dir)
    return Path(os.path.relpath(target, ed.tx.path.parent)).as_posix()


def _finite(op: str, field: str, given: float | tuple[float, ...], message: str) -> None:
    """Refuse (``bad_value``) a number or tuple of numbers that is not all finite."""
    values = given if isinstance(given, tuple) else (given,)
    if not all(math.isfinite(c) for c in values):
        raise EditRefused(RefusalReason.BAD_VALUE, message, op=op, field=field, value=given)


def move(
    ed: Editing,
    name: str,
    *,
    to: tuple[float, float] | None = None,
    by: tuple[float, float] | None = None,
    force: bool = False,
) -> EditResult:
    """Move an object on the ground to ``to`` (x, y) or by ``by`` (dx, dy) metres; z follows the ground."""
    if to is not None and by is None:
        key, given = "to", to
    elif by is not None and to is None:
        key, given = "by", by
    else:
        raise EditRefused(
            RefusalReason.BAD_VALUE,
            "move: give exactly one of a target point (to) or a displacement (by)",
            op="move",
            subject=name,
            field="to",
        )
    _finite("move", key, tuple(given), f"move: {key} must be finite, got {tuple(given)}")
    with ed.tx.locked():
        obj = ed.state.one(name, op="move")
        xy = np.array(given if key == "to" else np.add(obj.position_world[:2], given), dtype=np.float64)
        states = ed.state.near(obj, xy)
        surface, z = ed.state.where(xy)
        yaw = math.radians(obj.yaw_deg)
        cand = rules.Candidate(obj.class_name, obj.footprint_centre(xy, yaw), np.array(obj.footprint_lw), yaw)
        others = footprints(states).without(obj.name)
        found = rules.check_placement(cand, others, ed.state.ground(), ed.surface_rules)
        v = _gate("move", obj.name, found, force)
        prim = ed.stage.GetPrimAtPath(obj.path)
        args = {"name": obj.name, key: [float(c) for c in given]}
        step = _commit(
            ed,
            "move",
            args,
            [prim.GetPath()],
            v,
            lambda: _xform_op(prim, "translate").Set(Gf.Vec3d(float(xy[0]), float(xy[1]), z)),
        )
        return _result(
            "move", obj.name, step, v, f"moved {obj.name} to ({xy[0]:.2f}, {xy[1]:.2f}) on {surface}"
        )


def _footprint_centre(
    origin_xy: np.ndarray, offset: tuple[float, float], scale: float, yaw_deg: float
) -> np.ndarray:
    """(2,) float64 centre of a new object's rule footprint: its origin plus its unscaled
    asset-frame ``offset`` (:meth:`~usdworld.authoring.editing.state.WorldState.footprint_offset`)
    at ``scale``, turned by ``yaw_deg``."""
    scaled = (offset[0] * scale, offset[1] * scale)
    return np.asarray(origin_xy, dtype=np.float64)[:2] + turned(scaled, math.radians(yaw_deg))


def rotate(ed: Editing, name: str, yaw_deg: float, *, force: bool = False) -> EditResult:
    """Set an object's yaw (rotation about Z) to ``yaw_deg`` degrees."""
    _finite("rotate", "yaw_deg", yaw_deg, f"rotate: yaw_deg must be finite, got {yaw_deg}")
    with ed.tx.locked():
        obj = ed.state.one(name, op="rotate")
        states = ed.state.near(obj, np.array(obj.position_world[:2]))
        yaw = wrap_deg(yaw_deg)
        centre = obj.footprint_centre(np.array(obj.position_world[:2]), math.radians(yaw))
        cand = rules.Candidate(obj.class_name, centre, np.array(obj.footprint_lw), math.radians(yaw))
        others = footprints(states).without(obj.name)
        found = rules.check_placement(cand, others, ed.state.ground(), ed.surface_rules, surface=False)
        v = _gate("rotate", obj.name, found, force)
        prim = ed.stage.GetPrimAtPath(obj.path)
        step = _commit(
            ed,
            "rotate",
            {"name": obj.name, "yaw_deg": float(yaw_deg)},
            [prim.GetPath()],
            v,
            lambda: _xform_op(prim, "rotateZ").Set(float(yaw)),
        )
        return _result("rotate", obj.name, step, v, f"rotated {obj.name} to {yaw:.1f} deg")


def delete(ed: Editing, name: str) -> EditResult:
    """Deactivate an object (``active = false``); the prim stays in the stage."""
    with ed.tx.locked():
        obj, _ = ed.state.find(name, op="delete")
        prim = ed.stage.GetPrimAtPath(obj.path)
        step = _commit(ed, "delete", {"name": obj.name}, [prim.GetPath()], [], lambda: prim.SetActive(False))
        return _result("delete", obj.name, step, [], f"deleted {obj.name} (inactive)")


def _default_yaw(
    ed: Editing, class_name: str, prior: ClassPrior, xy: np.ndarray, states: list[ObjectState]
) -> float:
    """The yaw of the class's habit: along the nearest object with the same road-aligned habit, facing the camera, or 0."""
    how = prior.yaw
    if how == "camera":
        return wrap_deg(math.degrees(math.atan2(-xy[1], -xy[0])))
    if how in ("road", "face_road"):
        road = [
            s
            for s in states
            if s.active and s.class_name in ed.classes and ed.classes[s.class_name].yaw == how
        ]
        same = [s for s in road if s.class_name == class_name] or road
        if same:
            near = min(same, key=lambda s: (math.dist(s.position_world[:2], xy), s.name))
            return near.yaw_deg
    return 0.0


def _next_name(ed: Editing, class_name: str) -> str:
    taken = [c.GetName() for c in ed.stage.GetPrimAtPath(OBJECTS_PATH).GetAllChildren()]
    spec = ed.tx.layer.GetPrimAtPath(OBJECTS_PATH)
    if spec:
        taken += list(spec.nameChildren.keys())
    pat = re.compile(rf"^{re.escape(class_name)}_(\d+)$")
    numbers = [int(m.group(1)) for m in map(pat.match, taken) if m]
    return f"{class_name}_{max(numbers, default=0) + 1:04d}"


def add(
    ed: Editing,
    class_name: str,
    at: tuple[float, float],
    *,
    variant: str | None = None,
    yaw_deg: float | None = None,
    force: bool = False,
) -> EditResult:
    """Add an object of ``class_name`` at ``at`` (x, y), scaled like its neighbours of the class."""
    values = (*at, *(() if yaw_deg is None else (yaw_deg,)))
    _finite(
        "add", "at", values, f"add: position and yaw must be finite, got at={tuple(at)}, yaw_deg={yaw_deg}"
    )
    prior = _prior(ed, "add", class_name)
    with ed.tx.locked():
        variant = _variant(ed, "add", class_name, variant)
        states = ed.state.all()
        others = footprints(states)
        xy = np.array(at, dtype=np.float64)
        yaw = wrap_deg(yaw_deg) if yaw_deg is not None else _default_yaw(ed, class_name, prior, xy, states)
        scale = rules.neighbour_scale(class_name, xy, others, prior.scale_range)
        length, width = ed.state.footprint_size(class_name, variant)
        centre = _footprint_centre(xy, ed.state.footprint_offset(class_name, variant), scale, yaw)
        size = np.array([length * scale, width * scale])
        cand = rules.Candidate(class_name, centre, size, math.radians(yaw))
        name = _next_name(ed, class_name)
        v = _gate(
            "add", name, rules.check_placement(cand, others, ed.state.ground(), ed.surface_rules), force
        )
        surface, z = ed.state.where(xy)
        ref = _asset_ref(ed, class_name)
        path = Sdf.Path(OBJECTS_PATH).AppendChild(name)

        def author() -> None:
            from usdworld.authoring.editing.user_object import author_user_object  # with UsdSemantics

            author_user_object(
                ed.stage, path, class_name, ref, variant, (float(xy[0]), float(xy[1]), z), yaw, scale
            )

        args = {
            "class": class_name,
            "at": [float(c) for c in at],
            "variant": variant,
            "yaw_deg": yaw_deg,
            "name": name,
        }
        step = _commit(ed, "add", args, [path], v, author)
        return _result(
            "add",
            name,
            step,
            v,
            f"added {name} ({class_name} {variant}, scale {scale:.2f}) at ({xy[0]:.2f}, {xy[1]:.2f}) on {surface}",
        )


def replace(
    ed: Editing, name: str, with_class: str, *, variant: str | None = None, force: bool = False
) -> EditResult:
    """Replace an object by another class (explicit reference list) or another variant of its own."""
    prior = _prior(ed, "replace", with_class)
    with ed.tx.locked():
        obj, states = ed.state.find(name, op="replace")
        same = with_class == obj.class_name
        if same and variant is None:
            info = asset_library.asset_info(with_class, ed.libraries)
            raise EditRefused(
                RefusalReason.SAME_CLASS,
                f"replace {obj.name}: it is already a {with_class}; name a variant "
                f"(one of {', '.join(info.variants) or 'none'})",
                op="replace",
                subject=obj.name,
                field="with",
                value=with_class,
                choices=info.variants,
            )
        variant = _variant(ed, "replace", with_class, variant)
        others = footprints(states).without(obj.name)
        xy = np.array(obj.position_world[:2])
        if same:
            scale = obj.scale
        else:
            fallback = float(np.clip(obj.scale, *prior.scale_range))
            scale = rules.neighbour_scale(with_class, xy, others, prior.scale_range, fallback)
        length, width = ed.state.footprint_size(with_class, variant)
        centre = _footprint_centre(xy, ed.state.footprint_offset(with_class, variant), scale, obj.yaw_deg)
        cand = rules.Candidate(
            with_class, centre, np.array([length * scale, width * scale]), math.radians(obj.yaw_deg)
        )
        found = rules.replacement_violations(obj.class_name, with_class, ed.replacement_rules)
        found += rules.check_placement(cand, others, ed.state.ground(), ed.surface_rules)
        v = _gate("replace", obj.name, found, force)
        ref = None if same else _asset_ref(ed, with_class)
        prim = ed.stage.GetPrimAtPath(obj.path)

        def author() -> None:
            from usdworld.authoring.editing.user_object import set_label  # with UsdSemantics

            paint.clear_restyle(ed.tx.layer, prim)
            if ref is not None:
                prim.GetReferences().SetReferences([Sdf.Reference(ref)])
                set_label(prim, with_class)
                _xform_op(prim, "scale").Set(Gf.Vec3f(scale, scale, scale))
                if prim.HasAttribute("usdworld:scaleFactor"):
                    prim.GetAttribute("usdworld:scaleFactor").Set(float(scale))
            if variant:
                prim.GetVariantSets().SetSelection(asset_library.VARIANT_SET, variant)
            if obj.color:
                paint.apply_restyle(prim, obj.color)
            elif same:
                # The base layer colours the built variant's paint only: the photo's colour
                # goes onto the new variant's paint here (a restyle, above, wins over it).
                paint.apply_photo_colour(prim)

        args = {"name": obj.name, "with": with_class, "variant": variant}
        step = _commit(ed, "replace", args, [prim.GetPath()], v, author)
        what = f"{with_class} {variant}".strip()
        return _result(
            "replace",
            obj.name,
            step,
            v,
            f"replaced {obj.name} ({obj.class_name} {obj.variant}) with {what}, scale {scale:.2f}",
        )


def restyle(ed: Editing, name: str, color: str) -> EditResult:
    """Recolour an object's paint (see :mod:`usdworld.authoring.editing.restyle`)."""
    _, hexed = paint.parse_color(color)
    with ed.tx.locked():
        obj, _ = ed.state.find(name, op="restyle")
        prim = ed.stage.GetPrimAtPath(obj.path)
        if prim.IsInstance():
            raise EditRefused(
                RefusalReason.NOT_EDITABLE,
                f"{obj.name} is instanceable; its materials cannot be overridden per object",
                op="restyle",
                subject=obj.name,
            )
        materials, meshes = paint.restyle_targets(prim)
        if not materials and not meshes:
            raise EditRefused(
                RefusalReason.NOT_EDITABLE,
                f"{obj.name}: its asset has no materials or meshes to recolour",
                op="restyle",
                subject=obj.name,
            )

        def author() -> None:
            paint.clear_restyle(ed.tx.layer, prim)
            paint.apply_restyle(prim, hexed)

        step = _commit(ed, "restyle", {"name": obj.name, "color": hexed}, [prim.GetPath()], [], author)
        parts = ", ".join(m.GetPrim().GetName() for m in materials) or "display colour"
        return _result("restyle", obj.name, step, [], f"restyled {obj.name} {hexed} ({parts})")


def reset(ed: Editing, name: str, *, force: bool = False) -> EditResult:
    """Drop every edit of one object (an added object disappears)."""
    path = object_path(name)
    layer = ed.tx.layer
    ed.state.unmask()  # the object may be anywhere, or gone
    with ed.tx.locked():
        if not layer.GetPrimAtPath(path):
            raise EditRefused(
                RefusalReason.NOTHING_TO_RESET,
                f"{path.name} has no edits to reset",
                op="reset",
                subject=path.name,
            )
        text, index = capture(layer, path)
        restore(layer, path, "", -1)
        prim = ed.stage.GetPrimAtPath(path)
        found: list[rules.Violation] = []
        if prim and prim.IsDefined() and prim.IsActive():
            states = ed.state.all()
            obj = next(s for s in states if s.path == str(path))
            cand = rules.Candidate(
                obj.class_name,
                obj.footprint_centre(np.array(obj.position_world[:2]), math.radians(obj.yaw_deg)),
                np.array(obj.footprint_lw),
                math.radians(obj.yaw_deg),
            )
            found = rules.fit_violations(cand, footprints(states).without(obj.name))
        restore(layer, path, text, index)
        v = _gate("reset", path.name, found, force)
        step = _commit(ed, "reset", {"name": path.name}, [path], v, lambda: restore(layer, path, "", -1))
        return _result("reset", path.name, step, v, f"reset {path.name} to the base")
