"""Which side of a closed mesh faces out: the winding that back-face culling may drop.

A mesh whose triangles close up (every edge, its points welded by position, is shared by
exactly two triangles that run along it in opposite directions) has an inside and an
outside, and every triangle is wound the same way as seen from outside. Its signed volume
(the sum of ``a . (b x c)`` / 6 over its triangles ``(a, b, c)``) is positive when that way
is counter-clockwise (the normals point out) and negative when it is clockwise.

Seen from outside, a ray's first hit on such a mesh is a face turned towards it: the faces
turned away (the back faces) are hidden behind the mesh's own front faces, so a camera
outside the mesh and beyond its near plane sees the same surface with them culled.

Example:
    >>> outward_winding(cube_topology)      # counter-clockwise outside       # doctest: +SKIP
    1
"""

from __future__ import annotations

import weakref

import numpy as np

from usdworld.authoring.mesh_reader import MeshTopology


#: id(topology) -> (a weak reference to it, its winding): a drive's frames are scenes of their own
#: that share their meshes' topologies, which are read once.
_WINDINGS: dict[int, tuple[weakref.ref, int]] = {}


def outward_winding(topology: MeshTopology) -> int:
    """+1: a closed mesh wound counter-clockwise seen from outside; -1: clockwise; 0: neither.

    0 means the triangles do not close up consistently (an open mesh, a boundary, an edge
    of three or more triangles, two neighbours wound alike) or enclose no volume; such a
    mesh shows its back faces and is never culled.

    Args:
        topology: the mesh's points and triangles in its own frame (as drawn: the authored
            ``orientation`` is not applied, see :class:`~usdworld.authoring.mesh_reader.MeshTopology`).

    Returns:
        The sign of the outward faces' winding, or 0 (remembered while the topology lives).
    """
    key = id(topology)
    kept = _WINDINGS.get(key)
    if kept is not None and kept[0]() is topology:
        return kept[1]
    winding = _winding(topology)
    _WINDINGS[key] = (weakref.ref(topology, lambda _, k=key: _WINDINGS.pop(k, None)), winding)
    return winding


def _winding(topology: MeshTopology) -> int:
    """:func:`outward_winding`, worked out."""
    points = np.asarray(topology.points, dtype=np.float64)
    tris = np.asarray(topology.triangles, dtype=np.int64).reshape(-1, 3)
    if len(tris) < 4 or len(points) == 0:
        return 0
    _, welded = np.unique(points, axis=0, return_inverse=True)
    welded = welded.reshape(-1)
    t = welded[tris]
    if np.any((t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 2] == t[:, 0])):
        return 0  # a degenerate triangle: no consistent orientation to read
    n = int(welded.max()) + 1
    tail = t.reshape(-1)
    head = t[:, [1, 2, 0]].reshape(-1)
    forward = tail * n + head
    backward = head * n + tail
    forward_sorted = np.sort(forward)
    if np.any(forward_sorted[1:] == forward_sorted[:-1]):
        return 0  # an edge run the same way twice: neighbours wound alike, or three faces on it
    found = np.searchsorted(forward_sorted, backward)
    found = np.minimum(found, len(forward_sorted) - 1)
    if not np.array_equal(forward_sorted[found], backward):
        return 0  # an edge with no opposite: a boundary (open mesh)
    a, b, c = (points[tris[:, k]] for k in range(3))
    volume = float(np.einsum("ij,ij->", a, np.cross(b, c))) / 6.0
    extent = float(np.max(points.max(axis=0) - points.min(axis=0)))
    if not abs(volume) > 1e-9 * extent**3:
        return 0  # encloses nothing measurable (e.g. two faces back to back)
    return 1 if volume > 0 else -1


def culled_face(winding: int, world_from_local: np.ndarray) -> str | None:
    """The GL face (``"back"`` or ``"front"``, with counter-clockwise front faces) that every
    instance of a mesh may drop, or None.

    Args:
        winding: the mesh's :func:`outward_winding`.
        world_from_local: (N, 4, 4) float64 the instances' transforms; a mirroring one (negative
            determinant) turns the winding over.

    Returns:
        ``"back"`` when the outside faces are counter-clockwise on screen for every instance,
        ``"front"`` when they are clockwise for every instance, None when the mesh is not
        closed or its instances disagree.
    """
    if winding == 0 or len(world_from_local) == 0:
        return None
    det = np.linalg.det(np.asarray(world_from_local, dtype=np.float64)[:, :3, :3])
    if np.all(det > 0):
        return "back" if winding > 0 else "front"
    if np.all(det < 0):
        return "front" if winding > 0 else "back"
    return None
