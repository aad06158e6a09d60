"""Headless OpenGL rendering of composed USD stages (moderngl over EGL).

Public API:

* :class:`RenderScene` (``RenderScene.from_stage(stage)``): the triangles, colours and
  Cityscapes class / instance ids of a composed stage; ``cull=ViewCull(...)`` leaves out
  the objects a view cannot see nor receive shadows from (:class:`ViewCull`).
* :class:`Renderer` (``with Renderer(w, h) as r: r.render(scene, K, world_from_cam)``)
  -> :class:`RenderResult` (rgb, class_ids, instance_ids, object_ids, depth_m).
* :func:`camera_from_usd`: K and pose of a ``UsdGeom.Camera`` prim.
* :class:`Lighting`, :func:`sun_direction`: sun, ambient, sky and shadow settings.
* :class:`RenderError`: no usable OpenGL; the message says which packages to install.
"""

from __future__ import annotations

from usdworld.render.camera import CameraPose, camera_from_usd, gl_projection, gl_view
from usdworld.render.classes import class_label_ids, label_id_for_class, thing_label_ids
from usdworld.render.context import INSTALL_HINT, RenderError, create_context
from usdworld.render.instancing import ViewCull
from usdworld.render.lighting import Lighting, sun_direction
from usdworld.render.renderer import Renderer, RenderResult
from usdworld.render.scene import RenderObject, RenderScene

__all__ = [
    "INSTALL_HINT",
    "CameraPose",
    "Lighting",
    "RenderError",
    "RenderObject",
    "RenderResult",
    "RenderScene",
    "Renderer",
    "ViewCull",
    "camera_from_usd",
    "class_label_ids",
    "create_context",
    "gl_projection",
    "gl_view",
    "label_id_for_class",
    "sun_direction",
    "thing_label_ids",
]
