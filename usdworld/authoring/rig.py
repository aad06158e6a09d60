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
  ``usdworld:fusionMethod`` (``single``, ``fused`` or ``triangulated``).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

from usdworld.authoring.camera import define_camera, world_from_usdcam
from usdworld.world_files import BASE_LAYER, CAMERA_PATH, OBJECTS_PATH, WORLD_PATH

if TYPE_CHECKING:  # annotations only: ``render --camera`` imports this module, and layout's imports cost it
    from usdworld.geometry.camera import PinholeCamera
    from usdworld.layout.model import WorldModel
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
) -> None:
    """Add the rig's cameras and the multi-view provenance to a written world's base layer.

    Args:
        out_dir: the world folder (:func:`~usdworld.authoring.world.write_world` wrote it).
        views: the views, in order.
        view_models: each view's own world (its camera, in its ground frame).
        world_from_ground: each view's (4, 4) float64 ground frame in the world.
        objects: the fused objects, named as the world's objects.
    """
    stage = Usd.Stage.Open(str(Path(out_dir) / BASE_LAYER), Usd.Stage.LoadNone)
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
    for obj in objects:
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
