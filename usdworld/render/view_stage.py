"""A large world read for one view: only the objects whose box or shadow can reach it.

Composing every object of a 10,000-object world (a reference and a variant each) costs more
than drawing the few hundred the camera sees. A world whose object index is kept
(:mod:`usdworld.authoring.editing.index_file`: the base layer's object opinions, keyed by
its SHA-256) gives each object's class, ``model`` variant, ``active``, asset, translate,
rotateZ and scale, and whether its spec holds anything else (plain), without composing it or
reading its spec. :func:`open_outside` composes everything outside the objects scope
(camera, lights, ground); :func:`scene_for_view` picks the objects whose box (an upright
cylinder around the asset's box, any yaw) or its shadow may meet the view
(:class:`~.instancing.ViewCull`, the test the scene reader uses), composes beside the rest
the objects the edits layer touches (and the scope's first object), and reads the scene with
the other picks as virtual objects (:class:`~.scene.VirtualObjects`): each asset and variant
is composed once, on a stage of its own, as the prototype the scene reader would read, and
each object's transform is made from its ops with UsdGeom's products, replicated in numpy
for all objects at once (the same bits). The scene's objects then get the ids they have in
the whole world (class counts in stage order). The far plane and the shadow map's box take
in the culled objects' boxes: the objects that may hold the culled boxes' extreme
coordinates are read too, and a scene whose bounds another object's box could widen is
refused. Whatever the index cannot describe (no kept index, another sublayer, an object that
is not plain: a child, another transform, a visibility or purpose, primvars, a payload; an
asset with parts of another thing class, hidden, or not read as a prototype) gives None, and
the caller composes the whole world; the pixels are the same bits either way.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom

from usdworld.render.classes import label_id_for_class, thing_label_ids
from usdworld.render.instancing import (
    Prototype,
    ViewCull,
    local_layer_ids,
    prototype_key,
    pruned,
    read_prototype,
)
from usdworld.render.scene import RenderObject, RenderScene, VirtualObjects, gf_rows, gf_product
from usdworld.render.usd_mesh import GeometryCache

OBJECTS = "/World/Objects"
#: Which corner of a box takes the upper side, per axis (the order of :func:`~.instancing.box_corners`).
_CORNER_BITS = tuple(np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=bool).T)
#: Metres a conservative box is widened by (float rounding of the composed transforms).
_SLACK_M = 1e-3


@dataclass(frozen=True)
class WorldObjects:
    """Every object of the world as the index and the base layer give them, in stage order.

    Attributes:
        order: every name under the objects scope in any layer, in the composed stage's order.
        names: the base layer's objects the edits layer does not touch (defined, active), in that order.
        labels: their ``class`` labels.
        lo: (N, 3) float64 lower corner of a box holding each object's meshes, metres.
        hi: (N, 3) float64 upper corner.
        composed: (N,) bool, the object is read with the scene: in the masked stage or virtual.
        virtual: the objects read from the index and their prototypes instead of the stage.
        prototypes: those prototypes, by key (a cache for the scene reader).
        geometry: the meshes they were read from (shared with the scene reader).
    """

    order: tuple[str, ...]
    names: tuple[str, ...]
    labels: tuple[str, ...]
    lo: np.ndarray
    hi: np.ndarray
    composed: np.ndarray
    virtual: VirtualObjects
    prototypes: dict[tuple, Prototype]
    geometry: GeometryCache


def _root_sublayers(world_file: Path) -> list[Sdf.Layer] | None:
    """The edits and the base layer of a world with a kept index file, or None."""
    from usdworld.authoring.editing.index_file import INDEX_FILE

    root = Sdf.Layer.FindOrOpen(str(world_file))
    if root is None or root.rootPrims or len(root.subLayerPaths) != 2:
        return None  # a drive's layer or opinions in the root: not what the index knows
    paths = [root.ComputeAbsolutePath(p) for p in root.subLayerPaths]
    if not (Path(paths[-1]).parent / INDEX_FILE).is_file():
        return None  # no index kept (a small world): its layers are not parsed twice
    layers = [Sdf.Layer.FindOrOpen(p) for p in paths]
    if any(layer is None for layer in layers):
        return None
    meta = root.pseudoRoot
    units = meta.GetInfo("metersPerUnit") if meta.HasInfo("metersPerUnit") else None
    up = meta.GetInfo("upAxis") if meta.HasInfo("upAxis") else None
    if root.defaultPrim != "World" or units != 1.0 or up != "Z":
        return None
    return layers


def _outside_paths(layers: list[Sdf.Layer]) -> list[str]:
    """Every prim outside the objects scope (root prims, the children of /World but Objects)."""
    out: set[str] = set()
    for layer in layers:
        for prim in layer.rootPrims:
            if prim.name != "World":
                out.add(str(prim.path))
                continue
            out.update(str(c.path) for c in prim.nameChildren if c.name != "Objects")
    return sorted(out)


def _stage_order(layers: list[Sdf.Layer]) -> list[str] | None:
    """The objects scope's children as composition orders them (weakest layer's first), or
    None when a layer reorders them."""
    names: list[str] = []
    seen: set[str] = set()
    for layer in reversed(layers):
        scope = layer.GetPrimAtPath(OBJECTS)
        if not scope:
            continue
        if scope.HasInfo("primOrder") or scope.HasInfo("references") or scope.HasInfo("inheritPaths"):
            return None
        for name in scope.GetInfo("primChildren"):
            if name not in seen:
                seen.add(name)
                names.append(name)
    return names


@dataclass(frozen=True)
class _Kinds:
    """What each (asset file, variant) gives an object that references it, read once."""

    boxes: dict[tuple[str, str | None], np.ndarray]  # (2, 3) box of its meshes in the object's frame
    part_labels: dict[tuple[str, str | None], set[str]]  # the class labels its parts carry of their own
    keys: dict[tuple[str, str | None], tuple]  # its prototype key (as the scene reader makes it)
    prototypes: dict[tuple, Prototype]  # by prototype key
    geometry: GeometryCache  # the meshes read


def _asset_kinds(kinds: set[tuple[str, str | None]]) -> _Kinds | None:
    """Read each (asset file, variant) as the scene reader reads a plain object referencing it
    (an ``Xform`` with one reference and a ``model`` selection), on a stage of its own; None
    when one would not be read as a prototype (hidden, a mesh, a reset transform, no mesh)."""
    layer = Sdf.Layer.CreateAnonymous(".usda")
    Sdf.CreatePrimInLayer(layer, "/K").specifier = Sdf.SpecifierDef
    paths = {}
    for k, (asset, variant) in enumerate(sorted(kinds, key=str)):
        spec = Sdf.CreatePrimInLayer(layer, f"/K/k{k}")
        spec.specifier = Sdf.SpecifierDef
        spec.typeName = "Xform"
        spec.referenceList.Prepend(Sdf.Reference(asset))
        if variant:
            spec.variantSelections["model"] = variant
        paths[(asset, variant)] = f"/K/k{k}"
    stage = Usd.Stage.Open(layer)
    predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
    local_layers = list(stage.GetLayerStack(includeSessionLayers=True))
    local_ids = local_layer_ids(stage)
    out = _Kinds({}, {}, {}, {}, {})
    for kind, path in paths.items():
        prim = stage.GetPrimAtPath(path)
        if not prim or pruned(prim):
            return None
        key = prototype_key(prim, local_ids, local_layers)
        if key is None:
            return None
        proto = out.prototypes.get(key) or read_prototype(prim, predicate, out.geometry)
        if proto is None or not proto.parts:
            return None
        out.keys[kind] = key
        out.prototypes[key] = proto
        out.boxes[kind] = proto.box_local
        out.part_labels[kind] = {part.label for part in proto.parts if part.label is not None}
    return out


def _local_to_world(translate: np.ndarray, yaw_deg: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """The transforms ``UsdGeom.XformCache`` gives objects of the objects scope (whose ancestors
    have no transform) with the ops translate, rotateZ, scale, as ``Gf.Matrix4d`` holds them:
    the same products in the same order (``UsdGeomXformable``: the ops from the last, identity
    ones skipped; then times the parent's identity), with Gf's bits (:func:`~.scene.gf_product`;
    each distinct angle's rotation is Gf's own).

    Args:
        translate: (N, 3) float64 the translate ops' values.
        yaw_deg: (N,) float64 the rotateZ ops' (float) values, degrees.
        scale: (N, 3) float64 the scale ops' (float3) values.

    Returns:
        (N, 4, 4) float64 row-vector matrices (:func:`~.scene.gf_rows`).
    """
    n = len(yaw_deg)
    identity = np.eye(4)
    move = np.tile(identity, (n, 1, 1))
    move[:, 3, :3] = translate
    angles, which = np.unique(yaw_deg, return_inverse=True)
    z = Gf.Vec3d.ZAxis()
    turns = np.stack([gf_rows(Gf.Matrix4d(1.0).SetRotate(Gf.Rotation(z, float(a)))) for a in angles])
    turn = turns.reshape(-1, 4, 4)[which.reshape(-1)]
    size = np.tile(identity, (n, 1, 1))
    size[:, [0, 1, 2], [0, 1, 2]] = scale
    local = np.tile(identity, (n, 1, 1))
    for op in (size, turn, move):  # the ops from the last
        use = ~np.all(op == identity, axis=(1, 2))  # Gf's == (an identity op is skipped)
        local[use] = gf_product(local[use], op[use])
    return gf_product(local, identity)


@dataclass(frozen=True)
class _Base:
    """The base layer's objects that the edits layer does not touch (defined, active), in stage order."""

    names: list[str]
    labels: list[str]
    kinds: list[tuple[str, str | None]]  # (asset file, variant) per object
    translate: np.ndarray  # (N, 3) float64
    scale: np.ndarray  # (N, 3) float64
    yaw_deg: np.ndarray  # (N,) float64 the rotateZ values


def _base_objects(layers: list[Sdf.Layer], names: list[str], edited: set[str]) -> _Base | None:
    """Class, variant, asset, translate and scale of the objects the edits layer does not touch,
    from the object index (:mod:`~usdworld.authoring.editing.index_file`; a file keyed to other
    bytes is read again from the layer and rewritten, as the editor does); None when an object
    is not plain (:func:`~usdworld.authoring.editing.index.plain_asset`: a child, another
    transform, a visibility, a purpose, primvars, a material binding, a payload, instancing ...)."""
    from usdworld.authoring.editing.index_file import lower_opinions

    base = layers[1]
    if not base.realPath:
        return None
    kept = lower_opinions(layers, 0)  # the file exists (_root_sublayers): keep it current
    at = {n: i for i, n in enumerate(kept.names)}
    rows = [at.get(name) for name in names if name not in edited]
    if None in rows:
        return None
    rows_a = np.array(rows, dtype=np.int64)
    active = np.array([a is not False for a in kept.active], dtype=bool)
    rows_a = rows_a[kept.defined[rows_a] & active[rows_a]]
    if not kept.plain[rows_a].all():
        return None
    labels = [kept.label[i] for i in rows_a]
    if not all(labels):
        return None
    translate = np.column_stack([kept.translate[rows_a], kept.z_scale_yaw[rows_a, 0]])
    scale = np.column_stack([kept.scale[rows_a], kept.z_scale_yaw[rows_a, 1]])
    yaw = kept.z_scale_yaw[rows_a, 2]
    if np.isnan(translate).any() or np.isnan(scale).any() or np.isnan(yaw).any():
        return None
    assets: dict[str, str] = {}
    kinds = []
    for i in rows_a.tolist():
        ref = kept.asset[i]
        asset = assets.get(ref)
        if asset is None:
            asset = assets[ref] = base.ComputeAbsolutePath(ref)
        kinds.append((asset, kept.variant[i]))
    names_a = [kept.names[i] for i in rows_a]
    return _Base(names_a, labels, kinds, translate.reshape(-1, 3), scale.reshape(-1, 3), yaw.reshape(-1))


def open_outside(world_file: Path, min_objects: int) -> Usd.Stage | None:
    """The world composed without its objects (the camera, the lights, the ground, the image
    size), or None when it has fewer than ``min_objects`` objects or layers the index does not
    describe. Keep it open while :func:`scene_for_view` runs: its layers are not read again."""
    try:
        layers = _root_sublayers(world_file)
        if layers is None:
            return None
        order = _stage_order(layers)
        if order is None or len(order) < min_objects:
            return None
        stage = Usd.Stage.OpenMasked(str(world_file), Usd.StagePopulationMask(_outside_paths(layers)))
    except Tf.ErrorException:
        return None  # not a world's layers: the whole stage's open says why
    return stage if stage.GetPrimAtPath("/World") else None


def scene_for_view(world_file: Path, outside: Usd.Stage, cull: ViewCull) -> RenderScene | None:
    """The scene :meth:`RenderScene.from_stage` reads from the whole world with ``cull``, read
    from a stage of the objects that may reach the view; None when it cannot be told apart
    (compose the whole world then).

    Args:
        world_file: the world's root layer.
        outside: :func:`open_outside`'s stage.
        cull: the view's culling test.
    """
    opened = view_stage(world_file, outside, cull)
    if opened is None:
        return None
    stage, facts = opened
    try:
        scene = RenderScene.from_stage(
            stage,
            cull=cull,
            prototypes=dict(facts.prototypes),
            virtual=facts.virtual,
            geometry=facts.geometry,
        )
    except (KeyError, ValueError):
        return None  # a composed object the index does not name, or no objects scope
    return whole_world_scene(facts, scene)


def view_stage(
    world_file: Path, outside_stage: Usd.Stage, cull: ViewCull
) -> tuple[Usd.Stage, WorldObjects] | None:
    """The world composed with the objects that may reach the view (see the module docstring).

    Args:
        world_file: the world's root layer.
        outside_stage: :func:`open_outside`'s stage (its layers stay loaded).
        cull: the view's culling test, the one the scene is read with.

    Returns:
        The masked stage and every object's facts, or None (compose the whole world).
    """
    layers = _root_sublayers(world_file)
    if layers is None:
        return None
    order = _stage_order(layers)
    if order is None:
        return None
    edits = layers[0]
    scope = edits.GetPrimAtPath(OBJECTS)
    edited = set(scope.nameChildren.keys()) if scope else set()
    base = _base_objects(layers, order, edited)
    if base is None:
        return None
    read = _asset_kinds(set(base.kinds))
    if read is None:
        return None
    boxes, part_labels = read.boxes, read.part_labels
    things = thing_label_ids()
    for kind, label in set(zip(base.kinds, base.labels)):
        own = label_id_for_class(label)
        if any(label_id_for_class(c) in things and label_id_for_class(c) != own for c in part_labels[kind]):
            return None  # a part of another thing class (a rider) counts instance ids of its own
    rows = {k: n for n, k in enumerate(boxes)}
    table = np.array(list(boxes.values())).reshape(-1, 2, 3)
    box = table[np.array([rows[k] for k in base.kinds], dtype=np.int64)] * base.scale[:, None, :]
    box = np.stack([box.min(axis=1), box.max(axis=1)], axis=1)  # a negative scale flips the box
    r = np.hypot(np.abs(box[:, :, 0]).max(axis=1), np.abs(box[:, :, 1]).max(axis=1))  # any yaw about Z
    t = base.translate
    lo = np.column_stack([t[:, 0] - r, t[:, 1] - r, t[:, 2] + box[:, 0, 2]]) - _SLACK_M
    hi = np.column_stack([t[:, 0] + r, t[:, 1] + r, t[:, 2] + box[:, 1, 2]]) + _SLACK_M
    names = base.names
    corners = np.stack(
        [np.where(bits, hi[:, a, None], lo[:, a, None]) for a, bits in enumerate(_CORNER_BITS)], axis=-1
    )
    out = cull.outside_all(corners)
    pick = ~out
    culled = np.flatnonzero(out)
    if len(culled):  # the objects that may hold the culled boxes' extreme coordinates
        c = culled
        for a in range(2):  # x, y: the box's true side lies between its conservative sides
            pick[c[lo[c, a] <= hi[c, a].min()]] = True
            pick[c[hi[c, a] >= lo[c, a].max()]] = True
        # z is exact up to the slack (a yaw keeps it); not the lowest: the ground lies below
        # the objects, and whole_world_scene checks the bounds
        pick[c[hi[c, 2] >= hi[c, 2].max() - 2.0 * _SLACK_M]] = True
    # composed: the edited objects and the first (the objects scope is then in the stage, and
    # the virtual objects are counted in at their places in it); the other picks are virtual
    real = {*edited, order[0]}
    pick[[k for k, name in enumerate(names) if name == order[0]]] = True
    paths = [str(p) for p in outside_stage.GetPopulationMask().GetPaths()]
    paths += [f"{OBJECTS}/{n}" for n in sorted(real)]
    stage = Usd.Stage.OpenMasked(str(world_file), Usd.StagePopulationMask(paths))
    for path in ("/World", OBJECTS):
        prim = stage.GetPrimAtPath(path)
        xformable = UsdGeom.Xformable(prim)
        if not prim or pruned(prim) or (xformable and xformable.GetOrderedXformOps()):
            return None
    virtual = [k for k in np.flatnonzero(pick).tolist() if names[k] not in real]
    transforms = _local_to_world(base.translate[virtual], base.yaw_deg[virtual], base.scale[virtual])
    objects = VirtualObjects(
        {name: k for k, name in enumerate(order)},
        tuple(names[k] for k in virtual),
        tuple(base.labels[k] for k in virtual),
        tuple(read.keys[base.kinds[k]] for k in virtual),
        transforms,
    )
    facts = WorldObjects(
        tuple(order), tuple(names), tuple(base.labels), lo, hi, pick, objects, read.prototypes, read.geometry
    )
    return stage, facts


def whole_world_scene(facts: WorldObjects, scene: RenderScene) -> RenderScene | None:
    """The scene read from :func:`view_stage`'s stage with the whole world's objects and ids.

    Returns:
        The scene the whole world gives for this view, or None when it cannot be told from
        the masked one (an object with parts of another thing class, an edited object hidden,
        a box not inside its conservative one's reach of the bounds).
    """
    things = thing_label_ids()
    read = {o.path: o for o in scene.objects}
    base = {f"{OBJECTS}/{n}": (k, label) for k, (n, label) in enumerate(zip(facts.names, facts.labels))}
    counts: dict[int, int] = {}
    objects: list[RenderObject] = []
    for path in (f"{OBJECTS}/{n}" for n in facts.order):
        mine = read.get(path)
        if path in base:
            k, label = base[path]
            if facts.composed[k] and (mine is None or mine.class_name != label):
                return None  # hidden or labelled otherwise than the base layer says
        elif mine is None:
            continue  # an edited object inactive, undefined or hidden: not an object of the scene
        else:
            label = mine.class_name
        label_id = label_id_for_class(label)
        instance_id = label_id
        if label_id in things:
            instance_id = label_id * 1000 + counts.get(label_id, 0)
            counts[label_id] = counts.get(label_id, 0) + 1
        objects.append(RenderObject(path, label, label_id, instance_id, len(objects) + 1))
    whole = {o.path: o for o in objects}
    if any(o.path not in whole for o in scene.objects):
        return None
    n = len(scene.objects) + 1
    index_map, old_id, new_id, label_of = (np.zeros(n, dtype=np.int64) for _ in range(4))
    for o in scene.objects:
        w = whole[o.path]
        index_map[o.index], old_id[o.index], new_id[o.index], label_of[o.index] = (
            w.index, o.instance_id, w.instance_id, o.label_id
        )
    thing_ids = np.array(sorted(things), dtype=np.int64)
    batches = []
    for b in scene.batches:
        obj = np.asarray(b.object_ids, dtype=np.int64)
        inst = np.asarray(b.instance_ids, dtype=np.int64)
        cls = np.asarray(b.class_ids, dtype=np.int64)
        if np.any((obj > 0) & (cls != label_of[obj]) & np.isin(cls, thing_ids)):
            return None  # a thing part unlike its object counts ids of its own
        own = (obj > 0) & (inst == old_id[obj])
        inst = np.where(own, new_id[obj], inst)
        ids = inst.astype(b.instance_ids.dtype), index_map[obj].astype(b.object_ids.dtype)
        batches.append(b.with_ids(*ids))
    out = RenderScene(tuple(batches), scene.part_order, tuple(objects), scene.culled_bounds_world)
    lo, hi = out.bounds_world()
    rest = ~facts.composed
    # bounds are float32 values and rounding is monotone: a box inside them leaves them as they are
    if np.any(facts.lo[rest] < lo) or np.any(facts.hi[rest] > hi):
        return None  # an object not composed might widen the bounds
    return out

