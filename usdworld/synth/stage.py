"""Author a :class:`~usdworld.synth.scene.SynthScene` as a USD stage.

Layout (Z up, metres, ``defaultPrim = World``)::

    /World                      Xform, kind assembly
      Looks/{Asphalt,Paint,Paving,Grass}   UsdPreviewSurface materials
      Street/Road               Xform, class road: Surface + Markings meshes
      Street/Sidewalks          Xform, class sidewalk: Right + Left meshes
      Street/Terrain            Xform, class terrain: Ground mesh
      Objects                   Scope, kind group
        car_0000 ...            Xform referencing the class asset, variant ``model`` selected,
                                xformOps translate, rotateZ (degrees), scale; class label
      SourceCamera              the scene camera (usdworld.authoring.camera)

Objects are authored in the scene's order, so the renderer's per-class instance counter
``k`` follows that order.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from pxr import Gf, Kind, Sdf, Usd, UsdGeom, UsdSemantics, UsdShade, Vt

from usdworld.authoring.camera import define_camera
from usdworld.synth import ground
from usdworld.synth.placement import SynthObject

if TYPE_CHECKING:
    from usdworld.synth.scene import SynthScene

WORLD = "/World"
OBJECTS = "/World/Objects"
CAMERA = "/World/SourceCamera"

#: Linear RGB of the street surfaces.
SURFACE_COLORS = {
    "Asphalt": (0.085, 0.085, 0.09),
    "Paint": (0.75, 0.75, 0.72),
    "Paving": (0.33, 0.31, 0.29),
    "Grass": (0.10, 0.17, 0.05),
}


def _label(prim: Usd.Prim, name: str) -> None:
    UsdSemantics.LabelsAPI.Apply(prim, "class").CreateLabelsAttr([name])


def _material(stage: Usd.Stage, name: str) -> UsdShade.Material:
    path = f"{WORLD}/Looks/{name}"
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*SURFACE_COLORS[name]))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.9)
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def define_surface_mesh(
    stage: Usd.Stage, path: str, polys: ground.Polys, look: str, label: str
) -> UsdGeom.Mesh:
    """A complete, labelled mesh prim: points, topology, faceVarying normals, extent, colour.

    Args:
        stage: the stage.
        path: prim path of the mesh.
        polys: ``(points (N, 3) float64, face_counts, face_indices)``.
        look: name of the material under ``/World/Looks`` (a key of :data:`SURFACE_COLORS`);
            its diffuse colour is also the displayColor.
        label: semantic ``class`` label.
    """
    points, counts, indices = polys
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(points, dtype=np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray(list(counts)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray(list(indices)))
    normals = []
    start = 0
    for n in counts:
        p = points[indices[start : start + n]]
        fn = np.cross(p[1] - p[0], p[2] - p[0])
        fn = fn / np.linalg.norm(fn)
        normals += [fn] * n
        start += n
    mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(normals, dtype=np.float32)))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.faceVarying)
    mesh.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*SURFACE_COLORS[look])]))
    mesh.CreateExtentAttr(UsdGeom.Boundable.ComputeExtentFromPlugins(mesh, Usd.TimeCode.Default()))
    material = UsdShade.Material(stage.GetPrimAtPath(f"{WORLD}/Looks/{look}"))
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    _label(mesh.GetPrim(), label)
    return mesh


def _asset_reference(asset: Path, stage_path: Path | None) -> str:
    if stage_path is None:
        return asset.resolve().as_posix()
    rel = os.path.relpath(asset.resolve(), stage_path.resolve().parent)
    return Path(rel).as_posix() if rel.startswith("..") else "./" + Path(rel).as_posix()


def define_synth_object(
    stage: Usd.Stage, obj: SynthObject, asset: Path, stage_path: Path | None
) -> UsdGeom.Xform:
    """One object placement: reference, variant, translate / rotateZ / scale ops, class label."""
    xf = UsdGeom.Xform.Define(stage, f"{OBJECTS}/{obj.name}")
    prim = xf.GetPrim()
    prim.GetReferences().AddReference(_asset_reference(asset, stage_path))
    vset = prim.GetVariantSets().GetVariantSet("model")
    if vset:
        vset.SetVariantSelection(obj.variant)
    else:
        prim.GetVariantSets().AddVariantSet("model").SetVariantSelection(obj.variant)
    xf.AddTranslateOp().Set(Gf.Vec3d(*obj.centre_world.tolist()))
    xf.AddRotateZOp().Set(float(math.degrees(obj.yaw)))
    xf.AddScaleOp().Set(Gf.Vec3f(*obj.scale.tolist()))
    _label(prim, obj.class_name)
    return xf


def author_stage(scene: SynthScene, path: str | Path | None = None) -> Usd.Stage:
    """Write ``scene`` as a stage (in memory, or saved at ``path`` with relative asset paths).

    Args:
        scene: the scene.
        path: where to save the stage (``.usda``); None keeps it in memory (absolute asset paths).

    Returns:
        The stage (already saved when ``path`` is given).
    """
    stage_path = Path(path) if path is not None else None
    stage = Usd.Stage.CreateNew(str(stage_path)) if stage_path else Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, WORLD)
    stage.SetDefaultPrim(world.GetPrim())
    Usd.ModelAPI(world.GetPrim()).SetKind(Kind.Tokens.assembly)

    UsdGeom.Scope.Define(stage, f"{WORLD}/Looks")
    for name in SURFACE_COLORS:
        _material(stage, name)
    UsdGeom.Xform.Define(stage, f"{WORLD}/Street")
    street = scene.street
    for group, label in (("Road", "road"), ("Sidewalks", "sidewalk"), ("Terrain", "terrain")):
        _label(UsdGeom.Xform.Define(stage, f"{WORLD}/Street/{group}").GetPrim(), label)
    define_surface_mesh(stage, f"{WORLD}/Street/Road/Surface", ground.road_surface(street), "Asphalt", "road")
    define_surface_mesh(stage, f"{WORLD}/Street/Road/Markings", ground.lane_markings(street), "Paint", "road")
    right, left = ground.sidewalks(street)
    define_surface_mesh(stage, f"{WORLD}/Street/Sidewalks/Right", right, "Paving", "sidewalk")
    define_surface_mesh(stage, f"{WORLD}/Street/Sidewalks/Left", left, "Paving", "sidewalk")
    define_surface_mesh(stage, f"{WORLD}/Street/Terrain/Ground", ground.terrain(street), "Grass", "terrain")

    objects = UsdGeom.Scope.Define(stage, OBJECTS)
    Usd.ModelAPI(objects.GetPrim()).SetKind(Kind.Tokens.group)
    for obj in scene.objects:
        define_synth_object(stage, obj, scene.asset_paths[obj.class_name], stage_path)
    define_camera(stage, CAMERA, scene.camera)
    if stage_path is not None:
        stage.GetRootLayer().Save()
    return stage
