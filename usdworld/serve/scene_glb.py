"""A composed world as a glTF 2.0 binary for the web page: one node per object, Y up, metres.

The triangles come from :class:`usdworld.render.scene.RenderScene` (what usdworld's own
renderer draws: edits, variants and restyle colours applied, deleted objects left out).
Each object becomes one node named like its prim (``car_0003``) holding one mesh in
**world** coordinates (the node's transform is the identity), so the page moves an object
by translating its node; the ground surfaces become the node ``ground``.

Corners are welded where position, normal and colour are equal (the renderer's triangles
are unindexed). Colours are written as ``COLOR_0`` (linear RGB, unsigned bytes), the
normals as ``NORMAL``. glTF is Y up: world ``(x, y, z)`` (Z up) is written as ``(x, z, -y)``;
the page turns the scene back with a +90 degree rotation about X.
"""

from __future__ import annotations

import numpy as np

from usdworld.render.scene import RenderScene

#: (3, 3) rotation taking world (Z up) to glTF (Y up) coordinates: (x, y, z) -> (x, z, -y).
GLTF_FROM_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
#: Node name of the ground surfaces (and of any mesh outside the objects scope).
GROUND_NODE = "ground"


def weld(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge identical rows.

    Args:
        rows: (V, C) float32 per-corner attributes (V a multiple of 3).

    Returns:
        The distinct rows (U, C) float32, in order of first use, and (V // 3, 3) int64
        triangles indexing them.
    """
    rows = np.ascontiguousarray(rows, dtype=np.float32)
    if len(rows) == 0:
        return rows.reshape(0, rows.shape[1]), np.zeros((0, 3), dtype=np.int64)
    keys = rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # distinct rows in order of first use
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rows[first[order]], rank[inverse.ravel()].reshape(-1, 3)


def scene_glb(scene: RenderScene) -> bytes:
    """The scene as a ``.glb``.

    Args:
        scene: the composed world's triangles.

    Returns:
        The glTF binary: node ``ground`` (when there is ground) and one node per object
        that has triangles, named by the last element of its prim path.
    """
    import trimesh  # ~0.5 s to import: only when a scene is served

    out = trimesh.Scene()
    names = [GROUND_NODE] + [o.path.rsplit("/", 1)[-1] for o in scene.objects]
    ids = scene.object_ids
    for index in np.unique(ids):
        mask = ids == index
        rows = np.concatenate(
            [
                scene.positions_world[mask] @ GLTF_FROM_WORLD.T.astype(np.float32),
                scene.normals_world[mask] @ GLTF_FROM_WORLD.T.astype(np.float32),
                scene.colors[mask],
            ],
            axis=1,
        )
        verts, faces = weld(rows)
        rgb = np.clip(np.round(verts[:, 6:9] * 255.0), 0, 255).astype(np.uint8)
        rgba = np.concatenate([rgb, np.full((len(rgb), 1), 255, np.uint8)], axis=1)
        mesh = trimesh.Trimesh(
            vertices=verts[:, :3].astype(np.float64),
            faces=faces,
            vertex_normals=verts[:, 3:6].astype(np.float64),
            vertex_colors=rgba,
            process=False,
        )
        name = names[int(index)]
        out.add_geometry(mesh, node_name=name, geom_name=name)
    return bytes(out.export(file_type="glb", include_normals=True))
