"""Shared torch plumbing of the network backends: device choice, checkpoint loading,
strict state-dict matching and resizing.

torch is imported inside each function so that this module (and the package) imports
without torch installed.
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from usdworld.errors import InputError

if TYPE_CHECKING:
    import torch

log = logging.getLogger(__name__)

#: Most keys of each kind named in a key-mismatch message.
MAX_KEYS_LISTED = 5


def import_torch(where: str) -> Any:
    """Import torch or raise InputError saying how to install it."""
    try:
        import torch
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise InputError(
            f"{where}: needs PyTorch, which is not installed: pip install torch ({exc})"
        ) from exc
    return torch


def import_transformers(where: str) -> Any:
    """Import transformers offline (``HF_HUB_OFFLINE=1`` set first) or raise InputError saying how to install it."""
    os.environ["HF_HUB_OFFLINE"] = "1"
    os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")
    try:
        import transformers
    except ImportError as exc:
        raise InputError(
            f"{where}: needs the transformers package, which is not installed: pip install transformers ({exc})"
        ) from exc
    return transformers


@contextlib.contextmanager
def progress_bars_off(transformers: Any) -> Iterator[None]:
    """transformers' progress bars off while a model loads (the library prints nothing), restored after."""
    bars = transformers.utils.logging.is_progress_bar_enabled()
    transformers.utils.logging.disable_progress_bar()
    try:
        yield
    finally:
        if bars:
            transformers.utils.logging.enable_progress_bar()


def first_line(exc: BaseException, limit: int = 200) -> str:
    """The first line of an exception's message (its type's name when empty), at most ``limit`` characters."""
    text = str(exc).strip()
    return (text.splitlines()[0] if text else type(exc).__name__)[:limit]


def select_device(device: str | None, where: str) -> torch.device:
    """The device a network runs on.

    None picks CUDA when available, else the CPU; on the CPU the intra-op thread count
    is set to ``min(4, os.cpu_count())``.

    Args:
        device: ``cpu``, ``cuda``, ``cuda:1`` ... or None.
        where: backend name for messages.

    Raises:
        InputError: unknown device string or CUDA asked for but not available.
    """
    torch = import_torch(where)
    if device is None:
        device = "cuda" if torch.cuda.is_available() else "cpu"
    try:
        dev = torch.device(device)
    except (RuntimeError, ValueError) as exc:
        raise InputError(f"{where}: device {device!r} is not a torch device ({exc})") from exc
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise InputError(f"{where}: device {device!r} asked for but CUDA is not available; use --device cpu")
    if dev.type == "cpu":
        threads = min(4, os.cpu_count() or 1)
        if torch.get_num_threads() != threads:
            torch.set_num_threads(threads)
    log.debug("%s runs on %s", where, dev)
    return dev


def load_checkpoint(path: Path, where: str) -> dict[str, Any]:
    """Read a torch checkpoint file (tensors, numbers, strings only: ``weights_only``).

    Args:
        path: the ``.pth`` file.
        where: backend name for messages.

    Returns:
        The dictionary stored in the file.

    Raises:
        InputError: missing file, not a torch file, or not a dictionary.
    """
    torch = import_torch(where)
    if not path.is_file():
        raise InputError(f"{where} weights {path}: no such file")
    try:
        obj = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises many types for a bad file (pickle, zip, runtime)
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{where} weights {path}: not a PyTorch checkpoint ({first[:160]})") from exc
    if not isinstance(obj, Mapping):
        raise InputError(f"{where} weights {path}: expected a state dict, got {type(obj).__name__}")
    return dict(obj)


def _listed(keys: list[str]) -> str:
    shown = ", ".join(keys[:MAX_KEYS_LISTED])
    more = f", ... (+{len(keys) - MAX_KEYS_LISTED} more)" if len(keys) > MAX_KEYS_LISTED else ""
    return f"{shown}{more}"


def load_state_dict_strict(
    module: torch.nn.Module,
    state: Mapping[str, Any],
    path: Path,
    where: str,
    optional_suffixes: tuple[str, ...] = ("num_batches_tracked",),
) -> None:
    """Load ``state`` into ``module``, refusing any missing, unexpected or mis-shaped key.

    Keys ending in ``optional_suffixes`` may be missing (BatchNorm counters that older
    torch versions did not save).

    Raises:
        InputError: one line naming at most 5 keys of each kind plus their counts, e.g.
            ``monodepth2 weights enc.pth: state dict does not match the network:
            2 missing keys (a, b), 1 unexpected key (c)``.
    """
    torch = import_torch(where)
    expected = module.state_dict()
    missing = [k for k in expected if k not in state and not k.endswith(optional_suffixes)]
    unexpected = [k for k in state if k not in expected]
    mis_shaped = [
        f"{k} {tuple(state[k].shape)} != {tuple(expected[k].shape)}"
        for k in expected
        if k in state and isinstance(state[k], torch.Tensor) and state[k].shape != expected[k].shape
    ]
    not_tensors = [k for k in expected if k in state and not isinstance(state[k], torch.Tensor)]
    parts = []
    if missing:
        parts.append(f"{len(missing)} missing key{'s' * (len(missing) != 1)} ({_listed(missing)})")
    if unexpected:
        parts.append(
            f"{len(unexpected)} unexpected key{'s' * (len(unexpected) != 1)} ({_listed(unexpected)})"
        )
    if mis_shaped:
        parts.append(
            f"{len(mis_shaped)} shape mismatch{'es' * (len(mis_shaped) != 1)} ({_listed(mis_shaped)})"
        )
    if not_tensors:
        parts.append(
            f"{len(not_tensors)} non-tensor value{'s' * (len(not_tensors) != 1)} ({_listed(not_tensors)})"
        )
    if parts:
        raise InputError(f"{where} weights {path}: state dict does not match the network: {', '.join(parts)}")
    module.load_state_dict(dict(state), strict=False)


def rgb_to_tensor(rgb: np.ndarray, height: int, width: int, device: torch.device) -> torch.Tensor:
    """(H, W, 3) uint8 RGB -> (1, 3, height, width) float32 in [0, 1], resized with area/bilinear.

    Downsizing uses area averaging (no aliasing), upsizing bilinear interpolation.
    """
    torch = import_torch("depth")
    # A copy: inputs are often read-only (frozen dataclass arrays), which torch warns about.
    x = torch.from_numpy(np.array(rgb, dtype=np.uint8, copy=True)).to(device).permute(2, 0, 1)[None].float() / 255.0
    if x.shape[2:] != (height, width):
        shrink = height <= x.shape[2] and width <= x.shape[3]
        mode = "area" if shrink else "bilinear"
        kwargs = {} if shrink else {"align_corners": False}
        x = torch.nn.functional.interpolate(x, size=(height, width), mode=mode, **kwargs)
    return x.clamp(0.0, 1.0)


def resize_map(values: torch.Tensor, height: int, width: int) -> np.ndarray:
    """(h, w) map -> (height, width) float32 numpy array, bilinear (pixel-centre aligned)."""
    torch = import_torch("depth")
    v = values.detach().float()[None, None]
    if v.shape[2:] != (height, width):
        v = torch.nn.functional.interpolate(v, size=(height, width), mode="bilinear", align_corners=False)
    return v[0, 0].cpu().numpy().astype(np.float32)


def require_weights_path(weights: Path | None, where: str, source: str) -> Path:
    """The weights path, or InputError saying where such weights come from."""
    if weights is None:
        raise InputError(f"{where}: needs --depth-weights PATH; {source}")
    weights = Path(weights)
    if not weights.exists():
        raise InputError(f"{where} weights {weights}: no such file or folder; {source}")
    return weights
