"""``OUT/index.usda``: every built world side by side, each as a payload.

::

    #usda 1.0
    (defaultPrim = "Worlds"  metersPerUnit = 1  upAxis = "Z")
    def Xform "Worlds" (kind = "assembly")
    {
        def Xform "frankfurt_000000_000294" (
            kind = "assembly"
            payload = @./frankfurt_000000_000294/world.usda@
            assetInfo = {string name = "frankfurt_000000_000294", asset identifier = @./.../world.usda@}
            customData = {dictionary usdworld = {string frameId = "...", string sourceImage = "leftImg8bit/..."}}
        )
        { double3 xformOp:translate = (0, 0, 0)  uniform token[] xformOpOrder = ["xformOp:translate"] }
        ...
    }

Read the metadata with ``prim.GetCustomDataByKey("usdworld:frameId")`` (and
``"usdworld:sourceImage"``) or ``prim.GetAssetInfo()``. Payloads let a DCC tool open thousands of frames lazily (``Usd.Stage.Open(path,
Usd.Stage.LoadNone)`` reads only this file) and load the ones it needs. The worlds sit on a
square grid, :data:`GRID_FACTOR` times the largest ``max_range_m`` apart, in frame-id order.
Prim names are the frame ids made valid USD identifiers (a leading digit gets ``frame_``).
Payload paths are relative and nothing depends on the time, so the same records give the
same bytes.

(This is the only module of :mod:`usdworld.batch` that imports ``pxr``; it belongs with the
other authoring code in :mod:`usdworld.authoring` when that package takes it over.)
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from pxr import Gf, Kind, Sdf, Tf, Usd, UsdGeom

from usdworld.errors import OutputError

INDEX_FILE = "index.usda"
ROOT_PRIM = "/Worlds"
#: Grid spacing as a multiple of the largest ``max_range_m`` (worlds reach that far ahead).
GRID_FACTOR = 2.5


@dataclass(frozen=True)
class IndexEntry:
    """One world of the index.

    Attributes:
        frame_id: the frame id (the world is ``OUT/<frame_id>/world.usda``).
        source: the photo as the dataset names it.
        max_range_m: the frame's farthest meshed ground distance.
    """

    frame_id: str
    source: str
    max_range_m: float


def prim_names(frame_ids: Sequence[str]) -> list[str]:
    """Unique, valid USD prim names for frame ids (same order).

    ``frankfurt_000000_000294`` stays as it is; ``000008`` becomes ``frame_000008``; ``a.b``
    becomes ``a_b``; a clash gets ``_2``, ``_3`` ...
    """
    names, used = [], set()
    for frame_id in frame_ids:
        name = Tf.MakeValidIdentifier(f"frame_{frame_id}" if frame_id[:1].isdigit() else frame_id)
        base, k = name, 2
        while name in used:
            name, k = f"{base}_{k}", k + 1
        used.add(name)
        names.append(name)
    return names


def build_index_layer(entries: Sequence[IndexEntry]) -> Sdf.Layer:
    """The index as an anonymous layer (payloads unloaded; nothing is opened).

    Args:
        entries: the built worlds, in the order to lay them out.
    """
    layer = Sdf.Layer.CreateAnonymous(INDEX_FILE)
    stage = Usd.Stage.Open(layer, Usd.Stage.LoadNone)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, ROOT_PRIM)
    stage.SetDefaultPrim(root.GetPrim())
    Usd.ModelAPI(root.GetPrim()).SetKind(Kind.Tokens.assembly)
    spacing = GRID_FACTOR * max((e.max_range_m for e in entries), default=1.0)
    columns = max(1, math.ceil(math.sqrt(len(entries))))
    for i, (entry, name) in enumerate(zip(entries, prim_names([e.frame_id for e in entries]))):
        world = f"./{entry.frame_id}/world.usda"
        xform = UsdGeom.Xform.Define(stage, f"{ROOT_PRIM}/{name}")
        prim = xform.GetPrim()
        prim.GetPayloads().AddPayload(world)
        Usd.ModelAPI(prim).SetKind(Kind.Tokens.assembly)
        prim.SetAssetInfoByKey("name", entry.frame_id)
        prim.SetAssetInfoByKey("identifier", Sdf.AssetPath(world))
        prim.SetCustomDataByKey("usdworld:frameId", entry.frame_id)
        prim.SetCustomDataByKey("usdworld:sourceImage", entry.source)
        row, col = divmod(i, columns)
        xform.AddTranslateOp().Set(Gf.Vec3d(row * spacing, -col * spacing, 0.0))
    return layer


def write_index(out_dir: Path, entries: Sequence[IndexEntry]) -> Path:
    """Write ``out_dir/index.usda`` atomically (temporary file, then rename).

    Args:
        out_dir: the batch output folder (holding ``<frame_id>/world.usda`` for every entry).
        entries: the built worlds.

    Returns:
        The index path.

    Raises:
        OutputError: the folder cannot be written.
    """
    path = Path(out_dir) / INDEX_FILE
    layer = build_index_layer(entries)
    try:
        fd, tmp = tempfile.mkstemp(prefix=".index.", suffix=".usda", dir=path.parent)
        os.close(fd)
    except OSError as exc:
        raise OutputError(
            f"{path}: cannot write ({exc.strerror or exc}); check the output folder is writable"
        ) from exc
    try:
        if not layer.Export(tmp):
            raise OutputError(f"{path}: USD could not write the index; check the output folder is writable")
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
