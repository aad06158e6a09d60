"""Meshes drawn once per asset: one batch per distinct mesh (and colour), many instances each.

A world's objects reference a few class assets, so most of its meshes are the same mesh at
several places. :func:`group_parts` turns the scene's parts (one mesh, one transform and
its ids each, in stage order) into :class:`MeshBatch` es: one per distinct mesh (the
topology and normals read once, :data:`~usdworld.render.usd_mesh.GeometryCache`) and
colour pattern. A mesh of one colour throughout keeps its colour per instance (objects
painted differently share a batch); a mesh of several colours is batched with the
instances painted exactly alike. The renderer uploads each batch's corners once and
draws it with one instanced draw call per pass.

The flat, per-corner arrays of the whole scene (:func:`expand`) are the same bits as
placing every part on the CPU (:func:`~usdworld.render.usd_mesh.place_mesh`), in stage order.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from usdworld.authoring.mesh_reader import MeshTopology
from usdworld.render.usd_mesh import LocalMesh, MeshTriangles, place_mesh


@dataclass(frozen=True)
class ScenePart:
    """One mesh of the scene at one place.

    Attributes:
        mesh: the mesh in its own frame.
        world_from_local: (4, 4) float64 column-vector transform, mesh -> world (Z up, metres).
        class_id: Cityscapes label id of its pixels.
        instance_id: Cityscapes instance id of its pixels.
        object_index: 1-based index of its object in the scene (0: none).
    """

    mesh: LocalMesh
    world_from_local: np.ndarray
    class_id: int
    instance_id: int
    object_index: int


def _frozen(a: np.ndarray, dtype: type) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=dtype)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class MeshBatch:
    """One mesh and the places it is drawn at (N instances).

    Attributes:
        topology: the mesh's points and triangles, in its own frame.
        normals_local: (T*3, 3) float64 authored normals per corner, or None (flat normals).
        vertex_colors: (T*3, 3) float64 linear RGB per corner, shared by every instance; None
            when each instance has one colour of its own (``instance_colors``).
        instance_colors: (N, 3) float64 linear RGB per instance, or None (``vertex_colors``).
        world_from_local: (N, 4, 4) float64 transforms, mesh -> world.
        class_ids: (N,) int32 Cityscapes label id per instance.
        instance_ids: (N,) int32 Cityscapes instance id per instance.
        object_ids: (N,) int32 object index per instance (0: no object).
    """

    topology: MeshTopology
    normals_local: np.ndarray | None
    vertex_colors: np.ndarray | None
    instance_colors: np.ndarray | None
    world_from_local: np.ndarray
    class_ids: np.ndarray
    instance_ids: np.ndarray
    object_ids: np.ndarray
    _used_points: np.ndarray = field(init=False, repr=False)
    _bounds: np.ndarray | None = field(init=False, repr=False, default=None)

    def __post_init__(self) -> None:
        n = len(self.world_from_local)
        transforms = _frozen(self.world_from_local, np.float64).reshape(n, 4, 4)
        object.__setattr__(self, "world_from_local", transforms)
        for name in ("class_ids", "instance_ids", "object_ids"):
            a = _frozen(getattr(self, name), np.int32)
            if a.shape != (n,):
                raise ValueError(f"MeshBatch.{name}: shape {a.shape}, expected ({n},)")
            object.__setattr__(self, name, a)
        if (self.vertex_colors is None) == (self.instance_colors is None):
            raise ValueError("MeshBatch: exactly one of vertex_colors and instance_colors is needed")
        if self.instance_colors is not None and np.shape(self.instance_colors) != (n, 3):
            shape = np.shape(self.instance_colors)
            raise ValueError(f"MeshBatch.instance_colors: shape {shape}, expected ({n}, 3)")
        used = np.zeros(len(self.topology.points), dtype=bool)
        used[self.topology.triangles.reshape(-1)] = True
        object.__setattr__(self, "_used_points", self.topology.points[used])

    @property
    def n_instances(self) -> int:
        return len(self.world_from_local)

    @property
    def n_corners(self) -> int:
        """Corners of one instance (3 per triangle)."""
        return int(self.topology.corners.size)

    def used_points_local(self) -> np.ndarray:
        """(U, 3) float64 the points the triangles use, in the mesh's frame (read-only)."""
        return self._used_points

    def corners_local(self) -> np.ndarray:
        """(T*3, 3) float64 the triangles' corners in the mesh's frame."""
        return self.topology.points[self.topology.triangles.reshape(-1)]

    def flat_normals_local(self) -> np.ndarray:
        """(T*3, 3) float64 each triangle's (unnormalised) face normal in the mesh's frame, per corner.

        Placed by the inverse transpose of an instance's linear part, it points along the
        face normal of the placed triangle (up to sign, which the two-sided shading ignores).
        """
        tri = self.corners_local().reshape(-1, 3, 3)
        return np.repeat(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), 3, axis=0)

    def local_mesh(self, i: int) -> LocalMesh:
        """Instance ``i``'s mesh as :func:`~usdworld.render.usd_mesh.place_mesh` takes it."""
        if self.vertex_colors is not None:
            colors = self.vertex_colors
        else:
            colors = np.tile(self.instance_colors[i], (self.n_corners, 1))
        return LocalMesh(self.topology, self.normals_local, colors)

    def placed_points(self, max_points: int = 1_000_000) -> Iterator[np.ndarray]:
        """The points its triangles use, placed by every instance, in chunks of instances.

        Yields:
            (n, P, 3) float32 points of n instances, the same values as the corners in the
            flat arrays (the product place_mesh makes, points @ linear.T + t, done for a chunk
            of instances at once).
        """
        for placed in self._placed64(max_points):
            yield placed.astype(np.float32)

    def _placed64(self, max_points: int = 1_000_000) -> Iterator[np.ndarray]:
        """:meth:`placed_points` before rounding to float32: (n, P, 3) float64."""
        pts = self._used_points
        chunk = max(1, max_points // max(1, len(pts)))
        for s in range(0, self.n_instances, chunk):
            m = self.world_from_local[s : s + chunk]
            yield np.matmul(pts[None], np.transpose(m[:, :3, :3], (0, 2, 1))) + m[:, None, :3, 3]

    def bounds_world(self) -> np.ndarray:
        """(2, 3) float64 ``[min, max]`` of every instance's corners, as float32 positions give
        them (read-only; worked out once)."""
        if self._bounds is None:
            # the extremes of the float64 products, rounded: rounding to float32 keeps the order,
            # so these are the extremes of the float32 points (placed_points) without rounding them all
            lo = np.full(3, np.inf)
            hi = np.full(3, -np.inf)
            for placed in self._placed64():
                # per coordinate: numpy reduces an (n, P) strided column far faster than over two axes
                lo = np.minimum(lo, [placed[..., c].min() for c in range(3)])
                hi = np.maximum(hi, [placed[..., c].max() for c in range(3)])
            bounds = np.stack([lo, hi]).astype(np.float32).astype(np.float64)
            bounds.setflags(write=False)
            object.__setattr__(self, "_bounds", bounds)
        return self._bounds

    def with_ids(self, instance_ids: np.ndarray, object_ids: np.ndarray) -> MeshBatch:
        """The same meshes at the same places with other ids (its bounds not worked out again).

        Args:
            instance_ids: (N,) int Cityscapes instance id per instance.
            object_ids: (N,) int object index per instance.
        """
        out = dataclasses.replace(self, instance_ids=instance_ids, object_ids=object_ids)
        object.__setattr__(out, "_bounds", self._bounds)
        return out


def _colour_key(mesh: LocalMesh) -> tuple[bytes | None, np.ndarray | None]:
    """(bytes of the per-corner colours, None) or (None, the one colour) for a one-colour mesh."""
    c = mesh.colors
    if len(c) and np.all(c == c[0]):
        return None, c[0]
    return np.ascontiguousarray(c).tobytes(), None


def group_parts(parts: list[ScenePart]) -> tuple[tuple[MeshBatch, ...], np.ndarray]:
    """Batch the parts by mesh and colour pattern, in order of first appearance.

    Args:
        parts: the scene's parts in stage order.

    Returns:
        The batches and a (P, 2) int64 array: for each part, its batch and instance index.
    """
    keys: dict[tuple, int] = {}
    members: list[list[int]] = []
    colours: list[np.ndarray | None] = []
    where = np.zeros((len(parts), 2), dtype=np.int64)
    seen: dict[int, tuple[bytes | None, np.ndarray | None]] = {}
    for k, part in enumerate(parts):
        mesh = part.mesh
        if id(mesh) not in seen:
            seen[id(mesh)] = _colour_key(mesh)
        pattern, one = seen[id(mesh)]
        normals = mesh.normals_local
        key = (id(mesh.topology), None if normals is None else id(normals), pattern)
        b = keys.get(key)
        if b is None:
            b = keys[key] = len(members)
            members.append([])
        where[k] = (b, len(members[b]))
        members[b].append(k)
        colours.append(one)
    batches = []
    for idx in members:
        first = parts[idx[0]].mesh
        uniform = colours[idx[0]] is not None
        batches.append(
            MeshBatch(
                topology=first.topology,
                normals_local=first.normals_local,
                vertex_colors=None if uniform else first.colors,
                instance_colors=np.array([colours[i] for i in idx]) if uniform else None,
                world_from_local=np.array([parts[i].world_from_local for i in idx]),
                class_ids=np.array([parts[i].class_id for i in idx]),
                instance_ids=np.array([parts[i].instance_id for i in idx]),
                object_ids=np.array([parts[i].object_index for i in idx]),
            )
        )
    return tuple(batches), where


def expand(batches: tuple[MeshBatch, ...], order: np.ndarray) -> dict[str, np.ndarray]:
    """Every part's triangles placed on the CPU and concatenated in stage order.

    Args:
        batches: the scene's batches.
        order: (P, 2) int64 batch and instance index of each part, in stage order.

    Returns:
        ``positions_world``, ``normals_world``, ``colors`` ((V, 3) float32 each) and
        ``class_ids``, ``instance_ids``, ``object_ids`` ((V,) int32 each), V = 3 * triangles.
    """
    if len(order) == 0:
        empty3 = np.zeros((0, 3), dtype=np.float32)
        empty = np.zeros(0, dtype=np.int32)
        return {
            "positions_world": empty3,
            "normals_world": empty3,
            "colors": empty3,
            "class_ids": empty,
            "instance_ids": empty,
            "object_ids": empty,
        }
    placed: list[MeshTriangles] = [
        place_mesh(batches[b].local_mesh(i), batches[b].world_from_local[i]) for b, i in order
    ]
    sizes = [len(t.positions_world) for t in placed]
    return {
        "positions_world": np.concatenate([t.positions_world for t in placed]).astype(np.float32),
        "normals_world": np.concatenate([t.normals_world for t in placed]).astype(np.float32),
        "colors": np.concatenate([t.colors for t in placed]).astype(np.float32),
        "class_ids": np.repeat([batches[b].class_ids[i] for b, i in order], sizes).astype(np.int32),
        "instance_ids": np.repeat([batches[b].instance_ids[i] for b, i in order], sizes).astype(np.int32),
        "object_ids": np.repeat([batches[b].object_ids[i] for b, i in order], sizes).astype(np.int32),
    }
