"""One ``UsdGeom.Mesh`` -> world-space triangles with normals and colours.

Polygons are fan-triangulated (``v0, v_i, v_i+1``); holes are ignored. Normals are the
authored ``primvars:normals`` / ``normals`` when present (any interpolation), otherwise
flat face normals. The colour of a face is the ``diffuseColor`` of the UsdPreviewSurface
bound to it (GeomSubset bindings included), else ``primvars:displayColor``, else
:data:`DEFAULT_COLOR`. Colours are linear RGB, as USD stores them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom, UsdShade

#: Linear RGB of meshes with neither a material nor a displayColor.
DEFAULT_COLOR = (0.5, 0.5, 0.5)


@dataclass(frozen=True)
class MeshTriangles:
    """Unindexed triangles of one mesh in the world frame.

    Attributes:
        positions_world: (T*3, 3) float64 corner positions, metres.
        normals_world: (T*3, 3) float64 unit normals per corner.
        colors: (T*3, 3) float64 linear RGB per corner, in [0, 1].
    """

    positions_world: np.ndarray
    normals_world: np.ndarray
    colors: np.ndarray


@dataclass(frozen=True)
class _Fan:
    face_of_tri: np.ndarray  # (T,) face index of each triangle
    corners: np.ndarray  # (T, 3) index into the face-vertex list
    vertices: np.ndarray  # (T, 3) point index


def _fan_triangulate(counts: np.ndarray, indices: np.ndarray) -> _Fan:
    counts = counts.astype(np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    n_tri = np.maximum(counts - 2, 0)
    face_of_tri = np.repeat(np.arange(len(counts)), n_tri)
    first_tri = np.concatenate([[0], np.cumsum(n_tri)[:-1]])
    local = np.arange(len(face_of_tri)) - np.repeat(first_tri, n_tri) + 1  # 1 .. n-2
    s = starts[face_of_tri]
    corners = np.stack([s, s + local, s + local + 1], axis=1)
    return _Fan(face_of_tri, corners, indices[corners])


def _expand(values: np.ndarray, interpolation: str, fan: _Fan, n_points: int) -> np.ndarray | None:
    """Per-corner values (T*3, C) from a flattened primvar, or None when the size is wrong."""
    n_faces = int(fan.face_of_tri.max()) + 1 if len(fan.face_of_tri) else 0
    if interpolation == UsdGeom.Tokens.constant and len(values) >= 1:
        return np.repeat(values[:1], fan.corners.size, axis=0)
    if interpolation == UsdGeom.Tokens.uniform and len(values) >= n_faces:
        return np.repeat(values[fan.face_of_tri], 3, axis=0)
    if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying) and len(values) >= n_points:
        return values[fan.vertices.reshape(-1)]
    if interpolation == UsdGeom.Tokens.faceVarying and len(values) > fan.corners.max(initial=-1):
        return values[fan.corners.reshape(-1)]
    return None


def _primvar(prim: Usd.Prim, name: str) -> tuple[np.ndarray, str] | None:
    pv = UsdGeom.PrimvarsAPI(prim).GetPrimvar(name)
    if not pv or not pv.HasAuthoredValue():
        return None
    value = pv.ComputeFlattened(Usd.TimeCode.Default())
    if value is None or len(value) == 0:
        return None
    return np.asarray(value, dtype=np.float64).reshape(len(value), -1), pv.GetInterpolation()


def _normals(mesh: UsdGeom.Mesh, fan: _Fan, n_points: int) -> tuple[np.ndarray, str] | None:
    found = _primvar(mesh.GetPrim(), "normals")
    if found is not None:
        return found
    attr = mesh.GetNormalsAttr()
    value = attr.Get() if attr.HasAuthoredValue() else None
    if value is None or len(value) == 0:
        return None
    return np.asarray(value, dtype=np.float64).reshape(-1, 3), mesh.GetNormalsInterpolation()


def _surface_diffuse(material: UsdShade.Material) -> tuple[float, float, float] | None:
    shader, _, _ = material.ComputeSurfaceSource()
    if not shader:
        return None
    inp = shader.GetInput("diffuseColor")
    if not inp:
        return None
    for attr in inp.GetValueProducingAttributes():
        value = attr.Get()
        if value is not None:
            return (float(value[0]), float(value[1]), float(value[2]))
    return None


def _bound_diffuse(prim: Usd.Prim) -> tuple[float, float, float] | None:
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    return _surface_diffuse(material) if material else None


def _face_colors(mesh: UsdGeom.Mesh, fan: _Fan, n_points: int) -> np.ndarray:
    """(T*3, 3) linear RGB per corner."""
    prim = mesh.GetPrim()
    n_corners = fan.corners.size
    colors: np.ndarray | None = None
    diffuse = _bound_diffuse(prim)
    if diffuse is not None:
        colors = np.tile(np.asarray(diffuse), (n_corners, 1))
    else:
        found = _primvar(prim, "displayColor")
        if found is not None:
            colors = _expand(found[0][:, :3], found[1], fan, n_points)
    if colors is None:
        colors = np.tile(np.asarray(DEFAULT_COLOR), (n_corners, 1))
    for subset in UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets():
        sub_diffuse = _bound_diffuse(subset.GetPrim())
        faces = subset.GetIndicesAttr().Get()
        if sub_diffuse is None or faces is None or len(faces) == 0:
            continue
        tri_mask = np.isin(fan.face_of_tri, np.asarray(faces))
        colors.reshape(-1, 3, 3)[tri_mask] = np.asarray(sub_diffuse)
    return np.clip(colors, 0.0, 1.0)


def mesh_triangles(mesh: UsdGeom.Mesh, world_from_local: np.ndarray) -> MeshTriangles | None:
    """Triangles of ``mesh`` moved into the world frame.

    Args:
        mesh: the mesh prim (its composed values at the default time are read).
        world_from_local: (4, 4) float64 column-vector transform, local -> world.

    Returns:
        The triangles, or None when the mesh has no renderable face.
    """
    points = mesh.GetPointsAttr().Get()
    counts = mesh.GetFaceVertexCountsAttr().Get()
    indices = mesh.GetFaceVertexIndicesAttr().Get()
    if not points or not counts or not indices:
        return None
    points_local = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    counts_a = np.asarray(counts, dtype=np.int64)
    indices_a = np.asarray(indices, dtype=np.int64)
    if counts_a.sum() != len(indices_a) or indices_a.min() < 0 or indices_a.max() >= len(points_local):
        return None  # malformed topology: skip rather than crash on user files
    fan = _fan_triangulate(counts_a, indices_a)
    if len(fan.face_of_tri) == 0:
        return None
    linear = world_from_local[:3, :3]
    positions = points_local[fan.vertices.reshape(-1)] @ linear.T + world_from_local[:3, 3]
    tri = positions.reshape(-1, 3, 3)
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    if mesh.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded:
        face_n = -face_n
    normals: np.ndarray | None = None
    authored = _normals(mesh, fan, len(points_local))
    if authored is not None:
        local_n = _expand(authored[0][:, :3], authored[1], fan, len(points_local))
        if local_n is not None:
            normals = local_n @ np.linalg.inv(linear)  # inverse transpose for column vectors
    if normals is None:
        normals = np.repeat(face_n, 3, axis=0)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(
        normals, length, out=np.tile([0.0, 0.0, 1.0], (len(normals), 1)), where=length > 1e-12
    )
    return MeshTriangles(positions, normals, _face_colors(mesh, fan, len(points_local)))
