"""What the renderer draws, read from a **composed** USD stage.

:meth:`RenderScene.from_stage` walks the stage with ``Usd.PrimRange`` (active, loaded,
defined, non-abstract prims; instance proxies included, so instanced objects render;
variant selections and edits layers are already applied by composition). Invisible
prims and ``guide`` / ``proxy`` purpose prims are pruned. Every ``UsdGeom.Mesh`` is
triangulated into the world frame (see :mod:`usdworld.render.usd_mesh`).

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

from dataclasses import dataclass, field

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom

from usdworld.render.classes import label_id_for_class, thing_label_ids
from usdworld.render.usd_mesh import MeshTriangles, mesh_triangles

_LABEL_ATTR = "semantics:labels:class"
_PRUNED_PURPOSES = (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy)


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


def _frozen(a: np.ndarray, dtype: type) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=dtype)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class RenderScene:
    """All triangles of a stage, unindexed (3 corners per triangle), world frame.

    Attributes:
        positions_world: (V, 3) float32 corner positions, metres (V = 3 * triangles).
        normals_world: (V, 3) float32 unit normals.
        colors: (V, 3) float32 linear RGB.
        class_ids: (V,) int32 Cityscapes label id per corner.
        instance_ids: (V,) int32 Cityscapes instance id per corner.
        object_ids: (V,) int32 1-based index into ``objects`` (0: no object).
        objects: the top-level objects, in stage order.
    """

    positions_world: np.ndarray
    normals_world: np.ndarray
    colors: np.ndarray
    class_ids: np.ndarray
    instance_ids: np.ndarray
    object_ids: np.ndarray
    objects: tuple[RenderObject, ...]
    _bounds: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        n = len(self.positions_world)
        for name, dtype, cols in (
            ("positions_world", np.float32, 3),
            ("normals_world", np.float32, 3),
            ("colors", np.float32, 3),
            ("class_ids", np.int32, 0),
            ("instance_ids", np.int32, 0),
            ("object_ids", np.int32, 0),
        ):
            a = _frozen(getattr(self, name), dtype)
            if len(a) != n or (cols and a.shape != (n, cols)) or (not cols and a.ndim != 1):
                raise ValueError(f"RenderScene.{name}: shape {a.shape} does not match {n} corners")
            object.__setattr__(self, name, a)
        if n % 3:
            raise ValueError(f"RenderScene: {n} corners is not a whole number of triangles")
        p = self.positions_world
        bounds = np.stack([p.min(axis=0), p.max(axis=0)]).astype(np.float64) if n else np.zeros((2, 3))
        bounds.setflags(write=False)
        object.__setattr__(self, "_bounds", bounds)

    @property
    def n_triangles(self) -> int:
        return len(self.positions_world) // 3

    def bounds_world(self) -> np.ndarray:
        """(2, 3) float64 axis-aligned bounds ``[min, max]``; zeros for an empty scene."""
        return self._bounds

    def object_by_path(self) -> dict[str, RenderObject]:
        """``{prim path: object}``."""
        return {o.path: o for o in self.objects}

    @classmethod
    def from_stage(cls, stage: Usd.Stage, objects_path: str | None = None) -> RenderScene:
        """Collect every renderable mesh of the composed stage.

        Args:
            stage: an open stage; its current composition is read (edits, variants, active).
            objects_path: the scope whose children are the objects; default
                ``<defaultPrim>/Objects`` when it exists, else ``/World/Objects``.
        """
        return _extract(stage, objects_path)


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


def _default_objects_path(stage: Usd.Stage) -> str:
    default = stage.GetDefaultPrim()
    if default and default.GetChild("Objects"):
        return str(default.GetPath().AppendChild("Objects"))
    return "/World/Objects"


def _own_label(prim: Usd.Prim) -> str | None:
    attr = prim.GetAttribute(_LABEL_ATTR)
    if not attr:
        return None
    value = attr.Get()
    return str(value[0]) if value is not None and len(value) else None


def _extract(stage: Usd.Stage, objects_path: str | None) -> RenderScene:
    objects_sdf = Sdf.Path(objects_path or _default_objects_path(stage))
    world_T = world_from_stage(stage)
    xf_cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    things = thing_label_ids()
    labels: dict[Sdf.Path, str | None] = {}
    objects: dict[Sdf.Path, RenderObject] = {}
    per_class_count: dict[int, int] = {}
    part_instances: dict[tuple[Sdf.Path, int], int] = {}
    parts: list[tuple[MeshTriangles, int, int, int]] = []

    predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
    it = iter(Usd.PrimRange(stage.GetPseudoRoot(), predicate))
    for prim in it:
        path = prim.GetPath()
        if prim.IsPseudoRoot():
            continue
        imageable = UsdGeom.Imageable(prim)
        if imageable and (
            imageable.GetVisibilityAttr().Get() == UsdGeom.Tokens.invisible
            or imageable.GetPurposeAttr().Get() in _PRUNED_PURPOSES
        ):
            it.PruneChildren()
            continue
        own = _own_label(prim)
        labels[path] = own if own is not None else labels.get(path.GetParentPath())
        if path.GetParentPath() == objects_sdf:
            label = labels[path] or ""
            label_id = label_id_for_class(label)
            if label_id in things:
                k = per_class_count.get(label_id, 0)
                per_class_count[label_id] = k + 1
                instance_id = label_id * 1000 + k
            else:
                instance_id = label_id
            objects[path] = RenderObject(str(path), label, label_id, instance_id, len(objects) + 1)
        if not prim.IsA(UsdGeom.Mesh):
            continue
        world_from_local = world_T @ matrix_from_gf(xf_cache.GetLocalToWorldTransform(prim))
        tris = mesh_triangles(UsdGeom.Mesh(prim), world_from_local)
        if tris is None:
            continue
        class_id = label_id_for_class(labels[path])
        owner = _owner(path, objects_sdf, objects)
        if owner is None:
            instance_id, object_index = class_id, 0
        else:
            object_index = owner.index
            if class_id not in things:
                instance_id = class_id
            elif class_id == owner.label_id:
                instance_id = owner.instance_id
            else:
                # A thing part labelled unlike its object (a rider on a bicycle) is an
                # instance of its own class, one per (object, class).
                key = (Sdf.Path(owner.path), class_id)
                if key not in part_instances:
                    k = per_class_count.get(class_id, 0)
                    per_class_count[class_id] = k + 1
                    part_instances[key] = class_id * 1000 + k
                instance_id = part_instances[key]
        parts.append((tris, class_id, instance_id, object_index))
    return _concatenate(parts, tuple(objects.values()))


def _owner(
    path: Sdf.Path, objects_sdf: Sdf.Path, objects: dict[Sdf.Path, RenderObject]
) -> RenderObject | None:
    if not path.HasPrefix(objects_sdf) or path == objects_sdf:
        return None
    prefixes = path.GetPrefixes()
    depth = objects_sdf.pathElementCount
    return objects.get(prefixes[depth]) if len(prefixes) > depth else None


def _concatenate(
    parts: list[tuple[MeshTriangles, int, int, int]], objects: tuple[RenderObject, ...]
) -> RenderScene:
    if not parts:
        empty3 = np.zeros((0, 3))
        empty = np.zeros(0)
        return RenderScene(empty3, empty3, empty3, empty, empty, empty, objects)
    sizes = [len(t.positions_world) for t, _, _, _ in parts]
    return RenderScene(
        positions_world=np.concatenate([t.positions_world for t, _, _, _ in parts]),
        normals_world=np.concatenate([t.normals_world for t, _, _, _ in parts]),
        colors=np.concatenate([t.colors for t, _, _, _ in parts]),
        class_ids=np.repeat([c for _, c, _, _ in parts], sizes),
        instance_ids=np.repeat([i for _, _, i, _ in parts], sizes),
        object_ids=np.repeat([o for _, _, _, o in parts], sizes),
        objects=objects,
    )
