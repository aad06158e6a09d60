"""Ground surfaces (road, sidewalk) as meshes, from class masks projected to the ground.

The mask's outline (with holes) is traced in the image, clipped to the rows that lie
within ``max_range_m``, mapped to ground metres through the DLT homography (a
homography maps straight edges to straight edges, so the polygon stays exact),
cleaned and extruded with manifold3d cross-sections: the road as a thin slab whose top
is the ground plane, the sidewalk raised to the kerb height.

Cars, people and posts hide the ground behind them: :func:`ground_occluders` lists the
placed objects the ground continues behind, :func:`fill_hidden_ground` fills a few metres
of it in. :func:`surface_points` samples a surface's pixels on the road plane (for the
road axis and the kerb lines).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import manifold3d
import numpy as np

from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.homography import apply_homography
from usdworld.io.class_table import ClassTable
from usdworld.parameters.scene import SceneParams

if TYPE_CHECKING:
    from usdworld.layout.placement import Placement
#: Cityscapes classes each ground surface is made of (parking is driven on like the road).
SURFACE_CLASSES = {"road": ("road", "parking"), "sidewalk": ("sidewalk",)}
#: Thickness of the road slab below z = 0, metres.
SLAB_DEPTH_M = 0.05
#: Smallest surface piece kept, square metres.
MIN_PIECE_AREA_M2 = 0.5
#: How far behind the camera the terrain reaches (the fly-through starts there), metres.
TERRAIN_BEHIND_M = 20.0
#: Triangles smaller than this are dropped from surface meshes, square metres.
MIN_TRIANGLE_AREA_M2 = 1e-8
#: Outline simplification tolerance in pixels.
OUTLINE_TOLERANCE_PX = 1.0


@dataclass(frozen=True)
class SurfaceMesh:
    """A triangle mesh of one ground surface, world frame.

    Attributes:
        name: ``road`` or ``sidewalk``.
        points_world: (V, 3) float64 vertices.
        faces: (F, 3) int64 triangles, counter-clockwise seen from outside.
        area_m2: area of its top face.
    """

    name: str
    points_world: np.ndarray
    faces: np.ndarray
    area_m2: float


def _range_cutoff_row(camera: PinholeCamera, max_range_m: float) -> int:
    """First image row whose ground points lie within ``max_range_m`` (at the centre column)."""
    px, depth = camera.project(np.array([[max_range_m, 0.0, 0.0]]))
    if not np.isfinite(px).all():
        return 0
    return int(np.clip(np.ceil(px[0, 1]), 0, camera.height))


def ground_cross_section(
    mask: np.ndarray, camera: PinholeCamera, ground_from_px: np.ndarray, max_range_m: float
) -> manifold3d.CrossSection:
    """The ground region covered by a class mask, as a manifold3d cross-section.

    Args:
        mask: (H, W) bool class mask.
        camera: the source camera (for the range cut-off row).
        ground_from_px: (3, 3) float64 DLT homography.
        max_range_m: farthest ground distance kept.

    Returns:
        The cross-section in ground metres (may be empty).
    """
    cut = _range_cutoff_row(camera, max_range_m)
    clipped = np.zeros(mask.shape, dtype=np.uint8)
    clipped[cut:] = mask[cut:]
    contours, _ = cv2.findContours(clipped, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_SIMPLE)
    rings = []
    for contour in contours:
        approx = cv2.approxPolyDP(contour, OUTLINE_TOLERANCE_PX, True).reshape(-1, 2).astype(np.float64)
        if len(approx) < 3:
            continue
        ground = apply_homography(ground_from_px, approx)
        if not np.isfinite(ground).all():
            continue
        rings.append(ground)
    if not rings:
        return manifold3d.CrossSection()
    section = manifold3d.CrossSection(rings, manifold3d.FillRule.EvenOdd)
    disc = manifold3d.CrossSection.circle(max_range_m, 128)
    section = section ^ disc
    pieces = [p for p in section.decompose() if p.area() >= MIN_PIECE_AREA_M2]
    if not pieces:
        return manifold3d.CrossSection()
    return manifold3d.CrossSection.compose(pieces).simplify(0.01)


def extrude_surface(name: str, section: manifold3d.CrossSection, top_z: float, bottom_z: float) -> SurfaceMesh | None:
    """Extrude a cross-section between two heights; None when it is empty.

    Args:
        name: surface name.
        section: ground region.
        top_z: height of the top face, metres.
        bottom_z: height of the bottom face, metres (< top_z).
    """
    if section.is_empty() or section.area() <= 0:
        return None
    solid = section.extrude(top_z - bottom_z).translate((0.0, 0.0, bottom_z))
    mesh = solid.to_mesh()
    points = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    faces = np.asarray(mesh.tri_verts, dtype=np.int64)
    # Drop slivers: zero-area triangles have no normal (validators and glTF reject them).
    a, b, c = (points[faces[:, k]] for k in range(3))
    faces = faces[np.linalg.norm(np.cross(b - a, c - a), axis=1) > MIN_TRIANGLE_AREA_M2 * 2.0]
    return SurfaceMesh(name, points, faces, float(section.area()))


def fill_behind_occluders(label_ids: np.ndarray, fill: np.ndarray, vanishing_px: tuple[float, float]) -> np.ndarray:
    """Labels with the hidden ground behind occluders filled in from just below them.

    Cars, people and poles hide the road behind them; their silhouettes, projected to
    the ground, would leave holes that run to the horizon. Each pixel to fill takes the
    label found by walking down the image line towards the road's vanishing point: lines
    through the vanishing point are the images of ground lines parallel to the road, so
    kerbs and lane edges continue behind the occluder where they really run. Callers
    pass only the part of each silhouette that lies within a few metres behind the
    object (:func:`occluded_ground_mask`).

    Args:
        label_ids: (H, W) uint8 Cityscapes label ids.
        fill: (H, W) bool pixels to fill (all below the horizon).
        vanishing_px: (u, v) vanishing point of the road direction; v is the horizon row.

    Returns:
        (H, W) uint8 filled copy.
    """
    out = np.array(label_ids, copy=True)
    H, W = out.shape
    u_vp, v_h = vanishing_px
    rows = np.nonzero(fill.any(axis=1))[0]
    for r in rows[::-1]:
        if r + 1 >= H or r <= v_h + 0.5:
            continue
        cols = np.nonzero(fill[r])[0]
        below = u_vp + (cols - u_vp) * (r + 1 - v_h) / (r - v_h)
        out[r, cols] = out[r + 1, np.clip(np.rint(below).astype(np.int64), 0, W - 1)]
    return out


def occluded_ground_mask(
    shape: tuple[int, int],
    occluders: list[tuple[np.ndarray, np.ndarray, float]],
    camera: PinholeCamera,
    reach_m: float,
) -> np.ndarray:
    """Pixels of occluders that hide ground lying at most ``reach_m`` behind them.

    Args:
        shape: (H, W) of the image.
        occluders: per object ``(box_px (4,) int, mask crop (h, w) bool, front depth m)``.
        camera: the source camera (a ground row's depth follows from the horizon).
        reach_m: how far behind each object the hidden ground is filled in.

    Returns:
        (H, W) bool.
    """
    out = np.zeros(shape, dtype=bool)
    horizon = camera.horizon_v()
    for box, crop, front in occluders:
        x0, y0, x1, y1 = (int(b) for b in box)
        if not (np.isfinite(front) and front > 0) or y1 <= horizon:
            continue
        # Rows below the horizon scale as 1 / depth: the row of depth front + reach.
        v_front = float(y1)
        v_far = horizon + (v_front - horizon) * front / (front + reach_m)
        rows = np.arange(y0, y1)[:, None] >= v_far
        out[y0:y1, x0:x1] |= crop & rows
    return out


def ground_occluders(
    placements: Sequence[Placement], table: ClassTable, min_front_m: float
) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Box, mask and front depth of every placed object the ground continues behind.

    Things (cars, people) and the class table's ``thin_occluder`` classes (trunks, posts)
    hide ground that goes on behind them; a facade's does not. The front depth is the
    centre's less the footprint's half diagonal, at least ``min_front_m``.

    Args:
        placements: the placed objects.
        table: the class table (roles).
        min_front_m: least front depth, metres (:attr:`SceneParams.occluder_min_front_m`).

    Returns:
        Per occluder ``(box_px (4,) int, mask crop (h, w) bool, front depth m)``, the input of
        :func:`occluded_ground_mask`.
    """
    out = []
    for p in placements:
        o = p.obj
        if o.is_thing or table.has(o.class_name, "thin_occluder"):
            front = float(p.depth_m) - float(np.hypot(*p.size_m[:2])) / 2.0
            out.append((o.box_px, o.mask, max(front, min_front_m)))
    return out


def fill_hidden_ground(
    label_ids: np.ndarray,
    placements: Sequence[Placement],
    camera: PinholeCamera,
    road_angle: float,
    table: ClassTable,
    params: SceneParams,
) -> np.ndarray:
    """Labels with the ground hidden by placed objects filled in, up to
    :attr:`SceneParams.fill_reach_m` behind each (:func:`fill_behind_occluders`).

    Args:
        label_ids: (H, W) uint8 Cityscapes label ids.
        placements: the placed objects.
        camera: the source camera.
        road_angle: world yaw of the road axis, radians; the fill walks towards its
            vanishing point (the horizon's centre when it has none in view).
        table: the class table (roles).
        params: the scene parameters.

    Returns:
        (H, W) uint8 filled copy.
    """
    occluders = ground_occluders(placements, table, params.occluder_min_front_m)
    fill = occluded_ground_mask(label_ids.shape, occluders, camera, params.fill_reach_m)
    ahead = np.array([np.cos(road_angle), np.sin(road_angle), 0.0])
    road_vp = camera.vanishing_point(ahead) or (camera.cx, camera.horizon_v())
    return fill_behind_occluders(label_ids, fill, road_vp)


def surface_points(
    mask: np.ndarray, ground_from_px: np.ndarray, camera: PinholeCamera, max_range_m: float, stride_px: int
) -> np.ndarray | None:
    """Road-plane points of every ``stride_px``-th pixel of a surface (within range), or None.

    A sidewalk's pixels are mapped onto the road plane too: its kerb face, labelled
    sidewalk, stands on the road, so its kerb line comes out right (0.04 m median on the
    synthetic set), while its raised top lands about 10 % too far (its back edge 0.4 m).

    Args:
        mask: (H, W) bool pixels of the surface.
        ground_from_px: (3, 3) float64 DLT homography.
        camera: the source camera (the points' depths).
        max_range_m: farthest depth kept, metres.
        stride_px: sampling step in rows and columns; each sample is its cell's centre.

    Returns:
        (N, 2) float64 ground points, metres, or None when the mask is empty.
    """
    ys, xs = np.nonzero(mask[::stride_px, ::stride_px])
    if len(ys) == 0:
        return None
    px = np.column_stack([xs * stride_px + stride_px / 2, ys * stride_px + stride_px / 2])
    pts = apply_homography(ground_from_px, px)
    _, depth = camera.ground_points(px)
    keep = np.isfinite(pts).all(axis=1) & (depth > 0) & (depth <= max_range_m)
    return pts[keep]


def build_surfaces(
    filled_ids: np.ndarray | None,
    class_ids: dict[str, list[int]],
    camera: PinholeCamera,
    ground_from_px: np.ndarray,
    curb_height_m: float,
    max_range_m: float,
) -> list[SurfaceMesh]:
    """Road and sidewalk meshes; the road is cut where the sidewalk lies.

    Args:
        filled_ids: None without labels (then only the terrain is made), else (H, W)
            uint8 Cityscapes label ids with the ground behind occluders filled in
            (:func:`fill_behind_occluders`).
        class_ids: label ids that make up each surface, e.g. ``{"road": [7, 9], "sidewalk": [8]}``.
        camera: the source camera.
        ground_from_px: (3, 3) float64 DLT homography.
        curb_height_m: height of the sidewalk's top.
        max_range_m: farthest ground distance meshed.

    Returns:
        The non-empty surfaces: road, sidewalk, then ``terrain``, the plain ground that
        fills the rest of a square reaching ``max_range_m`` ahead and to each side.
    """
    sections = {}
    if filled_ids is not None:
        sections = {
            name: ground_cross_section(np.isin(filled_ids, ids), camera, ground_from_px, max_range_m)
            for name, ids in class_ids.items()
        }
    out = []
    road = sections.get("road")
    sidewalk = sections.get("sidewalk")
    if sidewalk is not None and not sidewalk.is_empty():
        # The homography maps onto the road plane z = 0; the sidewalk's top is the kerb
        # height, where each viewing ray lands (h - kerb) / h as far from the camera.
        factor = (camera.height_m - curb_height_m) / camera.height_m
        sidewalk = sidewalk.scale((factor, factor))
    if road is not None and sidewalk is not None and not sidewalk.is_empty():
        road = road - sidewalk
    if road is not None:
        mesh = extrude_surface("road", road, 0.0, -SLAB_DEPTH_M)
        if mesh is not None:
            out.append(mesh)
    if sidewalk is not None:
        mesh = extrude_surface("sidewalk", sidewalk, curb_height_m, -SLAB_DEPTH_M)
        if mesh is not None:
            out.append(mesh)
    # Everything else within range is plain ground, so no view shows sky below the horizon.
    square = manifold3d.CrossSection.square((max_range_m + TERRAIN_BEHIND_M, 2.0 * max_range_m)).translate(
        (-TERRAIN_BEHIND_M, -max_range_m)
    )
    mesh = terrain_surface(square, road, sidewalk)
    if mesh is not None:
        out.append(mesh)
    return out


def terrain_surface(
    area: manifold3d.CrossSection,
    road: manifold3d.CrossSection | None,
    sidewalk: manifold3d.CrossSection | None,
) -> SurfaceMesh | None:
    """The plain ground: ``area`` less the road and the sidewalk, a slab with its top at z = 0.

    Args:
        area: the ground's extent on the ground plane, metres.
        road: the road's cross-section, or None.
        sidewalk: the sidewalk's cross-section, or None.

    Returns:
        The ``terrain`` mesh, or None when nothing is left.
    """
    for section in (road, sidewalk):
        if section is not None and not section.is_empty():
            area = area - section
    return extrude_surface("terrain", area, 0.0, -SLAB_DEPTH_M)
