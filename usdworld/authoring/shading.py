"""Mesh shading helpers shared by the built-in asset generator and user-asset import."""

from __future__ import annotations

import math

import numpy as np
from pxr import Gf, Vt

#: Faces meeting at a larger angle than this keep a hard edge (degrees).
CREASE_DEG = 40.0
#: Normals are rounded to this many decimals. A component that is zero in exact arithmetic
#: comes out as about 1e-17 of either sign, and which one depends on the CPU and numpy build
#: (fused multiply-add or not); rounded, the asset library is byte-identical on every machine.
NORMAL_DECIMALS = 6


def crease_normals(points: np.ndarray, faces: np.ndarray, crease_deg: float = CREASE_DEG) -> np.ndarray:
    """Per-corner normals, angle-weighted over the faces around each vertex within ``crease_deg``.

    Args:
        points: (N, 3) float64 vertex positions.
        faces: (M, 3) int triangles, counter-clockwise seen from outside.
        crease_deg: faces meeting at a larger angle keep a hard edge.

    Returns:
        (3M, 3) float32 unit normals (to :data:`NORMAL_DECIMALS` decimals) in face-corner order
        (USD faceVarying).
    """
    tri = points[faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(face_n, axis=1, keepdims=True)
    face_n = face_n / np.where(length > 0, length, 1.0)
    e1 = np.roll(tri, -1, axis=1) - tri
    e2 = np.roll(tri, -2, axis=1) - tri
    angle = np.arctan2(np.linalg.norm(np.cross(e1, e2), axis=2), np.einsum("ijk,ijk->ij", e1, e2)).reshape(-1)
    corner_v = faces.reshape(-1)
    corner_f = np.repeat(np.arange(len(faces)), 3)
    order = np.argsort(corner_v, kind="stable")
    _, start, count = np.unique(corner_v[order], return_index=True, return_counts=True)
    group = np.repeat(np.arange(len(start)), count)
    reps = count[group]
    a = np.repeat(np.arange(len(order)), reps)
    offset = np.arange(len(a)) - np.repeat(np.cumsum(reps) - reps, reps)
    b = start[group][a] + offset
    ca, cb = order[a], order[b]
    fa, fb = corner_f[ca], corner_f[cb]
    ok = np.einsum("ij,ij->i", face_n[fa], face_n[fb]) >= math.cos(math.radians(crease_deg))
    acc = np.zeros((len(corner_v), 3))
    np.add.at(acc, ca[ok], face_n[fb[ok]] * angle[cb[ok], None])
    norm = np.linalg.norm(acc, axis=1, keepdims=True)
    out = np.where(norm > 1e-12, acc / np.where(norm > 1e-12, norm, 1.0), face_n[corner_f])
    return (np.round(out, NORMAL_DECIMALS) + 0.0).astype(np.float32)  # + 0.0: no negative zeros


def extent(points: np.ndarray) -> Vt.Vec3fArray:
    """USD ``extent`` (min and max corners) of (N, 3) points."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    return Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))])
