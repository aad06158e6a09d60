"""Read composed USD meshes as triangle arrays, with their look (what exporters and importers need).

A USD Mesh holds polygons of any size, normals at one of five interpolations, an optional
left-handed orientation, and a look that comes from a bound UsdPreviewSurface or from
``primvars:displayColor``. The functions here turn one Mesh prim into plain numpy arrays
(triangulated by :mod:`usdworld.authoring.mesh_reader`, counter-clockwise seen from the
front) so that writers of other formats never touch these details.

Example::

    arrays = read_mesh(UsdGeom.Mesh(prim))
    vertices, normals, faces = weld_corners(arrays.points[arrays.triangles], arrays.corner_normals)
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from pxr import Usd, UsdGeom, UsdShade

from usdworld.authoring.mesh_reader import MeshTopology, expand_primvar, read_normals, read_topology

#: UsdPreviewSurface fallbacks (UsdPreviewSurface spec) used when an input is not authored.
PREVIEW_DEFAULTS = {"diffuseColor": (0.18, 0.18, 0.18), "metallic": 0.0, "roughness": 0.5, "opacity": 1.0}


@dataclass(frozen=True)
class MeshArrays:
    """One Mesh prim as triangles in the prim's own space.

    Attributes:
        points: (N, 3) float64 point positions.
        triangles: (T, 3) int64 indices into ``points``, counter-clockwise seen from the front.
        corner_normals: (T, 3, 3) float64 unit normal at each triangle corner.
        double_sided: the Mesh's ``doubleSided`` value.
    """

    points: np.ndarray
    triangles: np.ndarray
    corner_normals: np.ndarray
    double_sided: bool


@dataclass(frozen=True)
class Look:
    """A flat (untextured) PBR look.

    Attributes:
        name: name of the bound Material prim ('' when the colour came from displayColor).
        color: (r, g, b) linear base colour in [0, 1].
        metallic: 0..1.
        roughness: 0..1.
        opacity: 0..1.
    """

    name: str
    color: tuple[float, float, float]
    metallic: float
    roughness: float
    opacity: float


#: Triangles whose doubled area is below (this x the mesh's size)^2 are dropped as degenerate.
DEGENERATE_REL = 1e-7


def _unit(v: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(length > 1e-20, length, 1.0)


def read_mesh(mesh: UsdGeom.Mesh, time: Usd.TimeCode | None = None) -> MeshArrays | None:
    """Triangles, corner normals and sidedness of one Mesh prim.

    Normals come from ``primvars:normals`` (or ``normals``) at any interpolation; when absent
    or unusable, flat face normals are used (also for single zero-length normals). Left-handed
    meshes are flipped so triangles are always counter-clockwise seen from the front.
    Degenerate (zero-area) triangles are dropped: they draw nothing, and glTF validators
    reject the zero normals they carry.

    Args:
        mesh: the Mesh.
        time: time to read (default time when None).

    Returns:
        The arrays, or None when the mesh has no points or no polygon with 3+ vertices.
    """
    time = Usd.TimeCode.Default() if time is None else time
    topology = read_topology(mesh, time)
    if topology is None:
        return None
    pts = topology.points
    corners, poly = topology.corners, topology.face_of_tri
    if topology.left_handed:
        corners = corners[:, ::-1]
    tris = topology.face_vertex_indices[corners]
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    cross = np.cross(b - a, c - a)
    area2 = np.linalg.norm(cross, axis=1)
    scale = max(float(np.ptp(pts, axis=0).max()), 1e-9)
    keep = np.isfinite(area2) & (area2 > (DEGENERATE_REL * scale) ** 2)
    if not keep.any():
        return None
    corners, poly, tris, cross = corners[keep], poly[keep], tris[keep], cross[keep]
    face_n = _unit(cross)
    normals = _authored_normals(mesh, time, replace(topology, corners=corners, face_of_tri=poly))
    if normals is None:
        normals = np.repeat(face_n[:, None, :], 3, axis=1)
    else:
        # zero or non-finite authored normals: use the face's own normal there
        bad = ~np.isfinite(normals).all(axis=2) | (np.linalg.norm(normals, axis=2) < 0.5)
        normals = np.where(bad[..., None], face_n[:, None, :], normals)
    double_sided = bool(mesh.GetDoubleSidedAttr().Get(time))
    return MeshArrays(pts, tris, normals, double_sided)


def _authored_normals(mesh: UsdGeom.Mesh, time: Usd.TimeCode, kept: MeshTopology) -> np.ndarray | None:
    """(T, 3, 3) unit normals per corner of the kept triangles from the authored normals, or None."""
    authored = read_normals(mesh, time)
    if authored is None:
        return None
    out = expand_primvar(authored[0], authored[1], kept)
    if out is None:
        return None
    return _unit(np.where(np.isfinite(out), out, 0.0))


def _preview_surface(material: UsdShade.Material) -> UsdShade.Shader | None:
    shader = material.ComputeSurfaceSource()[0]
    if not shader:
        return None
    shader_id = shader.GetIdAttr().Get() if shader.GetIdAttr() else None
    return shader if shader_id == "UsdPreviewSurface" else None


def _input_value(shader: UsdShade.Shader, name: str) -> object:
    """Authored value of a shader input, following connections to other inputs; None if not a value."""
    inp = shader.GetInput(name)
    if not inp:
        return None
    attrs = inp.GetValueProducingAttributes()
    if attrs and UsdShade.Input.IsInput(attrs[0]):
        return attrs[0].Get()
    return None if inp.HasConnectedSource() else inp.Get()


def _f32(value: float) -> float:
    """A float32 value as the shortest decimal that reads back to it (0.05, not 0.0500000007)."""
    return float(str(np.float32(value)))


def read_look(prim: Usd.Prim, time: Usd.TimeCode | None = None) -> Look:
    """The look of a Mesh prim: its bound UsdPreviewSurface, else its displayColor, else grey.

    Textured inputs are not followed (their fallback value, or the spec default, is used).

    Args:
        prim: a Mesh prim.
        time: time to read (default time when None).
    """
    time = Usd.TimeCode.Default() if time is None else time
    material = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]
    shader = _preview_surface(material) if material else None
    if shader is not None:
        values: dict[str, Any] = {}
        for key, default in PREVIEW_DEFAULTS.items():
            v = _input_value(shader, key)
            values[key] = default if v is None else v
        color = tuple(_f32(np.clip(c, 0.0, 1.0)) for c in values["diffuseColor"])
        return Look(
            material.GetPrim().GetName(),
            color,  # type: ignore[arg-type]
            _f32(np.clip(values["metallic"], 0.0, 1.0)),
            _f32(np.clip(values["roughness"], 0.0, 1.0)),
            _f32(np.clip(values["opacity"], 0.0, 1.0)),
        )
    primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayColor")
    if primvar and primvar.HasValue():
        colors = primvar.ComputeFlattened(time)
        if colors is not None and len(colors):
            mean = np.clip(np.asarray(colors, dtype=np.float64).reshape(-1, 3).mean(axis=0), 0.0, 1.0)
            return Look("", tuple(_f32(c) for c in mean), 0.0, PREVIEW_DEFAULTS["roughness"], 1.0)  # type: ignore[arg-type]
    return Look("", PREVIEW_DEFAULTS["diffuseColor"], 0.0, PREVIEW_DEFAULTS["roughness"], 1.0)  # type: ignore[arg-type]


def weld_corners(corner_points: np.ndarray, corner_normals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge triangle corners that share both position and normal into one vertex.

    Args:
        corner_points: (T, 3, 3) float64 position of each triangle corner.
        corner_normals: (T, 3, 3) float64 normal of each triangle corner.

    Returns:
        (V, 3) float64 vertices, (V, 3) float64 normals and (T, 3) int64 faces.
    """
    rows = np.concatenate([corner_points.reshape(-1, 3), corner_normals.reshape(-1, 3)], axis=1)
    # round the normal part so float noise does not split vertices that are really shared
    key = np.concatenate([rows[:, :3], np.round(rows[:, 3:], 6)], axis=1)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return rows[first, :3], rows[first, 3:], inverse.reshape(-1, 3).astype(np.int64)


def renderable_meshes(stage: Usd.Stage, time: Usd.TimeCode | None = None) -> list[Usd.Prim]:
    """Active, visible Mesh prims of default or render purpose, in traversal order."""
    time = Usd.TimeCode.Default() if time is None else time
    out = []
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        img = UsdGeom.Imageable(prim)
        if img.ComputeVisibility(time) == UsdGeom.Tokens.invisible:
            continue
        if img.ComputePurpose() in (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy):
            continue
        out.append(prim)
    return out


def scene_bounds(stage: Usd.Stage) -> tuple[int, np.ndarray]:
    """Number of renderable meshes and the exact (2, 3) world bounding box of their points.

    Computed from the points themselves (not from extents), in stage units and the stage's
    up axis. Raises nothing; an empty stage gives count 0 and a box of NaN.
    """
    time = Usd.TimeCode.Default()
    cache = UsdGeom.XformCache(time)
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    count = 0
    for prim in renderable_meshes(stage, time):
        arrays = read_mesh(UsdGeom.Mesh(prim), time)
        if arrays is None:
            continue
        count += 1
        m = np.asarray(cache.GetLocalToWorldTransform(prim), dtype=np.float64)
        used = arrays.points[np.unique(arrays.triangles)]
        world = used @ m[:3, :3] + m[3, :3]
        lo = np.minimum(lo, world.min(axis=0))
        hi = np.maximum(hi, world.max(axis=0))
    if count == 0:
        return 0, np.full((2, 3), np.nan)
    return count, np.stack([lo, hi])
