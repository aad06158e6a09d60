"""USD exports of a world: a ``.usdz`` package, or one ``.usdc`` / ``.usda`` layer.

Three shapes, by how much of the composition is resolved:

layered (``usdz`` by default)
    ``UsdUtils.CreateNewUsdzPackage`` on the world: the package holds ``world.usda``,
    ``layers/edits.usda``, the base layer (``layers/base.usda``, or ``base.usdc`` in a large
    world) and the assets, so layers, references and variant sets survive.
baked (``usdc``; ``usdz`` with ``bake=True``)
    ``UsdUtils.FlattenLayerStack``: the root, edits and base layers merged into one layer,
    so the edits are baked in while references to the assets and the ``model`` variant sets
    stay. Asset paths are rewritten relative to the output file and the files they name go
    into the export's own folder ``<name>_assets/`` beside it (:func:`assets_folder`; inside
    the package for usdz), so two exports into one folder never share or overwrite assets.
    Deleted objects (``active = false``) stay deactivated unless ``drop_inactive`` is set,
    which removes their prim specs.
composed (``usda-flat`` always; ``flatten=True``)
    ``Usd.Stage.Flatten``: one self-contained layer with references and variants resolved
    (the asset meshes are in it) and deactivated prims removed. Only files that are not
    layers (textures of a user's asset) still go to ``<name>_assets/``. For viewers that compose nothing themselves: three.js'
    ``USDLoader`` reads neither sublayers nor reference list ops in crate files, and ignores
    ``active``.

No payloads are written: objects reference their assets (Unity's USD package does not load
payloads by default). Crate files are checked to be version 0.8.0 or older (USD 20.08).
"""

from __future__ import annotations

import filecmp
import logging
import os
import shutil
import tempfile
from pathlib import Path, PurePosixPath

from pxr import Sdf, Usd, UsdUtils

from usdworld.authoring.stages import open_stage
from usdworld.errors import InputError, OutputError

log = logging.getLogger(__name__)

#: Crate (.usdc) file versions that USD 20.08 (inside Unity's USD package) reads.
MAX_CRATE_VERSION = (0, 8, 0)


def open_world(root: Path) -> Usd.Stage:
    """Open a world's root layer with everything loaded.

    Raises:
        InputError: the file does not open as a USD stage.
    """
    return open_stage(root)


class _Anchor:
    """Rewrites every asset path of a world relative to the world's folder (``./assets/car.usda``).

    The output layer sits at the same place relative to the files it needs (they are copied
    beside it), so these paths stay valid. Paths that point outside the world folder cannot
    be kept relative; they are collected in ``outside`` and reported after flattening (a
    callback must not raise into C++).
    """

    def __init__(self, world_dir: Path, folder: str = "") -> None:
        self.world_dir = world_dir.resolve()
        self.folder = folder
        self.outside: list[str] = []

    def __call__(self, layer: Sdf.Layer, path: str) -> str:
        if not path or Sdf.Layer.IsAnonymousLayerIdentifier(path):
            return path
        absolute = Path(os.path.normpath(layer.ComputeAbsolutePath(path))).resolve()
        try:
            rel = absolute.relative_to(self.world_dir)
        except ValueError:
            self.outside.append(path)
            return path
        return "./" + PurePosixPath(self.folder, *rel.parts).as_posix()


def _check_outside(anchor: _Anchor, root: Path) -> None:
    if anchor.outside:
        raise InputError(
            f"{root}: refers to {', '.join(sorted(set(anchor.outside)))} outside the world folder "
            f"{anchor.world_dir}; copy those files into the world folder (e.g. assets/) and point the "
            "references there, then export again"
        )


def assets_folder(out: Path) -> Path:
    """The folder beside an export that holds its own copies of the files it needs.

    ``exports/city.usdc`` -> ``exports/city_assets/``: named after the export, so every
    export into one folder keeps its assets apart.
    """
    return out.parent / f"{out.stem}_assets"


def flatten_layer_stack(stage: Usd.Stage, root: Path, folder: str = "") -> Sdf.Layer:
    """Merge the root layer stack (root, edits, base) into one anonymous layer.

    References, variant selections and ``active`` opinions are kept; asset paths are
    rewritten relative to the world's folder, under ``folder``.

    Args:
        stage: the world stage.
        root: the world's root layer file.
        folder: where the world folder's files will be, relative to the new layer
            (``""``: beside it, ``city_assets``: in that folder).
    """
    anchor = _Anchor(root.parent, folder)
    flat = UsdUtils.FlattenLayerStack(stage, anchor)
    _check_outside(anchor, root)
    return flat


def drop_inactive_specs(layer: Sdf.Layer) -> list[str]:
    """Remove every prim the layer defines (``def``) and authors ``active = false``, with its subtree.

    An ``over`` that deactivates a prim defined elsewhere (inside a referenced asset) is kept:
    removing it would bring the prim back.

    Returns:
        Paths of the removed prims, sorted.
    """
    doomed: list[Sdf.Path] = []

    def visit(path: Sdf.Path) -> None:
        if not path.IsPrimPath():
            return
        spec = layer.GetPrimAtPath(path)
        if (
            spec is not None
            and spec.specifier == Sdf.SpecifierDef
            and spec.HasInfo("active")
            and not spec.GetInfo("active")
        ):
            doomed.append(path)

    layer.Traverse(Sdf.Path.absoluteRootPath, visit)
    # deepest first, so removing a parent never invalidates a path still to be removed
    for path in sorted(doomed, key=lambda p: -p.pathElementCount):
        parent_path = path.GetParentPath()
        parent = layer.pseudoRoot if parent_path == Sdf.Path.absoluteRootPath else layer.GetPrimAtPath(parent_path)
        if parent is not None and path.name in parent.nameChildren:
            del parent.nameChildren[path.name]
    return sorted(str(p) for p in doomed)


def external_dependencies(stage: Usd.Stage, root: Path) -> list[Path]:
    """Files the world needs beyond its own layer stack (asset layers and their files), resolved."""
    own = {Path(layer.realPath).resolve() for layer in stage.GetLayerStack(includeSessionLayers=False) if layer.realPath}
    layers, assets, unresolved = UsdUtils.ComputeAllDependencies(Sdf.AssetPath(str(root)))
    if unresolved:
        raise InputError(
            f"{root}: unresolved dependencies {', '.join(unresolved)}; rebuild the world or restore those files"
        )
    out = []
    for dep in [Path(layer.realPath) for layer in layers if layer.realPath] + [Path(a) for a in assets]:
        dep = dep.resolve()
        if dep not in own and dep not in out:
            out.append(dep)
    return out


def copy_dependencies(deps: list[Path], world_dir: Path, out_dir: Path) -> list[Path]:
    """Copy files under ``world_dir`` to the same relative place under ``out_dir``.

    A file already there with the same bytes is left alone; different bytes are refused, so
    an export never silently changes another export's assets.

    Returns:
        The destination files.

    Raises:
        InputError: a dependency lies outside the world folder.
        OutputError: a different file already exists at a destination.
    """
    world_dir = world_dir.resolve()
    written = []
    for dep in deps:
        try:
            rel = dep.relative_to(world_dir)
        except ValueError as exc:
            raise InputError(
                f"the world depends on {dep} outside its folder {world_dir}; copy it into the world folder"
            ) from exc
        target = out_dir / rel
        written.append(target)
        if target.exists():
            if target.resolve() == dep or filecmp.cmp(target, dep, shallow=False):
                continue
            raise OutputError(
                f"{target} already exists with different content; export into an empty folder or remove it"
            )
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(dep, target)
    return written


def crate_version(path: Path) -> tuple[int, int, int]:
    """Version of a ``.usdc`` crate file, read from its header (``PXR-USDC`` then 3 version bytes).

    Raises:
        InputError: the file is not a crate file.
    """
    with open(path, "rb") as fh:
        head = fh.read(16)
    if len(head) < 11 or head[:8] != b"PXR-USDC":
        raise InputError(f"{path}: not a USD crate (.usdc) file")
    return head[8], head[9], head[10]


def check_crate_version(path: Path) -> None:
    """Refuse a crate newer than what USD 20.08 (Unity's USD package) reads.

    Raises:
        OutputError: the crate version is above :data:`MAX_CRATE_VERSION`.
    """
    version = crate_version(path)
    if version > MAX_CRATE_VERSION:
        have = ".".join(map(str, version))
        limit = ".".join(map(str, MAX_CRATE_VERSION))
        raise OutputError(
            f"{path}: crate version {have} is newer than {limit}, which USD 20.08 (Unity's USD package) "
            "reads; some authored value needs a newer file format (time codes, splines): remove it"
        )


def objects_with_payloads(stage: Usd.Stage) -> list[str]:
    """Paths of prims that have payload arcs (none are expected in a usdworld export)."""
    return [str(p.GetPath()) for p in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()) if p.HasAuthoredPayloads()]


def _umask_mode(path: Path) -> None:
    """Give a file made by ``mkstemp`` (mode 0600) the usual permissions (0666 less the umask)."""
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(path, 0o666 & ~mask)


def _save_as(layer: Sdf.Layer, path: Path) -> None:
    if not layer.Export(str(path)):
        raise OutputError(f"{path}: could not be written")


def _write_layer(layer: Sdf.Layer, out: Path) -> None:
    """Export a layer to ``out`` atomically (temporary file in the same folder, then rename)."""
    fd, tmp_name = tempfile.mkstemp(prefix=f".{out.stem}-", suffix=out.suffix, dir=out.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        _save_as(layer, tmp)
        _umask_mode(tmp)
        if out.suffix == ".usdc":
            check_crate_version(tmp)
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)


def write_flat(
    root: Path, out: Path, fmt: str, *, flatten: bool = False, drop_inactive: bool = False
) -> list[Path]:
    """Write the world as one layer with the edits baked in.

    Args:
        root: the world's root layer.
        out: the ``.usdc`` or ``.usda`` file to write; the files it needs go to its own
            :func:`assets_folder` (none for a composed layer, unless a user asset has textures).
        fmt: ``usdc`` or ``usda-flat`` (always composed: one self-contained text layer).
        flatten: resolve references and variants too (one self-contained layer).
        drop_inactive: remove deactivated (deleted) prims instead of keeping them inactive
            (always the case with ``flatten``).

    Returns:
        Every file written (the layer first).
    """
    want = ".usdc" if fmt == "usdc" else ".usda"
    if out.suffix != want:
        raise InputError(f"{out}: the {fmt} format needs a '{want}' file name")
    stage = open_world(root)
    out.parent.mkdir(parents=True, exist_ok=True)
    assets = assets_folder(out)
    if flatten or fmt == "usda-flat":
        layer, files = compose_to_layer(stage, root, assets.name)
        deps = copy_dependencies(files, root.parent, assets)
    else:
        layer = flatten_layer_stack(stage, root, assets.name)
        if drop_inactive:
            removed = drop_inactive_specs(layer)
            if removed:
                log.info("dropped %d deactivated prim(s): %s", len(removed), ", ".join(removed))
        deps = copy_dependencies(external_dependencies(stage, root), root.parent, assets)
    _write_layer(layer, out)
    return [out, *deps]


def write_usdz(
    root: Path, out: Path, *, bake: bool = False, flatten: bool = False, drop_inactive: bool = False
) -> list[Path]:
    """Package the world (and its assets) into one ``.usdz``.

    Args:
        root: the world's root layer.
        out: the ``.usdz`` file to write.
        bake: merge the world's layers into one root layer (references and variants kept).
        flatten: compose everything into one layer (references and variants resolved).
        drop_inactive: remove deactivated prims (needs ``bake``; implied by ``flatten``).

    Returns:
        ``[out]``.
    """
    if out.suffix != ".usdz":
        raise InputError(f"{out}: the usdz format needs a '.usdz' file name")
    if drop_inactive and not (bake or flatten):
        raise InputError(
            "--drop-inactive needs --bake-edits (or --flatten) for usdz: without them the package "
            "keeps the world's own layers unchanged"
        )
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=f".{out.stem}-", dir=out.parent) as scratch:
        staging = Path(scratch) / "staging"
        if flatten:
            package_root = _stage_composed(root, staging)
        elif bake:
            package_root = _stage_baked(root, staging, drop_inactive)
        else:
            package_root = _stage_layered(root, staging)
        tmp_out = Path(scratch) / out.name
        if not UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(str(package_root)), str(tmp_out)):
            raise OutputError(f"{out}: usdz packaging failed (see the USD messages above)")
        _umask_mode(tmp_out)
        os.replace(tmp_out, out)
    return [out]


def _is_search_path(path: str) -> bool:
    """True for a relative path written without ``./`` or ``../`` (USD resolves those as search paths)."""
    return bool(path) and not path.startswith(("./", "../", "/")) and ":" not in path


def _stage_layered(root: Path, staging: Path) -> Path:
    """Copy the world's layers and assets into ``staging`` with every relative path anchored.

    ``UsdUtils.CreateNewUsdzPackage`` moves layers reached through search-style paths
    (``layers/base.usda``) into numbered folders (``0/base.usda``); written as
    ``./layers/base.usda`` they keep their place in the package.
    """
    stage = open_world(root)
    world_dir = root.parent.resolve()
    own = [Path(layer.realPath).resolve() for layer in stage.GetLayerStack(includeSessionLayers=False) if layer.realPath]
    staging.mkdir(parents=True)
    copied = copy_dependencies(own + external_dependencies(stage, root), world_dir, staging)
    staged_root = staging / root.name
    layers = {path: _open_layer(path) for path in copied if path.suffix in (".usda", ".usdc", ".usd")}
    # text layers holding long arrays travel as crate (same name, .usdc), as omni's
    # UsdAsciiPerformanceChecker asks; paths to them are rewritten below
    renamed: dict[str, str] = {}
    for path, layer in list(layers.items()):
        crate = path.with_suffix(".usdc")
        if path != staged_root and path.suffix == ".usda" and _has_long_arrays(layer) and not crate.exists():
            _save_as(layer, crate)
            path.unlink()
            del layers[path]
            layers[crate] = _open_layer(crate)
            renamed[str(path.resolve())] = crate.name
    for layer in layers.values():

        def fix(p: str, layer: Sdf.Layer = layer) -> str:
            if not p or ":" in p or p.startswith("/"):
                return p
            anchored = Path(os.path.normpath(Path(layer.realPath).parent / p))
            new_name = renamed.get(str(anchored.resolve()))
            if new_name is not None:
                p = str(PurePosixPath(p).with_name(new_name))
            return "./" + p if _is_search_path(p) else p

        UsdUtils.ModifyAssetPaths(layer, fix)
        if layer.dirty and not layer.Save():
            raise OutputError(f"{layer.realPath}: could not be written")
    return staged_root


#: Longest array a text layer may hold before omni-asset-validator asks for a crate file.
ASCII_ARRAY_LIMIT = 64


def _open_layer(path: Path) -> Sdf.Layer:
    layer = Sdf.Layer.FindOrOpen(str(path))
    if layer is None:
        raise OutputError(f"{path}: copied layer does not open")
    return layer


def _has_long_arrays(layer: Sdf.Layer) -> bool:
    """True when an attribute of the layer holds an array longer than :data:`ASCII_ARRAY_LIMIT`."""
    found = False

    def visit(path: Sdf.Path) -> None:
        nonlocal found
        if found or not path.IsPropertyPath():
            return
        spec = layer.GetAttributeAtPath(path)
        if spec is None:
            return
        values = [spec.default] if spec.HasDefaultValue() else []
        values += [layer.QueryTimeSample(path, t) for t in layer.ListTimeSamplesForPath(path)]
        found = any(hasattr(v, "__len__") and not isinstance(v, str) and len(v) > ASCII_ARRAY_LIMIT for v in values)

    layer.Traverse(Sdf.Path.absoluteRootPath, visit)
    return found


def _stage_baked(root: Path, staging: Path, drop_inactive: bool) -> Path:
    """Write the baked world into ``staging``: one root crate layer plus the assets as they are."""
    stage = open_world(root)
    flat = flatten_layer_stack(stage, root)
    if drop_inactive:
        drop_inactive_specs(flat)
    staging.mkdir(parents=True)
    copy_dependencies(external_dependencies(stage, root), root.parent, staging)
    package_root = staging / f"{root.stem}.usdc"
    _save_as(flat, package_root)
    check_crate_version(package_root)
    return package_root


def compose_to_layer(stage: Usd.Stage, root: Path, folder: str = "") -> tuple[Sdf.Layer, list[Path]]:
    """The whole composed stage in one self-contained layer (``Usd.Stage.Flatten``).

    References and variant sets are resolved into plain prims, edits applied, deactivated
    prims removed. Asset-valued attributes (none in a usdworld world, maybe in a user's
    asset) are rewritten relative to the world folder, under ``folder`` (see
    :func:`flatten_layer_stack`).

    Returns:
        The layer, and the non-layer files (textures ...) it still points to, resolved.
    """
    composed = stage.Flatten(addSourceFileComment=False)
    anchor = _Anchor(root.parent, folder)
    files: list[Path] = []

    def relative(path: str) -> str:
        if not path or not os.path.isabs(path):
            return path
        before = len(anchor.outside)
        new = anchor(composed, path)
        if len(anchor.outside) == before:
            files.append(Path(path).resolve())
        return new

    UsdUtils.ModifyAssetPaths(composed, relative)
    _check_outside(anchor, root)
    return composed, files


def _stage_composed(root: Path, staging: Path) -> Path:
    """Write the fully composed world into ``staging`` as one crate layer (plus any textures)."""
    stage = open_world(root)
    composed, files = compose_to_layer(stage, root)
    staging.mkdir(parents=True)
    copy_dependencies(files, root.parent, staging)
    package_root = staging / f"{root.stem}.usdc"
    _save_as(composed, package_root)
    check_crate_version(package_root)
    return package_root
