"""The state reader: a world's objects, their footprints and its ground as the composed stage has them now.

:class:`WorldState` reads each object once and caches it; a listener on the stage marks
the objects a change touched, so after an edit only those are read again. The sizes come
from the world's assets (the class table's prior sizes for a class without one); the
footprint the rules use is the trunk's or post's for the classes with the ``trunk`` role
(people stand under crowns, lamp arms and sign plates, as the build lets them).

The stage may come masked to the ground (:data:`EDIT_MASK`): then a move or a rotation
composes only the object it edits and the objects its footprint could touch, found in an
:class:`~usdworld.authoring.editing.index.ObjectIndex` read from the layers, and the
ground's extent takes the placed objects' bounds from that index too. Anything that needs
every object (:meth:`WorldState.all`, :meth:`WorldState.find`) widens the mask to the
whole world first, and the reader works as on an unmasked stage from then on.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom

from usdworld.authoring import asset_library
from usdworld.authoring.editing.index import ObjectIndex, Opinions, read_index
from usdworld.authoring.editing.index_file import lower_opinions
from usdworld.authoring.editing.restyle import COLOR_KEY
from usdworld.errors import EditRefused, InputError, RefusalReason
from usdworld.geometry.rotation import turned
from usdworld.io.class_table import ClassTable
from usdworld.layout import permissible as rules
from usdworld.parameters.authoring import AuthoringParams
from usdworld.world_files import GROUND_PATH, OBJECTS_PATH

#: Surface meshes of a world and the surface name each stands for.
GROUND_MESHES = {"road": f"{GROUND_PATH}/Road", "sidewalk": f"{GROUND_PATH}/Sidewalk"}
#: What an editor composes when it opens a world: the ground; objects are added as edits need them.
EDIT_MASK = (GROUND_PATH,)


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
            trunk's or post's for classes with the ``trunk`` role (trees, poles, signs).
        footprint_offset: (x, y) scaled centre of that footprint in the asset's frame,
            metres: a street lamp's mast stands behind its origin (zero for most objects).
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
    footprint_offset: tuple[float, float] = (0.0, 0.0)

    def footprint_centre(self, origin_xy: np.ndarray, yaw_rad: float) -> np.ndarray:
        """(2,) float64 its rule footprint's centre, its origin at ``origin_xy`` turned by ``yaw_rad``."""
        return np.asarray(origin_xy, dtype=np.float64)[:2] + turned(self.footprint_offset, yaw_rad)


def footprints(states: list[ObjectState]) -> rules.Footprints:
    """The footprint table of the active objects among ``states``, in their order."""
    live = [s for s in states if s.active]
    return rules.Footprints(
        tuple(s.name for s in live),
        tuple(s.class_name for s in live),
        np.array(
            [s.footprint_centre(s.position_world[:2], math.radians(s.yaw_deg)) for s in live],
            dtype=np.float64,
        ).reshape(-1, 2),
        np.array([s.footprint_lw for s in live], dtype=np.float64).reshape(-1, 2),
        np.radians([s.yaw_deg for s in live]),
        np.array([s.scale for s in live], dtype=np.float64),
    )


def object_path(name: str) -> Sdf.Path:
    """The prim path of an object given by name (``car_0003``) or path.

    Raises:
        EditRefused: ``unknown_object`` with ``field`` ``name``: not an object name or path.
    """
    if name.startswith("/"):
        if not Sdf.Path.IsValidPathString(name) or Sdf.Path(name).GetParentPath() != Sdf.Path(OBJECTS_PATH):
            raise EditRefused(
                RefusalReason.UNKNOWN_OBJECT,
                f"'{name}': not an object path; objects are {OBJECTS_PATH}/<class>_<NNNN>",
                subject=name,
                field="name",
                value=name,
            )
        return Sdf.Path(name)
    if not Sdf.Path.IsValidIdentifier(name):
        raise EditRefused(
            RefusalReason.UNKNOWN_OBJECT,
            f"'{name}': not an object name; use e.g. car_0003 or {OBJECTS_PATH}/car_0003",
            subject=name,
            field="name",
            value=name,
        )
    return Sdf.Path(OBJECTS_PATH).AppendChild(name)


def _gf3(v: Any) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _fan(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """(T, 3) int64 fan triangles of polygons given as face-vertex counts and indices."""
    if np.all(counts == 3):
        return indices.reshape(-1, 3)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    fan = [(idx0, idx0 + k, idx0 + k + 1) for idx0, c in zip(starts, counts) for k in range(1, c - 1)]
    return indices[np.array(fan, dtype=np.int64).reshape(-1, 3)]


class WorldState:
    """Objects and ground of a composed world, cached and re-read only where the stage changed.

    Args:
        stage: the composed world (whole, or masked to :data:`EDIT_MASK`).
        layers: its sublayers, strongest first; the first is its edits layer (an object
            with a spec there is ``edited`` or ``added``).
        classes: the class table (prior sizes, the ``trunk`` role).
        libraries: asset folders, the world's own first.
    """

    def __init__(
        self, stage: Usd.Stage, layers: tuple[Sdf.Layer, ...], classes: ClassTable, libraries: tuple[Path, ...]
    ) -> None:
        self.stage, self.classes, self.libraries = stage, classes, libraries
        self.layers, self.edits = layers, layers[0]
        self._partial = stage.GetPopulationMask() != Usd.StagePopulationMask.All()
        self._index: ObjectIndex | None = None
        self._index_read = False
        self._lower: Opinions | None = None  # the opinions below the edits layer (unchanged by edits)
        self._sizes: dict[tuple[str, str], tuple[float, float]] = {}
        self._trunk_sizes: dict[tuple[str, str], tuple[float, float]] = {}
        self._trunk_offsets: dict[tuple[str, str], tuple[float, float]] = {}
        self._ground: rules.Ground | None = None
        self._states: dict[str, ObjectState] | None = None
        self._stale: set[str] = set()
        me = weakref.ref(self)  # the listener must not keep the reader alive

        def on_change(notice: Usd.Notice.ObjectsChanged, stage: Usd.Stage) -> None:
            reader = me()
            if reader is not None:
                reader._changed(notice)

        self._on_change = on_change  # Tf holds Python callbacks weakly
        self._listener = Tf.Notice.Register(Usd.Notice.ObjectsChanged, on_change, stage)

    def close(self) -> None:
        """Stop listening to the stage."""
        self._listener.Revoke()

    def forget(self) -> None:
        """Drop every cache (the base layers were reloaded)."""
        self._ground, self._states = None, None
        self._sizes, self._trunk_sizes, self._trunk_offsets = {}, {}, {}
        self._index, self._index_read, self._lower = None, False, None

    def unmask(self) -> None:
        """Compose the whole world from now on (what needs every object calls this first)."""
        if self._partial:
            self._partial = False
            self._index, self._index_read = None, False
            self.stage.SetPopulationMask(Usd.StagePopulationMask.All())

    def _object_index(self) -> ObjectIndex | None:
        """The index of the objects, read from the layers (None when they do not give one)."""
        if not self._index_read:
            if self._lower is None:
                self._lower = lower_opinions(self.layers, AuthoringParams().large_world_min_objects)
            self._index = read_index(self.layers, self.size, self.footprint_size, self.libraries, self._lower)
            self._index_read = True
        return self._index

    def _compose(self, paths: list[Sdf.Path]) -> None:
        """Add objects to the stage's mask (the ground and the index, unchanged by it, keep their caches)."""
        mask = self.stage.GetPopulationMask()
        missing = [p for p in paths if not mask.IncludesSubtree(p)]
        if missing:
            kept = self._ground, self._index, self._index_read  # a mask change resyncs the whole stage
            self.stage.SetPopulationMask(mask.GetUnion(Usd.StagePopulationMask(missing)))
            self._ground, self._index, self._index_read = kept

    def size(self, class_name: str, variant: str) -> tuple[float, float]:
        """Unscaled (length, width) of a class's variant, metres: its asset's, else the class prior's, else 1 x 1."""
        key = (class_name, variant)
        if key not in self._sizes:
            try:
                info = asset_library.asset_info(class_name, self.libraries)
                size = info.size_by_variant.get(variant, info.default_size)
            except InputError:
                size = self.classes[class_name].size_m if class_name in self.classes else (1.0, 1.0, 1.0)
            self._sizes[key] = (float(size[0]), float(size[1]))
        return self._sizes[key]

    def footprint_size(self, class_name: str, variant: str) -> tuple[float, float]:
        """Unscaled footprint for the rules, metres: the trunk's or post's for ``trunk``
        classes (as the build's collisions), else :meth:`size`."""
        if not self.classes.has(class_name, "trunk"):
            return self.size(class_name, variant)
        key = (class_name, variant)
        if key not in self._trunk_sizes:
            from usdworld.authoring.asset_measures import variant_measures

            try:
                m = variant_measures(class_name, variant or None, self.libraries)
                half = np.maximum(np.subtract(m.contact_half, np.abs(m.contact_offset)), 0.0)
                self._trunk_sizes[key] = (2.0 * float(half[0]), 2.0 * float(half[1]))
                self._trunk_offsets[key] = (float(m.contact_offset[0]), float(m.contact_offset[1]))
            except InputError:
                self._trunk_sizes[key] = self.size(class_name, variant)
                self._trunk_offsets[key] = (0.0, 0.0)
        return self._trunk_sizes[key]

    def footprint_offset(self, class_name: str, variant: str) -> tuple[float, float]:
        """Unscaled centre of :meth:`footprint_size`'s footprint in the asset's frame, metres:
        the trunk's contact for ``trunk`` classes (a street lamp's mast), else (0, 0)."""
        if not self.classes.has(class_name, "trunk"):
            return (0.0, 0.0)
        self.footprint_size(class_name, variant)
        return self._trunk_offsets[(class_name, variant)]

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
        length, width = self.size(class_name, variant)
        foot_l, foot_w = self.footprint_size(class_name, variant)
        off_x, off_y = self.footprint_offset(class_name, variant)
        spec = self.edits.GetPrimAtPath(prim.GetPath())
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
            (off_x * sx, off_y * sy),
        )

    def _changed(self, notice: Usd.Notice.ObjectsChanged) -> None:
        """Mark the objects a stage change touched (or all, when their parent changed)."""
        objects, ground = Sdf.Path(OBJECTS_PATH), Sdf.Path(GROUND_PATH)
        for resync, paths in ((True, notice.GetResyncedPaths()), (False, notice.GetChangedInfoOnlyPaths())):
            for path in paths:
                prim = path.GetPrimPath()
                if prim.HasPrefix(ground) or (resync and ground.HasPrefix(prim)):
                    self._ground = None
                if prim.HasPrefix(objects) or (resync and objects.HasPrefix(prim)):
                    self._index_read = False
                if self._states is None:
                    continue
                if prim.HasPrefix(objects) and prim != objects:
                    while prim.GetParentPath() != objects:
                        prim = prim.GetParentPath()
                    self._stale.add(str(prim))
                elif resync and objects.HasPrefix(prim):
                    self._states = None

    def all(self) -> list[ObjectState]:
        """Every defined object (deleted ones too), in stage order."""
        self.unmask()
        if self._states is not None and self._stale:
            for path in self._stale:
                prim = self.stage.GetPrimAtPath(path)
                if path not in self._states or not prim or not prim.IsDefined():
                    self._states = None  # an object appeared or vanished: re-read all, in stage order
                    break
                self._states[path] = self._read(prim)
        if self._states is None:
            objects = self.stage.GetPrimAtPath(OBJECTS_PATH)
            self._states = {
                str(p.GetPath()): self._read(p) for p in objects.GetAllChildren() if p.IsDefined()
            }
        self._stale = set()
        return list(self._states.values())

    def find(self, name: str, *, op: str, active: bool = True) -> tuple[ObjectState, list[ObjectState]]:
        """One object (by name or path) and every object.

        Raises:
            EditRefused: ``unknown_object`` (no such object) or ``deleted_object``
                (``active`` and the object is deleted).
        """
        self.unmask()
        path = object_path(name)
        self._require(path, op)
        states = self.all()
        state = next(s for s in states if s.path == str(path))
        if active and not state.active:
            raise EditRefused(
                RefusalReason.DELETED_OBJECT,
                f"{state.name} is deleted; a reset of {state.name} or an undo brings it back",
                op=op,
                subject=state.name,
            )
        return state, states

    def _require(self, path: Sdf.Path, op: str) -> Usd.Prim:
        prim = self.stage.GetPrimAtPath(path)
        if not prim or not prim.IsDefined():
            raise EditRefused(
                RefusalReason.UNKNOWN_OBJECT,
                f"no object '{path.name}' in this world",
                op=op,
                subject=path.name,
            )
        return prim

    def one(self, name: str, *, op: str) -> ObjectState:
        """One active object (by name or path), composing only it on a masked stage.

        Raises:
            EditRefused: ``unknown_object`` or ``deleted_object``, as :meth:`find`.
        """
        if not self._partial or self._object_index() is None:
            return self.find(name, op=op)[0]
        path = object_path(name)
        self._compose([path])
        state = self._read(self._require(path, op))
        if not state.active:
            raise EditRefused(
                RefusalReason.DELETED_OBJECT,
                f"{state.name} is deleted; a reset of {state.name} or an undo brings it back",
                op=op,
                subject=state.name,
            )
        return state

    def near(self, obj: ObjectState, center: np.ndarray) -> list[ObjectState]:
        """``obj`` and every object its rule footprint could touch when centred on ``center``
        ((2,) float64, metres), in stage order: every object on an unmasked stage."""
        index = self._object_index() if self._partial else None
        if index is None:
            return self.all()
        reach = 0.5 * math.hypot(*obj.footprint_lw) + math.hypot(*obj.footprint_offset)
        objects = Sdf.Path(OBJECTS_PATH)
        self._compose([objects.AppendChild(n) for n in index.near(center, reach)])
        scope = self.stage.GetPrimAtPath(objects)
        return [self._read(p) for p in scope.GetAllChildren() if p.IsDefined()]

    def _placed_bounds(self) -> np.ndarray | None:
        """(2, 2) float64 bounds of the rule footprints of the active objects the build placed, or None."""
        index = self._object_index() if self._partial else None
        if index is not None:
            return index.placed_bounds
        built = footprints([st for st in self.all() if st.status != "added"])
        if not len(built):
            return None
        h = 0.5 * built.size_lw.max(axis=1, keepdims=True)
        return np.array([(built.centers - h).min(axis=0), (built.centers + h).max(axis=0)])

    def ground(self) -> rules.Ground:
        """Top faces of the ground meshes and the ground extent (cached until a rebuild)."""
        if self._ground is None:
            tris = {}
            cache = UsdGeom.XformCache()
            for name, path in GROUND_MESHES.items():
                prim = self.stage.GetPrimAtPath(path)
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
            placed = self._placed_bounds()
            fallback = None
            if placed is not None and not tris:
                fallback = placed + np.array([[-1.0], [1.0]]) * rules.NO_MESH_MARGIN_M
            self._ground = rules.make_ground(tris, fallback, placed)
        return self._ground

    def where(self, xy: np.ndarray) -> tuple[str, float]:
        """The surface name under ``xy`` ((2,) float64 ground point) and its height (metres, rounded to 1e-6)."""
        names, z = rules.surface_at(xy[None, :], self.ground())
        return names[0], round(float(z[0]), 6)
