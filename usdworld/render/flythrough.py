"""The fly-through video of a world, as in the paper's user study T1.

The camera starts exactly at the source camera, moves forward along the road, then rises
to an aerial view while it turns about the vertical axis around a point ahead, looking
down at it (:func:`flythrough_poses`). The source vehicle (the car the photo was taken
from) is part of the scene, all in red: the car asset is referenced at the world origin
(the ground point below the camera) with a red material bound over it, in the stage's
**session layer** (:func:`add_source_vehicle`), so the world's files are never changed.
Frames stream into an H.264 MP4 (:mod:`usdworld.render.video`) as they are rendered. They
are shaded with :class:`~usdworld.parameters.video.VideoParams`' cheaper shadow filter (one
bilinear depth comparison instead of the still's four; ``usdworld render`` keeps four), and
closed meshes' faces turned away from the camera are culled (``cull_back_faces``) and
near surfaces are drawn first instead of a depth pre-pass (``near_first``).

Example:
    >>> stage = Usd.Stage.Open("world/world.usda")                          # doctest: +SKIP
    >>> render_flythrough(stage, "fly.mp4", n_frames=120, width=960, height=480)  # doctest: +SKIP
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

from usdworld.errors import InputError
from usdworld.parameters.video import VideoParams
from usdworld.render.lighting import Lighting
from usdworld.render.world_lights import lighting_from_stage
from usdworld.render.outputs import view_camera, world_image_size
from usdworld.render.renderer import Renderer
from usdworld.render.scene import RenderScene, StaticCache
from usdworld.render.timing import scene_at
from usdworld.render.video import Mp4Writer, check_video_size

log = logging.getLogger(__name__)

#: Where the source vehicle is added (session layer only).
SOURCE_VEHICLE_PATH = "/World/SourceVehicle"
#: Linear RGB of the source vehicle's paint.
SOURCE_VEHICLE_RED = (1.0, 0.0, 0.0)
#: The camera sits this far behind the source vehicle's front bumper (over the bonnet), metres.
CAMERA_BEHIND_FRONT_M = 0.5
#: Fewest frames of a fly-through.
MIN_FRAMES = 2

ProgressCallback = Callable[[int, int], None]


@dataclass(frozen=True)
class FlythroughPath:
    """Shape of the camera path (metres, degrees at the edge only).

    Attributes:
        forward_m: how far the camera drives forward before it rises.
        focus_m: distance ahead (along the road) of the ground point the aerial view circles.
        aerial_height_m: camera height at the end.
        aerial_radius_m: horizontal distance from the focus point at the end.
        turn_deg: how far the camera turns about the vertical axis while rising (positive: to the left).
        forward_fraction: share of the video spent driving forward.
    """

    forward_m: float = 10.0
    focus_m: float = 25.0
    aerial_height_m: float = 32.0
    aerial_radius_m: float = 24.0
    turn_deg: float = 110.0
    forward_fraction: float = 0.35

    def __post_init__(self) -> None:
        if not 0 <= self.forward_m < self.focus_m:
            raise InputError(
                f"fly-through: need 0 <= forward_m < focus_m, got {self.forward_m}, {self.focus_m}"
            )
        if not (self.aerial_height_m > 0 and self.aerial_radius_m > 0):
            raise InputError("fly-through: aerial height and radius must be > 0")
        if not 0 < self.forward_fraction < 1:
            raise InputError(f"fly-through: forward_fraction must be in (0, 1), got {self.forward_fraction}")


def _smoothstep(t: float) -> float:
    t = min(max(t, 0.0), 1.0)
    return t * t * (3.0 - 2.0 * t)


def look_rotation(direction_world: np.ndarray) -> np.ndarray:
    """(3, 3) world_from_cam rotation of an OpenCV camera looking along ``direction_world`` with no roll."""
    z = np.asarray(direction_world, dtype=np.float64)
    z = z / np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    if np.linalg.norm(x) < 1e-9:  # straight up or down: any right vector
        x = np.array([0.0, -1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.column_stack([x, y, z])


def _rotation_power(R: np.ndarray, fraction: float) -> np.ndarray:
    """``R`` raised to ``fraction`` (same axis, angle scaled)."""
    rvec, _ = cv2.Rodrigues(np.asarray(R, dtype=np.float64))
    out, _ = cv2.Rodrigues(rvec * fraction)
    return out


def flythrough_poses(
    world_from_cam_source: np.ndarray, n_frames: int, path: FlythroughPath | None = None
) -> np.ndarray:
    """Camera poses of the fly-through.

    Frame 0 is the source pose exactly. For the first ``forward_fraction`` of the video the
    camera drives ``forward_m`` along the road heading (the optical axis projected on the
    ground), keeping its orientation, and comes to rest. Then it circles a ground point
    ``focus_m`` ahead, turning ``turn_deg`` about the vertical axis: it first rises (it
    reaches ``aerial_height_m`` 60 % of the way through, so it clears roadside trees and
    buildings before it swings sideways), while its gaze turns from the source direction
    to the focus point and the source camera's roll fades out. Every motion starts and
    stops smoothly (smoothstep).

    Args:
        world_from_cam_source: (4, 4) float64 OpenCV camera -> world pose of the source camera.
        n_frames: number of frames (>= 2).
        path: the path's shape.

    Returns:
        (n_frames, 4, 4) float64 world_from_cam poses.
    """
    if n_frames < MIN_FRAMES:
        raise InputError(f"--frames must be >= {MIN_FRAMES}, got {n_frames}")
    path = path or FlythroughPath()
    T0 = np.asarray(world_from_cam_source, dtype=np.float64)
    R0, eye0 = T0[:3, :3], T0[:3, 3]
    axis = R0[:, 2]
    heading = np.array([axis[0], axis[1], 0.0])
    heading = (
        heading / np.linalg.norm(heading) if np.linalg.norm(heading) > 1e-6 else np.array([1.0, 0.0, 0.0])
    )
    focus = np.array([eye0[0], eye0[1], 0.0]) + heading * path.focus_m
    r0 = path.focus_m - path.forward_m
    phi0 = float(np.arctan2(-heading[1], -heading[0]))  # the eye starts behind the focus point
    correction = look_rotation(axis).T @ R0  # the source's roll, faded out while rising
    poses = np.tile(np.eye(4), (n_frames, 1, 1))
    a = path.forward_fraction
    for i in range(n_frames):
        t = i / (n_frames - 1)
        if t <= a:
            eye = eye0 + heading * path.forward_m * _smoothstep(t / a)
            R = R0
        else:
            s = (t - a) / (1.0 - a)
            phi = phi0 + np.radians(path.turn_deg) * _smoothstep(s)
            radius = r0 + (path.aerial_radius_m - r0) * _smoothstep(s)
            height = eye0[2] + (path.aerial_height_m - eye0[2]) * _smoothstep(s / 0.6)
            eye = focus + radius * np.array([np.cos(phi), np.sin(phi), 0.0]) + np.array([0.0, 0.0, height])
            w = _smoothstep(s / 0.4)
            to_focus = (focus - eye) / np.linalg.norm(focus - eye)
            gaze = (1.0 - w) * axis + w * to_focus
            R = look_rotation(gaze) @ _rotation_power(correction, 1.0 - w)
        poses[i, :3, :3] = R
        poses[i, :3, 3] = eye
    return poses


def clear_path(
    path: FlythroughPath, scene: RenderScene, world_from_cam_source: np.ndarray, margin_m: float = 6.0
) -> FlythroughPath:
    """``path`` with its aerial height raised to clear, by ``margin_m``, everything near its circle."""
    if scene.n_triangles == 0:
        return path
    T0 = np.asarray(world_from_cam_source, dtype=np.float64)
    axis = T0[:3, 2]
    heading = np.array([axis[0], axis[1]])
    heading = heading / np.linalg.norm(heading) if np.linalg.norm(heading) > 1e-6 else np.array([1.0, 0.0])
    focus = T0[:2, 3] + heading * path.focus_m
    reach = max(path.focus_m - path.forward_m, path.aerial_radius_m) + 5.0
    top = -np.inf
    for batch in scene.batches:  # every corner of the scene, without placing the triangles
        for p in batch.placed_points():
            p = p.reshape(-1, 3)
            near = np.linalg.norm(p[:, :2] - focus, axis=1) <= reach
            if near.any():
                top = max(top, float(p[near, 2].max()))
    top = top if np.isfinite(top) else 0.0
    if top + margin_m <= path.aerial_height_m:
        return path
    return replace(path, aerial_height_m=top + margin_m)


def video_intrinsics(K_source: np.ndarray, source_size: tuple[int, int], size: tuple[int, int]) -> np.ndarray:
    """(3, 3) camera matrix for the video: the source's horizontal field of view, square pixels.

    The principal point keeps its relative position (pixel corners scale), so for the same
    aspect ratio the first frame is the source view exactly.

    Args:
        K_source: (3, 3) float64 source camera matrix for ``source_size``.
        source_size: (width, height) of the source image.
        size: (width, height) of the video.
    """
    (ws, hs), (w, h) = source_size, size
    sx, sy = w / ws, h / hs
    K = np.eye(3)
    K[0, 0] = K[1, 1] = K_source[0, 0] * sx
    K[0, 2] = (K_source[0, 2] + 0.5) * sx - 0.5
    K[1, 2] = (K_source[1, 2] + 0.5) * sy - 0.5
    return K


def default_video_size(stage: Usd.Stage, width: int = 960) -> tuple[int, int]:
    """(width, even height) with the source image's aspect ratio."""
    ws, hs = world_image_size(stage)
    height = max(2, round(width * hs / ws / 2.0) * 2)
    return width, height


def add_source_vehicle(
    stage: Usd.Stage, car_asset: str | Path, color: tuple[float, float, float] = SOURCE_VEHICLE_RED
) -> Usd.Prim:
    """Reference the car asset at the world origin, all red, in the stage's session layer.

    The car faces world +X with its bonnet under the camera (its front bumper
    :data:`CAMERA_BEHIND_FRONT_M` ahead of the origin). A red ``UsdPreviewSurface`` is bound
    over the whole car with ``strongerThanDescendants`` strength, so body, glass and tyres
    are all red and the source vehicle stands out from red cars in the scene. Nothing is
    written to the world's layers. The stage is taken to be Z up in metres (as usdworld
    writes worlds); calling this twice on the same stage returns the vehicle already added.

    Args:
        stage: the opened world.
        car_asset: the car asset's root layer.
        color: linear RGB of the paint.

    Returns:
        The vehicle prim.
    """
    existing = stage.GetPrimAtPath(SOURCE_VEHICLE_PATH)
    if existing and stage.GetSessionLayer().GetPrimAtPath(SOURCE_VEHICLE_PATH):
        return existing  # already added to this stage
    car_asset = Path(car_asset)
    if not car_asset.is_file():
        raise InputError(f"{car_asset}: car asset not found; the source vehicle needs a car asset")
    with Usd.EditContext(stage, stage.GetSessionLayer()):
        xf = UsdGeom.Xform.Define(stage, SOURCE_VEHICLE_PATH)
        prim = xf.GetPrim()
        prim.GetReferences().AddReference(car_asset.resolve().as_posix())
        _, front = _extent_x(stage, prim)
        xf.AddTranslateOp().Set(Gf.Vec3d(CAMERA_BEHIND_FRONT_M - front, 0.0, 0.0))
        mat = UsdShade.Material.Define(stage, f"{SOURCE_VEHICLE_PATH}/SourceRed")
        shader = UsdShade.Shader.Define(stage, f"{SOURCE_VEHICLE_PATH}/SourceRed/PreviewSurface")
        shader.CreateIdAttr("UsdPreviewSurface")
        shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
        shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.4)
        mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
        UsdShade.MaterialBindingAPI.Apply(prim).Bind(mat, UsdShade.Tokens.strongerThanDescendants)
    return prim


def _extent_x(stage: Usd.Stage, prim: Usd.Prim) -> tuple[float, float]:
    cache = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_, UsdGeom.Tokens.render])
    box = cache.ComputeUntransformedBound(prim).ComputeAlignedRange()
    if box.IsEmpty():
        return (-2.1, 2.1)
    return float(box.GetMin()[0]), float(box.GetMax()[0])


def car_asset_for(world_file: Path | None) -> Path:
    """The world's own ``assets/car.usda`` when it has one, else the built-in library's car."""
    if world_file is not None:
        own = Path(world_file).resolve().parent / "assets" / "car.usda"
        if own.is_file():
            return own
    from usdworld.authoring import asset_library

    return asset_library.asset_path("car")


@dataclass(frozen=True)
class FlythroughResult:
    """What :func:`render_flythrough` wrote and how long it took.

    Attributes:
        path: the MP4 file.
        frames: frames written.
        width: frame width.
        height: frame height.
        render_s: seconds spent rendering frames (shadow maps included).
        total_s: seconds for the whole call (scene extraction and encoding included).
    """

    path: Path
    frames: int
    width: int
    height: int
    render_s: float
    total_s: float


#: A drive's ego camera (``build --views`` of timestamped views), which ``--follow-ego`` rides.
EGO_CAMERA_PATH = "/World/Ego/Camera"


def ego_poses(stage: Usd.Stage, n_frames: int, width: int, height: int) -> np.ndarray:
    """Poses of the ego camera of a drive's world, evenly spaced over the stage's time range.

    USD interpolates the ego's time-sampled transform linearly between its frames.

    Args:
        stage: a drive's composed world (it has :data:`EGO_CAMERA_PATH`).
        n_frames: number of poses (>= 2).
        width: image width of the video.
        height: image height of the video.

    Returns:
        (n_frames, 4, 4) float64 world_from_cam (OpenCV) poses.

    Raises:
        InputError: the world is not a drive's.
    """
    from usdworld.render.camera import camera_from_usd

    prim = stage.GetPrimAtPath(EGO_CAMERA_PATH)
    if not prim:
        raise InputError(
            f"--follow-ego: the world has no {EGO_CAMERA_PATH}; build a drive (build --views with timestamped views)"
        )
    codes = ego_codes(stage, n_frames)
    return np.array([camera_from_usd(prim, width, height, Usd.TimeCode(float(c))).world_from_cam for c in codes])


def ego_codes(stage: Usd.Stage, n_frames: int) -> np.ndarray:
    """(n_frames,) float64 the time codes of ``--follow-ego``'s frames, evenly over the stage's range."""
    return np.linspace(stage.GetStartTimeCode(), stage.GetEndTimeCode(), n_frames)


def render_flythrough(
    stage: Usd.Stage,
    output: str | Path,
    n_frames: int = 120,
    width: int = 960,
    height: int = 480,
    fps: float = 30.0,
    camera_path: str | None = None,
    path: FlythroughPath | None = None,
    lighting: Lighting | None = None,
    car_asset: str | Path | None = None,
    progress: ProgressCallback | None = None,
    follow_ego: bool = False,
    video: VideoParams | None = None,
) -> FlythroughResult:
    """Render the fly-through of a world to an H.264 MP4.

    Args:
        stage: the opened world; the source vehicle is added to its session layer.
        output: the ``.mp4`` file.
        n_frames: number of frames (>= 2).
        width: frame width (even).
        height: frame height (even).
        fps: frames per second.
        camera_path: the start camera (default ``/World/SourceCamera``).
        path: the shape of the camera path.
        lighting: sun and sky (default: the world's authored lights, else :class:`Lighting`).
        car_asset: the source vehicle's asset (default :func:`car_asset_for` the stage's root layer).
        progress: called with (frames done, frames total) after every frame.
        follow_ego: ride a drive's ego camera over the stage's time range (:func:`ego_poses`)
            instead of the fly-through path; no source vehicle is added (the ego is the camera).
            Each frame draws the scene at its time code (:func:`usdworld.render.timing.scene_at`,
            as ``render --time`` does): moving objects where they are then, hidden where
            they were not seen.
        video: the frames' shadow filter and the encoder's settings (default :class:`VideoParams`).

    Raises:
        InputError: bad size, frame count, camera path or car asset.
        RenderError: no usable OpenGL.
    """
    t_start = time.perf_counter()
    check_video_size(width, height)
    if n_frames < MIN_FRAMES:
        raise InputError(f"--frames must be >= {MIN_FRAMES}, got {n_frames}")
    source_size = world_image_size(stage)
    source = view_camera(stage, *source_size, camera_path=camera_path)
    K = video_intrinsics(source.K, source_size, (width, height))
    codes: list[float | None] = [None] * n_frames
    if follow_ego:
        poses = ego_poses(stage, n_frames, width, height)
        codes = [float(c) for c in ego_codes(stage, n_frames)]
    else:
        if car_asset is None:
            root = stage.GetRootLayer().realPath
            car_asset = car_asset_for(Path(root) if root else None)
        add_source_vehicle(stage, car_asset)
        scene = RenderScene.from_stage(stage)
        path = clear_path(path or FlythroughPath(), scene, source.world_from_cam)
        poses = flythrough_poses(source.world_from_cam, n_frames, path)
    if lighting is None:
        lighting = lighting_from_stage(stage)
    render_s = 0.0
    params = video or VideoParams()
    with (
        Renderer(
            width,
            height,
            lighting=lighting,
            shadow_taps=params.shadow_taps,
            cull_back_faces=params.cull_back_faces,
            near_first=params.near_first,
        ) as renderer,
        Mp4Writer(output, width, height, fps=fps, params=params, source="rgba_bottom_up") as writer,
    ):
        prototypes: dict = {}
        still = StaticCache()  # a drive's parked cars, buildings and trees: read at the first frame only
        if all(code is None for code in codes):
            # The scene is static along the path: one shadow map, drawn once, serves every frame.
            # (A drive's movers make each frame another scene, whose shadow box follows its view.)
            renderer.fix_shadow_box(scene, K, poses)
        for i, pose in enumerate(poses):
            if codes[i] is not None:  # the drive's movers where they are at the frame's time
                scene = scene_at(stage, codes[i], prototypes=prototypes, static=still)
            t0 = time.perf_counter()
            frame = renderer.render_rgba_rows(scene, K, pose)  # GL's rows: ffmpeg flips them
            render_s += time.perf_counter() - t0
            writer.write(frame)
            if progress is not None:
                progress(i + 1, n_frames)
    return FlythroughResult(Path(output), n_frames, width, height, render_s, time.perf_counter() - t_start)
