"""A car that overtakes the ego during a synthetic drive: a mover that enters the view late.

The drive's sampled movers are all ahead of the camera from the first frame on (cars start
8-60 m ahead, people walk slower than the ego drives). A mover first seen after the first
frame needs one that comes from outside the view, and the common one on a road is a car
overtaking the ego. :func:`add_overtaking_car` adds it on request (``usdworld synth
--sequence N --overtaking MPS``); without the request a drive stays what its seed gives.

* **Lane.** The lane beside the ego's in its own direction (the nearest one; of two, the
  left one, as traffic keeps right), or, on a
  street with one lane that way, the first oncoming lane (an overtaking manoeuvre on a
  two-lane road). The car drives along +X on the lane's centre line.
* **Speed.** ``overtake_mps`` faster than the ego, constant (as every synthetic mover).
* **Start.** Just outside the camera's view at the first frame: every corner of its box
  lies ``ENTRY_MARGIN_M`` (along X) beyond the image edge on its side, so no pixel of it is
  in the first frame, and it drives into view as it overtakes. It is in view from the
  frame at which it has gained ``ENTRY_MARGIN_M`` on the ego, and wholly so once it has
  gained its own length more.
* **Room.** Whatever its footprint would meet during the drive (a car of that lane it
  would run into, one coming the other way, a person standing at a crossing) is left out.
* **Asset.** The car asset's default variant at scale 1, named after the last car
  (``car_<n>``), role ``overtaking``.
"""

from __future__ import annotations

import numpy as np

from usdworld.errors import UsdWorldError
from usdworld.geometry.camera import PinholeCamera
from usdworld.synth.assets import ClassAsset
from usdworld.synth.placement import SynthObject
from usdworld.synth.street import StreetLayout

#: How far (along X) the overtaking car's box starts beyond the edge of the first frame's view, metres.
ENTRY_MARGIN_M = 0.3
#: Clearance kept between the overtaking car's footprint and anything else's during the drive, metres.
CLEARANCE_M = 0.5


def overtaking_lane_y(street: StreetLayout) -> float:
    """y of the lane the overtaking car drives in (see the module docstring).

    Args:
        street: the drive's street; the ego drives in the right-hand lane holding y = 0.

    Returns:
        The lane centre's y, metres (world, Y left).
    """
    right, left = street.lane_centres_y()
    half = 0.5 * street.lane_width_m
    beside = [y for y in right if abs(y) >= half]
    if beside:  # the nearest; of two alike the left one (traffic keeps right, so it passes on the left)
        return min(beside, key=lambda y: (round(abs(y), 6), -y))
    return left[0]


def entry_centre_x(camera: PinholeCamera, size_m: np.ndarray, lane_y: float) -> float:
    """The largest footprint-centre x at which a +X-facing box in the lane is wholly out of view.

    Every corner must lie outside the image edge on the lane's side: the half-space through
    the camera centre bounded by that edge's plane (left edge ``u = 0`` for a lane left of the
    camera, right edge ``u = width`` for one right of it). A corner's signed distance to
    that plane is linear in the box's x, so the bound is the least over the eight corners.

    Args:
        camera: the first frame's camera, in the drive's world (its ground frame).
        size_m: (3,) float64 the box's (length, width, height), metres.
        lane_y: y of the box's centre line, metres.

    Returns:
        The bound, metres.

    Raises:
        UsdWorldError: moving along +X does not bring the box into view (a camera looking backwards).
    """
    length, width, height = (float(v) for v in size_m)
    xs, ys, zs = np.meshgrid(
        [-0.5 * length, 0.5 * length],
        [lane_y - 0.5 * width, lane_y + 0.5 * width],
        [0.0, height],
        indexing="ij",
    )
    corners = np.stack([xs.ravel(), ys.ravel(), zs.ravel()], axis=1)  # (8, 3) at centre x = 0
    if lane_y > 0:  # left of the camera: inside the view is fx * x + cx * z >= 0 (u >= 0)
        normal = np.array([camera.fx, 0.0, camera.cx])
    else:  # right of it: (width - cx) * z - fx * x >= 0 (u <= width)
        normal = np.array([-camera.fx, 0.0, camera.width - camera.cx])
    along = float(camera.cam_from_world_points(np.array([[1.0, 0.0, 0.0]]) + camera.center_world)[0] @ normal)
    if along <= 0:
        raise UsdWorldError("overtaking car: driving along +X does not bring it into this camera's view")
    offsets = camera.cam_from_world_points(corners) @ normal  # (8,) signed, at centre x = 0
    return float(np.min(-offsets / along))


def _meets(
    a: SynthObject, va: float, b: SynthObject, vb: float, duration_s: float, clearance_m: float
) -> bool:
    """Whether two footprints moving along X at constant speeds come within ``clearance_m`` before ``duration_s``."""
    ba = a.footprint_aabb(0.5 * clearance_m)
    bb = b.footprint_aabb(0.5 * clearance_m)
    if ba[1] >= bb[3] or bb[1] >= ba[3]:
        return False
    reach = 0.5 * (ba[2] - ba[0] + bb[2] - bb[0])
    gap0 = 0.5 * (ba[0] + ba[2] - bb[0] - bb[2])  # centre distance along X at t = 0
    gap1 = gap0 + (va - vb) * duration_s
    if gap0 * gap1 <= 0:
        return True
    return min(abs(gap0), abs(gap1)) < reach


def add_overtaking_car(
    objects: tuple[SynthObject, ...],
    velocities: dict[str, np.ndarray],
    street: StreetLayout,
    camera: PinholeCamera,
    car: ClassAsset,
    speed_mps: float,
    overtake_mps: float,
    duration_s: float,
) -> tuple[tuple[SynthObject, ...], dict[str, np.ndarray]]:
    """Add a car that overtakes the ego (see the module docstring).

    Args:
        objects: the drive's objects at ``t = 0``.
        velocities: object name -> (2,) float64 ground velocity, m/s (moving objects only).
        street: the drive's street.
        camera: the first frame's camera (its ground frame is the drive's world).
        car: the car asset.
        speed_mps: the ego's speed along +X.
        overtake_mps: how much faster than the ego the car drives (> 0).
        duration_s: the drive's length in time (its last frame's time).

    Returns:
        The objects with the car appended and what it would meet left out, and their velocities.

    Raises:
        UsdWorldError: ``overtake_mps`` is not positive.
    """
    if not overtake_mps > 0:
        raise UsdWorldError(f"overtaking car: need a speed above the ego's (> 0 m/s), got {overtake_mps}")
    variant = car.variants[0]
    size = np.array(car.size_by_variant[variant], dtype=np.float64)
    lane_y = overtaking_lane_y(street)
    x0 = entry_centre_x(camera, size, lane_y) - ENTRY_MARGIN_M
    index = 1 + max((int(o.name.split("_")[-1]) for o in objects if o.class_name == "car"), default=-1)
    new = SynthObject(
        f"car_{index:04d}", "car", variant, np.array([x0, lane_y, 0.0]), 0.0, np.ones(3), size, "overtaking"
    )
    v_new = speed_mps + overtake_mps
    kept = [
        o
        for o in objects
        if not _meets(new, v_new, o, float(velocities.get(o.name, (0.0, 0.0))[0]), duration_s, CLEARANCE_M)
    ]
    moving = {o.name: velocities[o.name] for o in kept if o.name in velocities}
    moving[new.name] = np.array([v_new, 0.0])
    return (*kept, new), moving

