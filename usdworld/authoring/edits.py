"""Non-destructive editing of a world (paper step 4): every edit is an opinion in its edits layer.

A world's root layer (``world.usda``) stacks ``layers/edits.usda`` over ``layers/base.usda``.
:class:`WorldEditor` writes through a USD edit target on the root's **first** sublayer
only, so the base and the root stay byte-identical, a rebuild of the base keeps the
user's edits, and every DCC tool sees them. The same editor works on a variation root
written by ``usdworld vary`` (its first sublayer is the variation's own edits layer).

Operations and what they author in the edits layer:

=========  =======================================================================
move       ``double3 xformOp:translate`` (z follows the ground under the new point)
rotate     ``float xformOp:rotateZ`` (degrees)
delete     ``active = false`` (the prim stays, inactive)
add        ``def Xform "<class>_<NNNN>"`` with an explicit ``references`` list to
           ``../assets/<class>.usda`` (copied into the world when missing), the
           ``model`` variant, translate / rotateZ / scale ops, the ``class`` label and
           UsdWorldProvenanceAPI values marking it user-added (``depthMethod`` and
           ``yawSource`` = ``user``, no source image)
replace    another class: ``references = [@../assets/<new>.usda@]`` (an explicit list
           op, so the old asset is no longer composed), its label and scale; the same
           class: only the ``model`` variant selection
restyle    ``inputs:diffuseColor`` of the object's own paint materials (UsdPreviewSurface:
           usdworld's renderer, usdview/Storm, Omniverse, Blender, Unity and Unreal
           importers) and ``primvars:displayColor`` of the meshes bound to them (viewers
           that show display colours); the colour is recorded in the prim's
           customData ``usdworld:restyleColor`` and re-applied after a replacement
reset      removes every opinion the edits layer holds on the object
=========  =======================================================================

Each edit is one transaction: an exclusive ``fcntl.flock`` on ``<edits layer>.lock``,
re-reading the layer if another editor changed it, the permissibility rules of
:mod:`usdworld.layout.permissible` (refused edits raise :class:`LayoutError` and write
nothing; ``force=True`` applies them and records the rules overridden), the authoring,
a history entry, and an atomic save (temporary file in the same folder, fsync, rename).

History lives in the edits layer itself, in ``customLayerData["usdworld"]``: ``history``
holds one JSON object per step (operation, arguments, UTC time, forced, the violated
rules, the prims touched) and ``undo`` the step's inverse: for each prim it touched, the
edits layer's previous spec of it as usda text, its position among its siblings and
the ancestor specs the step created. ``undo`` puts those specs back (plain Sdf edits of
the same layer), so the layer, and with it the composed stage, becomes byte-identical
to what it was before the step; the history travels with the layer through rebuilds.
Opinions written into the edits layer by other tools (a DCC) are kept, but an undo of a
step restores that step's prims as the step found them.

The lock is a blocking ``flock``: a waiting editor is woken as soon as the holder is
done (no starvation), and a crashed editor's lock goes away with its process. A
``WorldEditor`` is not thread-safe; give each thread its own.

Example::

    editor = WorldEditor("out/world.usda")
    editor.move("car_0003", to=(12.5, -3.0))
    editor.replace("car_0003", "bus")          # LayoutError: fit: overlaps car_0005 by 0.80 m
    editor.undo()
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import math
import os
import re
import weakref
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from datetime import UTC, datetime
from fnmatch import fnmatch
from pathlib import Path
from typing import Any, Self

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdSemantics, UsdShade, Vt

from usdworld.atomic import write_text_atomic
from usdworld.authoring import asset_library
from usdworld.authoring.asset_measures import variant_measures
from usdworld.authoring.provenance import PROVENANCE_API, apply_with_values
from usdworld.authoring.stages import open_stage
from usdworld.authoring.world import ASSETS_DIR, GROUND_PATH, OBJECTS_PATH, ROOT_LAYER, copy_asset
from usdworld.errors import AuthoringError, InputError, LayoutError, OutputError
from usdworld.layout import permissible as rules
from usdworld.layout.priors import class_priors, prior_for
from usdworld.perception.objects import TRUNK_CLASSES

#: customLayerData key of usdworld's data in an edits layer, and the two arrays below it:
#: ``history`` (one JSON object per step: op, args, time, forced, violations, paths) and
#: ``undo`` (per step: the previous specs of those paths, their sibling index, and the
#: ancestor specs the step created).
DATA_KEY = "usdworld"
HISTORY_KEY = "history"
UNDO_KEY = "undo"
#: Prim customData key holding an object's restyle colour (``#rrggbb``).
COLOR_KEY = "usdworld:restyleColor"
#: Material names recoloured by ``restyle`` (fnmatch patterns), in priority order of
#: meaning: vehicle paint, frames, clothing, foliage, walls. When an asset has none of
#: them, all its materials are recoloured.
RESTYLE_MATERIALS = (
    "paint_*",
    "body*",
    "frame_*",
    "jacket",
    "shirt",
    "helmet",
    "leaves",
    "needles",
    "wall",
    "curtain_wall",
    "housing",
    "sign_blue",
    "cardboard",
)
#: Surface meshes of a world and the surface name each stands for.
GROUND_MESHES = {"road": f"{GROUND_PATH}/Road", "sidewalk": f"{GROUND_PATH}/Sidewalk"}
#: Name a restored spec is written under before it is moved into place.
_RESTORE_NAME = "_usdworld_restore"
_HEX = re.compile(r"^#?([0-9a-fA-F]{6}|[0-9a-fA-F]{3})$")
_ANCESTORS = ("/World", OBJECTS_PATH)


def utc_now() -> str:
    """Current UTC time, ISO 8601 with milliseconds (the history's clock)."""
    return datetime.now(UTC).isoformat(timespec="milliseconds")


def parse_color(text: str) -> tuple[tuple[float, float, float], str]:
    """An sRGB hex colour -> (linear RGB, normalised ``#rrggbb``).

    Raises:
        InputError: not ``#rrggbb`` or ``#rgb``.
    """
    m = _HEX.match(text.strip())
    if not m:
        raise InputError(f"--color: expected a hex colour like '#c03030', got '{text}'")
    h = m.group(1).lower()
    if len(h) == 3:
        h = "".join(c * 2 for c in h)
    srgb = np.array([int(h[i : i + 2], 16) / 255.0 for i in (0, 2, 4)])
    lin = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    return (float(lin[0]), float(lin[1]), float(lin[2])), f"#{h}"


def atomic_write_text(path: Path, text: str) -> None:
    """Write a layer so that readers see the old or the new content, never a mix (flushed to disk)."""
    write_text_atomic(path, text, fsync=True)


class _FileLock:
    """Exclusive ``fcntl.flock`` on a lock file, waiting (blocking) for other editors.

    A blocked waiter is woken by the kernel as soon as the holder releases, so a busy
    editor cannot starve another one; the lock goes away with its holder's process, so a
    crashed editor never leaves the world locked.
    """

    def __init__(self, path: Path) -> None:
        self.path, self.fd = path, -1

    def __enter__(self) -> Self:
        try:
            self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise AuthoringError(
                f"{self.path}: cannot create the edit lock ({exc.strerror}); is the folder writable?"
            ) from exc
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX)
        except BaseException:
            os.close(self.fd)
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        fcntl.flock(self.fd, fcntl.LOCK_UN)
        os.close(self.fd)


@dataclass(frozen=True)
class ObjectState:
    """One object of the composed world.

    Attributes:
        name: prim name, e.g. ``car_0003``.
        path: prim path.
        class_name: its ``class`` label.
        variant: its ``model`` variant ('' when the asset has none).
        position_world: (x, y, z) of its origin, metres.
        yaw_deg: rotation about Z, degrees.
        scale: uniform scale (the height's, for a footprint stretched along its axes).
        size_lw: scaled footprint (length, width), metres.
        footprint_lw: scaled footprint the permissibility rules use: ``size_lw``, but the
            trunk's or post's for trees, poles and signs (people stand under crowns, lamp
            arms and sign plates, as the build lets them).
        active: False once deleted.
        status: ``base`` (untouched), ``edited``, ``added`` or ``deleted``.
        color: restyle colour ``#rrggbb`` or ''.
    """

    name: str
    path: str
    class_name: str
    variant: str
    position_world: tuple[float, float, float]
    yaw_deg: float
    scale: float
    size_lw: tuple[float, float]
    footprint_lw: tuple[float, float]
    active: bool
    status: str
    color: str = ""


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
class OrphanEdit:
    """An edit whose target prim no longer exists (e.g. after a rebuild).

    Attributes:
        path: prim path the edits layer holds opinions on.
        steps: history steps that touched it (its object's steps for a path inside an object).
        object_name: the object the path belongs to ('' when outside ``/World/Objects``);
            ``reset`` of that object drops the orphaned opinions.
    """

    path: str
    steps: tuple[int, ...]
    object_name: str = ""


def _gf3(v: Any) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _wrap_deg(d: float) -> float:
    """Degrees wrapped to (-180, 180], rounded to 1e-6."""
    r = math.fmod(d, 360.0)
    if r > 180.0:
        r -= 360.0
    elif r <= -180.0:
        r += 360.0
    return round(r, 6)


class WorldEditor:
    """Edits one world through its edits layer; all operations of ``usdworld edit``.

    Keep one editor open for many edits (a web editor, a script): the stage stays
    composed between transactions, and each transaction re-reads the edits layer only
    when another editor changed it.

    Args:
        world: the root layer (``world.usda``, or a variation root) or a world folder.
        surface_rules: a surface rule table (default ``$USDWORLD_SURFACE_RULES`` or the shipped one).
        replacement_rules: a replacement rule table (likewise).
        library: a user asset library for classes the world has no asset for yet.
        clock: returns the time recorded in the history (``lambda: ""`` for reproducible layers).
    """

    def __init__(
        self,
        world: Path | str,
        *,
        surface_rules: Path | str | None = None,
        replacement_rules: Path | str | None = None,
        library: Path | str | None = None,
        clock: Callable[[], str] = utc_now,
    ) -> None:
        root = Path(world)
        if root.is_dir():
            root = root / ROOT_LAYER
        if not root.is_file():
            raise InputError(
                f"{root}: no such world; pass the world's root layer (e.g. OUT/world.usda) or its folder"
            )
        self.root = root
        self.surface_rules = rules.load_surface_rules(surface_rules)
        self.replacement_rules = rules.load_replacement_rules(replacement_rules)
        self._clock = clock
        self._stage = open_stage(root, "USD world")
        sublayers = list(self._stage.GetRootLayer().subLayerPaths)
        if len(sublayers) < 2:
            raise AuthoringError(
                f"{root}: needs an edits layer over a base layer (subLayers), found {sublayers}; "
                "rebuild the world"
            )
        layers = [self._find_layer(p) for p in sublayers]
        self.edits_path = Path(layers[0].realPath)
        self.base_paths = tuple(Path(layer.realPath) for layer in layers[1:])
        self._edits = layers[0]
        for layer in [self._stage.GetRootLayer(), *layers]:
            layer.Reload()  # a layer another stage of this process holds may be stale on disk
        self.assets_dir = self.base_paths[-1].parent.parent / ASSETS_DIR
        self._libraries = (self.assets_dir, *asset_library.library_dirs(Path(library) if library else None))
        self._lock_path = self.edits_path.with_name(self.edits_path.name + ".lock")
        self._synced: bytes | None = None
        self._base_stamp = self._stamp()
        self._sizes: dict[tuple[str, str], tuple[float, float]] = {}
        self._trunk_sizes: dict[tuple[str, str], tuple[float, float]] = {}
        self._ground: rules.Ground | None = None
        self._states: dict[str, ObjectState] | None = None
        self._stale: set[str] = set()
        me = weakref.ref(self)  # the listener must not keep the editor alive

        def on_change(notice: Usd.Notice.ObjectsChanged, stage: Usd.Stage) -> None:
            editor = me()
            if editor is not None:
                editor._changed(notice, stage)

        self._on_change = on_change  # Tf holds Python callbacks weakly
        self._listener = Tf.Notice.Register(Usd.Notice.ObjectsChanged, on_change, self._stage)
        if not self._stage.GetPrimAtPath(OBJECTS_PATH):
            raise AuthoringError(f"{root}: no {OBJECTS_PATH} scope; not a usdworld world")

    def close(self) -> None:
        """Stop listening and release the stage (the editor is unusable afterwards)."""
        self._listener.Revoke()
        self._stage = None  # type: ignore[assignment]

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- layers, lock, transactions ------------------------------------------------

    def _find_layer(self, sub: str) -> Sdf.Layer:
        root = self._stage.GetRootLayer()
        path = root.ComputeAbsolutePath(sub)
        layer = Sdf.Layer.Find(path) or Sdf.Layer.FindOrOpen(path)
        if layer is None or not layer.realPath:
            raise AuthoringError(f"{self.root}: sublayer {sub} is missing or not a file; rebuild the world")
        return layer

    @property
    def stage(self) -> Usd.Stage:
        """The composed stage (read it; write only through the editor's operations)."""
        return self._stage

    def _stamp(self) -> tuple:
        out = []
        for p in (self.root, *self.base_paths):
            st = p.stat()
            out.append((st.st_ino, st.st_mtime_ns, st.st_size))
        return tuple(out)

    def _sync(self) -> None:
        """Bring the in-memory layers in line with the files (other editors, rebuilds)."""
        stamp = self._stamp()
        if stamp != self._base_stamp:
            for p in (self.root, *self.base_paths):
                layer = Sdf.Layer.Find(str(p))
                if layer is not None:
                    layer.Reload(force=True)
            self._base_stamp, self._ground, self._states = stamp, None, None
            self._sizes, self._trunk_sizes = {}, {}
        for stale in self.edits_path.parent.glob(f".{self.edits_path.name}.*.tmp"):
            with contextlib.suppress(OSError):
                stale.unlink()  # a writer that died mid-save (we hold the lock)
        try:
            data = self.edits_path.read_bytes()
        except OSError as exc:
            raise AuthoringError(
                f"{self.edits_path}: cannot read the edits layer ({exc.strerror}); rebuild the world"
            ) from exc
        if data != self._synced:
            if self._edits.ExportToString().encode("utf-8") != data:
                try:
                    self._edits.ImportFromString(data.decode("utf-8"))
                except (Tf.ErrorException, UnicodeDecodeError) as exc:
                    raise AuthoringError(
                        f"{self.edits_path}: not a readable usda layer; restore it from a backup, or write "
                        "'#usda 1.0' into it to drop all edits"
                    ) from exc
            self._synced = data

    @contextlib.contextmanager
    def _locked(self) -> Iterator[None]:
        with _FileLock(self._lock_path):
            self._sync()
            try:
                yield
            except BaseException:
                if self._edits.ExportToString().encode("utf-8") != self._synced:
                    self._edits.ImportFromString((self._synced or b"#usda 1.0\n").decode("utf-8"))
                raise

    def _save(self) -> None:
        text = self._edits.ExportToString()
        try:
            atomic_write_text(self.edits_path, text)
        except OutputError as exc:
            cause = exc.__cause__
            reason = cause.strerror if isinstance(cause, OSError) and cause.strerror else str(exc)
            raise AuthoringError(
                f"{self.edits_path}: cannot save the edits ({reason}); nothing was changed"
            ) from exc
        self._synced = text.encode("utf-8")

    # --- history ---------------------------------------------------------------------

    def _journal(self) -> tuple[list[str], list[str]]:
        """The history and undo arrays (one JSON string per step, oldest first)."""
        data = self._edits.customLayerData.get(DATA_KEY, {})
        history, undo = list(data.get(HISTORY_KEY, ())), list(data.get(UNDO_KEY, ()))
        if len(history) != len(undo):
            raise AuthoringError(
                f"{self.edits_path}: customLayerData {DATA_KEY} history and undo differ in length; "
                "the layer was edited by hand"
            )
        return history, undo

    def _set_journal(self, history: list[str], undo: list[str]) -> None:
        cld = dict(self._edits.customLayerData)
        data = {k: v for k, v in dict(cld.get(DATA_KEY, {})).items() if k not in (HISTORY_KEY, UNDO_KEY)}
        if history:
            data[HISTORY_KEY], data[UNDO_KEY] = Vt.StringArray(history), Vt.StringArray(undo)
        if data:
            cld[DATA_KEY] = data
        else:
            cld.pop(DATA_KEY, None)
        if cld:
            self._edits.customLayerData = cld
        else:
            self._edits.ClearCustomLayerData()

    @staticmethod
    def _entry(step: int, text: str) -> HistoryEntry:
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

    def history(self) -> list[HistoryEntry]:
        """Every recorded edit, oldest first."""
        with self._locked():
            return [self._entry(i + 1, h) for i, h in enumerate(self._journal()[0])]

    def _capture(self, path: Sdf.Path) -> tuple[str, int]:
        """The edits layer's spec of ``path`` as usda text ('' when none) and its sibling index."""
        spec = self._edits.GetPrimAtPath(path)
        if not spec:
            return "", -1
        anon = Sdf.Layer.CreateAnonymous(".usda")
        Sdf.CreatePrimInLayer(anon, path.GetParentPath())
        Sdf.CopySpec(self._edits, path, anon, path)
        return anon.ExportToString(), list(spec.nameParent.nameChildren.keys()).index(path.name)

    def _restore(self, path: Sdf.Path, text: str, index: int) -> None:
        spec = self._edits.GetPrimAtPath(path)
        if spec:
            del spec.nameParent.nameChildren[path.name]
        if not text:
            return
        anon = Sdf.Layer.CreateAnonymous(".usda")
        anon.ImportFromString(text)
        parent = Sdf.CreatePrimInLayer(self._edits, path.GetParentPath())
        tmp = parent.path.AppendChild(_RESTORE_NAME)
        Sdf.CopySpec(anon, path, self._edits, tmp)
        edit = Sdf.BatchNamespaceEdit()
        edit.Add(
            Sdf.NamespaceEdit.ReparentAndRename(
                tmp, parent.path, path.name, min(index, len(parent.nameChildren) - 1)
            )
        )
        if not self._edits.Apply(edit):
            raise AuthoringError(f"{self.edits_path}: cannot restore {path}")

    def _prune(self, paths: list[str]) -> None:
        """Remove the given ancestor specs when an undo left them empty, deepest first."""
        for p in sorted(paths, key=len, reverse=True):
            spec = self._edits.GetPrimAtPath(p)
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
                    del self._edits.rootPrims[spec.name]

    def _commit(
        self,
        op: str,
        args: dict,
        paths: list[Sdf.Path],
        violations: list[rules.Violation],
        author: Callable[[], None],
    ) -> int:
        """Author one edit into the edits layer with its history entry and save it."""
        created = [p for p in _ANCESTORS if not self._edits.GetPrimAtPath(p)]
        captured = [self._capture(p) for p in paths]
        with Usd.EditContext(self._stage, Usd.EditTarget(self._edits)):
            author()
        history, undo = self._journal()
        entry = {
            "op": op,
            "args": args,
            "time": self._clock(),
            "forced": bool(violations),
            "violations": [str(v) for v in violations],
            "paths": [str(p) for p in paths],
        }
        inverse = {"before": [c[0] for c in captured], "index": [c[1] for c in captured], "created": created}
        history.append(json.dumps(entry, sort_keys=True))
        undo.append(json.dumps(inverse, sort_keys=True))
        self._set_journal(history, undo)
        self._save()
        return len(history)

    def undo(self, steps: int = 1) -> list[HistoryEntry]:
        """Undo the last ``steps`` edits, restoring the exact previous edits layer.

        Returns:
            The entries undone, newest first.

        Raises:
            InputError: fewer than ``steps`` edits are recorded.
        """
        if steps < 1:
            raise InputError(f"undo: N must be >= 1, got {steps}")
        with self._locked():
            history, undo = self._journal()
            if steps > len(history):
                raise InputError(f"undo {steps}: only {len(history)} edit(s) recorded in {self.edits_path}")
            undone = []
            for _ in range(steps):
                entry = self._entry(len(history), history.pop())
                inverse = json.loads(undo.pop())
                undone.append(entry)
                for p, text, index in reversed(list(zip(entry.paths, inverse["before"], inverse["index"]))):
                    self._restore(Sdf.Path(p), text, int(index))
                self._prune(list(inverse.get("created", ())))
            self._set_journal(history, undo)
            self._save()
            return undone

    # --- reading the world -----------------------------------------------------------

    def _size(self, class_name: str, variant: str) -> tuple[float, float]:
        key = (class_name, variant)
        if key not in self._sizes:
            try:
                info = asset_library.asset_info(class_name, self._libraries)
                size = info.size_by_variant.get(variant, info.default_size)
            except InputError:
                size = prior_for(class_name).size_m if class_name in class_priors() else (1.0, 1.0, 1.0)
            self._sizes[key] = (float(size[0]), float(size[1]))
        return self._sizes[key]

    def _footprint_size(self, class_name: str, variant: str) -> tuple[float, float]:
        """Unscaled footprint for the rules: the trunk's or post's for trees, poles and
        signs (as the build's collisions)."""
        if class_name not in TRUNK_CLASSES:
            return self._size(class_name, variant)
        key = (class_name, variant)
        if key not in self._trunk_sizes:
            try:
                half = variant_measures(class_name, variant or None, self._libraries).contact_half
                self._trunk_sizes[key] = (2.0 * half[0], 2.0 * half[1])
            except InputError:
                self._trunk_sizes[key] = self._size(class_name, variant)
        return self._trunk_sizes[key]

    def _read(self, prim: Usd.Prim) -> ObjectState:
        name = prim.GetName()
        labels = (
            prim.GetAttribute("semantics:labels:class").Get()
            if prim.HasAttribute("semantics:labels:class")
            else None
        )
        class_name = str(labels[0]) if labels else name.rsplit("_", 1)[0]
        vsets = prim.GetVariantSets()
        variant = (
            vsets.GetVariantSelection(asset_library.VARIANT_SET)
            if vsets.HasVariantSet(asset_library.VARIANT_SET)
            else ""
        )
        t, r, s = (prim.GetAttribute(f"xformOp:{op}") for op in ("translate", "rotateZ", "scale"))
        if t and r and s:
            pos, yaw, axes = _gf3(t.Get()), float(r.Get()), _gf3(s.Get())
        else:
            m = UsdGeom.Xformable(prim).GetLocalTransformation()
            pos = _gf3(m.ExtractTranslation())
            yaw = math.degrees(math.atan2(m[0][1], m[0][0]))
            axes = tuple(float(Gf.Vec3d(m[i][0], m[i][1], m[i][2]).GetLength()) for i in range(3))
        # A facade's footprint may be stretched (its unseen depth): the height's is the
        # object's uniform scale, the footprint takes each axis's own.
        sx, sy, scale = axes
        length, width = self._size(class_name, variant)
        foot_l, foot_w = self._footprint_size(class_name, variant)
        spec = self._edits.GetPrimAtPath(prim.GetPath())
        active = prim.IsActive()
        status = (
            "deleted"
            if not active
            else ("added" if spec and spec.specifier == Sdf.SpecifierDef else ("edited" if spec else "base"))
        )
        color = str(prim.GetCustomDataByKey(COLOR_KEY) or "")
        return ObjectState(
            name,
            str(prim.GetPath()),
            class_name,
            variant,
            pos,
            yaw,
            scale,
            (length * sx, width * sy),
            (foot_l * sx, foot_w * sy),
            active,
            status,
            color,
        )

    def _changed(self, notice: Usd.Notice.ObjectsChanged, stage: Usd.Stage) -> None:
        """Mark the objects a stage change touched (or all, when their parent changed)."""
        objects, ground = Sdf.Path(OBJECTS_PATH), Sdf.Path(GROUND_PATH)
        for resync, paths in ((True, notice.GetResyncedPaths()), (False, notice.GetChangedInfoOnlyPaths())):
            for path in paths:
                prim = path.GetPrimPath()
                if prim.HasPrefix(ground) or (resync and ground.HasPrefix(prim)):
                    self._ground = None
                if self._states is None:
                    continue
                if prim.HasPrefix(objects) and prim != objects:
                    while prim.GetParentPath() != objects:
                        prim = prim.GetParentPath()
                    self._stale.add(str(prim))
                elif resync and objects.HasPrefix(prim):
                    self._states = None

    def _all(self) -> list[ObjectState]:
        """Every defined object; cached, re-read only where the stage changed."""
        if self._states is not None and self._stale:
            for path in self._stale:
                prim = self._stage.GetPrimAtPath(path)
                if path not in self._states or not prim or not prim.IsDefined():
                    self._states = None  # an object appeared or vanished: re-read all, in stage order
                    break
                self._states[path] = self._read(prim)
        if self._states is None:
            objects = self._stage.GetPrimAtPath(OBJECTS_PATH)
            self._states = {
                str(p.GetPath()): self._read(p) for p in objects.GetAllChildren() if p.IsDefined()
            }
        self._stale = set()
        return list(self._states.values())

    def objects(self) -> list[ObjectState]:
        """Every object (deleted ones too), in stage order."""
        with self._locked():
            return self._all()

    @staticmethod
    def _footprints(states: list[ObjectState]) -> rules.Footprints:
        live = [s for s in states if s.active]
        return rules.Footprints(
            tuple(s.name for s in live),
            tuple(s.class_name for s in live),
            np.array([s.position_world[:2] for s in live], dtype=np.float64).reshape(-1, 2),
            np.array([s.footprint_lw for s in live], dtype=np.float64).reshape(-1, 2),
            np.radians([s.yaw_deg for s in live]),
            np.array([s.scale for s in live], dtype=np.float64),
        )

    def ground(self) -> rules.Ground:
        """Top faces of the ground meshes and the ground extent (cached until a rebuild)."""
        if self._ground is None:
            tris = {}
            cache = UsdGeom.XformCache()
            for name, path in GROUND_MESHES.items():
                prim = self._stage.GetPrimAtPath(path)
                if not prim or not prim.IsA(UsdGeom.Mesh):
                    continue
                mesh = UsdGeom.Mesh(prim)
                pts = np.asarray(mesh.GetPointsAttr().Get(), dtype=np.float64).reshape(-1, 3)
                counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get(), dtype=np.int64)
                idx = np.asarray(mesh.GetFaceVertexIndicesAttr().Get(), dtype=np.int64)
                if len(pts) == 0 or len(counts) == 0:
                    continue
                m = np.asarray(cache.GetLocalToWorldTransform(prim), dtype=np.float64)
                pts = pts @ m[:3, :3] + m[3, :3]
                tris[name] = rules.top_faces(pts, _fan(counts, idx))
            # The objects the build placed stand on the scene's ground too (buildings behind
            # the sidewalks, beyond the ground meshes); without meshes they make the extent.
            built = self._footprints([st for st in self._all() if st.status != "added"])
            fallback = placed = None
            if len(built):
                h = 0.5 * built.size_lw.max(axis=1, keepdims=True)
                placed = np.array([(built.centers - h).min(axis=0), (built.centers + h).max(axis=0)])
                if not tris:
                    fallback = placed + np.array([[-1.0], [1.0]]) * rules.NO_MESH_MARGIN_M
            self._ground = rules.make_ground(tris, fallback, placed)
        return self._ground

    def _path(self, name: str) -> Sdf.Path:
        if name.startswith("/"):
            if not Sdf.Path.IsValidPathString(name) or Sdf.Path(name).GetParentPath() != Sdf.Path(
                OBJECTS_PATH
            ):
                raise InputError(f"'{name}': not an object path; objects are {OBJECTS_PATH}/<class>_<NNNN>")
            return Sdf.Path(name)
        if not Sdf.Path.IsValidIdentifier(name):
            raise InputError(f"'{name}': not an object name; use e.g. car_0003 or {OBJECTS_PATH}/car_0003")
        return Sdf.Path(OBJECTS_PATH).AppendChild(name)

    def _object(self, name: str, *, active: bool = True) -> tuple[ObjectState, list[ObjectState]]:
        path = self._path(name)
        prim = self._stage.GetPrimAtPath(path)
        if not prim or not prim.IsDefined():
            raise InputError(
                f"no object '{path.name}' in {self.root}; `usdworld edit {self.root} list` shows the names"
            )
        states = self._all()
        state = next(s for s in states if s.path == str(path))
        if active and not state.active:
            raise InputError(f"{state.name} is deleted; `reset {state.name}` or `undo` brings it back")
        return state, states

    def _gate(
        self, op: str, name: str, violations: list[rules.Violation], force: bool
    ) -> list[rules.Violation]:
        if violations and not force:
            why = "; ".join(str(v) for v in violations)
            raise LayoutError(f"{op} {name} refused: {why}; nothing was written (--force applies it anyway)")
        return violations

    @staticmethod
    def _result(op: str, name: str, step: int, violations: list[rules.Violation], message: str) -> EditResult:
        if violations:
            message += f" (forced: {'; '.join(str(v) for v in violations)})"
        return EditResult(op, name, step, bool(violations), tuple(str(v) for v in violations), message)

    def _where(self, xy: np.ndarray) -> tuple[str, float]:
        names, z = rules.surface_at(xy[None, :], self.ground())
        return names[0], round(float(z[0]), 6)

    # --- operations ------------------------------------------------------------------

    def move(
        self,
        name: str,
        *,
        to: tuple[float, float] | None = None,
        by: tuple[float, float] | None = None,
        force: bool = False,
    ) -> EditResult:
        """Move an object on the ground to ``to`` (x, y) or by ``by`` (dx, dy) metres.

        Its height follows the ground surface under the new point.
        """
        if to is not None and by is None:
            key, given = "to", to
        elif by is not None and to is None:
            key, given = "by", by
        else:
            raise InputError("move: give exactly one of --to x,y or --by dx,dy")
        if not all(math.isfinite(c) for c in given):
            raise InputError(f"move: --{key} must be finite, got {tuple(given)}")
        with self._locked():
            obj, states = self._object(name)
            xy = np.array(given if key == "to" else np.add(obj.position_world[:2], given), dtype=np.float64)
            surface, z = self._where(xy)
            cand = rules.Candidate(obj.class_name, xy, np.array(obj.footprint_lw), math.radians(obj.yaw_deg))
            others = self._footprints(states).without(obj.name)
            v = self._gate(
                "move",
                obj.name,
                rules.check_placement(cand, others, self.ground(), self.surface_rules),
                force,
            )
            prim = self._stage.GetPrimAtPath(obj.path)
            args = {"name": obj.name, key: [float(c) for c in given]}
            step = self._commit(
                "move",
                args,
                [prim.GetPath()],
                v,
                lambda: self._op(prim, "translate").Set(Gf.Vec3d(float(xy[0]), float(xy[1]), z)),
            )
            return self._result(
                "move", obj.name, step, v, f"moved {obj.name} to ({xy[0]:.2f}, {xy[1]:.2f}) on {surface}"
            )

    def _op(self, prim: Usd.Prim, op: str) -> Usd.Attribute:
        attr = prim.GetAttribute(f"xformOp:{op}")
        if not attr:
            raise AuthoringError(
                f"{prim.GetPath()}: no xformOp:{op}; usdworld edits need the translate/rotateZ/scale ops "
                "build writes"
            )
        return attr

    def rotate(self, name: str, yaw_deg: float, *, force: bool = False) -> EditResult:
        """Set an object's yaw (rotation about Z) to ``yaw_deg`` degrees."""
        if not math.isfinite(yaw_deg):
            raise InputError(f"--yaw-deg: must be finite, got {yaw_deg}")
        with self._locked():
            obj, states = self._object(name)
            yaw = _wrap_deg(yaw_deg)
            cand = rules.Candidate(
                obj.class_name, np.array(obj.position_world[:2]), np.array(obj.footprint_lw), math.radians(yaw)
            )
            others = self._footprints(states).without(obj.name)
            v = self._gate(
                "rotate",
                obj.name,
                rules.check_placement(cand, others, self.ground(), self.surface_rules, surface=False),
                force,
            )
            prim = self._stage.GetPrimAtPath(obj.path)
            step = self._commit(
                "rotate",
                {"name": obj.name, "yaw_deg": float(yaw_deg)},
                [prim.GetPath()],
                v,
                lambda: self._op(prim, "rotateZ").Set(float(yaw)),
            )
            return self._result("rotate", obj.name, step, v, f"rotated {obj.name} to {yaw:.1f} deg")

    def delete(self, name: str) -> EditResult:
        """Deactivate an object (``active = false``); the prim stays in the stage."""
        with self._locked():
            obj, _ = self._object(name)
            prim = self._stage.GetPrimAtPath(obj.path)
            step = self._commit(
                "delete", {"name": obj.name}, [prim.GetPath()], [], lambda: prim.SetActive(False)
            )
            return self._result("delete", obj.name, step, [], f"deleted {obj.name} (inactive)")

    def variants(self, class_name: str) -> tuple[str, ...]:
        """The ``model`` variants of a class's asset (the world's copy first)."""
        return asset_library.asset_info(class_name, self._libraries).variants

    def _variant(self, class_name: str, variant: str | None) -> str:
        info = asset_library.asset_info(class_name, self._libraries)
        if variant is None:
            return info.default_variant
        if variant not in info.variants:
            raise InputError(
                f"--variant: {class_name} has no variant '{variant}'; "
                f"available: {', '.join(info.variants) or 'none'}"
            )
        return variant

    def _asset_ref(self, class_name: str) -> str:
        """Relative reference from the edits layer to the world's asset (copied in when missing)."""
        target = self.assets_dir / f"{class_name}.usda"
        if not target.is_file():
            copy_asset(asset_library.asset_path(class_name, self._libraries), self.assets_dir)
        return Path(os.path.relpath(target, self.edits_path.parent)).as_posix()

    def _default_yaw(self, class_name: str, xy: np.ndarray, states: list[ObjectState]) -> float:
        how = prior_for(class_name).yaw
        if how == "camera":
            return _wrap_deg(math.degrees(math.atan2(-xy[1], -xy[0])))
        if how in ("road", "face_road"):
            road = [
                s
                for s in states
                if s.active and s.class_name in class_priors() and prior_for(s.class_name).yaw == how
            ]
            same = [s for s in road if s.class_name == class_name] or road
            if same:
                near = min(same, key=lambda s: (math.dist(s.position_world[:2], xy), s.name))
                return near.yaw_deg
        return 0.0

    def _next_name(self, class_name: str) -> str:
        taken = [c.GetName() for c in self._stage.GetPrimAtPath(OBJECTS_PATH).GetAllChildren()]
        spec = self._edits.GetPrimAtPath(OBJECTS_PATH)
        if spec:
            taken += list(spec.nameChildren.keys())
        pat = re.compile(rf"^{re.escape(class_name)}_(\d+)$")
        numbers = [int(m.group(1)) for m in map(pat.match, taken) if m]
        return f"{class_name}_{max(numbers, default=0) + 1:04d}"

    def add(
        self,
        class_name: str,
        at: tuple[float, float],
        *,
        variant: str | None = None,
        yaw_deg: float | None = None,
        force: bool = False,
    ) -> EditResult:
        """Add an object of ``class_name`` at ``at`` (x, y), scaled like its neighbours.

        The yaw defaults to the class's habit: along the nearest road-aligned object,
        facing the camera, or 0.
        """
        if not all(math.isfinite(c) for c in at) or (yaw_deg is not None and not math.isfinite(yaw_deg)):
            raise InputError(f"add: position and yaw must be finite, got at={tuple(at)}, yaw_deg={yaw_deg}")
        prior = prior_for(class_name)
        with self._locked():
            variant = self._variant(class_name, variant)
            states = self._all()
            others = self._footprints(states)
            xy = np.array(at, dtype=np.float64)
            yaw = _wrap_deg(yaw_deg) if yaw_deg is not None else self._default_yaw(class_name, xy, states)
            scale = rules.neighbour_scale(class_name, xy, others, prior.scale_range)
            length, width = self._footprint_size(class_name, variant)
            cand = rules.Candidate(
                class_name, xy, np.array([length * scale, width * scale]), math.radians(yaw)
            )
            name = self._next_name(class_name)
            v = self._gate(
                "add", name, rules.check_placement(cand, others, self.ground(), self.surface_rules), force
            )
            surface, z = self._where(xy)
            ref = self._asset_ref(class_name)
            path = Sdf.Path(OBJECTS_PATH).AppendChild(name)

            def author() -> None:
                xform = UsdGeom.Xform.Define(self._stage, path)
                prim = xform.GetPrim()
                prim.GetReferences().SetReferences([Sdf.Reference(ref)])
                if variant:
                    prim.GetVariantSets().SetSelection(asset_library.VARIANT_SET, variant)
                xform.AddTranslateOp().Set(Gf.Vec3d(float(xy[0]), float(xy[1]), z))
                xform.AddRotateZOp().Set(float(yaw))
                xform.AddScaleOp().Set(Gf.Vec3f(scale, scale, scale))
                UsdSemantics.LabelsAPI.Apply(prim, "class").CreateLabelsAttr([class_name])
                apply_with_values(prim, PROVENANCE_API, _user_provenance(class_name, scale))

            args = {
                "class": class_name,
                "at": [float(c) for c in at],
                "variant": variant,
                "yaw_deg": yaw_deg,
                "name": name,
            }
            step = self._commit("add", args, [path], v, author)
            return self._result(
                "add",
                name,
                step,
                v,
                f"added {name} ({class_name} {variant}, scale {scale:.2f}) "
                f"at ({xy[0]:.2f}, {xy[1]:.2f}) on {surface}",
            )

    def replace(
        self, name: str, with_class: str, *, variant: str | None = None, force: bool = False
    ) -> EditResult:
        """Replace an object by another class (explicit reference list) or another variant of its own."""
        prior = prior_for(with_class)
        with self._locked():
            obj, states = self._object(name)
            same = with_class == obj.class_name
            if same and variant is None:
                info = asset_library.asset_info(with_class, self._libraries)
                raise InputError(
                    f"replace {obj.name}: it is already a {with_class}; "
                    f"pass --variant (one of {', '.join(info.variants) or 'none'})"
                )
            variant = self._variant(with_class, variant)
            others = self._footprints(states).without(obj.name)
            xy = np.array(obj.position_world[:2])
            if same:
                scale = obj.scale
            else:
                fallback = float(np.clip(obj.scale, *prior.scale_range))
                scale = rules.neighbour_scale(with_class, xy, others, prior.scale_range, fallback)
            length, width = self._footprint_size(with_class, variant)
            cand = rules.Candidate(
                with_class, xy, np.array([length * scale, width * scale]), math.radians(obj.yaw_deg)
            )
            found = rules.replacement_violations(obj.class_name, with_class, self.replacement_rules)
            found += rules.check_placement(cand, others, self.ground(), self.surface_rules)
            v = self._gate("replace", obj.name, found, force)
            ref = None if same else self._asset_ref(with_class)
            prim = self._stage.GetPrimAtPath(obj.path)

            def author() -> None:
                self._clear_restyle(prim)
                if ref is not None:
                    prim.GetReferences().SetReferences([Sdf.Reference(ref)])
                    _set_label(prim, with_class)
                    self._op(prim, "scale").Set(Gf.Vec3f(scale, scale, scale))
                    if prim.HasAttribute("usdworld:scaleFactor"):
                        prim.GetAttribute("usdworld:scaleFactor").Set(float(scale))
                if variant:
                    prim.GetVariantSets().SetSelection(asset_library.VARIANT_SET, variant)
                if obj.color:
                    self._apply_restyle(prim, obj.color)

            args = {"name": obj.name, "with": with_class, "variant": variant}
            step = self._commit("replace", args, [prim.GetPath()], v, author)
            what = f"{with_class} {variant}".strip()
            return self._result(
                "replace",
                obj.name,
                step,
                v,
                f"replaced {obj.name} ({obj.class_name} {obj.variant}) with {what}, scale {scale:.2f}",
            )

    def _clear_restyle(self, prim: Usd.Prim) -> None:
        spec = self._edits.GetPrimAtPath(prim.GetPath())
        if spec:
            for child in list(spec.nameChildren.keys()):
                del spec.nameChildren[child]

    def _restyle_targets(self, prim: Usd.Prim) -> tuple[list[UsdShade.Material], list[UsdGeom.Mesh]]:
        materials = [UsdShade.Material(p) for p in Usd.PrimRange(prim) if p.IsA(UsdShade.Material)]
        chosen = [
            m for m in materials if any(fnmatch(m.GetPrim().GetName(), pat) for pat in RESTYLE_MATERIALS)
        ] or materials
        chosen_paths = {m.GetPath() for m in chosen}
        meshes = []
        for p in Usd.PrimRange(prim):
            if p.IsA(UsdGeom.Mesh):
                bound = UsdShade.MaterialBindingAPI(p).ComputeBoundMaterial()[0]
                if (bound and bound.GetPath() in chosen_paths) or not materials:
                    meshes.append(UsdGeom.Mesh(p))
        return chosen, meshes

    def _apply_restyle(self, prim: Usd.Prim, color_hex: str) -> None:
        linear, hexed = parse_color(color_hex)
        materials, meshes = self._restyle_targets(prim)
        for m in materials:
            shader, _, _ = m.ComputeSurfaceSource()
            if shader and shader.GetPrim().IsValid():
                shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*linear))
        for mesh in meshes:
            mesh.CreateDisplayColorAttr().Set(Vt.Vec3fArray([Gf.Vec3f(*linear)]))
        prim.SetCustomDataByKey(COLOR_KEY, hexed)

    def restyle(self, name: str, color: str) -> EditResult:
        """Recolour an object's paint (see the module doc for what is authored)."""
        _, hexed = parse_color(color)
        with self._locked():
            obj, _ = self._object(name)
            prim = self._stage.GetPrimAtPath(obj.path)
            if prim.IsInstance():
                raise InputError(f"{obj.name} is instanceable; its materials cannot be overridden per object")
            materials, meshes = self._restyle_targets(prim)
            if not materials and not meshes:
                raise InputError(f"{obj.name}: its asset has no materials or meshes to recolour")

            def author() -> None:
                self._clear_restyle(prim)
                self._apply_restyle(prim, hexed)

            step = self._commit("restyle", {"name": obj.name, "color": hexed}, [prim.GetPath()], [], author)
            parts = ", ".join(m.GetPrim().GetName() for m in materials) or "display colour"
            return self._result("restyle", obj.name, step, [], f"restyled {obj.name} {hexed} ({parts})")

    def reset(self, name: str, *, force: bool = False) -> EditResult:
        """Drop every edit of one object (an added object disappears)."""
        path = self._path(name)
        with self._locked():
            if not self._edits.GetPrimAtPath(path):
                raise InputError(f"{path.name} has no edits to reset in {self.edits_path}")
            text, index = self._capture(path)
            self._restore(path, "", -1)
            prim = self._stage.GetPrimAtPath(path)
            found: list[rules.Violation] = []
            if prim and prim.IsDefined() and prim.IsActive():
                states = self._all()
                obj = next(s for s in states if s.path == str(path))
                cand = rules.Candidate(
                    obj.class_name,
                    np.array(obj.position_world[:2]),
                    np.array(obj.footprint_lw),
                    math.radians(obj.yaw_deg),
                )
                found = rules.fit_violations(cand, self._footprints(states).without(obj.name))
            self._restore(path, text, index)
            v = self._gate("reset", path.name, found, force)
            step = self._commit("reset", {"name": path.name}, [path], v, lambda: self._restore(path, "", -1))
            return self._result("reset", path.name, step, v, f"reset {path.name} to the base")

    def check(self) -> list[OrphanEdit]:
        """Edits whose target prim does not exist in the composed world (e.g. after a rebuild)."""
        with self._locked():
            steps: dict[str, list[int]] = {}
            for i, text in enumerate(self._journal()[0]):
                for p in self._entry(i + 1, text).paths:
                    steps.setdefault(p, []).append(i + 1)
            out: list[OrphanEdit] = []

            def visit(spec: Sdf.PrimSpec) -> None:
                prim = self._stage.GetPrimAtPath(spec.path)
                if spec.specifier == Sdf.SpecifierOver and (not prim or not prim.IsDefined()):
                    owner = spec.path
                    while owner.pathElementCount > 3:
                        owner = owner.GetParentPath()
                    inside = owner.GetParentPath() == Sdf.Path(OBJECTS_PATH)
                    out.append(
                        OrphanEdit(
                            str(spec.path), tuple(steps.get(str(owner), ())), owner.name if inside else ""
                        )
                    )
                    return
                if prim and not prim.IsActive():
                    return  # an inactive prim's children are not composed
                for child in spec.nameChildren:
                    visit(child)

            for root in self._edits.rootPrims:
                visit(root)
            return out


def _set_label(prim: Usd.Prim, class_name: str) -> None:
    """Author the ``class`` label (applying LabelsAPI only where no layer has yet)."""
    attr = prim.GetAttribute("semantics:labels:class")
    if attr:
        attr.Set([class_name])
    else:
        UsdSemantics.LabelsAPI.Apply(prim, "class").CreateLabelsAttr([class_name])


def _fan(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """(T, 3) int64 fan triangles of polygons given as face-vertex counts and indices."""
    if np.all(counts == 3):
        return indices.reshape(-1, 3)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    fan = [(idx0, idx0 + k, idx0 + k + 1) for idx0, c in zip(starts, counts) for k in range(1, c - 1)]
    return indices[np.array(fan, dtype=np.int64).reshape(-1, 3)]


def _user_provenance(class_name: str, scale: float) -> dict[str, Any]:
    """Provenance values of an object a user added: no image evidence, placed by hand."""
    return {
        "usdworld:sourceImage": "",
        "usdworld:sourceClass": class_name,
        "usdworld:instanceId": -1,
        "usdworld:imageBBox": Gf.Vec4f(0, 0, 0, 0),
        "usdworld:groundContactPixel": Gf.Vec2f(0, 0),
        "usdworld:maskArea": 0,
        "usdworld:bottomTruncated": False,
        "usdworld:bottomOccluded": False,
        "usdworld:depth": 0.0,
        "usdworld:depthMethod": "user",
        "usdworld:depthCueNames": [],
        "usdworld:depthCueValues": [],
        "usdworld:depthCueSigmas": [],
        "usdworld:scaleFactor": float(scale),
        "usdworld:scaleMeasured": float(scale),
        "usdworld:yawSource": "user",
        "usdworld:collisionDisplacement": Gf.Vec2f(0, 0),
        "usdworld:confidence": 1.0,
    }
