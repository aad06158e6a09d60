"""glTF 2.0 binary (``.glb``) export of a composed world, written with trimesh.

What the file holds:

- one node per USD prim on the way to a mesh (``World``, ``Objects``, ``car_0001``, ``Geom``,
  ``body`` ...), named like the prim, with the prim's local transform; the top nodes also
  carry the change from the stage's up axis and unit to glTF's Y up and metres;
- one glTF mesh per distinct USD mesh (objects that use the same asset variant share it),
  with welded positions and the USD normals (faceVarying normals split vertices at creases);
- one PBR material per USD material: UsdPreviewSurface ``diffuseColor`` -> ``baseColorFactor``
  (both linear), ``metallic``/``roughness`` -> the metallic-roughness factors; meshes without
  a material use their ``displayColor``; materials of one name with different looks (each
  object's paint in the colour of its photo) are numbered ``paint_white``, ``paint_white_1`` ...;
- node ``extras``: ``usdPath`` on every node, and where authored ``kind``, ``semanticLabels``
  (taxonomy -> labels), ``variants`` (set -> selection) and ``usdworld`` (every ``usdworld:*``
  attribute, NaN written as null). The scene's ``extras`` say where the file came from.

- the sun (``/World/Lights/Sun``, a ``UsdLux.DistantLight``) as a ``KHR_lights_punctual``
  directional light on a top node ``Sun`` turned so its -Z shines away from the sun; its
  ``color`` is the light's colour and its ``intensity`` the USD ``intensity * 2**exposure``
  (the renderer's units: 1 lights a white surface facing the sun to white). glTF has no
  ambient light: the sky (the DomeLight) is left out.

Deactivated (deleted) prims, invisible prims, guides and proxies are left out; cameras are
not exported.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdSemantics

import usdworld
from usdworld.authoring.usd_geometry import Look, read_look, read_mesh, renderable_meshes, weld_corners
from usdworld.errors import InputError, OutputError
from usdworld.export.usd_formats import open_world
from usdworld.world_files import SUN_PATH

log = logging.getLogger(__name__)

#: y_up_from_z_up as a column-vector matrix: (x, y, z) Z-up -> (x, z, -y) Y-up.
Y_UP_FROM_Z_UP = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]], dtype=np.float64)


@dataclass(frozen=True)
class GlbSummary:
    """What was written.

    Attributes:
        nodes: glTF nodes.
        mesh_nodes: nodes that hold a mesh (one per USD Mesh prim exported).
        meshes: distinct glTF meshes (shared between instances of one asset variant).
        materials: glTF materials.
    """

    nodes: int
    mesh_nodes: int
    meshes: int
    materials: int


def _json_value(value: Any, single: bool = False) -> Any:
    """A USD attribute value as JSON: lists for vectors, arrays and matrices, None for NaN/inf.

    Args:
        value: the value ``Usd.Attribute.Get`` returned.
        single: the attribute stores 32-bit floats; write the shortest decimal that reads
            back to the same float32 (0.3, not 0.30000001192092896).
    """
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            return None
        return float(str(np.float32(value))) if single else value
    if isinstance(value, (Gf.Matrix2d, Gf.Matrix3d, Gf.Matrix4d, Gf.Matrix2f, Gf.Matrix3f, Gf.Matrix4f)):
        return [[_json_value(float(c), single) for c in row] for row in value]
    if hasattr(value, "__len__") and not isinstance(value, dict):
        return [_json_value(v, single) for v in value]
    try:
        return _json_value(float(value), single)
    except (TypeError, ValueError):
        return str(value)


def _is_single(attr: Usd.Attribute) -> bool:
    """True when the attribute's scalar type is built on 32-bit floats (float, float3, color3f ...)."""
    scalar = attr.GetTypeName().scalarType
    return scalar.type.typeName.startswith(("float", "GfVec2f", "GfVec3f", "GfVec4f", "GfMatrix2f"))


def node_extras(prim: Usd.Prim) -> dict[str, Any]:
    """The ``extras`` of a prim's node: path, kind, semantic labels, variant selections, usdworld values."""
    extras: dict[str, Any] = {"usdPath": str(prim.GetPath())}
    kind = Usd.ModelAPI(prim).GetKind()
    if kind:
        extras["kind"] = str(kind)
    labels = {}
    for taxonomy in UsdSemantics.LabelsAPI.GetDirectTaxonomies(prim):
        attr = UsdSemantics.LabelsAPI(prim, taxonomy).GetLabelsAttr()
        value = attr.Get() if attr else None
        if value is not None:
            labels[str(taxonomy)] = [str(v) for v in value]
    if labels:
        extras["semanticLabels"] = labels
    vsets = prim.GetVariantSets()
    selections = {name: vsets.GetVariantSelection(name) for name in vsets.GetNames() if vsets.GetVariantSelection(name)}
    if selections:
        extras["variants"] = selections
    values = {}
    for attr in prim.GetAttributes():
        name = attr.GetName()
        if name.startswith("usdworld:") and attr.HasAuthoredValue():
            values[name.split(":", 1)[1]] = _json_value(attr.Get(), _is_single(attr))
    if values:
        extras["usdworld"] = values
    return extras


def _matrix(prim: Usd.Prim) -> np.ndarray:
    """(4, 4) float64 local transform of a prim in column-vector form (identity for non-Xformables)."""
    if prim.IsA(UsdGeom.Xformable):
        m = UsdGeom.Xformable(prim).GetLocalTransformation(Usd.TimeCode.Default())
        return np.asarray(m, dtype=np.float64).T
    return np.eye(4)


def _stage_root_matrix(stage: Usd.Stage) -> np.ndarray:
    """(4, 4) gltf_from_stage: up axis to Y and stage units to metres."""
    scale = np.diag([UsdGeom.GetStageMetersPerUnit(stage)] * 3 + [1.0])
    up = UsdGeom.GetStageUpAxis(stage)
    return (Y_UP_FROM_Z_UP if up == UsdGeom.Tokens.z else np.eye(4)) @ scale


def _look_material(look: Look, name: str, double_sided: bool) -> trimesh.visual.material.PBRMaterial:
    alpha = look.opacity
    return trimesh.visual.material.PBRMaterial(
        name=name,
        baseColorFactor=[*look.color, alpha],
        metallicFactor=look.metallic,
        roughnessFactor=look.roughness,
        doubleSided=double_sided,
        alphaMode="BLEND" if alpha < 1.0 else "OPAQUE",
    )


def _material_name(look: Look, looks: dict[str, Look]) -> str:
    """The USD material's name, numbered when a material of that name with another look is
    already exported (each object's paint carries the colour measured in its photo)."""
    base = look.name or "displayColor"
    name, k = base, 1
    while name in looks and looks[name] != look:
        name, k = f"{base}_{k}", k + 1
    return name


def build_scene(stage: Usd.Stage) -> tuple[trimesh.Scene, dict[str, dict[str, Any]], dict[str, Look]]:
    """A trimesh scene of the composed stage.

    Returns:
        The scene (graph node keys are prim paths), node key -> extras, and material
        name -> exact look (trimesh stores base colours as 8-bit; the writer restores them).
    """
    time = Usd.TimeCode.Default()
    meshes = renderable_meshes(stage, time)
    scene = trimesh.Scene(base_frame="__usdworld_root__")
    extras: dict[str, dict[str, Any]] = {}
    looks: dict[str, Look] = {}
    geometry_by_hash: dict[str, str] = {}
    added: set[str] = set()
    root_matrix = _stage_root_matrix(stage)

    def placement(prim: Usd.Prim) -> tuple[str, np.ndarray]:
        """Parent node key (created on the way) and local matrix of a prim's node."""
        parent = prim.GetParent()
        if parent.IsPseudoRoot():
            return str(scene.graph.base_frame), root_matrix @ _matrix(prim)
        return add_node(parent), _matrix(prim)

    def add_node(prim: Usd.Prim) -> str:
        key = str(prim.GetPath())
        if key not in added:
            parent_key, matrix = placement(prim)
            scene.graph.update(frame_to=key, frame_from=parent_key, matrix=matrix)
            extras[key] = node_extras(prim)
            added.add(key)
        return key

    for prim in meshes:
        arrays = read_mesh(UsdGeom.Mesh(prim), time)
        if arrays is None:
            log.debug("%s: no triangles, skipped", prim.GetPath())
            continue
        key = str(prim.GetPath())
        parent_key, matrix = placement(prim)
        look = read_look(prim, time)
        vertices, normals, faces = weld_corners(arrays.points[arrays.triangles], arrays.corner_normals)
        digest = hashlib.sha1()
        for part in (vertices, normals, faces):
            digest.update(np.ascontiguousarray(part).tobytes())
        digest.update(repr((look, arrays.double_sided)).encode())
        geom_key = geometry_by_hash.get(digest.hexdigest())
        if geom_key is None:
            geom_key = geometry_by_hash[digest.hexdigest()] = key
            mesh = trimesh.Trimesh(
                vertices=vertices, faces=faces, vertex_normals=normals, process=False, validate=False
            )
            material = _look_material(look, _material_name(look, looks), arrays.double_sided)
            looks[material.name] = look
            mesh.visual = trimesh.visual.TextureVisuals(material=material)
            scene.add_geometry(
                mesh, node_name=key, geom_name=geom_key, parent_node_name=parent_key, transform=matrix
            )
        else:
            scene.graph.update(frame_to=key, frame_from=parent_key, matrix=matrix, geometry=geom_key)
        extras[key] = node_extras(prim)
        added.add(key)
    return scene, extras, looks


def _postprocess(tree: dict[str, Any], extras: dict[str, dict[str, Any]], looks: dict[str, Look], source: str) -> None:
    """Name nodes and meshes like their prims, attach extras, restore exact base colours."""
    for node in tree.get("nodes", []):
        key = node.get("name", "")
        if key in extras:
            node["extras"] = extras[key]
            node["name"] = key.rsplit("/", 1)[-1]
    for mesh in tree.get("meshes", []):
        name = mesh.get("name", "")
        mesh["name"] = name.rsplit("/", 1)[-1]
        mesh.pop("extras", None)
    for material in tree.get("materials", []):
        look = looks.get(material.get("name", ""))
        if look is not None:
            material.setdefault("pbrMetallicRoughness", {})["baseColorFactor"] = [*look.color, look.opacity]
    # tell loaders which buffer views hold vertex attributes and which hold indices
    views = tree.get("bufferViews", [])
    accessors = tree.get("accessors", [])
    for mesh in tree.get("meshes", []):
        for primitive in mesh.get("primitives", []):
            for acc in primitive.get("attributes", {}).values():
                view = accessors[acc].get("bufferView")
                if view is not None:
                    views[view]["target"] = 34962  # ARRAY_BUFFER
            if "indices" in primitive:
                view = accessors[primitive["indices"]].get("bufferView")
                if view is not None:
                    views[view]["target"] = 34963  # ELEMENT_ARRAY_BUFFER
    tree["asset"]["generator"] = f"usdworld {usdworld.__version__} (trimesh {trimesh.__version__})"
    tree["scenes"][0]["extras"] = {
        "usdworld": {"source": source, "sourceUpAxis": "Z", "units": "metres", "version": usdworld.__version__}
    }


def sun_light(stage: Usd.Stage) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """The world's sun as a ``KHR_lights_punctual`` light and the node that holds it.

    Returns:
        (light, node) in glTF's frame (the node's rotation quaternion is x, y, z, w), or
        None when the world has no active sun.
    """
    prim = stage.GetPrimAtPath(SUN_PATH)
    if not (prim and prim.IsActive() and prim.IsA(UsdLux.DistantLight)):
        return None
    light = UsdLux.LightAPI(prim)
    colour = [float(c) for c in (light.GetColorAttr().Get() or (1.0, 1.0, 1.0))]
    intensity = float(light.GetIntensityAttr().Get() or 0.0) * 2.0 ** float(light.GetExposureAttr().Get() or 0.0)
    world = np.asarray(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default()), dtype=np.float64).T
    towards_sun = _stage_root_matrix(stage)[:3, :3] @ world[:3, 2]
    towards_sun /= np.linalg.norm(towards_sun)
    q = Gf.Rotation(Gf.Vec3d(0.0, 0.0, 1.0), Gf.Vec3d(*towards_sun.tolist())).GetQuat()
    rotation = [*(float(v) for v in q.GetImaginary()), float(q.GetReal())]
    return (
        {"type": "directional", "name": "Sun", "color": colour, "intensity": intensity},
        {"name": "Sun", "rotation": rotation, "extras": {"usdPath": SUN_PATH}},
    )


def add_sun(tree: dict[str, Any], sun: tuple[dict[str, Any], dict[str, Any]] | None) -> None:
    """Add the sun light (:func:`sun_light`) to a glTF tree as ``KHR_lights_punctual``."""
    if sun is None:
        return
    light, node = sun
    tree.setdefault("extensions", {})["KHR_lights_punctual"] = {"lights": [light]}
    used = tree.setdefault("extensionsUsed", [])
    if "KHR_lights_punctual" not in used:
        used.append("KHR_lights_punctual")
    nodes = tree.setdefault("nodes", [])
    nodes.append({**node, "extensions": {"KHR_lights_punctual": {"light": 0}}})
    tree["scenes"][0].setdefault("nodes", []).append(len(nodes) - 1)


def write_glb(root: Path, out: Path) -> tuple[list[Path], GlbSummary]:
    """Write the composed world as a ``.glb``.

    Args:
        root: the world's root layer.
        out: the ``.glb`` file to write.

    Returns:
        ``[out]`` and a summary of what was written.

    Raises:
        InputError: wrong file name, or the world has no mesh to export.
    """
    if out.suffix != ".glb":
        raise InputError(f"{out}: the glb format needs a '.glb' file name")
    stage = open_world(root)
    scene, extras, looks = build_scene(stage)
    if not scene.geometry:
        raise InputError(f"{root}: no visible mesh to export")
    source = root.name
    up = str(UsdGeom.GetStageUpAxis(stage))
    summary: dict[str, int] = {}
    sun = sun_light(stage)

    def post(tree: dict[str, Any]) -> None:
        _postprocess(tree, extras, looks, source)
        add_sun(tree, sun)
        tree["scenes"][0]["extras"]["usdworld"]["sourceUpAxis"] = up
        summary["nodes"] = len(tree.get("nodes", []))
        summary["mesh_nodes"] = sum(1 for n in tree.get("nodes", []) if "mesh" in n)
        summary["meshes"] = len(tree.get("meshes", []))
        summary["materials"] = len(tree.get("materials", []))

    data = trimesh.exchange.gltf.export_glb(scene, include_normals=True, tree_postprocessor=post)
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{out.stem}-", suffix=".glb", dir=out.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp_name, 0o666 & ~mask)
        os.replace(tmp_name, out)
    except OSError as exc:
        Path(tmp_name).unlink(missing_ok=True)
        raise OutputError(f"{out}: could not be written ({exc})") from exc
    return [out], GlbSummary(**summary)


def read_glb_json(path: Path) -> dict[str, Any]:
    """The JSON chunk of a ``.glb`` file (for checks and tests).

    Raises:
        InputError: not a glTF binary file.
    """
    data = Path(path).read_bytes()
    if len(data) < 20 or data[:4] != b"glTF":
        raise InputError(f"{path}: not a glTF binary (.glb) file")
    length = int.from_bytes(data[12:16], "little")
    if data[16:20] != b"JSON":
        raise InputError(f"{path}: first chunk is not JSON")
    return json.loads(data[20 : 20 + length])


__all__ = ["GlbSummary", "add_sun", "build_scene", "node_extras", "read_glb_json", "sun_light", "write_glb"]
