"""Users' own models as class assets: import a mesh file into a user asset library.

A user library is a folder of ``<class>.usda`` (+ ``<class>.geom.usdc``) files laid out exactly
like the built-in library (see ``tools/make_assets.py``): root ``/<class>`` Xform of kind
``component`` with the ``class`` semantic label, a typed ``Geom`` Xform and a ``Looks`` Scope
outside the variant set ``model``, one variant per imported model holding one Mesh and one
UsdPreviewSurface material per colour, mesh arrays in the crate sublayer, root customData
``usdworld:sizeByVariant`` / ``usdworld:defaultVariant``. Z up, metres, the model facing +X,
the origin at the centre of its bounding box's bottom face.

The library is layered over the built-in one (:func:`usdworld.authoring.asset_library.library_dirs`):
a class the user library holds is used instead of the built-in class; the other classes stay
built-in. The first model added to a class starts its user asset from a copy of the built-in
one, so the new variant stands beside the built-in variants (the root's customData
``usdworld:builtinVariants`` names the copied ones) and a build still chooses among them all;
``replace=True`` (``--replace``) drops the built-in variants instead, on purpose. The copy is
of the built-in library at the time of the add. Its folder comes from ``--library`` or
``$USDWORLD_LIBRARY``.

Input formats: OBJ (+ MTL), glTF/GLB, PLY (read with trimesh) and USD (usda/usdc/usdz: the
visible meshes under the default prim, with the current variant selections).

What is refused, with the reason:

- no triangles (empty file, points or lines only, everything degenerate);
- non-finite coordinates, or a non-positive unit scale;
- edges shared by more than two triangles (non-manifold): inside and outside, and so the
  normals and back-face culling, are undefined there;
- a size that is absurd after unit conversion: smaller than 2 cm or larger than 1 km, or a
  largest dimension more than 10x off the class's usual size (``class_priors.json``); the
  message suggests the ``--unit-scale`` that would fit.

What is repaired: degenerate and duplicate triangles are dropped, vertices are welded, every
connected part is given one consistent winding, closed parts face outwards, and materials
of parts that are open (not watertight) are made double-sided.

Example::

    added = add_asset(Path("my_assets"), "car", Path("beetle.glb"), variant="beetle", up="y", front="+z")
    added.path         # my_assets/car.usda
"""

from __future__ import annotations

import logging
import math
import os
import re
import shutil
import tempfile
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdSemantics, UsdShade, Vt

from usdworld.authoring.asset_library import (
    DEFAULT_KEY,
    SIZE_KEY,
    TAXONOMY,
    VARIANT_SET,
    asset_info,
    available_classes,
    define_asset_root,
)
from usdworld.authoring.shading import crease_normals, extent
from usdworld.authoring.stages import open_stage
from usdworld.errors import InputError
from usdworld.perception.colour_space import srgb_to_linear
from usdworld.resources import asset_library_dir

log = logging.getLogger(__name__)

#: Environment variable naming the user asset library folder.
LIBRARY_ENV = "USDWORLD_LIBRARY"
CREATOR = "usdworld assets add"
#: Root customData key listing the variants a user asset copied from the built-in library.
BUILTIN_KEY = "usdworld:builtinVariants"
#: File suffixes read by trimesh, and those read by OpenUSD.
MESH_SUFFIXES = (".obj", ".gltf", ".glb", ".ply")
USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
#: Edges whose faces meet at more than this angle stay hard (same as the built-in assets).
#: Sizes outside these bounds (metres, largest dimension) are refused.
MIN_SIZE_M, MAX_SIZE_M = 0.02, 1000.0
#: Largest allowed ratio between the model's largest dimension and the class's usual one.
MAX_CLASS_RATIO = 10.0
#: Colours closer than this (linear RGB, per channel) share one material.
COLOR_TOLERANCE = 1.0 / 512.0
#: At most this many materials per imported model; beyond it colours are averaged.
MAX_MATERIALS = 16
#: Points are rounded to this many decimals (metres), as in the built-in library.
POINT_DECIMALS = 5

_AXES = {
    "+x": (1.0, 0.0, 0.0),
    "-x": (-1.0, 0.0, 0.0),
    "+y": (0.0, 1.0, 0.0),
    "-y": (0.0, -1.0, 0.0),
    "+z": (0.0, 0.0, 1.0),
    "-z": (0.0, 0.0, -1.0),
}


# --------------------------------------------------------------------------------------------
# Library location and listing
# --------------------------------------------------------------------------------------------


def user_library(explicit: Path | None = None) -> Path | None:
    """The user library folder: ``explicit`` if given, else ``$USDWORLD_LIBRARY``, else None."""
    if explicit is not None:
        return Path(explicit)
    env = os.environ.get(LIBRARY_ENV, "").strip()
    return Path(env) if env else None


@dataclass(frozen=True)
class LibraryEntry:
    """One class asset in one library.

    Attributes:
        class_name: the class.
        library: ``user`` or ``built-in``.
        path: its ``<class>.usda``.
        variants: its ``model`` variants.
        default_variant: the variant used when none is chosen.
        active: False when a user asset of the same class is used instead of this built-in one.
        builtin_variants: of a user asset, the variants copied from the built-in asset (empty
            when the user asset replaces the built-in class); of a built-in asset, all of them.
    """

    class_name: str
    library: str
    path: Path
    variants: tuple[str, ...]
    default_variant: str
    active: bool
    builtin_variants: tuple[str, ...]


def builtin_variants_of(path: Path, class_name: str) -> tuple[str, ...]:
    """The variants a user asset copied from the built-in library (root customData), sorted."""
    layer = Sdf.Layer.FindOrOpen(str(path))
    spec = layer.GetPrimAtPath(f"/{class_name}") if layer is not None else None
    if spec is None:
        return ()
    recorded = spec.customData.get("usdworld", {}).get(BUILTIN_KEY.split(":", 1)[1], [])
    return tuple(sorted(str(v) for v in recorded))


def list_assets(user: Path | None = None) -> list[LibraryEntry]:
    """Every class asset of the user library (if any) and of the built-in library.

    Args:
        user: the user library folder (None: built-in only). It need not exist yet.

    Returns:
        Entries sorted by class, the user's before the built-in one.
    """
    libraries: list[tuple[str, Path]] = []
    if user is not None and Path(user).is_dir():
        libraries.append(("user", Path(user)))
    libraries.append(("built-in", asset_library_dir()))
    entries: list[LibraryEntry] = []
    seen: set[str] = set()
    for label, folder in libraries:
        for name in available_classes((folder,)):
            info = asset_info(name, (folder,))
            kept = builtin_variants_of(info.path, name) if label == "user" else info.variants
            entries.append(
                LibraryEntry(name, label, info.path, info.variants, info.default_variant, name not in seen, kept)
            )
        seen.update(available_classes((folder,)))
    order = {"user": 0, "built-in": 1}
    return sorted(entries, key=lambda e: (e.class_name, order[e.library]))


# --------------------------------------------------------------------------------------------
# Reading a model into parts (one per colour) in the source frame
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SourcePart:
    """Triangles of one colour, in the source file's frame and units.

    Attributes:
        name: a name for the part's material ('' when the source has none).
        color: (r, g, b) linear base colour.
        roughness: 0..1.
        metallic: 0..1.
        points: (N, 3) float64 positions.
        faces: (M, 3) int64 triangles, counter-clockwise seen from the front.
    """

    name: str
    color: tuple[float, float, float]
    roughness: float
    metallic: float
    points: np.ndarray
    faces: np.ndarray


def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """sRGB values, clipped to [0, 1], decoded to linear RGB."""
    return srgb_to_linear(np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0))


def _texture_mean(image: object) -> np.ndarray | None:
    """Mean linear RGB of a texture image (PIL image), or None."""
    try:
        rgb = np.asarray(image.convert("RGB"), dtype=np.float64) / 255.0  # type: ignore[attr-defined]
    except (AttributeError, OSError, ValueError):  # not an image we can read: ignore the texture
        return None
    return _srgb_to_linear(rgb.reshape(-1, 3)).mean(axis=0)


def _trimesh_looks(geom: object) -> tuple[list[tuple[str, tuple[float, float, float], float, float]], np.ndarray]:
    """Looks of a trimesh geometry and the look index of each face.

    Colours of glTF base colour factors and OBJ diffuse colours are taken as linear; texture
    images and PLY vertex/face colours as sRGB. Textures are reduced to their mean colour.
    """
    visual = getattr(geom, "visual", None)
    n_faces = len(geom.faces)  # type: ignore[attr-defined]
    grey = ("", (0.5, 0.5, 0.5), 0.6, 0.0)
    if visual is None:
        return [grey], np.zeros(n_faces, dtype=np.int64)
    kind = getattr(visual, "kind", None)
    if kind == "texture" or hasattr(visual, "material"):
        material = getattr(visual, "material", None)
        if material is None:
            return [grey], np.zeros(n_faces, dtype=np.int64)
        name = str(getattr(material, "name", "") or "")
        roughness, metallic = 0.6, 0.0
        factor = getattr(material, "baseColorFactor", None)
        texture = getattr(material, "baseColorTexture", None)
        if factor is None and hasattr(material, "diffuse"):
            factor = getattr(material, "diffuse", None)
            texture = getattr(material, "image", None)
        else:
            r = getattr(material, "roughnessFactor", None)
            m = getattr(material, "metallicFactor", None)
            roughness = 1.0 if r is None else float(r)
            metallic = 1.0 if m is None else float(m)
        color = np.ones(3) if factor is None else np.asarray(factor, dtype=np.float64)[:3]
        if color.max() > 1.0:  # trimesh stores 8-bit colours
            color = color / 255.0
        if texture is not None:
            mean = _texture_mean(texture)
            if mean is not None:
                color = color * mean
        look = (name, tuple(float(c) for c in np.clip(color, 0, 1)), float(np.clip(roughness, 0, 1)), float(np.clip(metallic, 0, 1)))
        return [look], np.zeros(n_faces, dtype=np.int64)  # type: ignore[list-item]
    if kind in ("face", "vertex"):
        rgba = np.asarray(visual.face_colors, dtype=np.float64)  # type: ignore[attr-defined]
        linear = _srgb_to_linear(rgba[:, :3] / 255.0)
        quant = np.round(linear / COLOR_TOLERANCE).astype(np.int64)
        uniq, inverse = np.unique(quant, axis=0, return_inverse=True)
        if len(uniq) > MAX_MATERIALS:
            average = tuple(float(c) for c in linear.mean(axis=0))
            return [("", average, 0.6, 0.0)], np.zeros(n_faces, dtype=np.int64)  # type: ignore[list-item]
        looks = []
        for k in range(len(uniq)):
            c = linear[inverse.ravel() == k].mean(axis=0)
            looks.append(("", tuple(float(v) for v in c), 0.6, 0.0))
        return looks, inverse.ravel().astype(np.int64)  # type: ignore[return-value]
    return [grey], np.zeros(n_faces, dtype=np.int64)


def _read_trimesh(path: Path) -> list[SourcePart]:
    import trimesh

    try:
        loaded = trimesh.load(str(path), force="scene", process=False)
    except Exception as exc:  # trimesh raises many kinds of errors on bad files
        raise InputError(f"{path}: cannot read it as {path.suffix[1:].upper()} ({exc})") from exc
    if not isinstance(loaded, trimesh.Scene):
        loaded = trimesh.Scene(loaded)
    parts = []
    for geom in loaded.dump(concatenate=False):
        if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
            continue
        looks, face_look = _trimesh_looks(geom)
        points = np.asarray(geom.vertices, dtype=np.float64)
        faces = np.asarray(geom.faces, dtype=np.int64)
        for k, (name, color, roughness, metallic) in enumerate(looks):
            sel = faces[face_look == k]
            if len(sel):
                parts.append(SourcePart(name, color, roughness, metallic, points, sel))
    return parts


def _read_usd(path: Path) -> tuple[list[SourcePart], str, float]:
    """Parts of a USD file (world space of its stage), its up axis and metres per unit."""
    from usdworld.authoring.usd_geometry import read_look, read_mesh, renderable_meshes

    stage = open_stage(path, "USD file")
    root = stage.GetDefaultPrim() or stage.GetPseudoRoot()
    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    parts = []
    for prim in renderable_meshes(stage):
        if not prim.GetPath().HasPrefix(root.GetPath()):
            continue
        arrays = read_mesh(UsdGeom.Mesh(prim))
        if arrays is None:
            continue
        look = read_look(prim)
        m = np.asarray(cache.GetLocalToWorldTransform(prim), dtype=np.float64)
        points = arrays.points @ m[:3, :3] + m[3, :3]
        faces = arrays.triangles if np.linalg.det(m[:3, :3]) > 0 else arrays.triangles[:, ::-1]
        parts.append(SourcePart(look.name, look.color, look.roughness, look.metallic, points, faces))
    up = "z" if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z else "y"
    return parts, up, float(UsdGeom.GetStageMetersPerUnit(stage))


# --------------------------------------------------------------------------------------------
# Conversion to the asset frame, repair and checks
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class AssetPart:
    """One Mesh prim of the asset, in the asset frame (Z up, metres, facing +X).

    Attributes:
        name: valid, unique prim name for the mesh and its material.
        color: (r, g, b) linear diffuse colour (also the displayColor).
        roughness: 0..1.
        metallic: 0..1.
        points: (N, 3) float64 welded positions, metres.
        faces: (M, 3) int32 triangles, counter-clockwise seen from outside.
        normals: (3M, 3) float32 per-corner normals (USD faceVarying order).
        double_sided: True when the part has open (not watertight) pieces.
    """

    name: str
    color: tuple[float, float, float]
    roughness: float
    metallic: float
    points: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    double_sided: bool


@dataclass(frozen=True)
class ImportedModel:
    """A model converted to the asset frame, checked and repaired.

    Attributes:
        parts: one per material.
        size: (length along +X, width along Y, height along Z) in metres.
        notes: what was repaired or looks odd (for the user).
    """

    parts: tuple[AssetPart, ...]
    size: tuple[float, float, float]
    notes: tuple[str, ...]


def asset_from_source(up: str, front: str) -> np.ndarray:
    """(3, 3) rotation taking source coordinates to the asset frame (Z up, front along +X).

    Args:
        up: the source's up axis, ``y`` or ``z`` (+Y or +Z).
        front: the source axis the model faces, one of ``+x -x +y -y +z -z``.

    Raises:
        InputError: unknown axis, or ``front`` along ``up``.
    """
    up = up.lower()
    front = front.lower()
    if up not in ("y", "z"):
        raise InputError(f"--up: must be y or z, got '{up}'")
    if front not in _AXES:
        raise InputError(f"--front: must be one of {', '.join(_AXES)}, got '{front}'")
    # Y up -> Z up: rotate +90 deg about X, (x, y, z) -> (x, -z, y)
    zup_from_src = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]]) if up == "y" else np.eye(3)
    f = zup_from_src @ np.array(_AXES[front])
    if abs(f[2]) > 0.5:
        raise InputError(f"--front {front} points along the up axis (--up {up}); choose a horizontal axis")
    angle = -math.atan2(f[1], f[0])
    c, s = round(math.cos(angle)), round(math.sin(angle))
    rot_z = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return rot_z @ zup_from_src


def _orient(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Make the winding consistent across every connected part.

    Args:
        faces: (M, 3) int64 triangles over welded vertices.

    Returns:
        The re-wound faces, (M,) int64 connected-part id of each face, and the number of
        non-manifold edges (shared by more than two faces; left as they are).
    """
    m = len(faces)
    directed = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    face_of = np.repeat(np.arange(m), 3)
    undirected = np.sort(directed, axis=1)
    forward = directed[:, 0] == undirected[:, 0]
    _, inverse, counts = np.unique(undirected, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    non_manifold = int((counts > 2).sum())
    order = np.argsort(inverse, kind="stable")
    sorted_edges = inverse[order]
    starts = np.flatnonzero(np.r_[True, sorted_edges[1:] != sorted_edges[:-1]])
    pairs = starts[counts[sorted_edges[starts]] == 2]
    a, b = order[pairs], order[pairs + 1]
    neighbours: list[list[tuple[int, bool]]] = [[] for _ in range(m)]
    for fa, fb, same in zip(face_of[a].tolist(), face_of[b].tolist(), (forward[a] == forward[b]).tolist()):
        neighbours[fa].append((fb, same))
        neighbours[fb].append((fa, same))
    flip = np.zeros(m, dtype=bool)
    part = np.full(m, -1, dtype=np.int64)
    n_parts = 0
    for seed in range(m):
        if part[seed] >= 0:
            continue
        part[seed] = n_parts
        queue = deque([seed])
        while queue:
            f = queue.popleft()
            for g, same in neighbours[f]:
                if part[g] < 0:
                    part[g] = n_parts
                    # two faces wound the same way traverse their shared edge in opposite directions
                    flip[g] = flip[f] ^ same
                    queue.append(g)
        n_parts += 1
    out = faces.copy()
    out[flip] = out[flip][:, ::-1]
    return out, part, non_manifold


def _closed_parts(faces: np.ndarray, part: np.ndarray) -> np.ndarray:
    """(P,) bool: True for parts where every edge is shared by exactly two faces."""
    directed = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    undirected = np.sort(directed, axis=1)
    _, inverse, counts = np.unique(undirected, axis=0, return_inverse=True, return_counts=True)
    edge_ok = counts[inverse.ravel()] == 2
    closed = np.ones(part.max() + 1, dtype=bool)
    np.logical_and.at(closed, np.repeat(part, 3), edge_ok)
    return closed


def _clean(points: np.ndarray, faces: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Weld points closer than ``tolerance``, drop unused points, degenerate and duplicate faces.

    Returns:
        Points, faces, number of degenerate faces dropped, number of duplicate faces dropped.
    """
    key = np.round(points / tolerance).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    pts = points[first]
    f = inverse.ravel()[faces]
    tri = pts[f]
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    distinct = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    good = distinct & (area2 > tolerance**2)
    degenerate = int((~good).sum())
    f = f[good]
    _, keep = np.unique(np.sort(f, axis=1), axis=0, return_index=True)
    duplicates = len(f) - len(keep)
    f = f[np.sort(keep)]
    used, remap = np.unique(f, return_inverse=True)
    return pts[used], remap.reshape(-1, 3).astype(np.int64), degenerate, duplicates


def _unique_names(names: list[str]) -> list[str]:
    out: list[str] = []
    for i, raw in enumerate(names):
        base = Tf.MakeValidIdentifier(raw) if raw else f"part_{i}"
        base = re.sub(r"_+", "_", base).strip("_") or f"part_{i}"
        if not Sdf.Path.IsValidIdentifier(base):
            base = f"part_{i}"
        name, k = base, 1
        while name in out:
            k += 1
            name = f"{base}_{k}"
        out.append(name)
    return out


def convert_model(
    parts: list[SourcePart], class_name: str, *, up: str, unit_scale: float, front: str, where: str
) -> ImportedModel:
    """Bring source parts into the asset frame, repair them and check them.

    Args:
        parts: the source's parts.
        class_name: the class (its usual size bounds the model's).
        up: the source's up axis (``y`` or ``z``).
        unit_scale: metres per source unit.
        front: the source axis the model faces.
        where: the source file, for messages.

    Raises:
        InputError: refused, with the reason (see the module docstring).
    """
    if not (math.isfinite(unit_scale) and unit_scale > 0):
        raise InputError(f"--unit-scale: must be a positive number of metres per file unit, got {unit_scale}")
    parts = [p for p in parts if len(p.faces)]
    if not parts:
        raise InputError(f"{where}: no triangles in the file (empty, or points/lines only); nothing to import")
    for p in parts:
        if not np.all(np.isfinite(p.points[np.unique(p.faces)])):
            raise InputError(f"{where}: has NaN or infinite coordinates; fix the file")
    rotation = asset_from_source(up, front) * unit_scale
    moved = [p.points @ rotation.T for p in parts]
    used = np.concatenate([m[np.unique(p.faces)] for m, p in zip(moved, parts)])
    lo, hi = used.min(axis=0), used.max(axis=0)
    size = hi - lo
    _check_size(size, class_name, unit_scale, where)
    origin = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    tolerance = max(1e-6, 1e-7 * float(size.max()))
    notes: list[str] = []
    # group source parts by look (same colour -> one material, one mesh)
    groups: dict[tuple, list[int]] = {}
    for i, p in enumerate(parts):
        key = tuple(np.round(np.array(p.color) / COLOR_TOLERANCE).astype(int)) + (round(p.roughness, 3), round(p.metallic, 3))
        groups.setdefault(key, []).append(i)
    if len(groups) > MAX_MATERIALS:
        notes.append(f"{len(groups)} colours merged into one material (more than {MAX_MATERIALS})")
        groups = {("all",): list(range(len(parts)))}
    names = _unique_names([parts[idx[0]].name for idx in groups.values()])
    out_parts = []
    for name, idx in zip(names, groups.values()):
        pts = np.concatenate([moved[i] - origin for i in idx])
        offsets = np.cumsum([0] + [len(moved[i]) for i in idx])[:-1]
        faces = np.concatenate([parts[i].faces + off for i, off in zip(idx, offsets)])
        pts = np.round(pts, POINT_DECIMALS) + 0.0
        pts, faces, degenerate, duplicates = _clean(pts, faces, tolerance)
        if degenerate:
            notes.append(f"{name}: dropped {degenerate} degenerate triangle(s)")
        if duplicates:
            notes.append(f"{name}: dropped {duplicates} duplicate triangle(s)")
        if len(faces) == 0:
            continue
        faces, part_id, non_manifold = _orient(faces)
        if non_manifold:
            raise InputError(
                f"{where}: material '{name}' has {non_manifold} non-manifold edge(s) (shared by more than two "
                "triangles), so inside and outside are undefined there; clean the mesh first (Blender: Select > "
                "Select All by Trait > Non Manifold, then Mesh > Clean Up > Merge by Distance / Delete Loose)"
            )
        closed = _closed_parts(faces, part_id)
        tri = pts[faces]
        signed = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))
        volume = np.bincount(part_id, weights=signed, minlength=len(closed))
        inward = closed & (volume < 0)
        if inward.any():
            faces[inward[part_id]] = faces[inward[part_id]][:, ::-1]
            notes.append(f"{parts[idx[0]].name or name}: turned {int(inward.sum())} inside-out part(s) outwards")
        p0 = parts[idx[0]]
        out_parts.append(
            AssetPart(
                name,
                p0.color,
                p0.roughness,
                p0.metallic,
                pts,
                faces.astype(np.int32),
                crease_normals(pts, faces),
                bool((~closed).any()),
            )
        )
    if not out_parts:
        raise InputError(f"{where}: every triangle is degenerate (zero area); nothing to import")
    all_pts = np.concatenate([p.points for p in out_parts])
    final = all_pts.max(axis=0) - all_pts.min(axis=0)
    _note_pose(final, class_name, notes)
    return ImportedModel(tuple(out_parts), (float(final[0]), float(final[1]), float(final[2])), tuple(notes))


def _class_size(class_name: str) -> tuple[float, float, float] | None:
    from usdworld.io.class_table import load_class_table

    prior = load_class_table().get(class_name)
    return prior.size_m if prior is not None else None


def _check_size(size: np.ndarray, class_name: str, unit_scale: float, where: str) -> None:
    largest = float(size.max())
    shown = " x ".join(f"{s:.3g}" for s in size)
    if largest < MIN_SIZE_M or largest > MAX_SIZE_M:
        hint = _scale_hint(largest, class_name, unit_scale)
        raise InputError(
            f"{where}: {shown} m after --unit-scale {unit_scale:g} is not a plausible size "
            f"(largest side must be {MIN_SIZE_M} to {MAX_SIZE_M:g} m){hint}"
        )
    usual = _class_size(class_name)
    if usual is not None:
        ratio = largest / max(usual)
        if ratio > MAX_CLASS_RATIO or ratio < 1.0 / MAX_CLASS_RATIO:
            raise InputError(
                f"{where}: {shown} m after --unit-scale {unit_scale:g} is {ratio:.3g}x the usual size of a "
                f"{class_name} ({' x '.join(f'{s:g}' for s in usual)} m){_scale_hint(largest, class_name, unit_scale)}"
            )


def _scale_hint(largest: float, class_name: str, unit_scale: float) -> str:
    usual = _class_size(class_name)
    if usual is None or largest <= 0:
        return "; check --unit-scale (metres per file unit: 0.01 for centimetres, 0.001 for millimetres)"
    suggested = unit_scale * max(usual) / largest
    return (
        f"; check --unit-scale (metres per file unit: 0.01 for centimetres, 0.001 for millimetres, "
        f"0.0254 for inches; about {suggested:.3g} would fit)"
    )


def _note_pose(size: np.ndarray, class_name: str, notes: list[str]) -> None:
    """Note when the model's proportions do not look like the class's (wrong --up or --front?)."""
    usual = _class_size(class_name)
    if usual is None:
        return
    usual_np = np.asarray(usual)
    if (np.argmax(size) == 2) != (np.argmax(usual_np) == 2):
        notes.append(
            f"the model is {size[2]:.2f} m tall but {size[:2].max():.2f} m long; a {class_name} usually is "
            f"{usual[2]:g} m tall and {max(usual[:2]):g} m long: check --up"
        )
    elif usual_np[0] > 1.5 * usual_np[1] and size[1] > 1.5 * size[0]:
        notes.append(f"the model is wider ({size[1]:.2f} m) than long ({size[0]:.2f} m): check --front")


def load_model(
    path: Path,
    class_name: str,
    *,
    up: str | None = None,
    unit_scale: float | None = None,
    front: str = "+x",
) -> ImportedModel:
    """Read a model file and convert it to the asset frame, checked and repaired.

    Args:
        path: an OBJ, glTF/GLB, PLY or USD file.
        class_name: the class it is for.
        up: the file's up axis; default ``y`` for OBJ/glTF/PLY (glTF's convention), the
            stage's ``upAxis`` for USD.
        unit_scale: metres per file unit; default 1 (glTF is metres), the stage's
            ``metersPerUnit`` for USD.
        front: the file axis the model faces (default ``+x``).

    Raises:
        InputError: unreadable, unsupported or refused (the reason is in the message).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix in MESH_SUFFIXES:
        parts = _read_trimesh(path)
        file_up, file_scale = "y", 1.0
    elif suffix in USD_SUFFIXES:
        parts, file_up, file_scale = _read_usd(path)
    else:
        raise InputError(
            f"{path}: unsupported file type '{suffix}'; use {', '.join(MESH_SUFFIXES + USD_SUFFIXES)}"
        )
    return convert_model(
        parts,
        class_name,
        up=up or file_up,
        unit_scale=file_scale if unit_scale is None else float(unit_scale),
        front=front,
        where=str(path),
    )


# --------------------------------------------------------------------------------------------
# Writing the asset
# --------------------------------------------------------------------------------------------


def _vec3f_array(points: np.ndarray) -> Vt.Vec3fArray:
    return Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(points, dtype=np.float32))


def _new_asset(usda: Path, geom: Path, class_name: str) -> None:
    """Create an empty class asset (root, Geom, Looks, label, metadata) and its geometry sublayer."""
    geom_layer = Sdf.Layer.CreateNew(str(geom))
    geom_layer.documentation = f"Mesh arrays of {usda.name} (written by usdworld assets add)."
    geom_layer.Save()
    layer = Sdf.Layer.CreateNew(str(usda))
    layer.customLayerData = {"creator": CREATOR}
    layer.documentation = (
        f"usdworld user asset '{class_name}', written by usdworld assets add. "
        f"Mesh arrays live in the sublayer {geom.name}."
    )
    layer.subLayerPaths.append(f"./{geom.name}")
    stage = Usd.Stage.Open(layer)
    stage.SetEditTarget(Usd.EditTarget(layer))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    prim = define_asset_root(stage, class_name)
    prim.GetVariantSets().AddVariantSet(VARIANT_SET)
    layer.Save()


def _remove_variant(layer: Sdf.Layer, class_name: str, variant: str) -> None:
    spec = layer.GetPrimAtPath(f"/{class_name}")
    if spec is None or VARIANT_SET not in spec.variantSets:
        return
    vset = spec.variantSets[VARIANT_SET]
    for spec_variant in list(vset.variantList):
        if spec_variant.name == variant:
            vset.RemoveVariant(spec_variant)


def _write_variant(usda: Path, geom: Path, class_name: str, variant: str, model: ImportedModel, default: bool) -> None:
    layer = Sdf.Layer.FindOrOpen(str(usda))
    geom_layer = Sdf.Layer.FindOrOpen(str(geom))
    if layer is None or geom_layer is None:
        raise InputError(f"{usda}: cannot open the asset for writing")
    _remove_variant(layer, class_name, variant)
    _remove_variant(geom_layer, class_name, variant)
    stage = Usd.Stage.Open(layer)
    stage.SetEditTarget(Usd.EditTarget(layer))
    root_path = f"/{class_name}"
    prim = stage.GetPrimAtPath(root_path)
    if not prim:
        raise InputError(f"{usda}: no /{class_name} root prim; move the file away and add the model again")
    vset = prim.GetVariantSets().AddVariantSet(VARIANT_SET)
    vset.AddVariant(variant)
    previous = vset.GetVariantSelection()
    vset.SetVariantSelection(variant)
    all_points = np.concatenate([p.points for p in model.parts])
    with vset.GetVariantEditContext():
        UsdGeom.ModelAPI(prim).SetExtentsHint(extent(all_points))
        for part in model.parts:
            mat = UsdShade.Material.Define(stage, f"{root_path}/Looks/{part.name}")
            shader = UsdShade.Shader.Define(stage, f"{root_path}/Looks/{part.name}/PreviewSurface")
            shader.CreateIdAttr("UsdPreviewSurface")
            shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*part.color))
            shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(part.roughness)
            shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(part.metallic)
            mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
            mesh = UsdGeom.Mesh.Define(stage, f"{root_path}/Geom/{part.name}")
            mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
            mesh.CreateExtentAttr(extent(part.points))
            mesh.CreateDoubleSidedAttr(part.double_sided)
            mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set(Vt.Vec3fArray([Gf.Vec3f(*part.color)]))
            UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
            UsdSemantics.LabelsAPI.Apply(mesh.GetPrim(), TAXONOMY).CreateLabelsAttr([class_name])
    stage.SetEditTarget(vset.GetVariantEditTarget(geom_layer))
    for part in model.parts:
        mesh = UsdGeom.Mesh(stage.GetPrimAtPath(f"{root_path}/Geom/{part.name}"))
        mesh.CreatePointsAttr(_vec3f_array(part.points))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(part.faces), 3, dtype=np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.ascontiguousarray(part.faces.reshape(-1))))
        mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(part.normals)))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.faceVarying)
    stage.SetEditTarget(Usd.EditTarget(layer))
    names = sorted(vset.GetVariantNames())
    chosen = variant if (default or not previous or previous not in names) else previous
    vset.SetVariantSelection(chosen)
    sizes = dict(prim.GetCustomDataByKey(SIZE_KEY) or {})
    sizes = {k: v for k, v in sizes.items() if k in names}
    sizes[variant] = Gf.Vec3d(*(round(c, 4) for c in model.size))
    prim.SetCustomDataByKey(DEFAULT_KEY, chosen)
    prim.SetCustomDataByKey(SIZE_KEY, sizes)
    layer.Save()
    geom_layer.Save()


def _copy_builtin(usda: Path, geom: Path, class_name: str) -> None:
    """Start a user asset from a copy of the built-in class asset, its variants recorded."""
    builtin = asset_library_dir()
    shutil.copyfile(builtin / usda.name, usda)
    shutil.copyfile(builtin / geom.name, geom)
    layer = Sdf.Layer.FindOrOpen(str(usda))
    layer.customLayerData = {"creator": CREATOR}
    layer.Save()
    _record_builtin(usda, class_name, asset_info(class_name, (builtin,)).variants)


def _record_builtin(usda: Path, class_name: str, names: tuple[str, ...]) -> None:
    """Write (or, for none, remove) the root customData listing the copied built-in variants."""
    layer = Sdf.Layer.FindOrOpen(str(usda))
    geom = f"{class_name}.geom.usdc"
    copied = f" from a copy of the built-in asset (its variants are listed in {BUILTIN_KEY})" if names else ""
    layer.documentation = (
        f"usdworld user asset '{class_name}', written by usdworld assets add{copied}. "
        f"Mesh arrays live in the sublayer {geom}."
    )
    spec = layer.GetPrimAtPath(f"/{class_name}")
    data = dict(spec.customData.get("usdworld", {}))
    key = BUILTIN_KEY.split(":", 1)[1]
    if names:
        data[key] = Vt.StringArray(sorted(names))
    else:
        data.pop(key, None)
    spec.SetInfo("customData", {**dict(spec.customData), "usdworld": data})
    layer.Save()


def _drop_variant(usda: Path, geom: Path, class_name: str, variant: str) -> None:
    """Remove a variant from both layers of an asset, with its size; a dropped default moves on."""
    layer, geom_layer = Sdf.Layer.FindOrOpen(str(usda)), Sdf.Layer.FindOrOpen(str(geom))
    _remove_variant(layer, class_name, variant)
    _remove_variant(geom_layer, class_name, variant)
    spec = layer.GetPrimAtPath(f"/{class_name}")
    data = dict(spec.customData.get("usdworld", {}))
    sizes = dict(data.get(SIZE_KEY.split(":", 1)[1], {}))
    sizes.pop(variant, None)
    data[SIZE_KEY.split(":", 1)[1]] = sizes
    if data.get(DEFAULT_KEY.split(":", 1)[1]) == variant:
        data.pop(DEFAULT_KEY.split(":", 1)[1])  # _write_variant then makes the new variant the default
    spec.SetInfo("customData", {**dict(spec.customData), "usdworld": data})
    selection = dict(spec.variantSelections)
    if selection.get(VARIANT_SET) == variant:
        del spec.variantSelections[VARIANT_SET]
    layer.Save()
    geom_layer.Save()


@dataclass(frozen=True)
class AddedAsset:
    """The outcome of :func:`add_asset`.

    Attributes:
        path: the class asset (``<library>/<class>.usda``).
        variant: the variant written.
        variants: every variant the class asset now has.
        default_variant: its default variant.
        size: (l, w, h) of the new variant, metres.
        notes: what was repaired or looks odd.
    """

    path: Path
    variant: str
    variants: tuple[str, ...]
    default_variant: str
    size: tuple[float, float, float]
    notes: tuple[str, ...]


def add_asset(
    library: Path,
    class_name: str,
    source: Path,
    *,
    variant: str | None = None,
    up: str | None = None,
    unit_scale: float | None = None,
    front: str = "+x",
    replace: bool = False,
    overwrite: bool = False,
    make_default: bool = False,
    validate: bool = True,
) -> AddedAsset:
    """Import a model file as a variant of a class asset in a user library.

    The asset is written in a scratch folder, validated in every variant (UsdValidation and,
    where installed, omni-asset-validator must report no error), and only then moved into the
    library with its card, which records the validation, so a refused model leaves the library
    as it was and exports need not validate the asset again.

    Args:
        library: the user library folder (created if missing).
        class_name: a class of the built-in library (``usdworld assets list``).
        source: the model file.
        variant: the variant name (default: the file name's stem).
        up: the file's up axis (``y``/``z``); see :func:`load_model`.
        unit_scale: metres per file unit; see :func:`load_model`.
        front: the file axis the model faces.
        replace: hide the built-in class's variants: a new user asset starts empty instead of
            from a copy of the built-in one, and an existing one drops the variants it copied.
        overwrite: replace an existing variant of the same name.
        make_default: make this variant the class's default (so is the first variant of an
            asset that starts empty, and any variant when the default was dropped).
        validate: run the validators before adding (tests of the writer may skip it).

    Raises:
        InputError: unknown class, bad variant name, existing variant, or the model is refused.
        ValidationFailed: the written asset fails validation (the library is unchanged).
    """
    from usdworld.authoring.validate import errors_only, validate_asset, validation_record
    from usdworld.errors import ValidationFailed

    known = available_classes()
    if class_name not in known:
        raise InputError(f"unknown class '{class_name}'; choose one of {', '.join(known)}")
    source = Path(source)
    variant = variant if variant is not None else Tf.MakeValidIdentifier(source.stem)
    if not Sdf.Path.IsValidIdentifier(variant):
        raise InputError(f"--variant: '{variant}' is not a valid name (letters, digits and _, not starting with a digit)")
    library = Path(library)
    if library.resolve() == asset_library_dir().resolve():
        raise InputError(f"{library} is the built-in library; pass your own folder with --library or ${LIBRARY_ENV}")
    if library.exists() and not library.is_dir():
        raise InputError(f"{library}: not a folder")
    usda = library / f"{class_name}.usda"
    geom = library / f"{class_name}.geom.usdc"
    if usda.is_file():
        existing = asset_info(class_name, (library,)).variants
    else:  # a new asset starts from the built-in variants unless it replaces them
        existing = () if replace else asset_info(class_name).variants
    if variant in existing and not overwrite:
        raise InputError(
            f"{usda} already has a variant '{variant}'; pass --overwrite to overwrite it, or another --variant"
        )
    model = load_model(source, class_name, up=up, unit_scale=unit_scale, front=front)
    library.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=f".{class_name}-", dir=library) as scratch:
        tmp_usda, tmp_geom = Path(scratch) / usda.name, Path(scratch) / geom.name
        if usda.is_file():
            if not geom.is_file():
                raise InputError(f"{usda}: its geometry sublayer {geom.name} is missing; restore it or remove {usda.name}")
            shutil.copyfile(usda, tmp_usda)
            shutil.copyfile(geom, tmp_geom)
        elif replace:
            _new_asset(tmp_usda, tmp_geom, class_name)
        else:
            _copy_builtin(tmp_usda, tmp_geom, class_name)
        kept = builtin_variants_of(tmp_usda, class_name)
        if replace:
            for name in kept:
                _drop_variant(tmp_usda, tmp_geom, class_name, name)
            kept = ()
        _write_variant(tmp_usda, tmp_geom, class_name, variant, model, make_default)
        _record_builtin(tmp_usda, class_name, tuple(v for v in kept if v != variant))
        record = None
        if validate:
            issues = validate_asset(tmp_usda)
            errors = errors_only(issues)
            if errors:
                shown = "; ".join(f"[{e.rule}] {e.at} {e.message}" for e in errors[:5])
                raise ValidationFailed(f"{source}: the asset written from it fails validation, not added: {shown}")
            record = validation_record(issues)
        from usdworld.authoring.asset_cards import card_path, write_card
        from usdworld.authoring.asset_measures import asset_card_text

        info = asset_info(class_name, (Path(scratch),))
        # builds and edits need not measure it, exports need not validate it again
        tmp_card = write_card(tmp_usda, asset_card_text(tmp_usda, record))
        for tmp, final in ((tmp_geom, geom), (tmp_usda, usda), (tmp_card, card_path(usda))):
            os.replace(tmp, final)
    for layer_path in (usda, geom):
        layer = Sdf.Layer.Find(str(layer_path))
        if layer is not None:
            layer.Reload(force=True)
    return AddedAsset(usda, variant, info.variants, info.default_variant, model.size, model.notes)


__all__ = [
    "BUILTIN_KEY",
    "LIBRARY_ENV",
    "AddedAsset",
    "AssetPart",
    "ImportedModel",
    "LibraryEntry",
    "SourcePart",
    "add_asset",
    "asset_from_source",
    "builtin_variants_of",
    "convert_model",
    "crease_normals",
    "list_assets",
    "load_model",
    "user_library",
]
