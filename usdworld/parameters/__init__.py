"""Every tuned number of usdworld, in one frozen, documented object (leaf package).

:class:`Parameters` groups the sections, one per stage that has thresholds. ``build``
takes a ``Parameters`` (the defaults unless the user passes ``--params FILE``) and
``report.json`` records the values used. ``tools/gen_parameters_doc.py`` writes
``docs/parameters.md`` from the fields' metadata (unit, meaning, origin).

Example:
    >>> p = Parameters()
    >>> p2 = p.replace(placement={"curb_height_m": 0.12})
    >>> p2.placement.curb_height_m, p.placement.curb_height_m
    (0.12, 0.15)
"""

from __future__ import annotations

import importlib
from typing import Any

#: What this package exports and the module defining each. Loaded on first use (PEP 562):
#: importing one section (``usdworld.parameters.collision``, which the editor needs) must
#: not import every other section with it.
_EXPORTS = {
    "CameraParams": "camera",
    "CollisionParams": "collision",
    "LightParams": "light",
    "PerceptionParams": "perception",
    "PlacementParams": "placement",
    "SceneParams": "scene",
    "Parameters": "composed",
    "DEFAULT_PARAMETERS": "composed",
    "param": "base",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'usdworld.parameters' has no attribute '{name}'")
    value = getattr(importlib.import_module(f"usdworld.parameters.{_EXPORTS[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])
