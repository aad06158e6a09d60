"""Instances the camera cannot see, found against a depth buffer of the big ones (Hi-Z test).

Most of a large world's objects inside the view frustum are hidden behind the street's
facades: the 10,000-object street shows 183 of the 2,224 objects left after frustum culling,
with 0.33 M of their 2.2 M triangles. :meth:`Renderer.render` draws the **occluders** (the
instances whose box covers many pixels per triangle, so that their depth is cheap per pixel
it hides) into a depth buffer, then skips, in the label and
colour passes only, every instance whose box lies strictly behind that depth wherever it
could cover a pixel. The shadow map still holds every instance. Which instances are occluders
(``RenderingParams.occluder_px_per_triangle``) changes the time only, never the pixels.

Exactness: a skipped instance's fragments could only land on pixel centres inside its box's
projection (widened by a pixel), and there the occluders' depth is nearer than the nearest
point of the box by more than :data:`DEPTH_MARGIN`: it loses the depth test at each of them
in whichever order it is drawn, so the ids, depth and colour are the same bits as drawing it.
"""

from __future__ import annotations

import numpy as np

from usdworld.render.batches import MeshBatch

#: Window-depth margin ([0, 1] depth buffer units) an instance's box must lie behind the
#: occluders' depth by: 64 steps of a 24-bit depth buffer, well above the float32 rounding of the
#: view-projection and of the depth interpolation (a few 1e-7), so a box that close
#: is kept. Geometry of the depth format, not tuned.
DEPTH_MARGIN = 64.0 / (1 << 24)
#: Relative widening of an instance's box: 8 float32 ulps (2^-23 each) of its coordinates.
BOX_MARGIN_REL = 8.0 / (1 << 23)
#: Texels of the sun's shadow map an instance's box must lie beyond a side of the sun's box
#: by to be left out of the map: the float32 rounding of the clip coordinates (a few 1e-7 of
#: the unit box) is far below one texel (2 / map size, 1e-3 at 2048). Geometry, not tuned.
SUN_MARGIN_TEXELS = 2.0
#: Cells per axis :meth:`DepthPyramid.max_over` reads (at the level whose cells are at least a
#: quarter of the rectangle, a rectangle spans at most 5): finer than 2 cells at the level of
#: the rectangle's own size, which takes in up to twice its size of the sky beside it.
WINDOW_CELLS = 5
#: Pixels an instance's projected box is widened by on each side (rasterisation rounding).
RECT_MARGIN_PX = 1.0


def _corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(..., 8, 3) corners of (..., 3) ``lo`` / ``hi`` boxes."""
    pick = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=bool)
    return np.where(pick, hi[..., None, :], lo[..., None, :])


def instance_corners(batch: MeshBatch) -> np.ndarray:
    """(N, 8, 3) float64 corners of a world box around each instance's triangles.

    The axis-aligned box of the mesh's used points' box placed by each instance, widened by
    :data:`BOX_MARGIN_REL` of its largest coordinate (the float32 rounding of the placed
    corners) plus 1 um.

    Args:
        batch: the mesh and its N instances.
    """
    pts = batch.used_points_local()
    if not len(pts):  # a mesh of no triangle draws nothing: any box will do
        pts = np.zeros((1, 3))
    local = _corners(pts.min(axis=0), pts.max(axis=0))
    m = batch.world_from_local
    placed = np.einsum("kj,nij->nki", local, m[:, :3, :3]) + m[:, None, :3, 3]
    corners = [placed[:, k] for k in range(8)]  # corner by corner: numpy's axis-1 reduction is slow here
    lo, hi = np.minimum.reduce(corners), np.maximum.reduce(corners)
    pad = BOX_MARGIN_REL * np.maximum(np.abs(lo).max(axis=1), np.abs(hi).max(axis=1)) + 1e-6
    return _corners(lo - pad[:, None], hi + pad[:, None])


def outside_clip_sides(corners_world: np.ndarray, view_proj: np.ndarray, margin: float) -> np.ndarray:
    """Which boxes lie wholly beyond one side (x or y) of a view's clip box, by more than ``margin``.

    Every triangle inside such a box is clipped away: it makes no fragment (the sun's shadow
    map leaves it out and keeps the same bits).

    Args:
        corners_world: (M, 8, 3) float64 box corners, world frame.
        view_proj: (4, 4) float64 world -> clip space.
        margin: clip-space units beyond the side (a few texels: float rounding in the shader).

    Returns:
        (M,) bool; False for a box with a corner at or behind the eye (w <= 0).
    """
    c = np.asarray(corners_world, dtype=np.float64)
    hom = c @ view_proj[:, :3].T + view_proj[:, 3]
    x, y, w = hom[..., 0], hom[..., 1], hom[..., 3]
    edge = (1.0 + margin) * w
    out = np.zeros(len(c), dtype=bool)
    for v in (x, y):
        out |= np.all(v > edge, axis=1) | np.all(v < -edge, axis=1)
    return out & np.all(w > 0.0, axis=1)


def project_boxes(
    corners_world: np.ndarray, view_proj: np.ndarray, width: int, height: int, near_w: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each box's pixel rectangle (image rows top-down) and nearest window depth.

    Args:
        corners_world: (M, 8, 3) float64 box corners, world frame.
        view_proj: (4, 4) float64 the GL view-projection matrix the passes draw with.
        width: image width, pixels.
        height: image height, pixels.
        near_w: the near clipping distance: a box with a corner closer (clip ``w``) is not projected.

    Returns:
        rect: (M, 4) int64 ``[x0, y0, x1, y1]`` inclusive pixel bounds, clipped to the image
            (x1 < x0 or y1 < y0: no pixel centre of the image);
        depth: (M,) float64 the box's nearest window depth in [0, 1];
        in_front: (M,) bool, every corner beyond the near plane (else rect and depth are meaningless).
    """
    c = corners_world @ view_proj[:3, :3].T + view_proj[:3, 3]
    w = corners_world @ view_proj[3, :3] + view_proj[3, 3]
    in_front = np.all(w > near_w, axis=1)
    w_safe = np.where(w > near_w, w, 1.0)
    ndc = c / w_safe[..., None]
    x = (ndc[..., 0] + 1.0) * 0.5 * width
    y = (1.0 - ndc[..., 1]) * 0.5 * height  # top-down rows
    z = ndc[..., 2] * 0.5 + 0.5
    m = RECT_MARGIN_PX
    # pixel i's centre is at i + 0.5: the centres inside [lo - m, hi + m]
    x0 = np.ceil(x.min(axis=1) - m - 0.5)
    x1 = np.floor(x.max(axis=1) + m - 0.5)
    y0 = np.ceil(y.min(axis=1) - m - 0.5)
    y1 = np.floor(y.max(axis=1) + m - 0.5)
    big = float(2 * max(width, height))
    rect = np.stack(
        [
            np.clip(x0, 0, big),
            np.clip(y0, 0, big),
            np.clip(x1, -1, width - 1),
            np.clip(y1, -1, height - 1),
        ],
        axis=1,
    ).astype(np.int64)
    return rect, z.min(axis=1), in_front


class DepthPyramid:
    """A max pyramid of a depth image: the farthest depth over any rectangle, bounded from above.

    Args:
        depth: (H, W) float window depth, rows top-down (1 where nothing was drawn).
    """

    def __init__(self, depth: np.ndarray) -> None:
        level = np.asarray(depth, dtype=np.float32)
        self.levels = [level]
        while level.shape[0] > 1 or level.shape[1] > 1:
            h, w = level.shape
            if h % 2 or w % 2:
                padded = np.ones((h + h % 2, w + w % 2), dtype=np.float32)  # 1 = the far plane
                padded[:h, :w] = level
                level = padded
            rows = np.maximum(level[0::2], level[1::2])
            level = np.maximum(rows[:, 0::2], rows[:, 1::2])
            self.levels.append(level)

    def max_over(self, rect: np.ndarray) -> np.ndarray:
        """(M,) float32 an upper bound of the depth over each ``[x0, y0, x1, y1]`` rectangle (non-empty).

        The level is the finest whose cells are at least a quarter of the rectangle's size: it
        spans at most :data:`WINDOW_CELLS` cells along each axis there, and the largest of
        those cells bounds it (a pixel's own depth for a one-pixel rectangle).
        """
        x0, y0, x1, y1 = (rect[:, k] for k in range(4))
        span = np.maximum(x1 - x0, y1 - y0) + 1
        # cells of 2^(ceil(log2 span) - 2) >= span / 4 pixels: a rectangle spans at most 5 of them
        lv = np.ceil(np.log2(np.maximum(span, 1))).astype(np.int64) - 2
        lv = np.clip(lv, 0, len(self.levels) - 1)
        out = np.ones(len(rect), dtype=np.float32)
        for k in np.unique(lv):
            sel = np.nonzero(lv == k)[0]
            level = self.levels[k]
            h, w = level.shape
            cx0, cx1 = x0[sel] >> k, np.minimum(x1[sel] >> k, w - 1)
            cy0, cy1 = y0[sel] >> k, np.minimum(y1[sel] >> k, h - 1)
            best = np.zeros(len(sel), dtype=np.float32)
            for dy in range(WINDOW_CELLS):
                cy = np.minimum(cy0 + dy, cy1)
                for dx in range(WINDOW_CELLS):
                    best = np.maximum(best, level[cy, np.minimum(cx0 + dx, cx1)])
            out[sel] = best
        return out


def hidden(
    rect: np.ndarray, box_depth: np.ndarray, in_front: np.ndarray, pyramid: DepthPyramid
) -> np.ndarray:
    """(M,) bool: the box covers no pixel centre of the image, or lies behind the depth everywhere it could.

    Args:
        rect: (M, 4) int64 from :func:`project_boxes`.
        box_depth: (M,) float64 the boxes' nearest window depth.
        in_front: (M,) bool, from :func:`project_boxes` (False: never hidden).
        pyramid: the occluders' depth.
    """
    empty = (rect[:, 2] < rect[:, 0]) | (rect[:, 3] < rect[:, 1])
    out = in_front & empty
    test = np.nonzero(in_front & ~empty)[0]
    if len(test):
        far = pyramid.max_over(rect[test]).astype(np.float64)
        out[test] = box_depth[test] > far + DEPTH_MARGIN
    return out


def occluders(
    rect: np.ndarray,
    in_front: np.ndarray,
    triangles: int | np.ndarray,
    px_per_triangle: float,
    image_px: int,
) -> np.ndarray:
    """(M,) bool: the instances whose box covers at least ``px_per_triangle`` pixels per triangle of
    the mesh: its rectangle's pixels, or the whole image for a box reaching past the near plane
    (the ground under the camera).

    Args:
        rect: (M, 4) int64 from :func:`project_boxes`.
        in_front: (M,) bool from :func:`project_boxes`.
        triangles: triangles of the mesh (each instance has them all), or (M,) int each instance's.
        px_per_triangle: ``RenderingParams.occluder_px_per_triangle``.
        image_px: pixels of the image.
    """
    area = np.maximum(rect[:, 2] - rect[:, 0] + 1, 0) * np.maximum(rect[:, 3] - rect[:, 1] + 1, 0)
    area = np.where(in_front, area, image_px)
    return (area > 0) & (area >= px_per_triangle * triangles)
