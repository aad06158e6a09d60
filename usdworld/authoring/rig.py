"""The multi-view parts of a rig's world: every view's camera and the provenance of fused objects.

:func:`write_rig` completes a world folder that :func:`usdworld.authoring.world.write_world`
wrote from the fused model (whose objects and ground are already in the rig's world frame):

* ``/World/SourceCamera`` is moved to the first view's pose (single-view tools look through it);
* ``/World/Cameras/<name>``: one camera per view, exact intrinsics, at its pose;
* ``/World``: ``usdworld:views``, ``usdworld:viewImages`` and ``usdworld:worldFrame``;
* each object: ``usdworld:sourceImage`` is its primary view's photo, and per observation
  (primary first) ``usdworld:views``, ``usdworld:viewImages``, ``usdworld:viewBBoxes``
  (pixels), ``usdworld:viewDepths``, ``usdworld:viewDepthSigmas`` (metres, along the ray),
  ``usdworld:viewDepthMethods`` and ``usdworld:viewCues`` (``view:cue=depth+-sigma``), with
  ``usdworld:fusionMethod`` (``single``, ``fused``, ``triangulated`` or, for a moving object
  of a drive, ``tracked``).

:func:`write_drive` adds a drive's time: the stage's time codes, the ego's time-sampled
trajectory ``/World/Ego`` (its camera ``/World/Ego/Camera``), and the moving objects'
time-sampled transforms (:mod:`usdworld.views.drive` says how they are decided).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

from usdworld.authoring.camera import define_camera, world_from_usdcam
from usdworld.authoring.stages import base_layer_file
from usdworld.world_files import CAMERA_PATH, DRIVE_LAYER, OBJECTS_PATH, ROOT_LAYER, WORLD_PATH

if TYPE_CHECKING:  # annotations only: ``render --camera`` imports this module, and layout's imports cost it
    from usdworld.geometry.camera import PinholeCamera
    from usdworld.layout.model import WorldModel
    from usdworld.views.drive import DriveObject
    from usdworld.views.fusion import FusedObject
    from usdworld.views.types import ViewSet

#: Where the rig's cameras go.
CAMERAS_PATH = f"{WORLD_PATH}/Cameras"


def _matrix(T: np.ndarray) -> Gf.Matrix4d:
    return Gf.Matrix4d(*np.asarray(T, dtype=np.float64).T.ravel().tolist())


def define_rig_camera(
    stage: Usd.Stage, path: str, camera: PinholeCamera, world_from_ground: np.ndarray
) -> UsdGeom.Camera:
    """Author a complete camera prim for one view at its pose in the rig's world.

    Args:
        stage: stage whose edit target receives the prim.
        path: prim path, e.g. ``/World/Cameras/CAM_FRONT``.
        camera: the view's camera in its ground frame.
        world_from_ground: (4, 4) float64 the view's ground frame in the world.

    Returns:
        The camera schema object.
    """
    cam = define_camera(stage, path, camera)
    cam.GetOrderedXformOps()[0].Set(_matrix(world_from_ground @ world_from_usdcam(camera)))
    return cam


def _set(prim: Usd.Prim, name: str, type_name: Sdf.ValueTypeName, value: object) -> None:
    prim.CreateAttribute(name, type_name, custom=True).Set(value)


def _object_provenance(prim: Usd.Prim, obj: FusedObject) -> None:
    obs = obj.observations
    _set(prim, "usdworld:sourceImage", Sdf.ValueTypeNames.String, obs[0].image_name)
    _set(prim, "usdworld:fusionMethod", Sdf.ValueTypeNames.Token, obj.method)
    _set(prim, "usdworld:views", Sdf.ValueTypeNames.StringArray, [o.view_name for o in obs])
    _set(prim, "usdworld:viewImages", Sdf.ValueTypeNames.StringArray, [o.image_name for o in obs])
    boxes = [Gf.Vec4f(*(float(b) for b in o.placement.obj.box_px)) for o in obs]
    _set(prim, "usdworld:viewBBoxes", Sdf.ValueTypeNames.Float4Array, Vt.Vec4fArray(boxes))
    _set(
        prim, "usdworld:viewDepths", Sdf.ValueTypeNames.FloatArray, [float(o.placement.depth_m) for o in obs]
    )
    _set(
        prim, "usdworld:viewDepthSigmas", Sdf.ValueTypeNames.FloatArray, [float(o.sigma_range_m) for o in obs]
    )
    _set(
        prim,
        "usdworld:viewDepthMethods",
        Sdf.ValueTypeNames.StringArray,
        [o.placement.depth_method for o in obs],
    )
    cues = [
        f"{o.view_name}:{c.name}={c.depth_m:.3f}+-{c.sigma_m:.3f}"
        for o in obs
        for c in o.placement.cues
        if c.depth_m is not None and c.sigma_m is not None
    ]
    _set(prim, "usdworld:viewCues", Sdf.ValueTypeNames.StringArray, cues)


def write_rig(
    out_dir: Path,
    views: ViewSet,
    view_models: Sequence[WorldModel],
    world_from_ground: Sequence[np.ndarray],
    objects: Sequence[FusedObject],
    object_provenance: bool = True,
) -> None:
    """Add the rig's cameras and the multi-view provenance to a written world's base layer.

    Args:
        out_dir: the world folder (:func:`~usdworld.authoring.world.write_world` wrote it).
        views: the views, in order.
        view_models: each view's own world (its camera, in its ground frame).
        world_from_ground: each view's (4, 4) float64 ground frame in the world.
        objects: the fused objects, named as the world's objects.
        object_provenance: whether to write the objects' provenance here; a drive's world has
            it in its crate layer (:func:`write_drive`), as its arrays grow with the frames.
    """
    stage = Usd.Stage.Open(str(base_layer_file(out_dir)), Usd.Stage.LoadNone)
    first = view_models[0].camera.camera
    source = UsdGeom.Camera(stage.GetPrimAtPath(CAMERA_PATH))
    source.GetOrderedXformOps()[0].Set(_matrix(world_from_ground[0] @ world_from_usdcam(first)))
    UsdGeom.Scope.Define(stage, CAMERAS_PATH)
    for view, model, pose in zip(views.views, view_models, world_from_ground):
        define_rig_camera(stage, f"{CAMERAS_PATH}/{view.name}", model.camera.camera, pose)
    world = stage.GetPrimAtPath(WORLD_PATH)
    _set(world, "usdworld:views", Sdf.ValueTypeNames.StringArray, [v.name for v in views.views])
    _set(world, "usdworld:viewImages", Sdf.ValueTypeNames.StringArray, [m.image_name for m in view_models])
    _set(world, "usdworld:worldFrame", Sdf.ValueTypeNames.String, views.frame)
    for obj in objects if object_provenance else ():
        _object_provenance(stage.GetPrimAtPath(f"{OBJECTS_PATH}/{obj.placement.name}"), obj)
    stage.GetRootLayer().Save()


def rig_view(stage: Usd.Stage, camera: str | None) -> tuple[str | None, str | None]:
    """Resolve ``render --camera``: a bare view name of a rig's world to its camera prim and photo.

    Args:
        stage: the composed world.
        camera: ``--camera`` as given: a prim path, a view name (``CAM_BACK``) or None.

    Returns:
        (prim path or None for the default camera, the view's photo file name or None when
        ``camera`` names no view of the rig; the world's source image is used then).
    """
    if camera is None or "/" in camera:
        return camera, None
    world = stage.GetPrimAtPath(WORLD_PATH)
    names = world.GetAttribute("usdworld:views").Get() if world else None
    images = world.GetAttribute("usdworld:viewImages").Get() if world else None
    if names and images and camera in list(names):
        return f"{CAMERAS_PATH}/{camera}", str(images[list(names).index(camera)])
    return f"{CAMERAS_PATH}/{camera}", None


#: The ego vehicle of a drive: a time-sampled Xform; its camera is a child.
EGO_PATH = f"{WORLD_PATH}/Ego"
EGO_CAMERA_PATH = f"{EGO_PATH}/Camera"


#: The world's attributes with an entry per view (or per view's input file): a drive's
#: world keeps them in its crate layer, as ASCII is slow for long arrays.
PER_VIEW_WORLD_ATTRIBUTES = ("usdworld:inputFiles", "usdworld:inputHashes", "usdworld:views", "usdworld:viewImages")


def _take_attributes(
    layer: Sdf.Layer, prim_path: str, names: Sequence[str]
) -> dict[str, tuple[Sdf.ValueTypeName, object]]:
    """Remove attributes from a prim spec of ``layer``; return name -> (type, default value) of those it had."""
    spec = layer.GetPrimAtPath(prim_path)
    out: dict[str, tuple[Sdf.ValueTypeName, object]] = {}
    for name in names:
        attr = spec.attributes.get(name) if spec else None
        if attr is not None:
            out[name] = (attr.typeName, attr.default)
            spec.RemoveProperty(attr)
    return out


def drive_timing(frame_times: Sequence[float]) -> tuple[float, float]:
    """(time codes per second, first time in seconds) of a drive's stage.

    One time code per median frame interval (rounded to 1e-6 per second), so frames at a
    steady rate fall on whole time codes; time code 0 is the first frame.

    Args:
        frame_times: (F,) the distinct frame timestamps, increasing, seconds (F >= 2).
    """
    t = np.asarray(frame_times, dtype=np.float64)
    return float(round(1.0 / float(np.median(np.diff(t))), 6)), float(t[0])


def write_drive(
    out_dir: Path,
    view_models: Sequence[WorldModel],
    world_from_ground: Sequence[np.ndarray],
    drive: Sequence[DriveObject],
    view_times: Sequence[float],
) -> None:
    """Add a drive's time to a written rig world, in its own crate layer ``layers/drive.usdc``.

    The layer sits between the edits and the base layer (time samples and long arrays in
    ASCII are slow to read). It holds:

    * ``timeCodesPerSecond`` = ``framesPerSecond`` (one code per median frame interval),
      ``startTimeCode`` 0 (the first frame) and ``endTimeCode`` (the last), also on ``world.usda``;
    * ``/World/Ego``: Xform whose ``xformOp:transform`` is time-sampled at every frame with
      the ego frame in the world (the ground frame of the frame's first camera: on the
      ground below it, X along its heading); its default value is the first frame's.
      ``/World/Ego/Camera`` is that camera, fixed on the ego (the first view's intrinsics);
    * each moving object: ``xformOp:translate`` and ``xformOp:rotateZ`` time-sampled at the
      frames where it is seen (their default values in the base layer, the first of them,
      stay), and on every object ``usdworld:moving``, ``usdworld:velocity`` (m/s) and
      ``usdworld:trackTimes`` (s), with the per-observation provenance :func:`write_rig`
      writes for a rig of one moment (called with ``object_provenance=False``);
    * each moving object not seen in every frame: ``visibility`` time-sampled
      (:func:`visibility_samples`): ``invisible`` before the first frame it is seen in and
      from the first frame after the last, ``inherited`` in between; its default value
      stays ``inherited``, so tools that read the default time show every object;
    * ``/World``'s attributes with an entry per view (:data:`PER_VIEW_WORLD_ATTRIBUTES`),
      moved here from the base layer.

    Args:
        out_dir: the world folder (:func:`write_rig` completed it).
        view_models: each view's own world, views in order.
        world_from_ground: each view's (4, 4) float64 ground frame in the world.
        drive: the objects' tracks, named as the world's objects.
        view_times: (V,) each view's frame time, seconds (:func:`usdworld.views.drive.frame_times`).
    """
    times = sorted({float(t) for t in view_times})
    tcps, t0 = drive_timing(times)
    code = lambda t: Usd.TimeCode(round((float(t) - t0) * tcps, 6))  # noqa: E731
    out = Path(out_dir)
    drive_layer = Sdf.Layer.CreateNew(str(out / DRIVE_LAYER))
    root = Sdf.Layer.FindOrOpen(str(out / ROOT_LAYER))
    root.subLayerPaths.insert(1, f"./{DRIVE_LAYER}")
    base = Sdf.Layer.FindOrOpen(str(base_layer_file(out)))
    moved = _take_attributes(base, WORLD_PATH, PER_VIEW_WORLD_ATTRIBUTES)
    for layer in (root, drive_layer, base):
        layer.timeCodesPerSecond = tcps
        layer.framesPerSecond = tcps
        layer.startTimeCode = 0.0
        layer.endTimeCode = round((times[-1] - t0) * tcps, 6)
        layer.Save()
    stage = Usd.Stage.Open(root, Usd.Stage.LoadNone)
    stage.SetEditTarget(Usd.EditTarget(drive_layer))
    world = stage.GetPrimAtPath(WORLD_PATH)
    for name, (type_name, value) in moved.items():
        _set(world, name, type_name, value)
    ego = UsdGeom.Xform.Define(stage, EGO_PATH)
    op = ego.AddTransformOp()
    first: dict[float, int] = {}
    for i, t in enumerate(view_times):
        first.setdefault(float(t), i)
    op.Set(_matrix(world_from_ground[first[times[0]]]))
    for t in times:
        op.Set(_matrix(world_from_ground[first[t]]), code(t))
    define_rig_camera(stage, EGO_CAMERA_PATH, view_models[0].camera.camera, np.eye(4))
    for obj in drive:
        prim = stage.GetPrimAtPath(f"{OBJECTS_PATH}/{obj.fused.placement.name}")
        _object_provenance(prim, obj.fused)
        _set(prim, "usdworld:moving", Sdf.ValueTypeNames.Bool, bool(obj.moving))
        _set(prim, "usdworld:velocity", Sdf.ValueTypeNames.Float2, Gf.Vec2f(*(float(v) for v in obj.velocity)))
        _set(prim, "usdworld:trackTimes", Sdf.ValueTypeNames.DoubleArray, [float(t) for t in obj.times])
        if not obj.moving:
            continue
        translate = prim.GetAttribute("xformOp:translate")
        rotate = prim.GetAttribute("xformOp:rotateZ")
        for t, p, yaw in zip(obj.times, obj.positions, obj.yaws):
            translate.Set(Gf.Vec3d(*(float(c) for c in p)), code(t))
            rotate.Set(float(round(np.degrees(yaw), 6)), code(t))
        seen = [code(t).GetValue() for t in obj.times]
        samples = visibility_samples(seen, [code(t).GetValue() for t in times])
        if samples:
            visibility = UsdGeom.Imageable(prim).CreateVisibilityAttr()
            for c, token in samples:
                visibility.Set(token, Usd.TimeCode(c))
    drive_layer.Save()


def visibility_samples(seen: Sequence[float], frames: Sequence[float]) -> list[tuple[float, str]]:
    """The ``visibility`` time samples of a moving object: shown over the frames it was seen in.

    ``visibility`` is a token, so USD holds each sample until the next (no interpolation),
    and before the first sample the first one holds; the samples follow the OpenUSD
    Imageable schema's animated-visibility example (``inherited`` / ``invisible`` at time codes).
    The object is ``invisible`` from the drive's first frame until the first frame it is seen
    in, ``inherited`` from there, and ``invisible`` again from the first frame of the drive
    after the last one it is seen in. Frames between its first and last where it is not seen
    keep it visible, on its motion's interpolated path (a track bridges such a gap).

    Args:
        seen: the time codes of the frames the object is seen in.
        frames: the time codes of all the drive's frames.

    Returns:
        (time code, token) pairs in time order; empty when it is seen in the first and the last frame.

    Example:
        >>> visibility_samples([1.0, 2.0], [0.0, 1.0, 2.0, 3.0])
        [(0.0, 'invisible'), (1.0, 'inherited'), (3.0, 'invisible')]
        >>> visibility_samples([0.0, 3.0], [0.0, 1.0, 2.0, 3.0])
        []
    """
    first, last = min(seen), max(seen)
    begin, end = min(frames), max(frames)
    if first <= begin and last >= end:
        return []
    out: list[tuple[float, str]] = []
    if first > begin:
        out.append((float(begin), str(UsdGeom.Tokens.invisible)))
    out.append((float(first), str(UsdGeom.Tokens.inherited)))
    later = [f for f in frames if f > last]
    if later:
        out.append((float(min(later)), str(UsdGeom.Tokens.invisible)))
    return out
