"""What the image tells about the camera before it is estimated, and the street's yaw after.

* :func:`street_view`: the photo's perspective for cutting facades, from the street's
  vanishing point or a given pitch (perception needs it before the camera is estimated);
* :func:`height_observations`: objects of rigid class height whose bottom and top are in
  view, with their top's extent beyond the contact (the camera's height and pitch cue);
* :func:`road_top_row`: the highest row with a meaningful amount of road (the horizon
  lies above it);
* :func:`vanishing_yaw`: the world yaw of the street's vanishing direction, once the
  camera is known (a cue to the road axis).

Frames: image pixels (u right, v down); world (Z up, metres, ground z = 0).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from usdworld.geometry.camera import PinholeCamera, intrinsics_from_fov
from usdworld.geometry.estimate import HeightObservations
from usdworld.geometry.vanishing import VanishingPoint
from usdworld.io.asset_catalogue import AssetSizes
from usdworld.io.class_table import ClassTable
from usdworld.io.types import CameraSpec
from usdworld.layout.boxes import box_view_angle
from usdworld.layout.silhouette import top_offsets
from usdworld.parameters.scene import SceneParams
from usdworld.parameters.camera import CameraParams
from usdworld.perception.facades import StreetView
from usdworld.perception.objects import ImageObject


def street_view(
    spec: CameraSpec | None,
    width: int,
    height: int,
    vanishing: VanishingPoint | None,
    curb_height_m: float,
    camera_params: CameraParams,
) -> StreetView | None:
    """The photo's perspective (for cutting facades), when its horizon is known: from the
    street's vanishing point, else from a given camera pitch (None otherwise).

    The camera is not estimated yet: a missing focal length is the default field of view's
    and a missing height the typical one (facade pieces scale with it). Facades stand on the
    sidewalk: the height is the camera's above it.

    Args:
        spec: the given camera, if any.
        width: image width, pixels.
        height: image height, pixels.
        vanishing: the street's vanishing point, if the photo's lines give one.
        curb_height_m: height of the sidewalk above the road, metres.
        camera_params: the default field of view and the typical camera height.
    """
    if spec is not None and spec.K is not None:
        K = spec.K
    else:
        K = intrinsics_from_fov(width, height, camera_params.default_hfov_deg)
    cam_height = spec.height_m if spec is not None and spec.height_m is not None else camera_params.height_prior_m[0]
    if vanishing is not None:
        horizon = vanishing.v
    elif spec is not None and spec.pitch is not None:
        horizon = PinholeCamera(width, height, K, cam_height, spec.pitch, spec.roll or 0.0).horizon_v()
    else:
        return None
    vanishing_u = float(vanishing.u) if vanishing is not None else None
    return StreetView(float(horizon), float(K[0, 0]), float(K[0, 2]), float(cam_height) - curb_height_m, vanishing_u)


def height_observations(
    objects: Sequence[ImageObject], catalogue: Mapping[str, AssetSizes], table: ClassTable, image_width: int
) -> HeightObservations:
    """Objects of rigid class height with bottom and top in view.

    The top's extent beyond the contact takes a box's turn from its aspect, else assumes
    the object is seen end on.

    Args:
        objects: the image objects.
        catalogue: asset sizes of (at least) the rigid-height classes among them.
        table: the class table (heights and their spread).
        image_width: pixels.

    Returns:
        N observations (N may be 0).
    """
    rows = []
    for o in objects:
        prior = table[o.class_name]
        if not prior.rigid_height or o.top_truncated or o.bottom_truncated or o.bottom_occluded:
            continue
        s = catalogue[o.class_name]
        angle = box_view_angle(o, prior, image_width)
        v = s.default_variant
        near, far = top_offsets(s.contact_half(v), s.top_half(v), s.footprint(v), angle or 0.0, o.box_only)
        rows.append(
            (o.contact_px[0], o.contact_px[1], float(o.edges_px[1]), prior.size_m[2], prior.height_std_m, near, far)
        )
    arr = np.array(rows, dtype=np.float64).reshape(-1, 7)
    return HeightObservations(*(arr[:, k].copy() for k in range(7)))


def road_top_row(road: np.ndarray | None, params: SceneParams) -> float | None:
    """Highest image row with a meaningful amount of road (:attr:`SceneParams.road_top_min_fraction`
    of the width, at least :attr:`SceneParams.road_top_min_px`).

    Args:
        road: (H, W) bool road pixels, or None without labels.
        params: the scene parameters.

    Returns:
        The row, or None without labels or without such a row.
    """
    if road is None:
        return None
    counts = road.sum(axis=1)
    rows = np.nonzero(counts >= max(params.road_top_min_px, params.road_top_min_fraction * road.shape[1]))[0]
    return float(rows[0]) if len(rows) else None


def vanishing_yaw(vanishing: VanishingPoint | None, camera: PinholeCamera) -> float | None:
    """World yaw (radians) of the direction the street's vanishing point lies in, or None."""
    if vanishing is None:
        return None
    ray = camera.rays_world(np.array([[vanishing.u, vanishing.v]]))[0]
    return float(np.arctan2(ray[1], ray[0]))
