"""One ``UsdGeom.Mesh`` -> world-space triangles with normals and colours.

Polygons are triangulated by :mod:`usdworld.authoring.mesh_reader` (a fan for convex
polygons, earcut for concave ones; holes are ignored). Normals are the authored
``primvars:normals`` / ``normals`` when present (any interpolation), otherwise flat face
normals. The colour of a face is the ``diffuseColor`` of the UsdPreviewSurface
bound to it (GeomSubset bindings included), else ``primvars:displayColor``, else
:data:`DEFAULT_COLOR`. Colours are linear RGB, as USD stores them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom, UsdShade

from usdworld.authoring.mesh_reader import (
    MeshTopology,
    expand_primvar,
    read_normals,
    read_primvar,
    read_topology,
)

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


def _face_colors(mesh: UsdGeom.Mesh, topology: MeshTopology) -> np.ndarray:
    """(T*3, 3) linear RGB per corner."""
    prim = mesh.GetPrim()
    n_corners = topology.corners.size
    colors: np.ndarray | None = None
    diffuse = _bound_diffuse(prim)
    if diffuse is not None:
        colors = np.tile(np.asarray(diffuse), (n_corners, 1))
    else:
        found = read_primvar(prim, "displayColor")
        if found is not None:
            expanded = expand_primvar(found[0][:, :3], found[1], topology)
            colors = None if expanded is None else expanded.reshape(-1, 3)
    if colors is None:
        colors = np.tile(np.asarray(DEFAULT_COLOR), (n_corners, 1))
    for subset in UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets():
        sub_diffuse = _bound_diffuse(subset.GetPrim())
        faces = subset.GetIndicesAttr().Get()
        if sub_diffuse is None or faces is None or len(faces) == 0:
            continue
        tri_mask = np.isin(topology.face_of_tri, np.asarray(faces))
        colors.reshape(-1, 3, 3)[tri_mask] = np.asarray(sub_diffuse)
    return np.clip(colors, 0.0, 1.0)


@dataclass(frozen=True)
class LocalMesh:
    """What :func:`place_mesh` needs of one mesh, read once in its own frame (shared by the
    objects that reference the same asset mesh).

    Attributes:
        topology: its points and triangulation.
        normals_local: (T*3, 3) float64 authored normals per corner, or None (flat normals).
        colors: (T*3, 3) float64 linear RGB per corner, in [0, 1].
    """

    topology: MeshTopology
    normals_local: np.ndarray | None
    colors: np.ndarray


#: Meshes' topology and normals by the specs that compose the mesh prim (see :func:`read_local_mesh`).
GeometryCache = dict[tuple, tuple[MeshTopology, np.ndarray | None] | None]


def _read_geometry(mesh: UsdGeom.Mesh) -> tuple[MeshTopology, np.ndarray | None] | None:
    topology = read_topology(mesh)
    if topology is None:
        return None
    normals: np.ndarray | None = None
    authored = read_normals(mesh)
    if authored is not None:
        local_n = expand_primvar(authored[0], authored[1], topology)
        if local_n is not None:
            normals = local_n.reshape(-1, 3)
    return topology, normals


def read_local_mesh(mesh: UsdGeom.Mesh, geometry: GeometryCache | None = None) -> LocalMesh | None:
    """The mesh's topology, normals and colours at the default time, or None when it has no renderable face.

    Args:
        mesh: the mesh prim.
        geometry: topology and normals already read, keyed by the prim specs that compose a
            mesh prim (layer and path of each): two mesh prims composed of the same specs (the
            same asset mesh under two objects, none of the world's own layers over it) have
            the same points, faces and normals, so they are read and triangulated once. The
            colours are read for every mesh (an object's own material opinions are on its
            material prims, not on the mesh). None reads everything.
    """
    if geometry is None:
        found = _read_geometry(mesh)
    else:
        key = tuple((spec.layer.identifier, spec.path) for spec in mesh.GetPrim().GetPrimStack())
        if key in geometry:
            found = geometry[key]
        else:
            found = geometry[key] = _read_geometry(mesh)
    if found is None:
        return None
    topology, normals = found
    return LocalMesh(topology, normals, _face_colors(mesh, topology))


def place_mesh(local: LocalMesh, world_from_local: np.ndarray) -> MeshTriangles:
    """The triangles of a mesh read by :func:`read_local_mesh`, moved into the world frame.

    Args:
        local: the mesh.
        world_from_local: (4, 4) float64 column-vector transform, local -> world.
    """
    topology = local.topology
    linear = world_from_local[:3, :3]
    positions = topology.points[topology.triangles.reshape(-1)] @ linear.T + world_from_local[:3, 3]
    normals: np.ndarray | None = None
    if local.normals_local is not None:
        normals = local.normals_local @ np.linalg.inv(linear)  # inverse transpose for column vectors
    else:
        tri = positions.reshape(-1, 3, 3)
        face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        if topology.left_handed:
            face_n = -face_n
        normals = np.repeat(face_n, 3, axis=0)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(
        normals, length, out=np.tile([0.0, 0.0, 1.0], (len(normals), 1)), where=length > 1e-12
    )
    return MeshTriangles(positions, normals, local.colors)


def mesh_triangles(
    mesh: UsdGeom.Mesh, world_from_local: np.ndarray, geometry: GeometryCache | None = None
) -> MeshTriangles | None:
    """Triangles of ``mesh`` moved into the world frame.

    Args:
        mesh: the mesh prim (its composed values at the default time are read).
        world_from_local: (4, 4) float64 column-vector transform, local -> world.
        geometry: meshes read before (:func:`read_local_mesh`); None reads this one.

    Returns:
        The triangles, or None when the mesh has no renderable face.
    """
    local = read_local_mesh(mesh, geometry)
    return None if local is None else place_mesh(local, world_from_local)
