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

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the names below are loaded on first use (see __getattr__)
    from usdworld.render.camera import CameraPose, camera_from_usd, gl_projection, gl_view
    from usdworld.render.classes import class_label_ids, label_id_for_class, thing_label_ids
    from usdworld.render.context import INSTALL_HINT, RenderError, create_context
    from usdworld.render.instancing import ViewCull
    from usdworld.render.lighting import Lighting, sun_direction
    from usdworld.render.renderer import Renderer, RenderResult
    from usdworld.render.scene import RenderObject, RenderScene

#: Where each public name lives. The package imports a module only when one of its names is
#: first used, so that importing one light module (``usdworld.render.lighting``, which a
#: build reads for the sun) does not load the renderer, the scene reader and their imports.
_HOMES = {
    "CameraPose": "camera",
    "camera_from_usd": "camera",
    "gl_projection": "camera",
    "gl_view": "camera",
    "class_label_ids": "classes",
    "label_id_for_class": "classes",
    "thing_label_ids": "classes",
    "INSTALL_HINT": "context",
    "RenderError": "context",
    "create_context": "context",
    "ViewCull": "instancing",
    "Lighting": "lighting",
    "sun_direction": "lighting",
    "Renderer": "renderer",
    "RenderResult": "renderer",
    "RenderObject": "scene",
    "RenderScene": "scene",
}


def __getattr__(name: str) -> Any:
    """A public name, imported from its module on first use (PEP 562)."""
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{home}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The module's names and the public names not yet loaded."""
    return sorted(set(globals()) | set(__all__))


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
