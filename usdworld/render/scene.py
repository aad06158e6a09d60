"""What the renderer draws, read from a **composed** USD stage.

:meth:`RenderScene.from_stage` walks the stage with ``Usd.PrimRange`` (active, loaded,
defined, non-abstract prims; instance proxies included, so instanced objects render;
variant selections and edits layers are already applied by composition), at one time
code (default: the default time). Invisible prims (``visibility`` at that time) and
``guide`` / ``proxy`` purpose prims are pruned. Every ``UsdGeom.Mesh`` is triangulated
into the world frame (see :mod:`usdworld.render.usd_mesh`).

Ids per mesh:

* **class id**: the Cityscapes label id (:mod:`usdworld.render.classes`) of the nearest
  ancestor-or-self's ``UsdSemantics`` LabelsAPI ``class`` label (first label listed).
* **object**: the top-level object the mesh belongs to, i.e. the child of
  ``objects_path`` (default ``<defaultPrim>/Objects``, else ``/World/Objects``) that is
  its ancestor; meshes outside it (road, sidewalks) belong to no object (index 0).
* **instance id**: Cityscapes style. For thing classes ``class*1000+k``, with ``k``
  counting the objects of that class from 0 in stage order; for stuff classes and meshes
  outside the objects scope, the class id.

The world frame is Z up, metres: stages authored Y up or in other units are converted.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom

from usdworld.render.batches import MeshBatch, ScenePart, expand, group_parts
from usdworld.render.classes import label_id_for_class, thing_label_ids
from usdworld.render.instancing import (
    Prototype,
    ViewCull,
    box_corners,
    local_layer_ids,
    own_label,
    prototype_key,
    pruned,
    read_prototype,
)
from usdworld.render.usd_mesh import GeometryCache, read_local_mesh


@dataclass(frozen=True)
class RenderObject:
    """One top-level object of the scene (a child of the objects scope).

    Attributes:
        path: prim path, e.g. ``/World/Objects/car_0001``.
        class_name: its ``class`` label (``""`` when unlabelled).
        label_id: Cityscapes label id of ``class_name``.
        instance_id: Cityscapes instance id its pixels get in ``RenderResult.instance_ids``.
        index: its value in ``RenderResult.object_ids`` (1-based; 0 means no object).
    """

    path: str
    class_name: str
    label_id: int
    instance_id: int
    index: int


@dataclass(frozen=True)
class VirtualObjects:
    """Objects of the objects scope that the stage does not compose, read as it would read them.

    Each is an object drawn as a prototype (:mod:`usdworld.render.instancing`): its label,
    the key of its prototype (:func:`~usdworld.render.instancing.prototype_key`; the
    prototype is in the ``prototypes`` cache given with it) and its local-to-world transform
    (the bits ``UsdGeom.XformCache`` gives). The scene reader counts them in among the
    composed objects at their place in the scope's stage order.

    Attributes:
        order: every object name of the scope -> its place in the composed stage's order.
        names: the virtual objects, in stage order.
        labels: their ``class`` labels.
        keys: their prototype keys.
        local_to_world: (N, 4, 4) float64 their transforms as ``Gf.Matrix4d`` holds them (row
            vectors, as USD gives them: ``np.array(m).reshape(4, 4)``).
    """

    order: dict[str, int]
    names: tuple[str, ...]
    labels: tuple[str, ...]
    keys: tuple[tuple, ...]
    local_to_world: np.ndarray


@dataclass(frozen=True, eq=False)
class RenderScene:
    """All meshes of a stage, batched by asset mesh (:mod:`usdworld.render.batches`), world frame.

    The renderer draws the batches (one instanced draw per batch and pass). The flat,
    unindexed arrays below (3 corners per triangle, in stage order) are the same triangles
    placed on the CPU; they are made on first use.

    Attributes:
        batches: the meshes and the places they are drawn at.
        part_order: (P, 2) int64 batch and instance index of each mesh part, in stage order.
        objects: the top-level objects, in stage order (culled ones too).
        culled_bounds_world: (2, 3) float64 ``[min, max]`` of the boxes of the objects
            culled when the scene was read, or None (they still cast the scene's extent:
            the far plane and the shadow box are the same as without culling, up to boxes).
    """

    batches: tuple[MeshBatch, ...]
    part_order: np.ndarray
    objects: tuple[RenderObject, ...]
    culled_bounds_world: np.ndarray | None = None
    _bounds: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        order = np.ascontiguousarray(self.part_order, dtype=np.int64).reshape(-1, 2)
        order.setflags(write=False)
        object.__setattr__(self, "part_order", order)
        counts = np.zeros(len(self.batches), dtype=np.int64)
        if len(order):
            if order[:, 0].min() < 0 or order[:, 0].max() >= len(self.batches):
                raise ValueError("RenderScene.part_order: batch index out of range")
            counts = np.bincount(order[:, 0], minlength=len(self.batches))
        if any(int(c) != b.n_instances for c, b in zip(counts, self.batches)):
            raise ValueError("RenderScene.part_order must name every instance of every batch once")
        boxes = [b.bounds_world() for b in self.batches if b.n_instances]
        n = bool(boxes)
        bounds = (
            np.stack([np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)])
            if n
            else np.zeros((2, 3))
        )
        if self.culled_bounds_world is not None:
            # float32 like the positions, so an exact box gives the same bounds as its triangles
            c = np.asarray(self.culled_bounds_world, dtype=np.float32).astype(np.float64).reshape(2, 3)
            bounds = np.stack([np.minimum(bounds[0], c[0]), np.maximum(bounds[1], c[1])]) if n else c.copy()
        bounds.setflags(write=False)
        object.__setattr__(self, "_bounds", bounds)

    @property
    def n_triangles(self) -> int:
        return sum(b.n_corners // 3 * b.n_instances for b in self.batches)

    @functools.cached_property
    def _flat(self) -> dict[str, np.ndarray]:
        arrays = expand(self.batches, self.part_order)
        for a in arrays.values():
            a.setflags(write=False)
        return arrays

    @property
    def positions_world(self) -> np.ndarray:
        """(V, 3) float32 corner positions, metres (V = 3 * triangles), in stage order."""
        return self._flat["positions_world"]

    @property
    def normals_world(self) -> np.ndarray:
        """(V, 3) float32 unit normals per corner."""
        return self._flat["normals_world"]

    @property
    def colors(self) -> np.ndarray:
        """(V, 3) float32 linear RGB per corner."""
        return self._flat["colors"]

    @property
    def class_ids(self) -> np.ndarray:
        """(V,) int32 Cityscapes label id per corner."""
        return self._flat["class_ids"]

    @property
    def instance_ids(self) -> np.ndarray:
        """(V,) int32 Cityscapes instance id per corner."""
        return self._flat["instance_ids"]

    @property
    def object_ids(self) -> np.ndarray:
        """(V,) int32 1-based index into ``objects`` per corner (0: no object)."""
        return self._flat["object_ids"]

    def label_ids_present(self) -> list[int]:
        """The Cityscapes label ids the scene's meshes carry, sorted (without expanding the arrays)."""
        return sorted({int(c) for b in self.batches for c in b.class_ids})

    def bounds_world(self) -> np.ndarray:
        """(2, 3) float64 axis-aligned bounds ``[min, max]``; zeros for an empty scene."""
        return self._bounds

    def object_by_path(self) -> dict[str, RenderObject]:
        """``{prim path: object}``."""
        return {o.path: o for o in self.objects}

    @classmethod
    def from_stage(
        cls,
        stage: Usd.Stage,
        objects_path: str | None = None,
        cull: ViewCull | None = None,
        time: Usd.TimeCode | None = None,
        prototypes: dict[tuple, Prototype | None] | None = None,
        static: StaticCache | None = None,
        virtual: VirtualObjects | None = None,
        geometry: GeometryCache | None = None,
    ) -> RenderScene:
        """Collect every renderable mesh of the composed stage.

        Objects referencing the same asset meshes share one read of them
        (:mod:`usdworld.render.instancing`) and one batch per mesh
        (:mod:`usdworld.render.batches`); the triangles are the same either way.

        Args:
            stage: an open stage; its current composition is read (edits, variants, active).
            objects_path: the scope whose children are the objects; default
                ``<defaultPrim>/Objects`` when it exists, else ``/World/Objects``.
            cull: leave out the triangles of the objects this view cannot see, nor their
                shadows (they keep their ids and place in ``objects``); None keeps all.
            time: the time code whose transforms and ``visibility`` are read (a drive's
                movers are time-sampled); None for the default time (every object shown
                where its default value puts it).
            prototypes: a cache of the assets' meshes (read at the default time) that
                several calls on one unchanged stage share, so that reading the scene at
                many times reads each asset once; None reads them afresh.
            static: the objects that stand still, kept by several calls on one unchanged
                stage at different times (:class:`StaticCache`), so that each of them is read
                once; None reads every object.
            virtual: objects the stage leaves out (a population mask) that are read as if it
                held them (:class:`VirtualObjects`; their prototypes in ``prototypes``); only
                at the default time, without ``static``.
            geometry: the asset meshes already read (shared with the reads of the virtual
                objects' prototypes, so their parts batch as the stage's own would).

        Raises:
            ValueError: ``virtual`` with a time or ``static``, or a virtual object's
                prototype not in ``prototypes``.
        """
        if virtual is not None and (time is not None or static is not None):
            raise ValueError("RenderScene.from_stage: virtual objects are read at the default time only")
        return _extract(stage, objects_path, cull, time, prototypes, static, virtual, geometry)


def world_from_stage(stage: Usd.Stage) -> np.ndarray:
    """(4, 4) float64 transform from the stage's units and up axis to metres, Z up."""
    scale = float(UsdGeom.GetStageMetersPerUnit(stage))
    T = np.diag([scale, scale, scale, 1.0])
    if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y:
        # Y-up (x right, y up, z towards the viewer) -> Z-up: rotate +90 degrees about X.
        T = np.array([[1.0, 0, 0, 0], [0, 0, -1.0, 0], [0, 1.0, 0, 0], [0, 0, 0, 1.0]]) @ T
    return T


def matrix_from_gf(m: Gf.Matrix4d) -> np.ndarray:
    """(4, 4) float64 column-vector matrix from a USD (row-vector) ``Gf.Matrix4d``."""
    return np.array(m, dtype=np.float64).reshape(4, 4).T


def gf_rows(m: Gf.Matrix4d) -> np.ndarray:
    """(4, 4) float64 a ``Gf.Matrix4d``'s elements as it holds them (row vectors)."""
    return np.array(m, dtype=np.float64).reshape(4, 4)


def gf_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a * b`` of ``Gf.Matrix4d`` s held as rows (:func:`gf_rows`), with Gf's bits.

    Each element is ``Gf.Matrix4d``'s sum of four products, added in its order (first to
    last, each rounded): the same bits as the product of the ``Gf.Matrix4d`` s.

    Args:
        a: (..., 4, 4) float64.
        b: (..., 4, 4) float64 (broadcast against ``a``).

    Returns:
        (..., 4, 4) float64.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    out = a[..., :, 0, None] * b[..., None, 0, :]
    for k in range(1, 4):
        out = out + a[..., :, k, None] * b[..., None, k, :]
    return out


def _default_objects_path(stage: Usd.Stage) -> str:
    default = stage.GetDefaultPrim()
    if default and default.GetChild("Objects"):
        return str(default.GetPath().AppendChild("Objects"))
    return "/World/Objects"


@dataclass(frozen=True)
class _StillObject:
    """An object that stands still, as read once: its label and its entries (ids as read then)."""

    label: str
    entries: tuple[ScenePart | _Pending, ...]


@dataclass
class StaticCache:
    """The objects of a stage that stand still, read once and shared by reads at several times.

    An object stands still when neither it, nor a prim below it, nor the objects scope or a
    prim above it has a time-varying transform or visibility: its meshes and transforms are
    then the same at every time. Its ids are counted again at every read, in stage order
    (a mover hidden at one time has no rider ids then, which moves later riders' ids), so a
    read with the cache gives the same scene as one without.
    """

    objects: dict[Sdf.Path, _StillObject] = field(default_factory=dict)
    moving: set[Sdf.Path] = field(default_factory=set)
    prototype_moves: dict[tuple, bool] = field(default_factory=dict)
    scope_moves: bool | None = None


def _moves(prim: Usd.Prim) -> bool:
    """True when the prim's transform or visibility might vary over time."""
    xformable = UsdGeom.Xformable(prim)
    if xformable and xformable.TransformMightBeTimeVarying():
        return True
    imageable = UsdGeom.Imageable(prim)
    return bool(imageable) and imageable.GetVisibilityAttr().ValueMightBeTimeVarying()


def _subtree_moves(prim: Usd.Prim, predicate: object) -> bool:
    return any(_moves(p) for p in Usd.PrimRange(prim, predicate))


def _replay(still: _StillObject, owner: RenderObject, ids: _Ids) -> list[ScenePart | _Pending]:
    """A still object's entries with its ids counted now (in the order they were first counted)."""
    out: list[ScenePart | _Pending] = []
    for e in still.entries:
        if isinstance(e, ScenePart):
            instance_id, object_index = ids.of_part(owner, e.class_id)
            out.append(dataclasses.replace(e, instance_id=instance_id, object_index=object_index))
        else:
            part_ids = [(c, *ids.of_part(owner, c)) for c, _, _ in e.ids]
            out.append(_Pending(e.proto, e.l2w, e.world_from_object, part_ids))
    return out


@dataclass
class _Pending:
    """An object drawn as a prototype, waiting for the (vectorised) culling test."""

    proto: Prototype
    l2w: np.ndarray  # (4, 4) float64 its local-to-world transform as Gf holds it (gf_rows)
    world_from_object: np.ndarray
    ids: list[tuple[int, int, int]]  # (class, instance, object index) of each part


def _extract(
    stage: Usd.Stage,
    objects_path: str | None,
    cull: ViewCull | None,
    time: Usd.TimeCode | None,
    cache: dict[tuple, Prototype | None] | None,
    static: StaticCache | None = None,
    virtual: VirtualObjects | None = None,
    geometry_cache: GeometryCache | None = None,
) -> RenderScene:
    objects_sdf = Sdf.Path(objects_path or _default_objects_path(stage))
    world_T = world_from_stage(stage)
    t = Usd.TimeCode.Default() if time is None else time
    xf_cache = UsdGeom.XformCache(t)
    ids = _Ids(thing_label_ids())
    labels: dict[Sdf.Path, str | None] = {}
    objects: dict[Sdf.Path, RenderObject] = {}
    entries: list[ScenePart | _Pending] = []
    local_layers = list(stage.GetLayerStack(includeSessionLayers=True))
    local_ids = local_layer_ids(stage)
    prototypes: dict[tuple, Prototype | None] = {} if cache is None else cache
    # asset meshes, shared by prototypes and by objects read on their own
    geometry: GeometryCache = {} if geometry_cache is None else geometry_cache

    predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
    if static is not None and static.scope_moves is None:
        scope = stage.GetPrimAtPath(objects_sdf)
        static.scope_moves = bool(scope) and any(_moves(p) for p in _self_and_ancestors(scope))
    keep = static is not None and not static.scope_moves
    first_entry: dict[Sdf.Path, int] = {}  # where each object's entries start
    to_keep: set[Sdf.Path] = set()  # the objects read now that stand still
    it = iter(Usd.PrimRange(stage.GetPseudoRoot(), predicate))
    n_virtual = 0 if virtual is None else len(virtual.names)
    placed = 0  # virtual objects counted in so far
    in_scope = False  # the objects scope was reached

    def count_in(until: float) -> int:
        """Count in the virtual objects before stage place ``until``; the next one's number."""
        k = placed
        while k < n_virtual and virtual.order[virtual.names[k]] < until:
            name = virtual.names[k]
            path = objects_sdf.AppendChild(name)
            label = labels[path] = virtual.labels[k]
            label_id = label_id_for_class(label)
            instance_id = ids.next(label_id) if label_id in ids.things else label_id
            owner = objects[path] = RenderObject(str(path), label, label_id, instance_id, len(objects) + 1)
            proto = prototypes.get(virtual.keys[k])
            if proto is None:
                raise ValueError(f"RenderScene.from_stage: no prototype for the virtual object {name}")
            part_ids = []
            for part in proto.parts:
                class_id = label_id_for_class(part.label if part.label is not None else label)
                part_ids.append((class_id, *ids.of_part(owner, class_id)))
            l2w = virtual.local_to_world[k]
            entries.append(_Pending(proto, l2w, world_T @ l2w.T, part_ids))
            k += 1
        return k

    for prim in it:
        path = prim.GetPath()
        if prim.IsPseudoRoot():
            continue
        if placed < n_virtual:
            if path.GetParentPath() == objects_sdf:
                placed = count_in(virtual.order[path.name])
            elif in_scope and not path.HasPrefix(objects_sdf):
                placed = count_in(float("inf"))  # past the scope
            in_scope = in_scope or path == objects_sdf
        still = static.objects.get(path) if keep and static is not None else None
        if still is not None:  # read before: only its ids are counted again
            it.PruneChildren()
            labels[path] = still.label
            label_id = label_id_for_class(still.label)
            instance_id = ids.next(label_id) if label_id in ids.things else label_id
            owner = RenderObject(str(path), still.label, label_id, instance_id, len(objects) + 1)
            objects[path] = owner
            first_entry[path] = len(entries)
            entries.extend(_replay(still, owner, ids))
            continue
        if pruned(prim, t):
            it.PruneChildren()
            if time is not None and path.GetParentPath() == objects_sdf and not pruned(prim):
                # hidden at this time only (a drive's mover not seen then): it keeps its id and
                # place in ``objects``, as a culled object does, so ids agree over time
                own = own_label(prim)
                label = (own if own is not None else labels.get(path.GetParentPath())) or ""
                label_id = label_id_for_class(label)
                instance_id = ids.next(label_id) if label_id in ids.things else label_id
                objects[path] = RenderObject(str(path), label, label_id, instance_id, len(objects) + 1)
            continue
        own = own_label(prim)
        labels[path] = own if own is not None else labels.get(path.GetParentPath())
        if path.GetParentPath() == objects_sdf:
            label = labels[path] or ""
            label_id = label_id_for_class(label)
            instance_id = ids.next(label_id) if label_id in ids.things else label_id
            owner = objects[path] = RenderObject(str(path), label, label_id, instance_id, len(objects) + 1)
            key = prototype_key(prim, local_ids, local_layers)
            if keep and static is not None and path not in static.moving:
                if key is not None and key in prototypes and prototypes[key] is not None:
                    if key not in static.prototype_moves:
                        static.prototype_moves[key] = _subtree_moves(prim, predicate)
                    moves = _moves(prim) or static.prototype_moves[key]
                else:
                    moves = _subtree_moves(prim, predicate)
                if moves:
                    static.moving.add(path)
                else:
                    to_keep.add(path)
            first_entry[path] = len(entries)
            if key is not None:
                if key not in prototypes:
                    prototypes[key] = read_prototype(prim, predicate, geometry)
                proto = prototypes[key]
                if proto is not None:
                    it.PruneChildren()
                    l2w = gf_rows(xf_cache.GetLocalToWorldTransform(prim))
                    part_ids = []
                    for part in proto.parts:
                        own_class = part.label if part.label is not None else owner.class_name
                        class_id = label_id_for_class(own_class)
                        part_ids.append((class_id, *ids.of_part(owner, class_id)))
                    entries.append(_Pending(proto, l2w, world_T @ l2w.T, part_ids))
                    continue
        if not prim.IsA(UsdGeom.Mesh):
            continue
        local = read_local_mesh(UsdGeom.Mesh(prim), geometry)
        if local is None:
            continue
        world_from_local = world_T @ matrix_from_gf(xf_cache.GetLocalToWorldTransform(prim))
        class_id = label_id_for_class(labels[path])
        instance_id, object_index = ids.of_part(_owner(path, objects_sdf, objects), class_id)
        entries.append(ScenePart(local, world_from_local, class_id, instance_id, object_index))
    if placed < n_virtual:
        if not in_scope:
            raise ValueError("RenderScene.from_stage: virtual objects without their scope in the stage")
        placed = count_in(float("inf"))
    if static is not None and to_keep:
        _keep_still(static, first_entry, to_keep, objects, entries)
    parts, culled = _place(entries, world_T, cull)
    batches, order = group_parts(parts)
    culled_box = None
    if culled:
        pts = np.concatenate(culled)
        culled_box = np.stack([pts.min(axis=0), pts.max(axis=0)])
    return RenderScene(batches, order, tuple(objects.values()), culled_box)


def _self_and_ancestors(prim: Usd.Prim) -> list[Usd.Prim]:
    out = []
    while prim and not prim.IsPseudoRoot():
        out.append(prim)
        prim = prim.GetParent()
    return out


def _keep_still(
    static: StaticCache,
    first_entry: dict[Sdf.Path, int],
    to_keep: set[Sdf.Path],
    objects: dict[Sdf.Path, RenderObject],
    entries: list[ScenePart | _Pending],
) -> None:
    """Put the still objects read now into the cache: each one's entries, up to the next object's."""
    starts = sorted(first_entry.items(), key=lambda item: item[1])
    for k, (path, start) in enumerate(starts):
        if path not in to_keep:
            continue
        end = starts[k + 1][1] if k + 1 < len(starts) else len(entries)
        owner = objects[path]
        mine = tuple(
            e
            for e in entries[start:end]
            if isinstance(e, _Pending) or e.object_index == owner.index  # a _Pending is the object itself
        )
        static.objects[path] = _StillObject(owner.class_name, mine)


def _place(
    entries: list[ScenePart | _Pending], world_T: np.ndarray, cull: ViewCull | None
) -> tuple[list[ScenePart], list[np.ndarray]]:
    """The parts in stage order, the culled objects left out; and the culled objects' box corners.

    A prototype's part is placed by exactly the products ``UsdGeom.XformCache`` makes (each
    prim's local transform times its parent's, :func:`gf_product`: for every object and part
    at once, one chain level at a time), so it has the same bits as when read on its own.
    """
    pending = [e for e in entries if isinstance(e, _Pending) and e.proto.parts]
    out: set[int] = set()
    culled: list[np.ndarray] = []
    if cull is not None and pending:
        box: dict[int, np.ndarray] = {}
        corners = []
        for e in pending:
            local = box.get(id(e.proto))
            if local is None:
                local = box[id(e.proto)] = box_corners(e.proto.box_local)
            w = e.world_from_object
            corners.append(local @ w[:3, :3].T + w[:3, 3])
        outside = cull.outside_all(np.stack(corners))
        for e, c, o in zip(pending, corners, outside):
            if o:
                out.add(id(e))
                culled.append(c)
    shown = [e for e in pending if id(e) not in out]
    # every (object, part) pair at once: its l2w times the part's chain, one chain level at a
    # time over the pairs whose chain is that long (a few numpy products, whatever the prototypes)
    links: list[np.ndarray] = []  # the chains' matrices, as rows
    chain_at: dict[int, list[list[int]]] = {}  # by prototype: per part, its chain's rows in ``links``
    pair_object: list[int] = []
    pair_chain: list[list[int]] = []
    for k, e in enumerate(shown):
        chains = chain_at.get(id(e.proto))
        if chains is None:
            chains = chain_at[id(e.proto)] = []
            for part in e.proto.parts:
                chains.append(list(range(len(links), len(links) + len(part.chain))))
                links.extend(gf_rows(local) for local in part.chain)
        pair_object.extend([k] * len(chains))
        pair_chain.extend(chains)
    world_from_part = np.zeros((0, 4, 4))
    if shown:
        m = np.stack([e.l2w for e in shown])[np.array(pair_object, dtype=np.int64)]
        table = np.stack(links) if links else np.zeros((0, 4, 4))
        depth = np.array([len(c) for c in pair_chain], dtype=np.int64)
        for level in range(int(depth.max(initial=0))):
            sel = np.flatnonzero(depth > level)
            rows = np.array([pair_chain[i][level] for i in sel.tolist()], dtype=np.int64)
            m[sel] = gf_product(table[rows], m[sel])
        world_from_part = np.matmul(world_T, np.transpose(m, (0, 2, 1)))
    first = {id(e): n for n, e in zip(np.cumsum([0] + [len(e.proto.parts) for e in shown]).tolist(), shown)}
    parts: list[ScenePart] = []
    for e in entries:
        if isinstance(e, ScenePart):
            parts.append(e)
            continue
        n = first.get(id(e))
        if n is None:
            continue
        for part, (class_id, instance_id, object_index) in zip(e.proto.parts, e.ids):
            parts.append(ScenePart(part.mesh, world_from_part[n], class_id, instance_id, object_index))
            n += 1
    return parts, culled


class _Ids:
    """Cityscapes instance ids, counted per class in stage order."""

    def __init__(self, things: frozenset[int] | set[int]) -> None:
        self.things = things
        self.per_class: dict[int, int] = {}
        self.parts: dict[tuple[str, int], int] = {}

    def next(self, class_id: int) -> int:
        k = self.per_class.get(class_id, 0)
        self.per_class[class_id] = k + 1
        return class_id * 1000 + k

    def of_part(self, owner: RenderObject | None, class_id: int) -> tuple[int, int]:
        """(instance id, object index) of a mesh labelled ``class_id`` inside ``owner``."""
        if owner is None:
            return class_id, 0
        if class_id not in self.things:
            return class_id, owner.index
        if class_id == owner.label_id:
            return owner.instance_id, owner.index
        # A thing part labelled unlike its object (a rider on a bicycle) is an
        # instance of its own class, one per (object, class).
        key = (owner.path, class_id)
        if key not in self.parts:
            self.parts[key] = self.next(class_id)
        return self.parts[key], owner.index



def _owner(
    path: Sdf.Path, objects_sdf: Sdf.Path, objects: dict[Sdf.Path, RenderObject]
) -> RenderObject | None:
    if not path.HasPrefix(objects_sdf) or path == objects_sdf:
        return None
    prefixes = path.GetPrefixes()
    depth = objects_sdf.pathElementCount
    return objects.get(prefixes[depth]) if len(prefixes) > depth else None


