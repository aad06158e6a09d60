"""Write a :class:`~usdworld.layout.model.WorldModel` as a layered USD world in a folder.

Layout of the folder::

    world.usda          root: subLayers = [layers/edits.usda, layers/base.usda], Z up, metres
    layers/base.usda    /World (assembly) with Objects, Ground (a reference), SourceCamera and
                        Lights (a DistantLight sun and a DomeLight sky, from the photo);
                        layers/base.usdc instead (USD's binary crate format) in a world of
                        at least AuthoringParams.large_world_min_objects objects
    layers/ground.usdc  /Ground: road and sidewalk meshes with their materials (binary:
                        long arrays in text layers are a performance error for Omniverse)
    layers/edits.usda   the user's edits (empty until edited)
    assets/<class>.usda the class assets the world references (relative paths)

Nothing written depends on the time or on absolute paths, so the same model gives
byte-identical layers.
"""

from __future__ import annotations

import math
import os
import shutil
import uuid
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from pxr import Gf, Kind, Sdf, Usd, UsdGeom, UsdSemantics, UsdShade, UsdUtils, Vt

import usdworld
from usdworld.authoring.appearance import define_appearances
from usdworld.authoring.asset_cards import card_path
from usdworld.authoring.camera import define_camera
from usdworld.authoring.lights import define_lights
from usdworld.authoring.provenance import (
    PROVENANCE_API,
    SCENE_API,
    apply_with_values,
    author_values,
    prepend_api_schema,
)
from usdworld.errors import AuthoringError
from usdworld.parameters.authoring import AuthoringParams
from usdworld.world_files import (  # re-exported: the names of what this module writes
    ASSETS_DIR,
    BASE_CRATE_LAYER,
    BASE_LAYER,
    CAMERA_PATH,
    EDITS_LAYER,
    GROUND_LAYER,
    GROUND_PATH,
    OBJECTS_PATH,
    ROOT_LAYER,
    WORLD_PATH,
)

if TYPE_CHECKING:  # annotations only: the editor imports this module, and layout's imports cost it 0.2 s
    from usdworld.authoring.editing.index import Opinions
    from usdworld.layout.model import WorldModel
    from usdworld.layout.placement import Placement
    from usdworld.layout.surfaces import SurfaceMesh


#: Colours of the ground surfaces (linear RGB) and their semantic class.
SURFACE_LOOKS = {"road": (0.09, 0.09, 0.1), "sidewalk": (0.45, 0.43, 0.4), "terrain": (0.16, 0.2, 0.1)}


#: The ops every object's transform is made of, in order.
_XFORM_OP_ORDER = ["xformOp:translate", "xformOp:rotateZ", "xformOp:scale"]
#: The semantic labels API instance and attribute of the ``class`` taxonomy.
_LABELS_API = "SemanticsLabelsAPI:class"
_LABELS_ATTR = "semantics:labels:class"


def _set_stage_metadata(stage: Usd.Stage) -> None:
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)


def _label(prim: Usd.Prim, label: str) -> None:
    UsdSemantics.LabelsAPI.Apply(prim, "class").CreateLabelsAttr([label])


def _preview_material(stage: Usd.Stage, path: str, color: tuple[float, float, float]) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.9)
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def define_surface(stage: Usd.Stage, parent: str, surface: SurfaceMesh) -> UsdGeom.Mesh:
    """Author one ground surface mesh with flat normals, extent, colour, material and label.

    Args:
        stage: the stage to write into.
        parent: path of the prim that holds the surfaces (``Looks`` go under it too).
        surface: the mesh in world coordinates.

    Returns:
        The mesh schema object.
    """
    name = surface.name.capitalize()
    color = SURFACE_LOOKS[surface.name]
    mesh = UsdGeom.Mesh.Define(stage, f"{parent}/{name}")
    points = surface.points_world.astype(np.float32)
    faces = surface.faces
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(faces), 3, dtype=np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(faces.astype(np.int32).ravel()))
    a, b, c = (surface.points_world[faces[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(np.repeat(normals, 3, axis=0).astype(np.float32)))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.faceVarying)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreateDoubleSidedAttr(False)
    lo, hi = points.min(axis=0), points.max(axis=0)
    mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*lo.tolist()), Gf.Vec3f(*hi.tolist())]))
    mesh.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*color)]))
    material = _preview_material(stage, f"{parent}/Looks/{name}", color)
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    _label(mesh.GetPrim(), surface.name)
    return mesh


def _nan_if_none(value: float | None) -> float:
    return float("nan") if value is None else float(value)


def define_objects(
    layer: Sdf.Layer, placements: Sequence[Placement], asset_refs: dict[str, str], image_name: str
) -> None:
    """Author the placed objects under ``/World/Objects``: each a reference to its class asset,
    with its model variant, transform, class label and provenance.

    Written straight into the layer through Sdf, in one change block: no stage composes
    the objects while they are written (a stage open on the layer recomposes once, at the
    end). The layer's text is what the Usd schema calls write (``Xform``, ``translate`` /
    ``rotateZ`` / ``scale`` ops, ``SemanticsLabelsAPI:class``, ``UsdWorldProvenanceAPI``);
    parents missing from the layer are created as ``over``.

    Args:
        layer: the base layer.
        placements: where and how the objects are placed.
        asset_refs: class name -> relative path of the class asset from the base layer.
        image_name: source image file name.

    Raises:
        AuthoringError: an object name that is no valid prim name, or a class without an asset.
    """
    for placement in placements:
        if not Sdf.Path.IsValidIdentifier(placement.name):
            raise AuthoringError(f"invalid object name '{placement.name}'")
        if placement.obj.class_name not in asset_refs:
            raise AuthoringError(f"{placement.name}: no asset for class '{placement.obj.class_name}'")
    objects = Sdf.Path(OBJECTS_PATH)
    with Sdf.ChangeBlock():
        Sdf.CreatePrimInLayer(layer, objects)
        for placement in placements:
            spec = Sdf.CreatePrimInLayer(layer, objects.AppendChild(placement.name))
            spec.specifier = Sdf.SpecifierDef
            spec.typeName = "Xform"
            _define_object_opinions(spec, placement, image_name)
            spec.referenceList.Prepend(Sdf.Reference(asset_refs[placement.obj.class_name]))
            spec.variantSelections["model"] = placement.variant


def _attribute(spec: Sdf.PrimSpec, name: str, type_name: Sdf.ValueTypeName, value: object, *, uniform: bool = False) -> None:
    variability = Sdf.VariabilityUniform if uniform else Sdf.VariabilityVarying
    Sdf.AttributeSpec(spec, name, type_name, variability, declaresCustom=False).default = value


def _define_object_opinions(spec: Sdf.PrimSpec, placement: Placement, image_name: str) -> None:
    """One object's own opinions: transform ops, class label and provenance."""
    p = placement.position_world
    s = float(placement.scale) * np.asarray(placement.stretch, dtype=np.float64)
    names = Sdf.ValueTypeNames
    _attribute(spec, "xformOp:translate", names.Double3, Gf.Vec3d(float(p[0]), float(p[1]), float(p[2])))
    _attribute(spec, "xformOp:rotateZ", names.Float, float(round(math.degrees(placement.yaw), 6)))
    _attribute(spec, "xformOp:scale", names.Float3, Gf.Vec3f(*(float(v) for v in s)))
    _attribute(spec, "xformOpOrder", names.TokenArray, _XFORM_OP_ORDER, uniform=True)
    prepend_api_schema(spec, _LABELS_API)
    _attribute(spec, _LABELS_ATTR, names.TokenArray, [placement.obj.class_name])
    obj = placement.obj
    cues = placement.cues
    author_values(
        spec,
        PROVENANCE_API,
        {
            "usdworld:sourceImage": image_name,
            "usdworld:sourceClass": obj.source_label,
            "usdworld:instanceId": int(obj.instance_id),
            "usdworld:imageBBox": Gf.Vec4f(*(float(b) for b in obj.box_px)),
            "usdworld:groundContactPixel": Gf.Vec2f(*(float(c) for c in obj.contact_px)),
            "usdworld:maskArea": int(obj.mask_area),
            "usdworld:bottomTruncated": bool(obj.bottom_truncated),
            "usdworld:bottomOccluded": bool(obj.bottom_occluded),
            "usdworld:depth": float(placement.depth_m),
            "usdworld:depthMethod": placement.depth_method,
            "usdworld:depthCueNames": [c.name for c in cues],
            "usdworld:depthCueValues": [_nan_if_none(c.depth_m) for c in cues],
            "usdworld:depthCueSigmas": [_nan_if_none(c.sigma_m) for c in cues],
            "usdworld:scaleFactor": float(placement.scale),
            "usdworld:scaleMeasured": float(placement.scale_measured),
            "usdworld:yawSource": placement.yaw_source,
            "usdworld:collisionDisplacement": Gf.Vec2f(*(float(d) for d in placement.collision_displacement)),
            "usdworld:confidence": float(placement.confidence),
        },
    )


def _scene_values(model: WorldModel) -> dict:
    cam = model.camera.camera
    fit = model.ground_fit
    return {
        "usdworld:version": usdworld.__version__,
        "usdworld:sourceImage": model.image_name,
        "usdworld:imageSize": Gf.Vec2i(*model.image_size),
        "usdworld:intrinsics": Gf.Matrix3d(*cam.K.ravel().tolist()),
        "usdworld:intrinsicsEstimated": "K" in model.camera.estimated,
        "usdworld:cameraHeight": float(cam.height_m),
        "usdworld:cameraPitch": float(cam.pitch),
        "usdworld:cameraRoll": float(cam.roll),
        "usdworld:cameraYaw": float(cam.yaw),
        "usdworld:cameraEstimated": list(model.camera.estimated),
        "usdworld:cameraMethod": model.camera.method,
        "usdworld:homography": Gf.Matrix3d(*fit.dst_from_src.ravel().tolist()),
        "usdworld:dltPixels": fit.src.ravel().tolist(),
        "usdworld:dltGround": fit.dst.ravel().tolist(),
        "usdworld:dltRmsPx": float(fit.rms_src),
        "usdworld:dltSource": model.dlt_source,
        "usdworld:depthSource": model.depth_source,
        "usdworld:depthKind": model.depth_kind,
        "usdworld:depthAlignment": model.depth_alignment,
        "usdworld:depthAlignmentFit": Gf.Vec4f(*(float(v) for v in model.depth_fit)),
        "usdworld:inputFiles": [f"{f.role}={f.name}" for f in model.inputs],
        "usdworld:inputHashes": [f.sha256 for f in model.inputs],
    }


def write_base_layer(
    model: WorldModel,
    path: Path,
    asset_refs: dict[str, str],
    asset_sources: dict[str, tuple[Path, ...]] | None = None,
) -> None:
    """Write ``layers/base.usda`` (or any layer file: its extension picks the format).

    Args:
        model: the world.
        path: file to write.
        asset_refs: class name -> asset path relative to the base layer.
        asset_sources: asset path relative to the base layer -> the library asset's files it
            copies (:func:`asset_dependencies`), so its paint is looked up once per process
            (:func:`~usdworld.authoring.appearance.define_appearances`); None to look each up.
    """
    layer = Sdf.Layer.CreateNew(str(path))
    stage = Usd.Stage.Open(layer)
    _set_stage_metadata(stage)
    world = UsdGeom.Xform.Define(stage, WORLD_PATH)
    stage.SetDefaultPrim(world.GetPrim())
    Usd.ModelAPI(world.GetPrim()).SetKind(Kind.Tokens.assembly)
    apply_with_values(world.GetPrim(), SCENE_API, _scene_values(model))
    objects = UsdGeom.Scope.Define(stage, OBJECTS_PATH)
    Usd.ModelAPI(objects.GetPrim()).SetKind(Kind.Tokens.group)
    if model.surfaces:
        ground = UsdGeom.Xform.Define(stage, GROUND_PATH)
        ground.GetPrim().GetReferences().AddReference(f"./{Path(GROUND_LAYER).name}")
    define_camera(stage, CAMERA_PATH, model.camera.camera)
    if model.lights is not None:
        define_lights(stage, model.lights, model.light)
    del stage  # the objects go straight into the layer; no stage composes them
    define_objects(layer, model.placements, asset_refs, model.image_name)
    if model.appearances:
        # The colour overrides land on the referenced assets' materials, found in each
        # asset's own stage (and the ground layer's): no stage composes the world.
        define_appearances(layer, model.appearances, asset_sources)
    layer.Save()


def base_layer_name(n_objects: int, params: AuthoringParams) -> str:
    """Where a world's base layer goes, relative to the world folder.

    Args:
        n_objects: the objects the world places.
        params: the authoring parameters (:attr:`AuthoringParams.large_world_min_objects`).

    Returns:
        :data:`BASE_CRATE_LAYER` (binary) for a world of at least ``large_world_min_objects``
        objects, else :data:`BASE_LAYER` (text).
    """
    return BASE_CRATE_LAYER if n_objects >= params.large_world_min_objects else BASE_LAYER


def write_base_crate_layer(
    model: WorldModel,
    path: Path,
    asset_refs: dict[str, str],
    asset_sources: dict[str, tuple[Path, ...]] | None = None,
) -> None:
    """Write the base layer in the crate format, atomically: to a temporary ``.usdc`` name in
    the same folder (the extension picks the format), then renamed onto ``path``.

    Args:
        model: the world.
        path: the ``.usdc`` file to write.
        asset_refs: class name -> asset path relative to the base layer.
        asset_sources: as for :func:`write_base_layer`.
    """
    path = Path(path)
    # a fresh name, not a file made by mkstemp: Sdf creates it with the umask's permissions
    tmp = path.with_name(f".{path.stem}.tmp-{uuid.uuid4().hex[:12]}.usdc")
    try:
        write_base_layer(model, tmp, asset_refs, asset_sources)
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def object_opinions(placements: Sequence[Placement], asset_refs: dict[str, str]) -> Opinions:
    """The opinions :func:`define_objects` writes on the objects, as the editor's index reads
    them from the layer (:func:`~usdworld.authoring.editing.index.read_opinions`).

    Args:
        placements: the objects, in the order they are written.
        asset_refs: class name -> the asset path each object's reference names.

    Returns:
        Their names; translate x, y ((N, 2) float64); scale x, y ((N, 2) float64, rounded to
        float32 as the float3 attribute stores it); class label; ``model`` variant; no
        ``active`` opinion; translate z, scale z and rotateZ ((N, 3) float64); the asset path; plain
        (every object is one ``def`` of only these opinions and its provenance).
    """
    from usdworld.authoring.editing.index import Opinions  # large worlds only: not with the module

    n = len(placements)
    position = np.array([p.position_world[:3] for p in placements], dtype=np.float64).reshape(n, 3)
    factor = np.array([float(p.scale) for p in placements], dtype=np.float64)
    stretch = np.array([p.stretch for p in placements], dtype=np.float64).reshape(n, -1)
    scale = (factor[:, None] * stretch[:, :3]).astype(np.float32).astype(np.float64).reshape(n, 3)
    # the float rotateZ attribute's value, as _define_object_opinions writes it
    yaw = np.array([round(math.degrees(p.yaw), 6) for p in placements], dtype=np.float32).astype(np.float64)
    return Opinions(
        tuple(p.name for p in placements),
        np.ones(n, dtype=bool),
        position[:, :2].copy(),
        scale[:, :2].copy(),
        tuple(p.obj.class_name for p in placements),
        tuple(p.variant for p in placements),
        (None,) * n,
        np.column_stack([position[:, 2], scale[:, 2], yaw]).reshape(n, 3),
        tuple(asset_refs[p.obj.class_name] for p in placements),
        np.ones(n, dtype=bool),
    )


def write_object_index(placements: Sequence[Placement], base: Path, asset_refs: dict[str, str]) -> None:
    """Write the editor's object index beside a world's base layer, keyed by that layer
    (:mod:`usdworld.authoring.editing.index_file`).

    Args:
        placements: the objects the base layer holds, in its order.
        base: the base layer file, already written; the file is valid while the root stacks
            only the edits layer on it (a rig's drive layer makes the editor read it again).
        asset_refs: class name -> the asset path the base layer's references name.
    """
    from usdworld.authoring.editing.index_file import INDEX_FILE, layers_key, save_opinions

    save_opinions(base.parent / INDEX_FILE, object_opinions(placements, asset_refs), layers_key([base]))


def write_ground_layer(model: WorldModel, path: Path) -> None:
    """Write ``layers/ground.usdc``: ``/Ground`` holding the road and sidewalk meshes."""
    stage = Usd.Stage.CreateNew(str(path))
    _set_stage_metadata(stage)
    root = UsdGeom.Xform.Define(stage, "/Ground")
    stage.SetDefaultPrim(root.GetPrim())
    UsdGeom.Scope.Define(stage, "/Ground/Looks")
    for surface in model.surfaces:
        define_surface(stage, "/Ground", surface)
    stage.GetRootLayer().Save()


def write_root_layer(path: Path, base: str = BASE_LAYER) -> None:
    """Write ``world.usda``: sublayers, units, up axis and default prim.

    Args:
        path: file to write.
        base: the base layer, relative to the world folder (:func:`base_layer_name`).
    """
    layer = Sdf.Layer.CreateNew(str(path))
    layer.subLayerPaths.append(f"./{EDITS_LAYER}")
    layer.subLayerPaths.append(f"./{base}")
    layer.defaultPrim = WORLD_PATH.strip("/")
    # The metadata UsdGeom.SetStageUpAxis / SetStageMetersPerUnit author, set on the layer:
    # a stage opened here would compose the whole world just to write two fields.
    layer.pseudoRoot.SetInfo(UsdGeom.Tokens.upAxis, UsdGeom.Tokens.z)
    layer.pseudoRoot.SetInfo(UsdGeom.Tokens.metersPerUnit, 1.0)
    layer.Save()


def write_edits_layer(path: Path) -> None:
    """Write an empty ``layers/edits.usda``."""
    layer = Sdf.Layer.CreateNew(str(path))
    layer.Save()


#: Most assets whose dependencies :func:`asset_dependencies` remembers (a library holds a few dozen).
_MAX_REMEMBERED_ASSETS = 256
#: Resolved asset root -> (each dependency's (mtime_ns, size), the dependencies).
_DEPENDENCIES: dict[Path, tuple[tuple[tuple[int, int], ...], tuple[Path, ...]]] = {}


def _stamp(path: Path) -> tuple[int, int]:
    status = path.stat()
    return status.st_mtime_ns, status.st_size


def asset_dependencies(src: Path) -> tuple[Path, ...]:
    """Every file an asset needs: its root layer, the layers it composes and their assets (resolved).

    ``UsdUtils.ComputeAllDependencies`` parses every layer; its answer is remembered per
    asset, with each file's modification time and size, and given again while none of the
    files has changed (a process building many worlds, a batch worker, parses the library's
    assets once). An edit to any of the files changes its stamp, so the asset is read again;
    at most ``_MAX_REMEMBERED_ASSETS`` assets are remembered.

    Args:
        src: the asset's root layer, resolved.

    Returns:
        The files, the root layer first.

    Raises:
        AuthoringError: a dependency that does not resolve.
    """
    remembered = _DEPENDENCIES.get(src)
    if remembered is not None:
        stamps, deps = remembered
        try:
            if tuple(_stamp(d) for d in deps) == stamps:
                return deps
        except OSError:
            pass  # a file went away: read the asset again (and say what is missing)
    layers, assets, unresolved = UsdUtils.ComputeAllDependencies(Sdf.AssetPath(str(src)))
    if unresolved:
        raise AuthoringError(f"{src}: unresolved dependencies {', '.join(unresolved)}; fix the asset library")
    deps = tuple(Path(p).resolve() for p in [layer.realPath or layer.identifier for layer in layers] + list(assets))
    if len(_DEPENDENCIES) >= _MAX_REMEMBERED_ASSETS:
        _DEPENDENCIES.pop(next(iter(_DEPENDENCIES)))
    _DEPENDENCIES[src] = (tuple(_stamp(d) for d in deps), deps)
    return deps


def copy_asset(src: Path, dst_dir: Path) -> Path:
    """Copy an asset and every layer it depends on (sublayers, references) into a folder.

    Dependencies must sit beside the asset or below its folder, so relative paths
    inside the asset stay valid after the copy. The asset's card
    (:mod:`usdworld.authoring.asset_cards`) goes with it when it has one, so whoever edits
    the world reads the asset's sizes and measures without measuring it again.

    Args:
        src: the asset's root layer.
        dst_dir: destination folder.

    Returns:
        The copied root layer.
    """
    src = Path(src).resolve()
    for dep in asset_dependencies(src):
        try:
            rel = dep.relative_to(src.parent)
        except ValueError as exc:
            raise AuthoringError(f"{src}: depends on {dep} outside its folder; keep asset files together") from exc
        target = dst_dir / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(dep, target)
    card = card_path(src)
    if card.is_file():
        shutil.copyfile(card, dst_dir / card.name)
    return dst_dir / src.name


def write_world(
    model: WorldModel,
    out_dir: Path,
    asset_files: dict[str, Path],
    keep_edits: Path | None,
    params: AuthoringParams = AuthoringParams(),
) -> None:
    """Write the whole world folder (which must be new and empty).

    Args:
        model: the world.
        out_dir: the folder to fill.
        asset_files: class name -> library asset file to copy into ``assets/``.
        keep_edits: an existing edits layer to carry over instead of an empty one.
        params: how the layers are written (the base layer's format, :func:`base_layer_name`).
    """
    (out_dir / "layers").mkdir(parents=True, exist_ok=True)
    (out_dir / ASSETS_DIR).mkdir(exist_ok=True)
    refs = {}
    sources = {}
    for class_name, src in sorted(asset_files.items()):
        copy_asset(src, out_dir / ASSETS_DIR)
        refs[class_name] = f"../{ASSETS_DIR}/{src.name}"
        sources[refs[class_name]] = asset_dependencies(Path(src).resolve())  # remembered by copy_asset
    if model.surfaces:
        write_ground_layer(model, out_dir / GROUND_LAYER)
    base = base_layer_name(len(model.placements), params)
    if base == BASE_CRATE_LAYER:
        write_base_crate_layer(model, out_dir / base, refs, sources)
        write_object_index(model.placements, out_dir / base, refs)
    else:
        write_base_layer(model, out_dir / base, refs, sources)
    if keep_edits is not None:
        shutil.copyfile(keep_edits, out_dir / EDITS_LAYER)
    else:
        write_edits_layer(out_dir / EDITS_LAYER)
    write_root_layer(out_dir / ROOT_LAYER, base)
