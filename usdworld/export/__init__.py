"""Export a usdworld world for other tools: usdz, usdc, flat usda and glTF binary.

Example::

    from pathlib import Path
    from usdworld.export import export_world

    result = export_world(Path("out/world.usda"), "glb", Path("out/world.glb"))
    result.check.ok          # True: the Khronos validator found no error (or did not run)

Formats (see :mod:`usdworld.export.usd_formats` and :mod:`usdworld.export.gltf`):

``usdz``       the layered world and its assets in one package (``bake``: layers merged;
               ``flatten``: everything composed into one layer, for three.js / AR viewers)
``usdc``       one crate layer, edits baked in, assets referenced from its own folder
               ``<name>_assets/`` beside it (``flatten``: self-contained)
``usda-flat``  the composed world as one self-contained text layer (asset meshes in it)
``glb``        the composed scene as glTF 2.0, Y up, metres
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from usdworld.errors import InputError, ValidationFailed
from usdworld.export.checks import CheckReport, check_glb_export, check_usd_export

log = logging.getLogger(__name__)

#: Export formats and the file suffix each needs.
FORMATS = {"usdz": ".usdz", "usdc": ".usdc", "usda-flat": ".usda", "glb": ".glb"}


@dataclass(frozen=True)
class ExportResult:
    """What an export wrote and how its check went.

    Attributes:
        format: the export format.
        output: the main file written.
        files: every file written (the main file first; then the files copied into its
            ``<name>_assets/`` folder).
        check: the validator's report (``check.skipped`` says why it did not run).
    """

    format: str
    output: Path
    files: tuple[Path, ...]
    check: CheckReport


def world_root(world: Path) -> Path:
    """The root layer of a world given as its folder or its root layer file.

    Raises:
        InputError: no such world.
    """
    world = Path(world)
    root = world / "world.usda" if world.is_dir() else world
    if not root.is_file():
        raise InputError(f"{world}: no world here; pass a world folder or its world.usda (made by usdworld build)")
    if root.suffix not in (".usda", ".usdc", ".usd"):
        raise InputError(f"{root}: not a USD layer; pass the world's world.usda")
    return root


def export_world(
    world: Path,
    fmt: str,
    output: Path,
    *,
    bake_edits: bool = False,
    flatten: bool = False,
    drop_inactive: bool = False,
    validate: bool = True,
    omni: bool = True,
) -> ExportResult:
    """Export a world and validate the result.

    Args:
        world: the world folder or its ``world.usda``.
        fmt: one of :data:`FORMATS`.
        output: the file to write (its suffix must match the format).
        bake_edits: usdz only: merge the world's layers (edits included) into one root layer.
            usdc/usda-flat always bake; glb is always the composed scene.
        flatten: usdz/usdc: compose everything (references, variants) into one
            self-contained layer; deactivated prims are left out (usda-flat always is).
        drop_inactive: remove deleted (deactivated) prims instead of keeping them inactive.
        validate: run the format's validator and raise when it finds errors.
        omni: let USD validation use omni-asset-validator where installed.

    Returns:
        What was written and the check report.

    Raises:
        InputError: bad world, format, file name or option combination.
        ValidationFailed: the export was written but its validator found errors.
    """
    if fmt not in FORMATS:
        raise InputError(f"unknown export format '{fmt}'; choose one of {', '.join(FORMATS)}")
    root = world_root(world)
    output = Path(output)
    if output.suffix != FORMATS[fmt]:
        raise InputError(f"{output}: the {fmt} format needs a '{FORMATS[fmt]}' file name")
    if output.resolve() == root.resolve():
        raise InputError(f"{output}: would overwrite the world's own root layer; choose another file")
    if fmt == "glb":
        if flatten or bake_edits or drop_inactive:
            log.info("glb is always the composed scene: --bake-edits/--flatten/--drop-inactive change nothing")
        from usdworld.export.gltf import write_glb

        files, summary = write_glb(root, output)
        log.info(
            "%s: %d mesh node(s), %d distinct mesh(es), %d material(s)",
            output,
            summary.mesh_nodes,
            summary.meshes,
            summary.materials,
        )
        check = check_glb_export(output) if validate else CheckReport("gltf-validator", skipped="not asked")
    else:
        from usdworld.export.usd_formats import write_flat, write_usdz

        if fmt == "usdz":
            files = write_usdz(root, output, bake=bake_edits, flatten=flatten, drop_inactive=drop_inactive)
        else:
            if bake_edits:
                log.debug("%s always bakes the edits into its one layer", fmt)
            files = write_flat(root, output, fmt, flatten=flatten, drop_inactive=drop_inactive)
        check = (
            check_usd_export(output, fmt, omni=omni, cards_dir=root.parent / "assets")
            if validate
            else CheckReport("usd", skipped="not asked")
        )
    result = ExportResult(fmt, output, tuple(files), check)
    if check.errors:
        shown = "; ".join(check.errors[:5]) + (f" (and {len(check.errors) - 5} more)" if len(check.errors) > 5 else "")
        raise ValidationFailed(f"{output} was written but fails {check.checker}: {shown}")
    return result


__all__ = ["FORMATS", "ExportResult", "export_world", "world_root"]
