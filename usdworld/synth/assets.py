"""Where synthetic scenes get their class assets from.

Anything with ``asset_path(class_name) -> Path`` and ``asset_info(class_name)`` (an object
with ``variants``, ``default_variant`` and ``size_by_variant``: variant -> (length, width,
height) in metres at scale 1) is an asset source; by default the built-in library
:mod:`usdworld.authoring.asset_library`. Tests pass a small stand-in library of boxes.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from usdworld.errors import AuthoringError


class AssetSource(Protocol):
    """The part of the asset library synthetic scenes use."""

    def asset_path(self, class_name: str) -> Path: ...

    def asset_info(self, class_name: str) -> Any: ...


@dataclass(frozen=True)
class ClassAsset:
    """One class's asset, as the street sampler needs it.

    Attributes:
        class_name: asset class (``car``, ``tree`` ...).
        path: the asset's root layer.
        variants: names of the ``model`` variants, default first.
        size_by_variant: variant -> (3,) float64 bounding-box size (length X, width Y, height Z), metres.
    """

    class_name: str
    path: Path
    variants: tuple[str, ...]
    size_by_variant: dict[str, np.ndarray]


def default_assets() -> AssetSource:
    """The built-in class library (:mod:`usdworld.authoring.asset_library`)."""
    try:
        from usdworld.authoring import asset_library
    except ImportError as exc:
        raise AuthoringError(
            f"the class asset library is not available ({exc}); run tools/make_assets.py or pass assets="
        ) from None
    return asset_library  # type: ignore[return-value]


def _get(info: Any, name: str) -> Any:
    return info[name] if isinstance(info, dict) else getattr(info, name)


def class_asset(source: AssetSource, class_name: str) -> ClassAsset:
    """Look one class up in ``source`` and check what the sampler relies on.

    Raises:
        AuthoringError: the class is missing or its info is incomplete.
    """
    try:
        info = source.asset_info(class_name)
        path = Path(source.asset_path(class_name))
        default = str(_get(info, "default_variant"))
        variants = [str(v) for v in _get(info, "variants")]
        sizes_raw = _get(info, "size_by_variant")
    except (KeyError, AttributeError, LookupError) as exc:
        raise AuthoringError(
            f"asset library: class '{class_name}' is missing or incomplete ({exc})"
        ) from None
    if default not in variants:
        raise AuthoringError(f"asset library: {class_name} default variant '{default}' is not in {variants}")
    ordered = tuple([default] + sorted(v for v in variants if v != default))
    sizes = {}
    for v in ordered:
        size = np.asarray(sizes_raw[v], dtype=np.float64)
        if size.shape != (3,) or not np.all(size > 0):
            raise AuthoringError(
                f"asset library: {class_name} variant '{v}' has size {size}; need 3 sizes > 0"
            )
        sizes[v] = size
    return ClassAsset(class_name, path, ordered, sizes)
