"""One ground for a rig: every view's road and sidewalk in the world, and plain terrain around them (layout).

Each view's build meshes its own road and sidewalk (from its labels) in its ground frame.
Their top faces are taken back to ground regions, moved into the world and united per
surface; the road is cut where a sidewalk lies, as in one view; and terrain fills the rest
of a square reaching ``max_range_m`` from the world's origin on every side, so no view
looks past the ground's edge below the horizon.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import manifold3d
import numpy as np

from usdworld.layout.surfaces import SLAB_DEPTH_M, SurfaceMesh, extrude_surface, terrain_surface

#: The surfaces united across views (terrain is made anew around the world origin).
UNITED = ("road", "sidewalk")


def top_section(mesh: SurfaceMesh) -> manifold3d.CrossSection:
    """The ground region of a surface mesh: the union of its upward triangles at its top height."""
    pts = mesh.points_world
    top = float(pts[:, 2].max())
    tris = pts[mesh.faces]
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    normal_z = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    keep = (np.abs(tris[:, :, 2] - top) < 1e-6).all(axis=1) & (normal_z > 0)
    rings = [t[:, :2].copy() for t in tris[keep]]
    if not rings:
        return manifold3d.CrossSection()
    return manifold3d.CrossSection(rings, manifold3d.FillRule.Positive)


def rig_surfaces(
    views: Sequence[tuple[Sequence[SurfaceMesh], np.ndarray]], curb_height_m: float, max_range_m: float
) -> list[SurfaceMesh]:
    """One ground from every view's surfaces.

    Args:
        views: per view, its surfaces (its ground frame) and its ``world_from_ground`` (4, 4) float64.
        curb_height_m: height of the sidewalk's top, metres.
        max_range_m: the terrain reaches this far from the world's origin on every side, metres.

    Returns:
        road, sidewalk (where any view saw them) and terrain, in the world frame.
    """
    united: dict[str, manifold3d.CrossSection] = {}
    for surfaces, world_from_ground in views:
        turn = math.degrees(math.atan2(world_from_ground[1, 0], world_from_ground[0, 0]))
        shift = (float(world_from_ground[0, 3]), float(world_from_ground[1, 3]))
        for mesh in surfaces:
            if mesh.name not in UNITED:
                continue
            section = top_section(mesh).rotate(turn).translate(shift)
            united[mesh.name] = united[mesh.name] + section if mesh.name in united else section
    road, sidewalk = united.get("road"), united.get("sidewalk")
    if road is not None and sidewalk is not None:
        road = road - sidewalk
    out = []
    for name, section, top in (("road", road, 0.0), ("sidewalk", sidewalk, curb_height_m)):
        if section is not None:
            mesh = extrude_surface(name, section, top, -SLAB_DEPTH_M)
            if mesh is not None:
                out.append(mesh)
    square = manifold3d.CrossSection.square((2.0 * max_range_m, 2.0 * max_range_m)).translate(
        (-max_range_m, -max_range_m)
    )
    mesh = terrain_surface(square, road, sidewalk)
    if mesh is not None:
        out.append(mesh)
    return out
