"""Non-destructive editing of a world (paper step 4): every edit is an opinion in its edits layer.

A world's root layer (``world.usda``) stacks ``layers/edits.usda`` over ``layers/base.usda``
(``layers/base.usdc`` in a large world; the editor takes the layers the root names).
:class:`WorldEditor` writes through a USD edit target on the root's **first** sublayer
only, so the base and the root stay byte-identical, a rebuild of the base keeps the
user's edits, and every DCC tool sees them. The same editor works on a variation root
written by ``usdworld vary`` (its first sublayer is the variation's own edits layer).

The editor is a facade over its parts (:mod:`usdworld.authoring.editing`):

* :mod:`~usdworld.authoring.editing.transaction` -- each edit is one transaction: a file
  lock on ``<edits layer>.lock``, re-reading the layer if another editor changed it, and
  an atomic save (temporary file in the same folder, fsync, rename);
* :mod:`~usdworld.authoring.editing.journal` -- the history and undo, kept in the edits
  layer's ``customLayerData["usdworld"]``; an undo makes the layer byte-identical to what
  it was before the step;
* :mod:`~usdworld.authoring.editing.state` -- the objects, footprints and ground as the
  composed stage has them now;
* :mod:`~usdworld.authoring.editing.operations` -- move, rotate, delete, add, replace,
  restyle, reset (what each authors is listed there), gated by the rules of
  :mod:`usdworld.layout.permissible`.

A refused edit raises :class:`~usdworld.errors.EditRefused`, whose ``reason`` and fields
say why (the rules broken, the unknown object, class or variant, the bad value); it writes
nothing. ``force=True`` applies an edit the rules refuse and records the rules overridden.
The class table is loaded once when the editor opens a world.

A ``WorldEditor`` is not thread-safe; give each thread its own.

Example::

    editor = WorldEditor("out/world.usda")
    editor.move("car_0003", to=(12.5, -3.0))
    editor.replace("car_0003", "bus")   # EditRefused: replace car_0003 refused: fit: overlaps car_0005 by 0.80 m; ...
    editor.undo()
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Self

from pxr import Sdf, Usd

from usdworld.authoring import asset_library
from usdworld.authoring.editing import operations as ops
from usdworld.authoring.editing.journal import HistoryEntry, entries, read_journal, undo_last, utc_now
from usdworld.authoring.editing.operations import EditResult
from usdworld.authoring.editing.orphans import OrphanEdit, orphan_edits
from usdworld.authoring.editing.restyle import COLOR_KEY, parse_color
from usdworld.authoring.editing.state import EDIT_MASK, ObjectState, WorldState
from usdworld.authoring.editing.transaction import EditsTransaction, atomic_write_text
from usdworld.authoring.stages import open_stage, world_root
from usdworld.errors import AuthoringError, EditRefused, InputError, RefusalReason
from usdworld.io.class_table import ClassTable, load_class_table
from usdworld.layout import permissible as rules
from usdworld.world_files import ASSETS_DIR, OBJECTS_PATH

__all__ = [
    "COLOR_KEY",
    "EditResult",
    "HistoryEntry",
    "ObjectState",
    "OrphanEdit",
    "WorldEditor",
    "atomic_write_text",
    "parse_color",
    "utc_now",
]


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
        classes: the class table (default: the shipped one, :func:`load_class_table`).
    """

    def __init__(
        self,
        world: Path | str,
        *,
        surface_rules: Path | str | None = None,
        replacement_rules: Path | str | None = None,
        library: Path | str | None = None,
        clock: Callable[[], str] = utc_now,
        classes: ClassTable | None = None,
    ) -> None:
        self.root = root = world_root(world)
        self.surface_rules = rules.load_surface_rules(surface_rules)
        self.replacement_rules = rules.load_replacement_rules(replacement_rules)
        self.classes = classes if classes is not None else load_class_table()
        self._stage = open_stage(root, "USD world", mask=EDIT_MASK)
        sublayers = list(self._stage.GetRootLayer().subLayerPaths)
        if len(sublayers) < 2:
            raise AuthoringError(
                f"{root}: needs an edits layer over a base layer (subLayers), found {sublayers}; "
                "rebuild the world"
            )
        layers = [self._find_layer(p) for p in sublayers]
        self.edits_path = Path(layers[0].realPath)
        self.base_paths = tuple(Path(layer.realPath) for layer in layers[1:])
        for layer in [self._stage.GetRootLayer(), *layers]:
            layer.Reload()  # a layer another stage of this process holds may be stale on disk
        self.assets_dir = self.base_paths[-1].parent.parent / ASSETS_DIR
        libraries = (self.assets_dir, *asset_library.library_dirs(Path(library) if library else None))
        self._state = WorldState(self._stage, tuple(layers), self.classes, libraries)
        tx = EditsTransaction(layers[0], (self.root, *self.base_paths), self._state.forget)
        self._ed = ops.Editing(
            self._stage,
            tx,
            self._state,
            self.classes,
            self.surface_rules,
            self.replacement_rules,
            libraries,
            self.assets_dir,
            clock,
        )
        if not any(layer.GetPrimAtPath(OBJECTS_PATH) for layer in layers):
            raise AuthoringError(f"{root}: no {OBJECTS_PATH} scope; not a usdworld world")

    def close(self) -> None:
        """Stop listening and release the stage (the editor is unusable afterwards)."""
        self._state.close()
        self._stage = None  # type: ignore[assignment]

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _find_layer(self, sub: str) -> Sdf.Layer:
        path = self._stage.GetRootLayer().ComputeAbsolutePath(sub)
        layer = Sdf.Layer.Find(path) or Sdf.Layer.FindOrOpen(path)
        if layer is None or not layer.realPath:
            raise AuthoringError(f"{self.root}: sublayer {sub} is missing or not a file; rebuild the world")
        return layer

    @property
    def stage(self) -> Usd.Stage:
        """The composed stage, every prim of it (read it; write only through the editor's operations)."""
        self._state.unmask()
        return self._stage

    # --- reading --------------------------------------------------------------------

    def objects(self) -> list[ObjectState]:
        """Every object (deleted ones too), in stage order."""
        with self._ed.tx.locked():
            return self._state.all()

    def ground(self) -> rules.Ground:
        """Top faces of the ground meshes and the ground extent (cached until a rebuild)."""
        return self._state.ground()

    def variants(self, class_name: str) -> tuple[str, ...]:
        """The ``model`` variants of a class's asset (the world's copy first)."""
        return asset_library.asset_info(class_name, self._ed.libraries).variants

    def size(self, class_name: str, variant: str) -> tuple[float, float]:
        """Unscaled (length, width) of a class's variant, metres (its asset's)."""
        return self._state.size(class_name, variant)

    def history(self) -> list[HistoryEntry]:
        """Every recorded edit, oldest first."""
        with self._ed.tx.locked():
            return entries(self._ed.tx.layer)

    def check(self) -> list[OrphanEdit]:
        """Edits whose target prim does not exist in the composed world (e.g. after a rebuild)."""
        self._state.unmask()
        with self._ed.tx.locked():
            return orphan_edits(self._stage, self._ed.tx.layer)

    # --- operations -----------------------------------------------------------------

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
        return ops.move(self._ed, name, to=to, by=by, force=force)

    def rotate(self, name: str, yaw_deg: float, *, force: bool = False) -> EditResult:
        """Set an object's yaw (rotation about Z) to ``yaw_deg`` degrees."""
        return ops.rotate(self._ed, name, yaw_deg, force=force)

    def delete(self, name: str) -> EditResult:
        """Deactivate an object (``active = false``); the prim stays in the stage."""
        return ops.delete(self._ed, name)

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
        return ops.add(self._ed, class_name, at, variant=variant, yaw_deg=yaw_deg, force=force)

    def replace(
        self, name: str, with_class: str, *, variant: str | None = None, force: bool = False
    ) -> EditResult:
        """Replace an object by another class (explicit reference list) or another variant of its own."""
        return ops.replace(self._ed, name, with_class, variant=variant, force=force)

    def restyle(self, name: str, color: str) -> EditResult:
        """Recolour an object's paint (see :mod:`usdworld.authoring.editing.restyle`)."""
        return ops.restyle(self._ed, name, color)

    def reset(self, name: str, *, force: bool = False) -> EditResult:
        """Drop every edit of one object (an added object disappears)."""
        return ops.reset(self._ed, name, force=force)

    def undo(self, steps: int = 1) -> list[HistoryEntry]:
        """Undo the last ``steps`` edits, restoring the exact previous edits layer.

        Returns:
            The entries undone, newest first.

        Raises:
            EditRefused: ``bad_value`` (``steps`` < 1) or ``nothing_to_undo`` (fewer edits recorded).
        """
        if steps < 1:
            raise EditRefused(
                RefusalReason.BAD_VALUE,
                f"undo: the number of steps must be >= 1, got {steps}",
                op="undo",
                field="steps",
                value=steps,
            )
        tx = self._ed.tx
        with tx.locked():
            recorded = len(read_journal(tx.layer)[0])
            if steps > recorded:
                raise EditRefused(
                    RefusalReason.NOTHING_TO_UNDO,
                    f"undo {steps}: only {recorded} edit(s) recorded",
                    op="undo",
                    field="steps",
                    value=steps,
                )
            undone = undo_last(tx.layer, steps)
            tx.save()
            return undone
