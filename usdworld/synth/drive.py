"""Synthetic drives: one street, a camera driving along it, some vehicles and people moving.

A drive is a :class:`~usdworld.synth.scene.SynthScene` sampled as for one photo, but with
its things and buildings reaching the drive's length farther along the road, plus:

* the ego camera drives along world +X at ``speed_mps``; frame ``i`` is taken at
  ``t = i * interval_s`` from ``x = speed_mps * t`` (same height, pitch, roll and yaw);
* every ``driving`` car moves along its lane at constant velocity: all cars of one lane at
  one speed (so they never run into each other), the ego's lane and the other lanes of its
  direction at 0-3 m/s faster than the ego (nothing is overtaken through), the oncoming
  lanes at 6-12 m/s;
* every ``walking`` person walks along the sidewalk (+X or -X, the sign of their heading's
  x) at 1.0-1.6 m/s (comfortable gait speeds, Bohannon 1997);
* everything else (buildings, street furniture, trees, parked cars, people at a crossing)
  stands still;
* on request (``overtake_mps``), one more car overtakes the ego, starting out of view
  beside it: a mover first seen after the first frame (:mod:`usdworld.synth.overtaking`).

The drive's world frame is the first frame's: origin on the ground below the camera at
``t = 0``, X along the road. Frame ``i`` is rendered in its own camera's ground frame (the
whole scene shifted by ``-x`` of the camera and moved to time ``t``), so each frame's
Cityscapes files are those of an ordinary synthetic photo.

Files written for a drive ``<name>`` (:func:`write_drive`):

* per frame ``<name>_<i, 6 digits>_{leftImg8bit,gtFine_labelIds,gtFine_instanceIds}.png``,
  ``_camera.json`` and ``_gt.json`` (as :func:`~usdworld.synth.cityscapes.write_cityscapes_frame`,
  in that frame's ground frame);
* ``<name>_views.json``: the views manifest ``usdworld build --views`` reads (image, K,
  camera_to_world in the drive's world, timestamp, labels, instances);
* ``<name>_drive_gt.json``: the drive's ground truth in its world: times, ego poses
  (``world_from_ego``, the ego frame being the camera's ground frame), and per object its
  class, asset variant and scale, yaw, size, whether it moves, its position per frame
  (``track``: its origin, the centre of its footprint's bottom) and its visible pixels per
  frame. (Drives written before the eighteenth session have no ``variant`` / ``scale``; their
  first frame's ``_gt.json`` has them.)
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from usdworld.atomic import write_bytes_atomic
from usdworld.errors import UsdWorldError
from usdworld.synth.assets import AssetSource, ClassAsset, class_asset, default_assets
from usdworld.synth.cityscapes import json_bytes, output_folder, rounded, write_cityscapes_frame
from usdworld.synth.placement import SYNTH_CLASSES, SynthObject, place_objects
from usdworld.synth.overtaking import add_overtaking_car
from usdworld.synth.scene import SynthScene, sample_camera
from usdworld.synth.street import STREET_X_RANGE_M, sample_street

DRIVE_GT_FORMAT = "usdworld-synth-drive-gt/1"
#: Speed of the oncoming lanes, m/s (urban traffic below the 50 km/h = 13.9 m/s limit).
ONCOMING_SPEED_RANGE_MPS = (6.0, 12.0)
#: How much faster than the ego the lanes of its own direction drive, m/s.
SAME_DIRECTION_EXTRA_MPS = (0.0, 3.0)
#: Walking speed of people on the sidewalks, m/s (comfortable gait, Bohannon 1997: 1.27-1.46 m/s).
WALKING_SPEED_RANGE_MPS = (1.0, 1.6)


@dataclass(frozen=True)
class SynthDrive:
    """A sampled drive (see the module docstring).

    Attributes:
        scene: the street and every object at ``t = 0`` in the drive's world.
        velocities: object name -> (2,) float64 ground velocity in the world, m/s (moving objects only).
        speed_mps: the ego's speed along +X.
        times: (N,) float64 frame timestamps, seconds, from 0.
    """

    scene: SynthScene
    velocities: Mapping[str, np.ndarray]
    speed_mps: float
    times: np.ndarray

    def __post_init__(self) -> None:
        times = np.array(self.times, dtype=np.float64)
        times.setflags(write=False)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "velocities", MappingProxyType(dict(self.velocities)))
        if times.ndim != 1 or len(times) < 1 or np.any(np.diff(times) <= 0):
            raise UsdWorldError(f"SynthDrive.times: need increasing timestamps, got {times}")

    def ego_x(self, t: float) -> float:
        """The camera's (and ego frame's) x in the world at time ``t``, metres."""
        return self.speed_mps * float(t)

    def world_from_ego(self, t: float) -> np.ndarray:
        """(4, 4) float64 the ego frame (the camera's ground frame) in the world at time ``t``."""
        T = np.eye(4)
        T[0, 3] = self.ego_x(t)
        return T

    def world_from_cam(self, t: float) -> np.ndarray:
        """(4, 4) float64 OpenCV camera -> world pose at time ``t``."""
        return self.world_from_ego(t) @ self.scene.camera.world_from_cam()

    def position(self, obj: SynthObject, t: float) -> np.ndarray:
        """(3,) float64 ``obj``'s (x, y, z_bottom) in the world at time ``t``."""
        v = self.velocities.get(obj.name)
        if v is None:
            return obj.centre_world.copy()
        return obj.centre_world + np.array([v[0], v[1], 0.0]) * float(t)

    def frame_scene(self, i: int) -> SynthScene:
        """Frame ``i`` as a scene of its own, in its camera's ground frame."""
        t = float(self.times[i])
        dx = self.ego_x(t)
        objects = []
        for obj in self.scene.objects:
            p = self.position(obj, t)
            p[0] -= dx
            objects.append(dataclasses.replace(obj, centre_world=p))
        street = self.scene.street
        street = dataclasses.replace(
            street,
            x_range=(street.x_range[0] - dx, street.x_range[1] - dx),
            crossing_x=None if street.crossing_x is None else street.crossing_x - dx,
        )
        return dataclasses.replace(self.scene, street=street, objects=tuple(objects))


def _velocities(rng: np.random.Generator, scene: SynthScene, speed_mps: float) -> dict[str, np.ndarray]:
    """Constant ground velocities of the driving cars (per lane) and walking people."""
    right, left = scene.street.lane_centres_y()
    half = 0.5 * scene.street.lane_width_m
    lane_speed: dict[tuple[int, int], float] = {}
    for i in range(len(right)):
        lane_speed[(0, i)] = speed_mps + float(rng.uniform(*SAME_DIRECTION_EXTRA_MPS))
    for i in range(len(left)):
        lane_speed[(1, i)] = -float(rng.uniform(*ONCOMING_SPEED_RANGE_MPS))
    out: dict[str, np.ndarray] = {}
    for obj in scene.objects:
        if obj.role == "driving":
            y = float(obj.centre_world[1])
            lane = next(
                (k, i) for k, lanes in enumerate((right, left)) for i, c in enumerate(lanes) if abs(y - c) < half
            )
            out[obj.name] = np.array([lane_speed[lane], 0.0])
        elif obj.role == "walking":
            direction = 1.0 if math.cos(obj.yaw) >= 0 else -1.0
            out[obj.name] = np.array([direction * float(rng.uniform(*WALKING_SPEED_RANGE_MPS)), 0.0])
    return out


def make_drive(
    rng: np.random.Generator,
    width: int,
    height: int,
    frames: int,
    speed_mps: float = 8.0,
    interval_s: float = 0.1,
    assets: AssetSource | None = None,
    overtake_mps: float | None = None,
) -> SynthDrive:
    """Sample a drive of ``frames`` frames.

    Args:
        rng: random generator; the same seed gives the same drive.
        width: image width in pixels.
        height: image height in pixels.
        frames: number of frames (>= 1).
        speed_mps: the ego's speed (>= 0).
        interval_s: time between frames (> 0); 0.1 s is KITTI's 10 Hz.
        assets: where class assets come from (default: the built-in library).
        overtake_mps: when given (> 0), add a car that overtakes the ego this much faster
            than it (:func:`~usdworld.synth.overtaking.add_overtaking_car`); it draws
            nothing from ``rng``, so the rest of the drive is the one the seed gives.
    """
    if frames < 1 or speed_mps < 0 or interval_s <= 0:
        raise UsdWorldError(
            f"make_drive: need frames >= 1, speed >= 0, interval > 0; got {frames}, {speed_mps}, {interval_s}"
        )
    from usdworld.render.lighting import sun_direction

    source = assets if assets is not None else default_assets()
    library: dict[str, ClassAsset] = {c: class_asset(source, c) for c in SYNTH_CLASSES}
    length = speed_mps * interval_s * (frames - 1)
    camera = sample_camera(rng, width, height)
    street = dataclasses.replace(
        sample_street(rng), x_range=(STREET_X_RANGE_M[0], STREET_X_RANGE_M[1] + length)
    )
    side = 1.0 if rng.random() < 0.5 else -1.0
    sun = sun_direction(180.0 + side * float(rng.uniform(25.0, 70.0)), float(rng.uniform(40.0, 65.0)))
    objects = place_objects(rng, street, library, extend_m=length)
    scene = SynthScene(
        camera=camera,
        street=street,
        objects=objects,
        sun_direction_world=sun,
        asset_paths={c: a.path for c, a in library.items()},
    )
    times = np.arange(frames, dtype=np.float64) * interval_s
    velocities = _velocities(rng, scene, speed_mps)
    if overtake_mps is not None:
        objects, velocities = add_overtaking_car(
            objects, velocities, street, camera, library["car"], speed_mps, overtake_mps, float(times[-1])
        )
        scene = dataclasses.replace(scene, objects=objects)
    return SynthDrive(scene, velocities, speed_mps, times)


def _matrix(T: np.ndarray) -> list[list[float]]:
    return [[rounded(v, 9) for v in row] for row in T]


def write_drive(drive: SynthDrive, out_dir: str | Path, name: str) -> dict[str, Path]:
    """Render every frame of ``drive`` and write its files (see the module docstring).

    Args:
        drive: the drive.
        out_dir: the folder (created if missing).
        name: the drive's name, the prefix of every file.

    Returns:
        Paths by role: ``views`` (the manifest) and ``gt`` (the drive's ground truth).

    Raises:
        RenderError: no usable OpenGL.
        OutputError: the folder cannot be written.
    """
    out = output_folder(out_dir)
    cam = drive.scene.camera
    views = []
    visible: dict[str, list[int]] = {o.name: [] for o in drive.scene.objects}
    for i, t in enumerate(drive.times):
        frame = f"{name}_{i:06d}"
        paths = write_cityscapes_frame(drive.frame_scene(i), out, frame)
        for entry in json.loads(paths["gt"].read_text())["objects"]:
            visible[entry["name"]].append(int(entry["visible_pixels"]))
        views.append(
            {
                "name": f"f{i:06d}",
                "image": paths["image"].name,
                "K": [[rounded(v, 9) for v in row] for row in cam.K],
                "camera_to_world": _matrix(drive.world_from_cam(float(t))),
                "timestamp": rounded(float(t), 9),
                "labels": paths["labels"].name,
                "instances": paths["instances"].name,
            }
        )
    objects = []
    for obj in drive.scene.objects:
        v = drive.velocities.get(obj.name)
        objects.append(
            {
                "name": obj.name,
                "class": obj.class_name,
                "role": obj.role,
                "variant": obj.variant,
                "scale": [rounded(c) for c in obj.scale],
                "moving": v is not None,
                "velocity_world": [rounded(c) for c in (v if v is not None else (0.0, 0.0))],
                "yaw_rad": rounded(obj.yaw),
                "size_m": [rounded(c) for c in obj.size_m],
                "track": [[rounded(c) for c in drive.position(obj, float(t))] for t in drive.times],
                "visible_pixels": visible[obj.name],
            }
        )
    gt = {
        "format": DRIVE_GT_FORMAT,
        "times": [rounded(float(t), 9) for t in drive.times],
        "speed_mps": rounded(drive.speed_mps),
        "world_from_ego": [_matrix(drive.world_from_ego(float(t))) for t in drive.times],
        "camera": {"width": cam.width, "height": cam.height, "K": _matrix(cam.K)},
        "street": drive.scene.street.to_json(),
        "objects": objects,
    }
    result = {"views": out / f"{name}_views.json", "gt": out / f"{name}_drive_gt.json"}
    write_bytes_atomic(result["views"], json_bytes({"views": views}))
    write_bytes_atomic(result["gt"], json_bytes(gt))
    return result
