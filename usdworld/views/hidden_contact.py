"""The unknown surface under a walker whose feet are hidden (layout level: pure numpy).

A person whose feet a parked car hides is placed by the top row of its head
(:func:`usdworld.layout.silhouette.depth_from_top_row`, method ``top_row``), or just behind the
car when that row put it in front of it (``behind``), assuming the head stands its class
height above the *road*. People walk on the road and on the sidewalk (the shipped surface
rules), and a single view cannot tell which: on the kerb the head is ``kerb`` higher. The top
row's viewing ray is a straight line, so the ground distance at which it reaches a height
grows linearly with that height's clearance over the camera: read on the kerb, the object
lies ``range * kerb / |height - camera height|`` beyond the road's reading. The two readings
are that far apart, so either one errs by half of it (standard deviation of two equally
likely values): :func:`surface_sigma`. The observation keeps its stated spread for
association and fusion; a drive's motion fit adds this term (:func:`fit_covariance`), so
frames whose contact is hidden do not drag a track that other frames, seeing the feet, fix.

Some hidden contacts give a *bound*, not a reading (:func:`depth_bound_side`): an object placed
just behind the object hiding its bottom (``behind``) stands at least that far, and one placed
by its visible bottom's ground point or by its cut height (``contact_partial``,
``height_partial``) at most that far. A drive's motion fit of a moving object holds such a frame
only where the track would break its bound (:func:`usdworld.views.drive.fit_motion_bounded`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from usdworld.io.class_table import load_class_table
from usdworld.layout.draft import DepthMethod
from usdworld.layout.placement import Placement

if TYPE_CHECKING:
    from usdworld.views.fusion import FusedObject

#: Depth methods that read a hidden contact from the top row on the road plane.
HIDDEN_CONTACT_METHODS = (DepthMethod.TOP_ROW, DepthMethod.BEHIND)
#: Depth methods whose depth bounds the object's from below: just behind what hides its bottom.
LOWER_BOUND_METHODS = (DepthMethod.BEHIND,)
#: Depth methods whose depth bounds it from above: the visible bottom's ground point (the hidden
#: contact lies lower in the image, so nearer on the ground) or the cut height (``f H / h`` with
#: the seen height ``h`` short of the whole).
UPPER_BOUND_METHODS = (DepthMethod.CONTACT_PARTIAL, DepthMethod.HEIGHT_PARTIAL)
#: Classes that stand on the road or the sidewalk (``usdworld/data/surface_rules.json``) and
#: whose hidden contact the top of the head places (their height clears a car camera's).
EITHER_SURFACE_CLASSES = ("person", "rider")


def surface_sigma(
    placement: Placement, range_m: float, camera_height_m: float, curb_height_m: float
) -> float:
    """Along-ray standard deviation, metres, of a hidden contact's unknown surface (road or kerb).

    Args:
        placement: the view's placement (its method, class and depth).
        range_m: its ground distance from the view camera, metres.
        camera_height_m: the camera's height above the road, metres.
        curb_height_m: the kerb's height above the road, metres.

    Returns:
        ``range * kerb / |class height - camera height| / 2`` for a person or rider placed
        ``top_row`` or ``behind``; 0 for any other placement or a head level with the camera.

    Example:
        A walker's head 1.75 m high seen 40 m away by a camera 1.21 m high, kerb 0.15 m:
        ``40 * 0.15 / 0.54 / 2 = 5.56`` m.
    """
    cls = placement.obj.class_name
    if placement.method not in HIDDEN_CONTACT_METHODS or cls not in EITHER_SURFACE_CLASSES:
        return 0.0
    clearance = abs(float(load_class_table()[cls].size_m[2]) - camera_height_m)
    if clearance <= 0.0 or not math.isfinite(range_m):
        return 0.0
    return 0.5 * range_m * curb_height_m / clearance


def fit_covariance(item: FusedObject) -> np.ndarray:
    """(2, 2) float64 a frame's ground covariance as a drive's motion fit takes it, metres squared.

    The frame's fused covariance, plus, when every view of the frame hides the object's
    contact, its primary observation's :func:`surface_sigma` squared along that view's ray
    (a view that sees the feet fixes the surface).
    """
    obs = item.observations
    if not obs or any(o.surface_sigma_m <= 0.0 for o in obs):
        return item.covariance
    o = obs[0]
    d = o.placement.contact_world[:2] - o.camera_ground
    u = d / max(float(np.linalg.norm(d)), 1e-9)
    return item.covariance + o.surface_sigma_m**2 * np.outer(u, u)


def depth_bound_side(item: FusedObject) -> int:
    """Whether a frame's position along its viewing ray is a reading or a bound.

    Args:
        item: the frame's object (its observations, one per view that placed it).

    Returns:
        ``+1`` when every view placed it by a bound from below (:data:`LOWER_BOUND_METHODS`: the
        object is at or beyond the position), ``-1`` when every view placed it by a bound from
        above (:data:`UPPER_BOUND_METHODS`: at or nearer), ``0`` otherwise (a view that reads
        the depth decides).
    """
    methods = {o.placement.method for o in item.observations}
    if methods and methods <= set(LOWER_BOUND_METHODS):
        return 1
    if methods and methods <= set(UPPER_BOUND_METHODS):
        return -1
    return 0
