"""Recolouring an object: which of its materials and meshes take the colour, and how.

``restyle`` authors ``inputs:diffuseColor`` of the object's own paint materials
(UsdPreviewSurface: usdworld's renderer, usdview/Storm, Omniverse, Blender, Unity and
Unreal importers) and ``primvars:displayColor`` of the meshes bound to them (viewers that
show display colours); the colour is recorded in the prim's customData
:data:`COLOR_KEY` and re-applied after a replacement. Without a restyle, a replacement by
another variant re-applies the photo's colour (:func:`apply_photo_colour`), which the base
layer authors on the built variant's paint only.
"""

from __future__ import annotations

import re
from fnmatch import fnmatch
from typing import TYPE_CHECKING

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

from usdworld.errors import EditRefused, RefusalReason
from usdworld.perception.colour_space import srgb_to_linear

if TYPE_CHECKING:
    from pxr import UsdShade

#: Prim customData key holding an object's restyle colour (``#rrggbb``).
COLOR_KEY = "usdworld:restyleColor"
#: Material names recoloured by ``restyle`` (fnmatch patterns), in priority order of
#: meaning: vehicle paint, frames, clothing, foliage, walls. When an asset has none of
#: them, all its materials are recoloured.
RESTYLE_MATERIALS = (
    "paint_*",
    "body*",
    "frame_*",
    "jacket",
    "shirt",
    "helmet",
    "leaves",
    "needles",
    "wall",
    "curtain_wall",
    "housing",
    "sign_blue",
    "cardboard",
)
_HEX = re.compile(r"^#?([0-9a-fA-F]{6}|[0-9a-fA-F]{3})$")


def parse_color(text: str) -> tuple[tuple[float, float, float], str]:
    """An sRGB hex colour -> (linear RGB, normalised ``#rrggbb``).

    Raises:
        EditRefused: ``bad_value`` (field ``color``): not ``#rrggbb`` or ``#rgb``.
    """
    m = _HEX.match(text.strip())
    if not m:
        raise EditRefused(
            RefusalReason.BAD_VALUE,
            f"color: expected a hex colour like '#c03030', got '{text}'",
            op="restyle",
            field="color",
            value=text,
        )
    h = m.group(1).lower()
    if len(h) == 3:
        h = "".join(c * 2 for c in h)
    srgb = np.array([int(h[i : i + 2], 16) / 255.0 for i in (0, 2, 4)])
    lin = srgb_to_linear(srgb)
    return (float(lin[0]), float(lin[1]), float(lin[2])), f"#{h}"


def restyle_targets(prim: Usd.Prim) -> tuple[list[UsdShade.Material], list[UsdGeom.Mesh]]:
    """The materials a restyle recolours (:data:`RESTYLE_MATERIALS`, else all) and the meshes bound to them."""
    from pxr import UsdShade  # with Sdr, ~10 ms: only an edit of materials needs it

    materials = [UsdShade.Material(p) for p in Usd.PrimRange(prim) if p.IsA(UsdShade.Material)]
    chosen = [
        m for m in materials if any(fnmatch(m.GetPrim().GetName(), pat) for pat in RESTYLE_MATERIALS)
    ] or materials
    chosen_paths = {m.GetPath() for m in chosen}
    meshes = []
    for p in Usd.PrimRange(prim):
        if p.IsA(UsdGeom.Mesh):
            bound = UsdShade.MaterialBindingAPI(p).ComputeBoundMaterial()[0]
            if (bound and bound.GetPath() in chosen_paths) or not materials:
                meshes.append(UsdGeom.Mesh(p))
    return chosen, meshes


def apply_restyle(prim: Usd.Prim, color_hex: str) -> None:
    """Author the colour on the prim's targets and record it (in the current edit target)."""
    linear, hexed = parse_color(color_hex)
    materials, meshes = restyle_targets(prim)
    author_colour(materials, meshes, linear)
    prim.SetCustomDataByKey(COLOR_KEY, hexed)


def author_colour(
    materials: list[UsdShade.Material], meshes: list[UsdGeom.Mesh], linear: tuple[float, float, float]
) -> None:
    """Author a linear colour as the materials' ``diffuseColor`` and the meshes' ``displayColor``
    (in the current edit target)."""
    for m in materials:
        shader, _, _ = m.ComputeSurfaceSource()
        if shader and shader.GetPrim().IsValid():
            shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*linear))
    for mesh in meshes:
        mesh.CreateDisplayColorAttr().Set(Vt.Vec3fArray([Gf.Vec3f(*linear)]))


def apply_photo_colour(prim: Usd.Prim) -> bool:
    """Author an object's photo colour (its ``usdworld:albedo``) on the paint materials of its
    current variant, in the current edit target: what ``replace`` does after selecting
    another variant, whose paint the base layer has no colour for.

    Args:
        prim: the object.

    Returns:
        True when the object has a photo colour (and it was authored).
    """
    attr = prim.GetAttribute("usdworld:albedo")
    albedo = attr.Get() if attr and attr.HasAuthoredValue() else None
    if albedo is None:
        return False
    author_colour(restyle_targets(prim)[0], [], (float(albedo[0]), float(albedo[1]), float(albedo[2])))
    return True


def clear_restyle(edits: Sdf.Layer, prim: Usd.Prim) -> None:
    """Remove the opinions the edits layer holds below the object (its restyle)."""
    spec = edits.GetPrimAtPath(prim.GetPath())
    if spec:
        for child in list(spec.nameChildren.keys()):
            del spec.nameChildren[child]
