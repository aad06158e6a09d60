"""The one reader of ``UsdGeom.Mesh`` topology: polygons -> triangles, and primvars per triangle corner.

The renderer, the glTF / USD exporters, the editor's geometry and the asset library all read
meshes through here, so a polygon is triangulated the same way everywhere.

Triangulation. A convex polygon is cut into a fan from its first corner,
``(c0, c_i, c_i+1)``: for triangles and convex quads (all the shipped assets and worlds) this is
exactly what the readers did before, so their renders and exports do not change. A concave
polygon is projected onto its best-fit plane (the Newell normal, which is also its area vector)
and cut by earcut (the maintained ``mapbox-earcut`` bindings of mapbox's C++ library); its
triangles keep the polygon's winding. A fan from the first corner would cover area outside a
concave polygon. Holes are not read (USD ``holeIndices`` faces are triangulated as faces).

Corners. Triangles are given as *corners*: positions in the face-vertex list
(``faceVertexIndices``), not point indices, so that face-varying primvars (normals, uv) index
with them directly; ``topology.triangles`` gives the point indices.

Example::

    topology = read_topology(UsdGeom.Mesh(prim))
    positions = topology.points[topology.triangles]          # (T, 3, 3)
    normals = expand_primvar(*read_normals(mesh), topology)  # (T, 3, 3) or None
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom

#: A turn whose sine is below minus this counts as a reflex (concave) corner.
CONVEX_SIN_TOL = 1e-9
#: A convex polygon turns once around: its exterior angles sum to 2 pi within this (radians).
TURNING_TOL_RAD = 1e-6


@dataclass(frozen=True)
class MeshTopology:
    """One Mesh prim's polygons as triangles, in the prim's own space.

    Attributes:
        points: (N, 3) float64 point positions.
        face_vertex_indices: (C,) int64 point index of each face corner (``faceVertexIndices``).
        corners: (T, 3) int64 positions in ``face_vertex_indices`` of each triangle's corners,
            wound like the polygon they come from (the authored orientation is not applied).
        face_of_tri: (T,) int64 polygon index of each triangle, non-decreasing.
        n_faces: number of polygons (``len(faceVertexCounts)``).
        left_handed: the Mesh's ``orientation`` is ``leftHanded``.
    """

    points: np.ndarray
    face_vertex_indices: np.ndarray
    corners: np.ndarray
    face_of_tri: np.ndarray
    n_faces: int
    left_handed: bool

    @property
    def triangles(self) -> np.ndarray:
        """(T, 3) int64 point indices of each triangle's corners."""
        return self.face_vertex_indices[self.corners]


def _fan(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fan corners ``(s, s+k, s+k+1)`` of every polygon with 3+ corners, and their polygon ids."""
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    n_tris = np.maximum(counts - 2, 0)
    face = np.repeat(np.arange(len(counts), dtype=np.int64), n_tris)
    k = np.arange(len(face), dtype=np.int64) - np.repeat(np.cumsum(n_tris) - n_tris, n_tris)
    first = starts[face]
    return np.stack([first, first + 1 + k, first + 2 + k], axis=1), face


def _newell(ring: np.ndarray) -> np.ndarray:
    """(F, 3) area vectors (Newell normals, length = area) of (F, n, 3) polygon rings."""
    centred = ring - ring.mean(axis=1, keepdims=True)
    return 0.5 * np.cross(centred, np.roll(centred, -1, axis=1)).sum(axis=1)


def _concave(ring: np.ndarray) -> np.ndarray:
    """(F,) bool: which (F, n, 3) polygon rings are not convex in their best-fit plane.

    Convex means every corner turns the same way as the area vector (within
    :data:`CONVEX_SIN_TOL`) and the turns add up to one full turn (a pentagram turns twice).
    Polygons of (near) zero area count as convex: the fan is as good as anything there.
    """
    area_vec = _newell(ring)
    area = np.linalg.norm(area_vec, axis=1)
    extent = np.ptp(ring, axis=1).max(axis=1)
    flat = area <= 1e-12 * np.maximum(extent, 1e-300) ** 2
    normal = area_vec / np.where(flat, 1.0, area)[:, None]
    edge_in = ring - np.roll(ring, 1, axis=1)  # edge arriving at corner i
    edge_out = np.roll(ring, -1, axis=1) - ring  # edge leaving corner i
    turn_sin = np.einsum("fij,fj->fi", np.cross(edge_in, edge_out), normal)
    turn_cos = np.einsum("fij,fij->fi", edge_in, edge_out)
    lengths = np.linalg.norm(edge_in, axis=2) * np.linalg.norm(edge_out, axis=2)
    reflex = turn_sin < -CONVEX_SIN_TOL * lengths
    turning = np.arctan2(turn_sin, turn_cos).sum(axis=1)
    winds_once = np.abs(turning - 2.0 * np.pi) <= TURNING_TOL_RAD
    return ~flat & (reflex.any(axis=1) | ~winds_once)


def _earcut(polygon: np.ndarray) -> np.ndarray:
    """(K, 3) int64 local corner indices cutting one (n, 3) polygon, wound like the polygon."""
    import mapbox_earcut  # small C++ extension; imported where first needed

    normal = _newell(polygon[None])[0]
    normal /= np.linalg.norm(normal)
    helper = np.eye(3)[int(np.argmin(np.abs(normal)))]
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)  # (u, v, normal) is right-handed: the polygon runs counter-clockwise in (u, v)
    centred = polygon - polygon.mean(axis=0)
    uv = np.ascontiguousarray(np.stack([centred @ u, centred @ v], axis=1))
    tris = mapbox_earcut.triangulate_float64(uv, np.array([len(uv)], dtype=np.uint32))
    tris = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    a, b, c = uv[tris[:, 0]], uv[tris[:, 1]], uv[tris[:, 2]]
    clockwise = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    tris[clockwise] = tris[clockwise][:, [0, 2, 1]]
    return tris


def triangulate_polygons(
    points: np.ndarray, counts: np.ndarray, indices: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Cut polygons into triangles: a fan for convex ones, earcut for concave ones.

    Args:
        points: (N, 3) float64 point positions.
        counts: (F,) int, corners per polygon (polygons with fewer than 3 give no triangle).
        indices: (sum(counts),) int, point index of each corner, all in ``[0, N)``.

    Returns:
        (T, 3) int64 corners (positions in ``indices``, wound like their polygon) and (T,) int64
        polygon ids, non-decreasing. A simple polygon of n corners gives n - 2 triangles that
        cover exactly its area; a self-intersecting one gives what earcut makes of it (it may
        leave parts out).
    """
    counts = np.asarray(counts, dtype=np.int64)
    indices = np.asarray(indices, dtype=np.int64)
    points = np.asarray(points, dtype=np.float64)
    corners, face = _fan(counts)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    concave_faces = []
    for n in np.flatnonzero(np.bincount(counts[counts >= 4])):  # sizes present; np.unique imports numpy.ma
        faces_n = np.flatnonzero(counts == n)
        ring = points[indices[starts[faces_n][:, None] + np.arange(n)]]
        concave_faces.append(faces_n[_concave(ring)])
    concave = np.concatenate(concave_faces) if concave_faces else np.zeros(0, dtype=np.int64)
    if len(concave) == 0:
        return corners, face
    keep = ~np.isin(face, concave)
    cut_corners, cut_face = [corners[keep]], [face[keep]]
    for f in concave:
        local = _earcut(points[indices[starts[f] : starts[f] + counts[f]]])
        cut_corners.append(starts[f] + local)
        cut_face.append(np.full(len(local), f, dtype=np.int64))
    face = np.concatenate(cut_face)
    order = np.argsort(face, kind="stable")
    return np.concatenate(cut_corners)[order], face[order]


def read_topology(mesh: UsdGeom.Mesh, time: Usd.TimeCode | None = None) -> MeshTopology | None:
    """Points and triangles of one Mesh prim.

    Args:
        mesh: the Mesh (its composed values are read).
        time: time to read (default time when None).

    Returns:
        The topology, or None when the mesh has no points, malformed topology (counts that do
        not add up, indices out of range: skipped rather than crashing on user files) or no
        polygon with 3+ corners.
    """
    time = Usd.TimeCode.Default() if time is None else time
    points = mesh.GetPointsAttr().Get(time)
    counts = mesh.GetFaceVertexCountsAttr().Get(time)
    indices = mesh.GetFaceVertexIndicesAttr().Get(time)
    if not points or not counts or not indices:
        return None
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    counts_np = np.asarray(counts, dtype=np.int64)
    idx = np.asarray(indices, dtype=np.int64)
    if counts_np.sum() != len(idx) or idx.min() < 0 or idx.max() >= len(pts):
        return None
    corners, face = triangulate_polygons(pts, counts_np, idx)
    if len(corners) == 0:
        return None
    left = mesh.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded
    return MeshTopology(pts, idx, corners, face, len(counts_np), left)


def read_primvar(prim: Usd.Prim, name: str, time: Usd.TimeCode | None = None) -> tuple[np.ndarray, str] | None:
    """The flattened authored values of primvar ``name`` and its interpolation, or None.

    Returns:
        (K, C) float64 values (indexed primvars flattened) and the interpolation token; None
        when the primvar is not authored or empty.
    """
    time = Usd.TimeCode.Default() if time is None else time
    primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar(name)
    if not primvar or not primvar.HasAuthoredValue():
        return None
    value = primvar.ComputeFlattened(time)
    if value is None or len(value) == 0:
        return None
    return np.asarray(value, dtype=np.float64).reshape(len(value), -1), primvar.GetInterpolation()


def read_normals(mesh: UsdGeom.Mesh, time: Usd.TimeCode | None = None) -> tuple[np.ndarray, str] | None:
    """Authored normals: ``primvars:normals`` when authored, else the ``normals`` attribute.

    Returns:
        (K, 3) float64 normals (as authored, not normalised) and their interpolation; None when
        neither is authored with values.
    """
    time = Usd.TimeCode.Default() if time is None else time
    found = read_primvar(mesh.GetPrim(), "normals", time)
    if found is not None:
        return found[0][:, :3], found[1]
    attr = mesh.GetNormalsAttr()
    value = attr.Get(time) if attr.HasAuthoredValue() else None
    if value is None or len(value) == 0:
        return None
    return np.asarray(value, dtype=np.float64).reshape(-1, 3), mesh.GetNormalsInterpolation()


def expand_primvar(values: np.ndarray, interpolation: str, topology: MeshTopology) -> np.ndarray | None:
    """Values of a primvar at each triangle corner.

    Args:
        values: (K, C) float64 flattened primvar values.
        interpolation: its USD interpolation token.
        topology: the mesh's triangles.

    Returns:
        (T, 3, C) float64, or None when ``K`` does not fit the interpolation (USD sizes:
        constant >= 1, uniform = faces, vertex / varying = points, faceVarying = corners).
    """
    corners = topology.corners
    if interpolation == UsdGeom.Tokens.constant and len(values) >= 1:
        return np.broadcast_to(values[0], (*corners.shape, values.shape[1])).copy()
    if interpolation == UsdGeom.Tokens.uniform and len(values) == topology.n_faces:
        return np.repeat(values[topology.face_of_tri][:, None, :], 3, axis=1)
    if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying) and len(values) == len(topology.points):
        return values[topology.triangles]
    if interpolation == UsdGeom.Tokens.faceVarying and len(values) == len(topology.face_vertex_indices):
        return values[corners]
    return None
