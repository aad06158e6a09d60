"""Opening USD files with one-line errors (every reader of user-supplied stages goes through here),
the registration of usdworld's schema plugin, and reading a world's layers ahead on a thread."""

from __future__ import annotations

import os
import re
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from pxr import Plug, Sdf

from usdworld.errors import InputError
from usdworld.resources import schemas_dir
from usdworld.world_files import ROOT_LAYER

if TYPE_CHECKING:
    from pxr import Usd


#: OpenUSD's error text: "Error in 'FUNCTION' at line N in file FILE : 'REASON'".
_USD_ERROR = re.compile(r"^\s*Error in .* : '(?P<reason>.*)'\s*$", re.DOTALL)


def usd_reason(exc: BaseException) -> str:
    """The reason in an OpenUSD error's last line, without the C++ function and file it came from."""
    lines = str(exc).strip().splitlines() or [type(exc).__name__]
    last = lines[-1].strip()
    match = _USD_ERROR.match(last)
    return match.group("reason") if match else last


def register_schemas() -> None:
    """Register the codeless schema plugin (``schemas/plugInfo.json``) with OpenUSD.

    Called when :mod:`usdworld.authoring` is imported; must run before the first stage is
    opened in the process. Registering the same folder again does nothing.
    """
    Plug.Registry().RegisterPlugins(str(schemas_dir()))


def open_stage(
    path: str | Path,
    what: str = "USD stage",
    mask: Sequence[str] | None = None,
    whole: bool = True,
) -> Usd.Stage:
    """Open a USD file, or raise an InputError that names it.

    Args:
        path: the file.
        what: how the message names the file (``USD stage``, ``USD asset``, ``USD world`` ...).
        mask: prim paths to compose (with their ancestors and descendants); None composes
            every prim. ``stage.SetPopulationMask`` widens it later.
        whole: every sublayer must open (:func:`unread_sublayer`); False opens the stage
            without the ones that do not (a validator reports them as its findings).

    Raises:
        InputError: the file does not open, or one of its sublayers does not when ``whole``
            (the USD error's reason is quoted).
    """
    from pxr import Usd  # not with the module: an edit starts its layer prefetch (Sdf) before it

    try:
        if mask is None:
            stage = Usd.Stage.Open(str(path), Usd.Stage.LoadAll)
        else:
            stage = Usd.Stage.OpenMasked(str(path), Usd.StagePopulationMask(list(mask)), Usd.Stage.LoadAll)
    except Exception as exc:  # pxr raises Tf.ErrorException
        raise InputError(f"{path}: not a readable {what} ({usd_reason(exc)})") from exc
    if stage is None:
        raise InputError(f"{path}: not a readable {what}")
    unread = unread_sublayer(stage) if whole else None
    if unread is not None:
        raise InputError(f"{path}: {unread}; restore that file or rebuild the world")
    return stage


def unread_sublayer(stage: Usd.Stage) -> str | None:
    """What is wrong with the first sublayer of the stage's layer stack that did not open, or None.

    OpenUSD opens a stage whose sublayer is missing or unreadable (a truncated crate file)
    without it, with only a warning, so the world would silently lack its objects.

    Args:
        stage: an opened stage.

    Returns:
        ``"sublayer FILE is missing"`` or ``"sublayer FILE is not readable (USD's reason)"``;
        None when every sublayer named in the stack opened.
    """
    stack = stage.GetLayerStack(includeSessionLayers=False)
    opened = {os.path.realpath(layer.realPath) for layer in stack if layer.realPath}
    for layer in stack:
        for sub in layer.subLayerPaths:
            file = layer.ComputeAbsolutePath(sub)
            if not file or os.path.realpath(file) in opened:
                continue
            if not os.path.isfile(file):
                return f"sublayer {file} is missing"
            try:
                reopened = Sdf.Layer.FindOrOpen(file)
            except Exception as exc:  # pxr raises Tf.ErrorException
                return f"sublayer {file} is not readable ({usd_reason(exc)})"
            if reopened is None:
                return f"sublayer {file} is not readable"
    return None


def world_root(world: str | Path) -> Path:
    """A world's root layer file, from the file itself or the world's folder.

    Args:
        world: the root layer (``world.usda``) or the world folder.

    Raises:
        InputError: no root layer there.
    """
    root = Path(world)
    if root.is_dir():
        root = root / ROOT_LAYER
    if not root.is_file():
        raise InputError(
            f"{root}: no such world; pass the world's root layer (e.g. OUT/world.usda) or its folder"
        )
    return root


def world_layer_files(world: str | Path) -> tuple[Path, ...]:
    """The files of a world root's sublayers, strongest first: the edits layer first, the base
    layer (``layers/base.usda``, or ``layers/base.usdc`` in a large world) last.

    Only the root's header is read (its metadata); the sublayers are not opened.

    Args:
        world: the root layer (``world.usda``) or the world folder.

    Raises:
        InputError: no root layer there, or one that does not open or names no sublayers.
    """
    root = world_root(world)
    try:
        layer = Sdf.Layer.OpenAsAnonymous(str(root), metadataOnly=True)
    except Exception as exc:  # pxr raises Tf.ErrorException
        raise InputError(f"{root}: not a readable USD world ({usd_reason(exc)})") from exc
    if layer is None or not layer.subLayerPaths:
        raise InputError(f"{root}: names no sublayers; not a usdworld world (rebuild it)")
    return tuple(Path(os.path.normpath(root.parent / sub)) for sub in layer.subLayerPaths)


def base_layer_file(world: str | Path) -> Path:
    """The file of a world's base layer: the root's last sublayer (see :func:`world_layer_files`)."""
    return world_layer_files(world)[-1]


class LayerPrefetch:
    """A world's layer files read on a background thread, while the process does other work.

    OpenUSD releases Python's global lock while it parses a layer, so a command can start
    parsing a world's layers (a large world's crate base layer: about 0.1 s at 10,000
    objects) and import the rest of its modules meanwhile. A stage opened later finds the
    layers already in OpenUSD's layer registry, as long as they are held: :meth:`wait`
    returns them; keep them until the stage is open. A file that does not open is left
    out silently: the stage's own open reports it.

    Args:
        files: the layer files, e.g. :func:`world_layer_files`.
    """

    def __init__(self, files: Sequence[Path]) -> None:
        self._files = tuple(os.path.abspath(f) for f in files)  # the identifiers a stage anchors
        self._layers: list[Sdf.Layer] = []
        self._thread = threading.Thread(target=self._read, name="usdworld-layer-prefetch", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        for file in self._files:
            try:
                layer = Sdf.Layer.FindOrOpen(file)
            except Exception:  # pxr raises Tf.ErrorException; the stage's open reports it
                continue
            if layer is not None:
                self._layers.append(layer)

    def wait(self) -> tuple[Sdf.Layer, ...]:
        """The layers that opened, once the thread is done (it reads each file once)."""
        self._thread.join()
        return tuple(self._layers)


def prefetch_world_layers(world: str | Path) -> LayerPrefetch | None:
    """Start reading a world's sublayers (:func:`world_layer_files`) on a thread, or None
    when ``world`` is not a readable world (whoever opens it next reports why)."""
    try:
        return LayerPrefetch(world_layer_files(world))
    except InputError:
        return None
