"""Depth from an object's image height, with its own depth extent taken into account.

The class-height cue ``d = f H / h_px`` treats an object as a flat board standing at its
contact point. A car is not: its lowest image point is its nearest ground contact (a
tyre, or a 3D box's nearest corner) while, its roof being below the camera, its highest
image point is the *far* edge of the roof, a few metres further on. Its silhouette is
taller than ``f H / d`` by that perspective, so the flat model puts it too close (by
about 10 % at 20 m for a KITTI car seen from behind). Here the silhouette is predicted
with the camera itself: bottom row of the contact point, top row of the highest of the
top's near and far edges, both at the candidate depth; the depth whose predicted height
matches the measured one is found on a log grid and refined by interpolation.

Frames: world (Z up, metres, ground z = 0); image pixels (u right, v down). "Beyond the
contact" means further along the horizontal viewing direction of the contact pixel.
"""

from __future__ import annotations

import functools

import numpy as np

from usdworld.geometry.camera import PinholeCamera
from usdworld.parameters.placement import PlacementParams


def _depth_grid(params: PlacementParams) -> np.ndarray:
    """(G,) float64 candidate depths, log-spaced over ``silhouette_depth_range_m``, metres (read-only)."""
    return _geomspace(*params.silhouette_depth_range_m, params.silhouette_grid_points)


@functools.lru_cache(maxsize=8)
def _geomspace(start: float, stop: float, num: int) -> np.ndarray:
    """``np.geomspace``, made once per grid (every object searches the same one), read-only."""
    grid = np.geomspace(start, stop, num)
    grid.setflags(write=False)
    return grid


def top_offsets(
    contact_half_m: np.ndarray, top_half_m: np.ndarray, size_lw_m: np.ndarray, rel_yaw: float, box_only: bool
) -> tuple[float, float]:
    """Near and far edges of an object's top, measured beyond its lowest image point.

    Args:
        contact_half_m: (2,) half extents (length, width) of where the object touches the
            ground (tyres, feet), metres, at its placed scale.
        top_half_m: (2,) half extents of its top (roof, head), metres, at its placed scale.
        size_lw_m: (2,) footprint length and width, metres, at its placed scale.
        rel_yaw: object yaw minus the bearing of the viewing ray, radians.
        box_only: the image evidence is a projected 3D box (its bottom is the footprint's
            nearest corner and its top the box's far top edge).

    Returns:
        (near, far) metres beyond the contact point along the view (near may be negative
        when the top overhangs the contact, e.g. a bus's front over its wheels).
    """
    c, s = abs(np.cos(rel_yaw)), abs(np.sin(rel_yaw))

    def along(half: np.ndarray) -> float:
        return float(half[0] * c + half[1] * s)

    if box_only:
        return 0.0, 2.0 * along(0.5 * np.asarray(size_lw_m, dtype=np.float64))
    contact = along(np.asarray(contact_half_m, dtype=np.float64))
    top = along(np.asarray(top_half_m, dtype=np.float64))
    return contact - top, contact + top


def silhouette_rows(
    camera: PinholeCamera,
    contact_px: tuple[float, float],
    depths_m: np.ndarray,
    height_m: float,
    offsets_m: tuple[float, float],
    near_plane_m: float,
) -> np.ndarray:
    """Predicted pixel height of an upright object for each candidate contact depth.

    Args:
        camera: the source camera.
        contact_px: (u, v) of the object's lowest image point; only its viewing
            direction is used, so the cue stays independent of the contact row.
        depths_m: (G,) candidate depths of the contact point along the optical axis.
        height_m: the object's height, metres.
        offsets_m: (near, far) edges of its top beyond the contact (:func:`top_offsets`).
        near_plane_m: points nearer than this along the optical axis count as behind the camera.

    Returns:
        (G,) float64 pixel heights (NaN where a point falls behind the camera).
    """
    depths = np.asarray(depths_m, dtype=np.float64)
    ray = camera.rays_world(np.array([contact_px], dtype=np.float64))[0]
    ahead = np.array([ray[0], ray[1]], dtype=np.float64)
    ahead /= max(float(np.linalg.norm(ahead)), 1e-12)
    # Ground points along the horizontal viewing direction, at the candidate depths.
    forward_cam = camera.rotation_world_from_cam[:, 2]
    rate = float(ahead @ forward_cam[:2])  # optical-axis depth per ground metre
    if rate <= 1e-6:
        return np.full(depths.shape, np.nan)
    base = camera.center_world[:2][None, :] + (depths / rate)[:, None] * ahead[None, :]
    # Three stacks projected at once, each as camera.project would on its own: the contact
    # points, and the top's near and far edges.
    points = np.empty((3, len(depths), 3))
    points[0, :, :2] = base
    points[0, :, 2] = 0.0
    for k, offset in enumerate(offsets_m, start=1):
        points[k, :, :2] = base + offset * ahead[None, :]
        points[k, :, 2] = height_m
    px, depth = camera.project_stacked(points)
    rows = np.where(depth > near_plane_m, px[:, :, 1], np.nan)
    top_row = np.fmin(rows[1], rows[2])
    return rows[0] - top_row


def depth_from_silhouette(
    camera: PinholeCamera,
    contact_px: tuple[float, float],
    height_px: float,
    height_m: float,
    offsets_m: tuple[float, float],
    params: PlacementParams,
) -> float | None:
    """The contact depth at which the object would look ``height_px`` tall.

    Args:
        camera: the source camera.
        contact_px: (u, v) of the object's lowest image point.
        height_px: measured silhouette height (bottom row minus top row), pixels, > 0.
        height_m: the object's height, metres.
        offsets_m: (near, far) edges of its top beyond the contact (:func:`top_offsets`).
        params: the depth grid searched and the near plane.

    Returns:
        Depth in metres along the optical axis, or None when no depth in range fits
        (taller than any candidate, or shorter than the farthest).

    Example:
        >>> from usdworld.geometry.camera import PinholeCamera
        >>> K = np.array([[1000.0, 0, 500], [0, 1000.0, 250], [0, 0, 1]])
        >>> cam = PinholeCamera(K=K, width=1000, height=500, height_m=1.5)
        >>> round(depth_from_silhouette(cam, (500.0, 400.0), 100.0, 2.0, (0.0, 0.0), PlacementParams()), 2)
        20.0
    """
    grid = _depth_grid(params)
    h = silhouette_rows(camera, contact_px, grid, height_m, offsets_m, params.near_plane_m)
    ok = np.isfinite(h) & (h > 0)
    if not ok.any():
        return None
    grid, h = grid[ok], h[ok]
    # Pixel height falls with depth; find the first grid step that brackets the target.
    above = h >= height_px
    crossings = np.nonzero(above[:-1] & ~above[1:])[0]
    if not len(crossings):
        return None
    k = int(crossings[0])
    # Interpolate 1/h linearly in depth (exact for a flat object: h = f H / d).
    x0, x1 = grid[k], grid[k + 1]
    y0, y1, y = 1.0 / h[k], 1.0 / h[k + 1], 1.0 / height_px
    t = (y - y0) / (y1 - y0) if y1 != y0 else 0.0
    return float(x0 + t * (x1 - x0))


def depth_from_top_row(
    camera: PinholeCamera,
    u: float,
    v_top: float,
    height_m: float,
    height_std_m: float,
    params: PlacementParams,
) -> tuple[float, float] | None:
    """Depth of an upright object whose top, ``height_m`` above the ground, is seen at row ``v_top``.

    The cue for an object whose bottom is hidden: its top row alone places it once its
    height is assumed (``v_top - v_h = f (h - H) / d`` for a level camera). It is only as
    good as ``|H - h|`` is large against the height's spread: a person's head, ~0.5 m
    above a car camera, places it to ~20 %; a car's roof, near the camera height, not at
    all (None then).

    Args:
        camera: the source camera.
        u: column of the object's top, pixels.
        v_top: row of the object's top, pixels.
        height_m: the object's assumed height, metres.
        height_std_m: the spread of that height, metres.
        params: the depth grid, the near plane and ``top_row_min_clearance_sigmas``.

    Returns:
        (depth, sigma) in metres along the optical axis, or None when the height is too
        close to the camera's for the row to say anything (within
        ``top_row_min_clearance_sigmas`` spreads: sigma above half the depth), or no depth
        in range fits.
    """
    clearance = abs(height_m - camera.height_m)
    if clearance <= params.top_row_min_clearance_sigmas * height_std_m:
        return None
    grid = _depth_grid(params)
    ray = camera.rays_world(np.array([[u, v_top]], dtype=np.float64))[0]
    ahead = np.array([ray[0], ray[1]], dtype=np.float64)
    ahead /= max(float(np.linalg.norm(ahead)), 1e-12)
    rate = float(ahead @ camera.rotation_world_from_cam[:2, 2])
    if rate <= 1e-6:
        return None
    base = camera.center_world[:2][None, :] + (grid / rate)[:, None] * ahead[None, :]
    px, depth = camera.project(np.column_stack([base, np.full(len(grid), height_m)]))
    rows = np.where(depth > params.near_plane_m, px[:, 1], np.nan)
    # Rows approach the horizon from below (top under the camera) or above (over it).
    gap = rows - v_top
    signs = np.sign(gap)
    crossings = np.nonzero(np.isfinite(gap[:-1]) & np.isfinite(gap[1:]) & (signs[:-1] != signs[1:]))[0]
    if not len(crossings):
        return None
    k = int(crossings[0])
    t = gap[k] / (gap[k] - gap[k + 1])
    d = float(grid[k] + t * (grid[k + 1] - grid[k]))
    sigma = d * float(np.hypot(height_std_m / clearance, d / (camera.fy * clearance)))
    return d, sigma


def height_from_top_row(camera: PinholeCamera, u: float, v_top: float, depth_m: float) -> float:
    """Height above the ground of an object's top seen at row ``v_top``, when its depth is known.

    The inverse of :func:`depth_from_top_row`: the point of the top row's ray at that
    depth along the optical axis stands this high.

    Args:
        camera: the source camera.
        u: column of the object's top, pixels.
        v_top: row of the object's top, pixels.
        depth_m: the object's depth along the optical axis, metres.

    Returns:
        Metres above the ground; NaN when the ray is at or below the ground there.
    """
    ray = camera.rays_world(np.array([[u, v_top]], dtype=np.float64))[0]
    z = float(camera.center_world[2] + ray[2] * depth_m)
    return z if z > 0 else float("nan")
